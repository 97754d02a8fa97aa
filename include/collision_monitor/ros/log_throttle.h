/// \file
/// Log throttling per object. ROS_*_THROTTLE keeps the time of its last line in a static of the
/// call site, shared by every object in the process: two monitors in one nodelet manager shared
/// it, so one monitor's warning silenced the other's (which names that monitor's own frames) for
/// the whole period, and their threads raced on the static (ThreadSanitizer).
#pragma once

#include <mutex>

#include <ros/time.h>

namespace collision_monitor {
namespace ros_layer {

/// ready() is true at most once per `period` seconds of wall time, the first time always. Wall
/// time, not ROS time: under a paused simulated clock ROS time stands still and a throttle on it
/// never lets a second line through. Thread-safe.
class LogThrottle {
 public:
  explicit LogThrottle(double period) : period_(period) {}
  bool ready() {
    const ros::WallTime now = ros::WallTime::now();
    std::lock_guard<std::mutex> lock(mutex_);
    if (!last_.isZero() && (now - last_).toSec() < period_) return false;
    last_ = now;
    return true;
  }

 private:
  const double period_;
  std::mutex mutex_;
  ros::WallTime last_;  ///< of the last true; zero before the first
};

}  // namespace ros_layer
}  // namespace collision_monitor
