/// \file
/// `~get_loggers` from log4cxx itself (logger_services.h: why not rosconsole's).
#include "collision_monitor/ros/logger_services.h"

#include <algorithm>

#include <log4cxx/level.h>
#include <log4cxx/logger.h>
#include <log4cxx/logmanager.h>
#include <ros/node_handle.h>
#include <ros/service_manager.h>
#include <ros/service_server.h>
#include <ros/this_node.h>
#include <roscpp/GetLoggers.h>

namespace collision_monitor {
namespace ros_layer {

namespace {

/// roscpp's spelling of a log4cxx level (levels between two of rosconsole's count as the lower).
const char* levelName(int level) {
  if (level < log4cxx::Level::INFO_INT) return "debug";
  if (level < log4cxx::Level::WARN_INT) return "info";
  if (level < log4cxx::Level::ERROR_INT) return "warn";
  if (level < log4cxx::Level::FATAL_INT) return "error";
  return "fatal";
}

bool getLoggers(roscpp::GetLoggers::Request& /*req*/, roscpp::GetLoggers::Response& res) {
  for (const auto& [name, level] : loggers()) {
    roscpp::Logger l;
    l.name = name;
    l.level = level;
    res.loggers.push_back(l);
  }
  return true;
}

}  // namespace

std::vector<std::pair<std::string, std::string>> loggers() {
  // Through LogManager, which holds the repository, not through rosconsole (logger_services.h).
  std::vector<std::pair<std::string, std::string>> out;
  for (const log4cxx::LoggerPtr& logger : log4cxx::LogManager::getCurrentLoggers()) {
    std::string name;
    logger->getName(name);
    out.emplace_back(name, levelName(logger->getEffectiveLevel()->toInt()));
  }
  std::sort(out.begin(), out.end());
  return out;
}

bool replaceGetLoggers() {
  bool done = false;
  // Once per process (a thread-safe static initialisation). Destroyed when the library is
  // unloaded or at exit: after ros::shutdown() (a nodelet loader unloads its plugins as the
  // process ends), before roscpp's own singletons, made earlier; the unadvertise it then makes
  // is a no-op of the shut-down ServiceManager.
  static const ::ros::ServiceServer server = [&done] {
    ::ros::ServiceManager::instance()->unadvertiseService(::ros::this_node::getName() +
                                                          "/get_loggers");
    ::ros::NodeHandle pnh("~");
    done = true;
    return pnh.advertiseService("get_loggers", &getLoggers);
  }();
  (void)server;
  return done;
}

}  // namespace ros_layer
}  // namespace collision_monitor
