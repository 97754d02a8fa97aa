// The parameters that change while the node runs: the rules every value is checked by, at
// start-up (fallback: the defaults) and on a dynamic_reconfigure change (fallback: the values in
// force). No master.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "collision_monitor/ros/tunables.h"

namespace collision_monitor {
namespace ros_layer {
namespace {

TEST(Tunables, ValidValuesPassUnchanged) {
  Tunables t;
  t.rate = 0.25;
  t.min_check_interval = 0.0;
  t.warning_distance = -0.01;  // may be negative, as long as contact is not above it
  t.contact_distance = -0.02;
  t.hysteresis = 0.0;
  t.pose_timeout = 1e-3;
  t.ttc_horizon = 1e6;
  t.backend = "libccd";
  t.marker_rate = 100.0;
  const Tunables before = t;
  std::vector<std::string> errors;
  validate(&t, Tunables(), &errors);
  EXPECT_TRUE(errors.empty()) << errors.front();
  EXPECT_EQ(differences(before, t), "");
}

TEST(Tunables, InvalidValuesTakeTheFallbackAndSayWhy) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  Tunables in_force;
  in_force.rate = 20.0;
  in_force.hysteresis = 0.01;
  in_force.backend = "libccd";
  Tunables t = in_force;
  t.rate = -5.0;
  t.hysteresis = -1.0;
  t.pose_timeout = 0.0;
  t.ttc_horizon = nan;
  t.contact_distance = inf;
  t.min_check_interval = -0.1;
  t.marker_rate = 0.0;
  t.backend = "bullet";
  std::vector<std::string> errors;
  validate(&t, in_force, &errors);
  const std::vector<std::string> expected = {
      "rate = -5.000000 (must be > 0); using 20.000000",
      "contact_distance = inf (must be finite); using 0.000000",
      "hysteresis = -1.000000 (must be >= 0); using 0.010000",
      "pose_timeout = 0.000000 (must be > 0); using 0.500000",
      "ttc_horizon = nan (must be > 0); using 10.000000",
      "min_check_interval = -0.100000 (must be >= 0); using 0.002000",
      "marker_rate = 0.000000 (must be > 0); using 15.000000",
      "backend = 'bullet' (must be gjk or libccd); using libccd"};
  EXPECT_EQ(errors, expected);
  EXPECT_EQ(differences(in_force, t), "");  // every value back to the one in force
}

TEST(Tunables, WarningBelowContact) {
  // At start-up: the default warning distance, unless the contact distance is beyond it.
  Tunables t;
  t.warning_distance = -0.1;
  std::vector<std::string> errors;
  validate(&t, Tunables(), &errors);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0],
            "warning_distance = -0.100000 (must be >= contact_distance = 0.000000); using "
            "0.050000");
  EXPECT_EQ(t.warning_distance, 0.05);
  // A change that raises contact above the warning in force: the contact distance is taken, the
  // warning distance becomes it.
  Tunables in_force;
  in_force.warning_distance = 0.1;
  t = in_force;
  t.contact_distance = 0.3;
  errors.clear();
  validate(&t, in_force, &errors);
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(t.contact_distance, 0.3);
  EXPECT_EQ(t.warning_distance, 0.3);
  EXPECT_EQ(differences(in_force, t), "warning_distance 0.1 -> 0.3, contact_distance 0 -> 0.3");
}

TEST(Tunables, WarningEqualToContactIsValid) {
  // warning_distance must be >= contact_distance: equal (no warning band) is valid and kept.
  Tunables t;
  t.warning_distance = 0.2;
  t.contact_distance = 0.2;
  std::vector<std::string> errors;
  validate(&t, Tunables(), &errors);
  EXPECT_TRUE(errors.empty()) << errors.front();
  EXPECT_EQ(t.warning_distance, 0.2);
  EXPECT_EQ(t.contact_distance, 0.2);
}

TEST(Tunables, WorldSettingsKeepTheLimits) {
  world::Settings limits;
  limits.max_bodies = 7;
  limits.max_unknown_pairs = 3;
  Tunables t;
  t.warning_distance = 0.2;
  t.contact_distance = 0.01;
  t.hysteresis = 0.001;
  t.pose_timeout = 2.0;
  t.ttc_horizon = 3.0;
  t.exact_min_distance = false;
  t.align_poses = false;
  t.backend = "libccd";
  const world::Settings s = worldSettings(t, limits);
  EXPECT_EQ(s.max_bodies, 7u);
  EXPECT_EQ(s.max_unknown_pairs, 3u);
  EXPECT_EQ(s.warning_distance, 0.2);
  EXPECT_EQ(s.contact_distance, 0.01);
  EXPECT_EQ(s.hysteresis, 0.001);
  EXPECT_EQ(s.pose_timeout, 2.0);
  EXPECT_EQ(s.ttc_horizon, 3.0);
  EXPECT_FALSE(s.exact_min_distance);
  EXPECT_FALSE(s.align_poses);
  EXPECT_EQ(s.backend, core::BackendType::Libccd);
}

TEST(Tunables, MarkerLifetimeFollowsTheSlowerRate) {
  Tunables t;
  EXPECT_EQ(markerOptions(t).lifetime, 1.0);  // 3 / min(50, 15) = 0.2 s: at least 1 s
  EXPECT_EQ(markerOptions(t).max_rate, 15.0);
  t.rate = 0.5;
  EXPECT_EQ(markerOptions(t).lifetime, 6.0);
  t.marker_frame_locked = false;
  EXPECT_FALSE(markerOptions(t).frame_locked);
  t.rate = 1e-9;  // valid; ros::Duration(3e9 s) would throw
  EXPECT_EQ(markerOptions(t).lifetime, kMaxMarkerLifetime);
}

}  // namespace
}  // namespace ros_layer
}  // namespace collision_monitor
