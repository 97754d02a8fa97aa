/// \file
/// Fills a tf2 buffer from /tf and /tf_static, as tf2_ros::TransformListener does (its own
/// callback queue and thread, the same queues, authority and time-jump handling), except that
/// each message goes into the buffer as one batch: a reader that holds snapshot() while it
/// looks up several frames sees every TF message whole or not at all.
///
/// Why: robot_state_publisher sends the moving links of one joint state in one message, and
/// TransformListener inserts it transform by transform, each under the buffer's own lock. A
/// check that looked up the Panda's links while a message was going in could pose some links
/// at one joint state and the rest at the previous one (a moving Panda at 100 Hz: 361 of 39,019
/// pair samples, up to 5.7 mm off; docs/reliability.md). The lock is held for the length of one
/// message's insertion or one check's lookups (microseconds per frame and stamp looked up).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>

#include "collision_monitor/ros/log_throttle.h"

namespace collision_monitor {
namespace ros_layer {

class TfReceiver {
 public:
  /// Subscribes to /tf (with `hints`) and /tf_static through `nh` and starts the receiving
  /// thread. `name` starts its log lines (the monitor's name). `on_message`, if set, runs after
  /// each message is in the buffer (outside the lock).
  TfReceiver(tf2_ros::Buffer& buffer, const ros::NodeHandle& nh, const ros::TransportHints& hints,
             std::string name, std::function<void()> on_message = {});
  ~TfReceiver();
  TfReceiver(const TfReceiver&) = delete;
  TfReceiver& operator=(const TfReceiver&) = delete;

  /// Hold while looking up frames that must come from the same messages. No message is
  /// inserted meanwhile: keep it short, and never wait for TF while holding it.
  std::unique_lock<std::mutex> snapshot() { return std::unique_lock<std::mutex>(batch_mutex_); }

  /// The stamps of the /tf transforms taken (distinct; the latest kStampsKept of them) strictly
  /// between `after` and `before`, at most `most` of them (spread(): the last always among
  /// them). They are the times at which some frame's transform is known rather than
  /// interpolated: a reader that looked up a frame at `after` before and at `before` now can
  /// look it up in between at these. `held` is snapshot()'s lock, which the call needs.
  std::vector<ros::Time> stampsBetween(const std::unique_lock<std::mutex>& held,
                                       const ros::Time& after, const ros::Time& before,
                                       std::size_t most) const;
  /// At most `most` of the increasing `stamps`, evenly spread over them, the last always among
  /// them (it is the nearest to the time looked up next).
  static std::vector<ros::Time> spread(std::vector<ros::Time> stamps, std::size_t most);
  /// Empties the buffer (static transforms stay, as tf2 keeps them) and forgets the stamps.
  void clear();
  static constexpr std::size_t kStampsKept = 4096;

  /// Messages inserted so far (/tf and /tf_static).
  std::size_t messages() const;
  /// /tf transforms stamped 0 so far, taken as of their arrival (ROS time).
  std::size_t zeroStamped() const;
  /// Transforms refused so far (empty or self-parented frames, non-finite values, rotations that
  /// are not unit quaternions, /tf stamped more than the buffer's cache length after the current
  /// ROS time or stamped 0 before ROS time started, anything tf2 throws on), and the last one's
  /// description. The rotations taken are normalised.
  std::pair<std::size_t, std::string> refused() const;

  /// Why `t` is refused, or empty: what tf2 refuses itself (logging every one: empty or
  /// self-parented frames, NaN, rotations whose |q|^2 is 0.01 or more off 1), and non-finite
  /// translations, which tf2 takes.
  static std::string whyRefused(const geometry_msgs::TransformStamped& t);

 private:
  /// Why a /tf transform stamped `stamp` is refused at ROS time `now`, or empty: see the
  /// definition.
  std::string whyTooFarAhead(const ros::Time& stamp, const ros::Time& now) const;
  void onMessage(const ros::MessageEvent<const tf2_msgs::TFMessage>& event, bool is_static);
  void clearLocked();  ///< clear() with batch_mutex_ held

  tf2_ros::Buffer& buffer_;
  std::function<void()> on_message_;
  std::string name_;
  ros::NodeHandle nh_;
  ros::CallbackQueue queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  ros::Subscriber tf_sub_, static_sub_;
  mutable std::mutex batch_mutex_;  ///< held while a message goes in and by snapshot()
  std::set<ros::Time> stamps_;      ///< guarded by batch_mutex_; see stampsBetween()
  ros::Time last_update_;           ///< receiving thread only
  /// Latest /tf stamp taken while ROS time was 0 (simulated time before /clock), until time
  /// starts (receiving thread only).
  ros::Time taken_before_time_;
  std::size_t messages_ = 0;      ///< guarded by batch_mutex_
  std::size_t refused_ = 0;       ///< guarded by batch_mutex_
  std::size_t zero_stamped_ = 0;  ///< guarded by batch_mutex_
  std::string last_refusal_;      ///< guarded by batch_mutex_
  LogThrottle refusal_log_{5.0};
  LogThrottle zero_stamp_log_{5.0};
  LogThrottle jump_log_{5.0};  ///< "detected jump back in time" (two /clock: one a message)
};

}  // namespace ros_layer
}  // namespace collision_monitor
