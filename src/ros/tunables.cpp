#include "collision_monitor/ros/tunables.h"

#include <algorithm>
#include <sstream>

#include "collision_monitor/core/backend.h"

namespace collision_monitor {
namespace ros_layer {

void validate(Tunables* t, const Tunables& fallback, std::vector<std::string>* errors) {
  const auto positive = [](double v) { return v > 0.0; };
  const auto non_negative = [](double v) { return v >= 0.0; };
  const auto any = [](double) { return true; };
  checkNumber("rate", &t->rate, fallback.rate, positive, "> 0", errors);
  checkNumber("warning_distance", &t->warning_distance, fallback.warning_distance, any, "finite",
              errors);
  checkNumber("contact_distance", &t->contact_distance, fallback.contact_distance, any, "finite",
              errors);
  if (t->warning_distance < t->contact_distance) {
    const double w = std::max(fallback.warning_distance, t->contact_distance);
    errors->push_back("warning_distance = " + std::to_string(t->warning_distance) +
                      " (must be >= contact_distance = " + std::to_string(t->contact_distance) +
                      "); using " + std::to_string(w));
    t->warning_distance = w;
  }
  checkNumber("hysteresis", &t->hysteresis, fallback.hysteresis, non_negative, ">= 0", errors);
  checkNumber("pose_timeout", &t->pose_timeout, fallback.pose_timeout, positive, "> 0", errors);
  checkNumber("ttc_horizon", &t->ttc_horizon, fallback.ttc_horizon, positive, "> 0", errors);
  checkNumber("min_check_interval", &t->min_check_interval, fallback.min_check_interval,
              non_negative, ">= 0", errors);
  checkNumber("marker_rate", &t->marker_rate, fallback.marker_rate, positive, "> 0", errors);
  if (!core::parseBackend(t->backend)) {
    errors->push_back("backend = '" + t->backend + "' (must be gjk or libccd); using " +
                      fallback.backend);
    t->backend = fallback.backend;
  }
}

world::Settings worldSettings(const Tunables& t, world::Settings limits) {
  limits.warning_distance = t.warning_distance;
  limits.contact_distance = t.contact_distance;
  limits.hysteresis = t.hysteresis;
  limits.pose_timeout = t.pose_timeout;
  limits.ttc_horizon = t.ttc_horizon;
  limits.exact_min_distance = t.exact_min_distance;
  limits.backend = core::parseBackend(t.backend).value_or(core::BackendType::Gjk);
  return limits;
}

MarkerOptions markerOptions(const Tunables& t) {
  MarkerOptions o;
  o.max_rate = t.marker_rate;
  // Arrays come at least as often as the slower of the heartbeat and the marker rate; a marker
  // lives for three such periods, and at least 1 s.
  o.lifetime = std::max(1.0, 3.0 / std::min(t.rate, t.marker_rate));
  o.frame_locked = t.marker_frame_locked;
  return o;
}

std::string differences(const Tunables& before, const Tunables& after) {
  std::ostringstream os;
  os << std::boolalpha;
  const auto diff = [&](const char* key, const auto& a, const auto& b) {
    if (a == b) return;
    if (os.tellp() > 0) os << ", ";
    os << key << " " << a << " -> " << b;
  };
  diff("rate", before.rate, after.rate);
  diff("min_check_interval", before.min_check_interval, after.min_check_interval);
  diff("check_on_pose", before.check_on_pose, after.check_on_pose);
  diff("check_on_tf", before.check_on_tf, after.check_on_tf);
  diff("warning_distance", before.warning_distance, after.warning_distance);
  diff("contact_distance", before.contact_distance, after.contact_distance);
  diff("hysteresis", before.hysteresis, after.hysteresis);
  diff("pose_timeout", before.pose_timeout, after.pose_timeout);
  diff("ttc_horizon", before.ttc_horizon, after.ttc_horizon);
  diff("exact_min_distance", before.exact_min_distance, after.exact_min_distance);
  diff("backend", before.backend, after.backend);
  diff("publish_markers", before.publish_markers, after.publish_markers);
  diff("marker_rate", before.marker_rate, after.marker_rate);
  diff("marker_frame_locked", before.marker_frame_locked, after.marker_frame_locked);
  return os.str();
}

}  // namespace ros_layer
}  // namespace collision_monitor
