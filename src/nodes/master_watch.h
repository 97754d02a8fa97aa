/// \file
/// MasterWatch: registers the node again with a ROS master that no longer knows it. roscpp
/// registers a node's topics and services once, at advertise and subscribe time; after roscore
/// restarts, the new master knows none of them, and the node runs on unseen: no client finds its
/// topics or services, and it hears no publisher that starts since (docs/node.md, *Master
/// restart*).
#pragma once

#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <ros/duration.h>

namespace collision_monitor {
namespace ros_layer {

/// Asks the master every `period` whether it knows this node (lookupNode). When a master that
/// answers does not, registers again, through the master's and the node's own XML-RPC APIs,
/// every topic the process publishes and subscribes to (with the publishers the master names,
/// so that subscriptions connect) and the services the first master listed for the node when
/// the watch started. When another node holds the name (a second instance started meanwhile),
/// shuts this one down, as a master does when a node's name is taken. Only for a process that
/// is one node (collision_monitor_node): in a nodelet manager the process's topics and services
/// are the manager's.
class MasterWatch {
 public:
  /// Starts the watch thread; the node's services are read from the master now.
  explicit MasterWatch(ros::WallDuration period);
  /// Stops and joins the thread.
  ~MasterWatch();
  MasterWatch(const MasterWatch&) = delete;
  MasterWatch& operator=(const MasterWatch&) = delete;

 private:
  void run();
  /// One check; false when the watch should stop (the name taken).
  bool checkOnce();
  /// Registers every topic and `services_` with the master; false and `why` on a failed call,
  /// false when roscpp shuts down meanwhile.
  bool registerAgain(std::string* why);

  const ros::WallDuration period_;
  std::vector<std::string> services_;  ///< the node's, as the master listed them at start
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace ros_layer
}  // namespace collision_monitor
