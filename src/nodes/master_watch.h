/// \file
/// MasterWatch: registers the node again with a ROS master that no longer knows it. roscpp
/// registers a node's topics and services once, at advertise and subscribe time; after roscore
/// restarts, the new master knows none of them, and the node runs on unseen: no client finds its
/// topics or services, and it hears no publisher that starts since (docs/node.md, *Master
/// restart*).
#pragma once

#include <atomic>
#include <chrono>
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
/// so that subscriptions connect) and the node's services, as the master listed them (read at
/// start and every 10 s while a master knows the node). A registration left incomplete (a call
/// refused or unanswered) is made again at the next period. When another node holds the name
/// (a second instance started meanwhile), shuts this one down, as a master does when a node's
/// name is taken; the name is checked before each registration, so that this node never takes
/// it back. Each call has a deadline of 2 s. Only for a process that is one node
/// (collision_monitor_node): in a nodelet manager the process's topics and services are the
/// manager's.
class MasterWatch {
 public:
  /// Starts the watch thread; the node's services are read from the master now.
  explicit MasterWatch(ros::WallDuration period);
  /// Stops and joins the thread (at most one call's deadline).
  ~MasterWatch();
  MasterWatch(const MasterWatch&) = delete;
  MasterWatch& operator=(const MasterWatch&) = delete;

 private:
  /// Who the master gives the node's name to.
  enum class Holder { NoAnswer, Nobody, This, Another };
  enum class Outcome { Done, Failed, Taken, Stopped };

  void run();
  /// One check; false when the watch should stop (the name taken, roscpp shutting down).
  bool checkOnce();
  Holder holder() const;
  /// Logs and asks roscpp to shut down; false.
  bool nameTaken() const;
  /// Registers every topic and `services_` with the master; `why` when Failed.
  Outcome registerAgain(std::string* why);
  /// `services_` from the master's getSystemState (unchanged when it does not answer).
  void readServices();
  bool stopping() const;

  const ros::WallDuration period_;
  std::vector<std::string> services_;  ///< the node's, as the master lists them
  std::chrono::steady_clock::time_point services_read_;
  bool incomplete_ = false;  ///< the last registration failed part way: again
  std::atomic<bool> stop_{false};
  std::mutex mutex_;  ///< for wake_
  std::condition_variable wake_;
  std::thread thread_;
};

/// Waits, at most `timeout`, until the node's log lines on /rosout reach a subscriber the master
/// names (rosout): roscpp publishes them without a queue for subscribers yet to connect, so the
/// node's start-up errors (an invalid parameter, a URDF's bad link) never reached /rosout,
/// rosout.log or rqt_console, only the terminal. Returns at once when the master names none.
void waitForRosout(ros::WallDuration timeout);

}  // namespace ros_layer
}  // namespace collision_monitor
