/// \file
/// `~get_loggers` served without rosconsole's `get_loggers`. roscpp advertises that service in
/// every node; on Debian 12 (rosconsole 1.14.3 built against log4cxx 1.0) rosconsole's
/// implementation leaves log4cxx's logger repository broken: the second `~get_loggers` call (or
/// the next log line that looks up a logger after the first) crashes the process with SIGSEGV in
/// log4cxx::LogManager::getLoggerLS. rqt_logger_level and `rosservice call <node>/get_loggers`
/// make that call; /rosout dies of it too (ros/rosconsole#62 reports the same family of crashes).
/// The nodelet replaces its process's service with loggers() below, which asks log4cxx itself:
/// the node executable's, and a nodelet manager's that hosts it (a crash there would take the
/// monitor down with the manager). `~set_logger_level` is roscpp's own (it does not touch the
/// repository).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace collision_monitor {
namespace ros_layer {

/// Every log4cxx logger of this process with its effective level as roscpp's GetLoggers spells
/// it ("debug", "info", "warn", "error", "fatal"), sorted by name: what roscpp's own answer holds.
/// Needs no master.
std::vector<std::pair<std::string, std::string>> loggers();

/// Unadvertises roscpp's `~get_loggers` of this process and advertises one served by loggers(),
/// once per process (later calls do nothing); returns true on the call that did it. Needs
/// ros::start() (any NodeHandle). The services belong to the process (in a nodelet manager, the
/// manager's), so the server lives as long as the process, not as the caller: nodelet loaders
/// keep plugin libraries loaded until the process ends (pluginlib without on-demand unloading).
bool replaceGetLoggers();

}  // namespace ros_layer
}  // namespace collision_monitor
