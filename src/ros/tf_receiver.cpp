#include "collision_monitor/ros/tf_receiver.h"

#include <utility>

namespace collision_monitor {
namespace ros_layer {

TfReceiver::TfReceiver(tf2_ros::Buffer& buffer, const ros::NodeHandle& nh,
                       const ros::TransportHints& hints, std::function<void()> on_message)
    : buffer_(buffer), on_message_(std::move(on_message)), nh_(nh) {
  // As tf2_ros::TransformListener: queues of 100 messages, /tf_static latched by its publishers.
  auto subscribe = [this](const std::string& topic, bool is_static, const ros::TransportHints& h) {
    ros::SubscribeOptions ops = ros::SubscribeOptions::create<tf2_msgs::TFMessage>(
        topic, 100,
        [this, is_static](const ros::MessageEvent<const tf2_msgs::TFMessage>& e) {
          onMessage(e, is_static);
        },
        ros::VoidPtr(), &queue_);
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
  spinner_->stop();  // waits for a callback in progress
}

std::size_t TfReceiver::messages() const {
  std::lock_guard<std::mutex> lock(batch_mutex_);
  return messages_;
}

void TfReceiver::onMessage(const ros::MessageEvent<const tf2_msgs::TFMessage>& event,
                           bool is_static) {
  const ros::Time now = ros::Time::now();
  const std::string& authority = event.getPublisherName();
  {
    std::lock_guard<std::mutex> lock(batch_mutex_);
    // As TransformListener: a jump back in ROS time (bag loop, simulation reset) clears the
    // buffer, and data stamped after the new time is dropped while that message goes in.
    const bool time_reset = now < last_update_;
    if (time_reset) {
      ROS_WARN_STREAM("Detected jump back in time of " << (last_update_ - now).toSec()
                                                       << "s. Clearing TF buffer.");
      buffer_.clear();
    }
    last_update_ = now;
    for (const auto& t : event.getConstMessage()->transforms) {
      if (time_reset && t.header.stamp > now) continue;
      try {
        buffer_.setTransform(t, authority, is_static);
      } catch (const tf2::TransformException& e) {
        ROS_ERROR_STREAM_THROTTLE(1.0, "Failure to set received transform from "
                                           << t.child_frame_id << " to " << t.header.frame_id
                                           << " with error: " << e.what());
      }
    }
    ++messages_;
  }
  if (on_message_) on_message_();
}

}  // namespace ros_layer
}  // namespace collision_monitor
