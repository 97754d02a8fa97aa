/// \file
/// collision_monitor_node: loads the CollisionMonitorNodelet in this process (like image_proc's
/// nodes), so the node and the nodelet run the same code. Parameters and topics are private to
/// the node name (default `collision_monitor`).
#include <csignal>
#include <cstdio>

#include <nodelet/loader.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include "master_watch.h"

namespace {

/// ros::spin() without its busy wait during shutdown. ros::shutdown() (run by roscpp's poll
/// thread after SIGINT) disables the global callback queue first and clears ros::ok() last; in
/// between, ros::spin()'s `while (ok()) callAvailable(0.1 s)` returns at once on the disabled
/// queue and spins without a system call. Under valgrind, which runs one thread at a time, that
/// spinning thread kept the lock while the threads ros::shutdown() waits for (its internal queue
/// thread, the XML-RPC server thread) waited seconds to minutes for their turn: 3 exits of 24
/// took 8.5 s, 45 s and 119 s instead of ~1 s (docs/reliability.md). Here the main thread sleeps
/// while the queue is disabled.
void spinUntilShutdown() {
  ros::CallbackQueue* const queue = ros::getGlobalCallbackQueue();
  while (ros::ok()) {
    if (queue->isEnabled()) {
      queue->callAvailable(ros::WallDuration(0.1));
    } else {
      ros::WallDuration(0.01).sleep();
    }
  }
}

/// SIGTERM (systemd, `docker stop`, kill) stops the node as SIGINT does: roscpp handles SIGINT
/// only, and SIGTERM ended the process at once, its node and services left registered with the
/// master until `rosnode cleanup`.
void onSigterm(int /*signal*/) {
  ros::requestShutdown();
}

}  // namespace

int main(int argc, char** argv) {
  // Log lines on stdout as they come, also into a file or a pipe (roslaunch's output="screen"
  // redirected, a container's log): fully buffered there, they came out at exit.
  std::setvbuf(stdout, nullptr, _IOLBF, BUFSIZ);
  ros::init(argc, argv, "collision_monitor");
  std::signal(SIGTERM, onSigterm);
  ros::NodeHandle nh;  // starts roscpp
  collision_monitor::ros_layer::waitForRosout(ros::WallDuration(2.0));
  nodelet::Loader loader(false);  // no manager services: this process hosts one nodelet
  const nodelet::M_string& remappings = ros::names::getRemappings();
  const nodelet::V_string my_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "collision_monitor/CollisionMonitorNodelet",
                   remappings, my_argv)) {
    ROS_FATAL("collision_monitor_node: cannot load collision_monitor/CollisionMonitorNodelet");
    return 1;
  }
  // After roscore restarts, the node registers its topics and services again (master_watch.h).
  collision_monitor::ros_layer::MasterWatch watch(ros::WallDuration(1.0));
  spinUntilShutdown();
  return 0;
}
