// Plain gtest (no master) of the loggers the node's ~get_loggers reports (logger_services.h).
#include <algorithm>
#include <map>
#include <string>

#include <gtest/gtest.h>
#include <log4cxx/logger.h>
#include <ros/console.h>

#include "collision_monitor/ros/logger_services.h"

namespace {

std::map<std::string, std::string> asMap() {
  const auto list = collision_monitor::ros_layer::loggers();
  EXPECT_TRUE(std::is_sorted(list.begin(), list.end()));
  return {list.begin(), list.end()};
}

}  // namespace

// Bug: roscpp's ~get_loggers went through rosconsole's get_loggers, which on log4cxx 1.0 freed
// log4cxx's logger repository: the next logger lookup crashed the process. Here every level is
// named as roscpp names it, children report their effective (inherited) level, and loggers are
// looked up after repeated listings.
TEST(Loggers, EffectiveLevelsByNameAndSafeToRepeat) {
  namespace lv = ros::console::levels;
  ros::console::initialize();
  const std::map<std::string, lv::Level> set = {{"ros.cm_test.d", lv::Debug},
                                                {"ros.cm_test.i", lv::Info},
                                                {"ros.cm_test.w", lv::Warn},
                                                {"ros.cm_test.e", lv::Error},
                                                {"ros.cm_test.f", lv::Fatal}};
  for (const auto& [name, level] : set)
    ros::console::set_logger_level(name, level);
  for (int round = 0; round < 3; ++round) {
    const std::map<std::string, std::string> got = asMap();
    EXPECT_EQ(got.at("ros.cm_test.d"), "debug");
    EXPECT_EQ(got.at("ros.cm_test.i"), "info");
    EXPECT_EQ(got.at("ros.cm_test.w"), "warn");
    EXPECT_EQ(got.at("ros.cm_test.e"), "error");
    EXPECT_EQ(got.at("ros.cm_test.f"), "fatal");
    // A logger first looked up now (where the crash was), below one set to "error".
    const std::string child = "ros.cm_test.e.child" + std::to_string(round);
    EXPECT_EQ(got.count(child), 0u);
    log4cxx::Logger::getLogger(child);  // rosconsole's lookup of a new logger name
    EXPECT_EQ(asMap().at(child), "error");
  }
}
