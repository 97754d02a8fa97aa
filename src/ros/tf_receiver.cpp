#include "collision_monitor/ros/tf_receiver.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <sstream>
#include <utility>

#include "collision_monitor/ros/conversions.h"

namespace collision_monitor {
namespace ros_layer {

TfReceiver::TfReceiver(tf2_ros::Buffer& buffer, const ros::NodeHandle& nh,
                       const ros::TransportHints& hints, std::string name,
                       std::function<void()> on_message)
    : buffer_(buffer), on_message_(std::move(on_message)), name_(std::move(name)), nh_(nh) {
  // As tf2_ros::TransformListener: queues of 100 messages, /tf_static latched by its publishers.
  // The callback takes the whole MessageEvent, which names the publisher (tf2's authority):
  // SubscribeOptions::create (as TransformListener uses it) passes the message alone, and every
  // transform came from "unknown_publisher".
  using Event = const ros::MessageEvent<const tf2_msgs::TFMessage>&;
  auto subscribe = [this](const std::string& topic, bool is_static, const ros::TransportHints& h) {
    ros::SubscribeOptions ops;
    ops.initByFullCallbackType<Event>(topic, 100,
                                      [this, is_static](Event e) { onMessage(e, is_static); });
    ops.callback_queue = &queue_;
    ops.transport_hints = h;
    return nh_.subscribe(ops);
  };
  tf_sub_ = subscribe("/tf", false, hints);
  static_sub_ = subscribe("/tf_static", true, ros::TransportHints());
  buffer_.setUsingDedicatedThread(true);
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

TfReceiver::~TfReceiver() {
  tf_sub_.shutdown();
  static_sub_.shutdown();
  queue_.disable();  // the spinner's wait for callbacks returns at once (0.1 s otherwise)
  spinner_->stop();  // waits for a callback in progress
}

std::size_t TfReceiver::messages() const {
  std::lock_guard<std::mutex> lock(batch_mutex_);
  return messages_;
}

std::size_t TfReceiver::zeroStamped() const {
  std::lock_guard<std::mutex> lock(batch_mutex_);
  return zero_stamped_;
}

std::pair<std::size_t, std::string> TfReceiver::refused() const {
  std::lock_guard<std::mutex> lock(batch_mutex_);
  return {refused_, last_refusal_};
}

std::vector<ros::Time> TfReceiver::stampsBetween(const std::unique_lock<std::mutex>& held,
                                                 const ros::Time& after, const ros::Time& before,
                                                 std::size_t most) const {
  assert(held.owns_lock() && held.mutex() == &batch_mutex_);
  (void)held;
  if (!(after < before)) return {};
  return spread({stamps_.upper_bound(after), stamps_.lower_bound(before)}, most);
}

std::vector<ros::Time> TfReceiver::spread(std::vector<ros::Time> stamps, std::size_t most) {
  const std::size_t n = stamps.size();
  if (n <= most) return stamps;
  std::vector<ros::Time> picked;
  picked.reserve(most);
  // The k-th of `most` picks, counted back from the last: index n - 1 - floor(k n / most).
  for (std::size_t k = most; k-- > 0;)
    picked.push_back(stamps[n - 1 - k * n / most]);
  return picked;
}

void TfReceiver::clear() {
  std::lock_guard<std::mutex> lock(batch_mutex_);
  clearLocked();
}

void TfReceiver::clearLocked() {
  buffer_.clear();
  stamps_.clear();
}

std::string TfReceiver::whyRefused(const geometry_msgs::TransformStamped& t) {
  const std::string child = tfFrameName(t.child_frame_id);
  const std::string parent = tfFrameName(t.header.frame_id);
  const auto& q = t.transform.rotation;
  if (child.empty() || parent.empty()) return "empty frame id";
  if (child == parent) return "frame is its own parent";
  if (!finite(t.transform.translation)) return "non-finite translation";
  // tf2's own test (TF_DENORMALIZED_QUATERNION): |q|^2 within 0.01 of 1.
  const double norm2 = q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w;
  if (!(std::abs(norm2 - 1.0) < 10e-3)) return "rotation not a unit quaternion";
  return {};
}

std::string TfReceiver::whyTooFarAhead(const ros::Time& stamp, const ros::Time& now) const {
  // tf2 drops a transform stamped more than its cache length before the latest one of the same
  // frame (TF_OLD_DATA). One transform stamped further ahead of ROS time than that would have
  // every later one of its frame dropped (and logged) until ROS time caught up with it: the
  // frame stale for hours after one bad stamp. Nearer stamps block nothing. Unknown while ROS
  // time is 0 (simulated time before the first /clock); static transforms have no time.
  if (now.isZero()) return {};
  const double ahead = stamp.toSec() - now.toSec();
  const double cache = buffer_.getCacheLength().toSec();
  if (!(ahead > cache)) return {};
  std::ostringstream os;
  os << "stamped " << ahead << " s after the current ROS time (more than the TF cache of " << cache
     << " s: every later transform of the frame would be dropped)";
  return os.str();
}

void TfReceiver::onMessage(const ros::MessageEvent<const tf2_msgs::TFMessage>& event,
                           bool is_static) {
  const ros::Time now = ros::Time::now();
  const std::string& authority = event.getPublisherName();
  {
    std::lock_guard<std::mutex> lock(batch_mutex_);
    if (now.isZero()) {
      // Simulated time before the first /clock: nothing can be judged ahead yet. Remember the
      // latest stamp taken, to judge it when time starts.
      if (!is_static) {
        for (const auto& t : event.getConstMessage()->transforms)
          taken_before_time_ = std::max(taken_before_time_, t.header.stamp);
      }
    } else if (!taken_before_time_.isZero()) {
      // Time has started. A transform taken before, stamped more than the cache after the new
      // time (a wall-clock stamp, a publisher ahead), would block its frame as whyTooFarAhead()
      // says: the buffer starts again (static transforms stay: tf2 keeps them through clear()).
      const std::string why = whyTooFarAhead(taken_before_time_, now);
      if (!why.empty()) {
        ROS_WARN_STREAM(name_ << ": TF received before ROS time started is " << why
                              << ": clearing the TF buffer");
        clearLocked();
      }
      taken_before_time_ = ros::Time();
    }
    // As TransformListener: a jump back in ROS time (bag loop, simulation reset) clears the
    // buffer, and data stamped after the new time is dropped while that message goes in.
    const bool time_reset = now < last_update_;
    if (time_reset) {
      if (jump_log_.ready()) {
        ROS_WARN_STREAM(name_ << ": detected jump back in time of " << (last_update_ - now).toSec()
                              << " s, clearing the TF buffer (logged at most once every 5 s)");
      }
      clearLocked();
    }
    last_update_ = now;
    for (const auto& t : event.getConstMessage()->transforms) {
      if (time_reset && t.header.stamp > now) continue;
      // tf2 refuses these itself, but logs each one (about 1,100 lines/s for one bad frame at
      // 200 Hz): refused here, counted, and logged at most once every 5 s.
      std::string why = whyRefused(t);
      if (why.empty() && !is_static) why = whyTooFarAhead(t.header.stamp, now);
      const bool zero_stamp = !is_static && t.header.stamp.isZero();
      if (why.empty() && zero_stamp && now.isZero())
        why = "stamped 0 on /tf before ROS time started";
      // tf2 composes a chain with the conjugate, not the inverse: a rotation it takes (|q|^2
      // within 0.01 of 1) scaled the offsets of the frames below it by |q|^2 (0.808 m for 0.8
      // with |q| = 1.004, as a hand-typed 0 0 0.71 0.71 gives). A transform that needs nothing
      // (unit to rounding, as robot_state_publisher sends them) goes in as it came, uncopied.
      const auto& r = t.transform.rotation;
      const double norm2 = r.x * r.x + r.y * r.y + r.z * r.z + r.w * r.w;
      const geometry_msgs::TransformStamped* in = &t;
      geometry_msgs::TransformStamped fixed;
      if (why.empty() && (zero_stamp || std::abs(norm2 - 1.0) > 1e-12)) {
        fixed = t;
        in = &fixed;
        auto& q = fixed.transform.rotation;
        const double norm = std::sqrt(norm2);
        q.x /= norm;
        q.y /= norm;
        q.z /= norm;
        q.w /= norm;
        if (zero_stamp) {
          // tf2 keeps stamp 0 on /tf: it looked static, and the body never went stale after its
          // publisher stopped. Taken as of its arrival, it ages like any other transform.
          fixed.header.stamp = now;
          ++zero_stamped_;
          if (zero_stamp_log_.ready()) {
            ROS_WARN_STREAM(name_ << ": TF: transform " << t.header.frame_id << " -> "
                                  << t.child_frame_id << " from " << authority
                                  << " stamped 0 on /tf: taken as of its arrival (" << zero_stamped_
                                  << " so far; fixed transforms go on /tf_static)");
          }
        }
      }
      if (why.empty()) {
        try {
          buffer_.setTransform(*in, authority, is_static);
          if (!is_static) {
            stamps_.insert(in->header.stamp);
            if (stamps_.size() > kStampsKept) stamps_.erase(stamps_.begin());
          }
        } catch (const std::exception& e) {
          // tf2::TransformException, and std::runtime_error from ros::Time for a stamp within
          // the cache time of the largest ROS time: it escaped this thread and aborted the
          // process (the whole nodelet manager).
          why = e.what();
        }
      }
      if (!why.empty()) {
        ++refused_;
        last_refusal_ = "transform " + t.header.frame_id + " -> " + t.child_frame_id + " from " +
                        authority + ": " + why;
        if (refusal_log_.ready()) {
          ROS_WARN_STREAM(name_ << ": TF: refused " << last_refusal_ << " (" << refused_
                                << " refused so far)");
        }
      }
    }
    ++messages_;
  }
  if (on_message_) on_message_();
}

}  // namespace ros_layer
}  // namespace collision_monitor
