/// \file
/// The parameters that may change while the monitor runs (dynamic_reconfigure, cfg/Monitor.cfg)
/// and the rules every value of them is checked by, at start-up and on each change. Pure: no
/// master needed, unit-tested directly.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "collision_monitor/ros/markers.h"
#include "collision_monitor/world/world_model.h"

namespace collision_monitor {
namespace ros_layer {

struct Tunables {
  double rate = 50.0;                 ///< Hz of the periodic check, > 0
  double min_check_interval = 0.002;  ///< s, >= 0
  bool check_on_pose = true;
  bool check_on_tf = true;
  double warning_distance = world::Settings().warning_distance;  ///< m, >= contact_distance
  double contact_distance = world::Settings().contact_distance;  ///< m, finite
  double hysteresis = world::Settings().hysteresis;              ///< m, >= 0
  double pose_timeout = world::Settings().pose_timeout;          ///< s, > 0
  double ttc_horizon = world::Settings().ttc_horizon;            ///< s, > 0
  bool exact_min_distance = world::Settings().exact_min_distance;
  bool align_poses = world::Settings().align_poses;
  bool estimate_twists = world::Settings().estimate_twists;
  std::string backend = "gjk";  ///< gjk or libccd
  bool publish_markers = true;
  double marker_rate = MarkerOptions().max_rate;  ///< Hz, > 0
  bool marker_frame_locked = MarkerOptions().frame_locked;
};

/// Applies X to the name of every Tunables field, in declaration order: for the code that treats
/// them alike (differences(), the node's conversions to and from cfg/Monitor.cfg's config, whose
/// names are the same).
// clang-format off
#define CM_TUNABLES(X)                                                                    \
  X(rate) X(min_check_interval) X(check_on_pose) X(check_on_tf)                           \
  X(warning_distance) X(contact_distance) X(hysteresis) X(pose_timeout) X(ttc_horizon)    \
  X(exact_min_distance) X(align_poses) X(estimate_twists) X(backend) X(publish_markers)     \
  X(marker_rate) X(marker_frame_locked)
// clang-format on

/// Checks `*value` (parameter `key`) by `valid` (`rule` says it in words): a non-finite or
/// invalid value is replaced by `fallback`, and why is appended to `errors`
/// ("rate = -5.000000 (must be > 0); using 50.000000").
template <class Valid>
void checkNumber(const std::string& key, double* value, double fallback, Valid valid,
                 const char* rule, std::vector<std::string>* errors) {
  if (std::isfinite(*value) && valid(*value)) return;
  errors->push_back(key + " = " + std::to_string(*value) + " (must be " + rule + "); using " +
                    std::to_string(fallback));
  *value = fallback;
}

/// Replaces every invalid value of `t` by `fallback`'s (the defaults at start-up, the values in
/// force on a change) and appends why to `errors`, one entry per value. warning_distance below
/// contact_distance becomes fallback's warning_distance, or contact_distance if that is larger.
void validate(Tunables* t, const Tunables& fallback, std::vector<std::string>* errors);

/// A warning_distance nobody chose (not set at start-up; left as it is by a change, which
/// dynamic_reconfigure's clients send with every value) follows a finite contact_distance above
/// it. Whether it was raised.
bool raiseWarningToContact(Tunables* t);

/// `limits` (max_* and the rest) with the world model's values of `t`. `t` must be valid.
world::Settings worldSettings(const Tunables& t, world::Settings limits);

/// s: the longest lifetime markerOptions() gives (body markers live five times as long).
constexpr double kMaxMarkerLifetime = 3600.0;

/// How ~markers look and how often they go out for `t`: at most marker_rate arrays a second; a
/// marker lives three periods of the slower of rate and marker_rate, at least 1 s and at most
/// kMaxMarkerLifetime.
MarkerOptions markerOptions(const Tunables& t);

/// "name old -> new" for every value that differs ("" when none).
std::string differences(const Tunables& before, const Tunables& after);

}  // namespace ros_layer
}  // namespace collision_monitor
