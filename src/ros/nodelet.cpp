/// \file
/// collision_monitor/CollisionMonitorNodelet: owns one Monitor (which runs its callbacks on a
/// queue and threads of its own, not the manager's). The node executable
/// (src/nodes/collision_monitor_node.cpp) loads this same class, so node and nodelet share one code
/// path.
#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "collision_monitor/ros/logger_services.h"
#include "collision_monitor/ros/monitor.h"

namespace collision_monitor {
namespace ros_layer {

class CollisionMonitorNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    // roscpp's ~get_loggers crashes the process on Debian 12 (logger_services.h): replaced in
    // this process (the node executable's, or a manager's) before the monitor starts its work.
    if (replaceGetLoggers())
      NODELET_INFO("%s/get_loggers served from log4cxx (roscpp's crashes on Debian 12)",
                   ::ros::this_node::getName().c_str());
    monitor_ = std::make_unique<Monitor>(getMTNodeHandle(), getMTPrivateNodeHandle(), getName());
  }
  std::unique_ptr<Monitor> monitor_;
};

}  // namespace ros_layer
}  // namespace collision_monitor

PLUGINLIB_EXPORT_CLASS(collision_monitor::ros_layer::CollisionMonitorNodelet, nodelet::Nodelet)
