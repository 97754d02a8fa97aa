/// \file
/// `~get_loggers` served without rosconsole's `get_loggers`. roscpp advertises that service in
/// every node; on Debian 12 (rosconsole 1.14.3 built against log4cxx 1.0) rosconsole's
/// implementation leaves log4cxx's logger repository broken: the second `~get_loggers` call (or
/// the next log line that looks up a logger after the first) crashes the process with SIGSEGV in
/// log4cxx::LogManager::getLoggerLS. rqt_logger_level and `rosservice call <node>/get_loggers`
/// make that call; /rosout dies of it too (ros/rosconsole#62 reports the same family of crashes).
/// The node executable replaces the service with loggers() below, which asks log4cxx itself.
/// `~set_logger_level` is roscpp's own (it does not touch the repository).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <ros/service_server.h>

namespace collision_monitor {
namespace ros_layer {

/// Every log4cxx logger of this process with its effective level as roscpp's GetLoggers spells
/// it ("debug", "info", "warn", "error", "fatal"), sorted by name: what roscpp's own answer holds.
/// Needs no master.
std::vector<std::pair<std::string, std::string>> loggers();

/// Unadvertises roscpp's `~get_loggers` of this process and advertises one served by loggers().
/// Call once after ros::start() (any NodeHandle) from the process's main: the services belong to
/// the process (a nodelet manager's are its own). Keep the returned server for the node's life.
::ros::ServiceServer replaceGetLoggers();

}  // namespace ros_layer
}  // namespace collision_monitor
