#include "collision_monitor/ros/tunables.h"

#include <algorithm>
#include <cmath>
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

bool raiseWarningToContact(Tunables* t) {
  if (!std::isfinite(t->contact_distance) || t->contact_distance <= t->warning_distance)
    return false;
  t->warning_distance = t->contact_distance;
  return true;
}

world::Settings worldSettings(const Tunables& t, world::Settings limits) {
  limits.warning_distance = t.warning_distance;
  limits.contact_distance = t.contact_distance;
  limits.hysteresis = t.hysteresis;
  limits.pose_timeout = t.pose_timeout;
  limits.ttc_horizon = t.ttc_horizon;
  limits.exact_min_distance = t.exact_min_distance;
  limits.align_poses = t.align_poses;
  limits.estimate_twists = t.estimate_twists;
  limits.backend = core::parseBackend(t.backend).value_or(core::BackendType::Gjk);
  return limits;
}

MarkerOptions markerOptions(const Tunables& t) {
  MarkerOptions o;
  o.max_rate = t.marker_rate;
  // Arrays come at least as often as the slower of the heartbeat and the marker rate; a marker
  // lives for three such periods, at least 1 s and at most kMaxMarkerLifetime (ros::Duration
  // throws beyond 2^31 s: rate 1e-9 Hz made every check with a marker subscriber fail).
  o.lifetime = std::clamp(3.0 / std::min(t.rate, t.marker_rate), 1.0, kMaxMarkerLifetime);
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
#define CM_DIFF(field) diff(#field, before.field, after.field);
  CM_TUNABLES(CM_DIFF)
#undef CM_DIFF
  return os.str();
}

}  // namespace ros_layer
}  // namespace collision_monitor
