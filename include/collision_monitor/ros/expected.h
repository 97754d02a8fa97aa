/// \file
/// A value or the reason there is none: what every boundary conversion of the ROS layer returns
/// instead of throwing, so that callbacks can drop bad input with a clear message.
#pragma once

#include <optional>
#include <string>
#include <utility>

namespace collision_monitor {
namespace ros_layer {

/// The reason a conversion failed, in words a user can act on ("part 2: negative radius -1").
struct Error {
  std::string what;
};

template <class T>
class Expected {
 public:
  Expected(T value) : value_(std::move(value)) {}           // NOLINT(google-explicit-constructor)
  Expected(Error error) : error_(std::move(error.what)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const { return value_.has_value(); }
  explicit operator bool() const { return ok(); }
  const T& value() const& { return *value_; }
  T& value() & { return *value_; }
  T&& value() && { return std::move(*value_); }
  const T* operator->() const { return &*value_; }
  T* operator->() { return &*value_; }
  const T& operator*() const { return *value_; }
  T& operator*() { return *value_; }
  /// Empty when ok().
  const std::string& error() const { return error_; }

 private:
  std::optional<T> value_;
  std::string error_;
};

}  // namespace ros_layer
}  // namespace collision_monitor
