/// \file
/// collision_monitor_node: loads the CollisionMonitorNodelet in this process (like image_proc's
/// nodes), so the node and the nodelet run the same code. Parameters and topics are private to
/// the node name (default `collision_monitor`).
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "collision_monitor");
  nodelet::Loader loader(false);  // no manager services: this process hosts one nodelet
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string my_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "collision_monitor/CollisionMonitorNodelet",
                   remappings, my_argv)) {
    ROS_FATAL("collision_monitor_node: cannot load collision_monitor/CollisionMonitorNodelet");
    return 1;
  }
  ros::spin();
  return 0;
}
