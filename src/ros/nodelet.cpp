/// \file
/// collision_monitor/CollisionMonitorNodelet: owns one Monitor on the nodelet's multi-threaded
/// callback queue. The node executable (src/nodes/collision_monitor_node.cpp) loads this same
/// class, so node and nodelet share one code path.
#include <memory>

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>

#include "collision_monitor/ros/monitor.h"

namespace collision_monitor {
namespace ros_layer {

class CollisionMonitorNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    monitor_ = std::make_unique<Monitor>(getMTNodeHandle(), getMTPrivateNodeHandle(), getName());
  }
  std::unique_ptr<Monitor> monitor_;
};

}  // namespace ros_layer
}  // namespace collision_monitor

PLUGINLIB_EXPORT_CLASS(collision_monitor::ros_layer::CollisionMonitorNodelet, nodelet::Nodelet)
