/// \file
/// Time stamps of the world model: integer nanoseconds, ROS time's own resolution, so that the
/// stamps the monitor publishes (events, state, markers) are the stamps of the poses it was given,
/// to the nanosecond. A double of seconds holds today's 1.7e9 s only to 2.4e-7 s: through
/// ros::Time::toSec() and back a stamp came out up to 119 ns off, and a client matching verdicts
/// to its own pose messages by stamp missed some.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <ostream>

namespace collision_monitor {
namespace world {

class Stamp {
 public:
  constexpr Stamp() = default;
  /// From seconds, rounded to the nanosecond (tests and callers without ROS). NaN and values
  /// beyond about 292 years give an invalid stamp (valid() false), which WorldModel::setPose()
  /// refuses. Implicit: a time in seconds reads as one.
  Stamp(double seconds) {  // NOLINT(google-explicit-constructor)
    const double ns = std::round(seconds * 1e9);
    // The bounds are doubles exactly; NaN fails both comparisons.
    ns_ = ns > -9.2e18 && ns < 9.2e18 ? static_cast<std::int64_t>(ns) : kInvalid;
  }
  static constexpr Stamp fromNanoseconds(std::int64_t ns) {
    Stamp s;
    s.ns_ = ns;
    return s;
  }

  constexpr std::int64_t nanoseconds() const { return ns_; }
  double seconds() const { return static_cast<double>(ns_) / 1e9; }
  constexpr bool valid() const { return ns_ != kInvalid; }
  /// Zero or negative: a static pose (valid at any time), or no timed pose at all.
  constexpr bool isStatic() const { return ns_ <= 0; }

  /// a - b in seconds.
  friend double operator-(Stamp a, Stamp b) {
    std::int64_t d = 0;
    if (__builtin_sub_overflow(a.ns_, b.ns_, &d)) return a.seconds() - b.seconds();
    return static_cast<double>(d) / 1e9;
  }
  friend constexpr bool operator==(Stamp a, Stamp b) { return a.ns_ == b.ns_; }
  friend constexpr bool operator!=(Stamp a, Stamp b) { return a.ns_ != b.ns_; }
  friend constexpr bool operator<(Stamp a, Stamp b) { return a.ns_ < b.ns_; }
  friend constexpr bool operator>(Stamp a, Stamp b) { return a.ns_ > b.ns_; }
  friend constexpr bool operator<=(Stamp a, Stamp b) { return a.ns_ <= b.ns_; }
  friend constexpr bool operator>=(Stamp a, Stamp b) { return a.ns_ >= b.ns_; }
  friend std::ostream& operator<<(std::ostream& os, Stamp s) { return os << s.ns_ << " ns"; }

 private:
  static constexpr std::int64_t kInvalid = std::numeric_limits<std::int64_t>::min();
  std::int64_t ns_ = 0;
};

}  // namespace world
}  // namespace collision_monitor
