// Pure per-pair logic: status machine with hysteresis, the event scheme, the CLEAR cutoff and
// the time to collision. No geometry core involved.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "collision_monitor/world/pair_logic.h"

namespace collision_monitor {
namespace world {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Thresholds that are exact in binary, so the boundaries are tested exactly:
// w = 1/16, h = 1/128, w + h = 0.0703125, c + h = 0.0078125.
Settings dyadicSettings() {
  Settings s;
  s.warning_distance = 0.0625;
  s.contact_distance = 0.0;
  s.hysteresis = 0.0078125;
  return s;
}

using S = PairStatus;
using E = EventType;

struct Step {
  double d;
  S expected;
};

// Runs the status machine over `steps` from CLEAR, checks every status and returns the events.
std::vector<E> run(const Settings& s, const std::vector<Step>& steps) {
  std::vector<E> events;
  S status = S::Clear;
  for (std::size_t k = 0; k < steps.size(); ++k) {
    const S next = nextStatus(status, steps[k].d, s);
    EXPECT_EQ(static_cast<int>(next), static_cast<int>(steps[k].expected))
        << "step " << k << " d = " << steps[k].d;
    E out[2];
    const int n = transitionEvents(status, next, out);
    for (int i = 0; i < n; ++i)
      events.push_back(out[i]);
    status = next;
  }
  return events;
}

TEST(PairLogic, HysteresisSequenceGivesExactEvents) {
  const std::vector<Step> steps = {
      {0.25, S::Clear},           //
      {0.0625, S::Clear},         // exactly w: not below it
      {0.06, S::Warning},         // WARNING_BEGIN
      {0.07, S::Warning},         // inside the band: stays
      {0.0625, S::Warning},       //
      {0.0703125, S::Clear},      // exactly w + h: leaves. WARNING_END
      {0.07, S::Clear},           // from CLEAR the band does not count
      {0.0, S::Collision},        // exactly c: COLLISION_BEGIN (no WARNING on the way)
      {0.0078125, S::Collision},  // exactly c + h: stays
      {0.0078126, S::Warning},    // past c + h, below w + h: COLLISION_END, WARNING_BEGIN
      {0.0, S::Collision},        // WARNING_END, COLLISION_BEGIN
      {-0.5, S::Collision},       // penetration
      {0.1, S::Clear},            // COLLISION_END
      {kNaN, S::Unknown},         // UNKNOWN_BEGIN
      {0.03, S::Warning},         // UNKNOWN_END, WARNING_BEGIN
      {kNaN, S::Unknown},         // WARNING_END, UNKNOWN_BEGIN
      {0.2, S::Clear},            // UNKNOWN_END
  };
  const std::vector<E> expected = {
      E::WarningBegin, E::WarningEnd,     E::CollisionBegin, E::CollisionEnd, E::WarningBegin,
      E::WarningEnd,   E::CollisionBegin, E::CollisionEnd,   E::UnknownBegin, E::UnknownEnd,
      E::WarningBegin, E::WarningEnd,     E::UnknownBegin,   E::UnknownEnd};
  EXPECT_EQ(run(dyadicSettings(), steps), expected);
}

TEST(PairLogic, NoChatterAroundTheWarningThreshold) {
  // A distance wobbling around w by less than h: one WARNING_BEGIN and nothing else.
  const Settings s = dyadicSettings();
  std::vector<Step> steps = {{0.2, S::Clear}, {0.0620, S::Warning}};
  for (int k = 0; k < 50; ++k) {
    steps.push_back({k % 2 ? 0.0690 : 0.0600, S::Warning});
  }
  EXPECT_EQ(run(s, steps), std::vector<E>{E::WarningBegin});
}

TEST(PairLogic, NoChatterAroundTheContactThreshold) {
  const Settings s = dyadicSettings();
  std::vector<Step> steps = {{0.03, S::Warning}, {-0.001, S::Collision}};
  for (int k = 0; k < 50; ++k) {
    steps.push_back({k % 2 ? 0.0070 : -0.0001, S::Collision});
  }
  EXPECT_EQ(run(s, steps), (std::vector<E>{E::WarningBegin, E::WarningEnd, E::CollisionBegin}));
}

TEST(PairLogic, BeginsAndEndsBalanceOverARandomWalk) {
  // Every BEGIN of a type is closed by an END of the same type before the next BEGIN of it.
  const Settings s = dyadicSettings();
  S status = S::Clear;
  int open[7] = {0, 0, 0, 0, 0, 0, 0};
  double d = 0.2;
  unsigned x = 12345u;
  int transitions = 0;
  for (int k = 0; k < 20000; ++k) {
    x = x * 1664525u + 1013904223u;
    d += (static_cast<int>((x >> 8) % 2001u) - 1000) * 1e-5;
    d = std::min(0.2, std::max(-0.05, d));
    const double dk = (x % 97 == 0) ? kNaN : d;
    const S next = nextStatus(status, dk, s);
    E out[2];
    const int n = transitionEvents(status, next, out);
    transitions += n > 0;
    for (int i = 0; i < n; ++i) {
      const int t = static_cast<int>(out[i]);
      if (t % 2 == 1) {
        EXPECT_EQ(open[t], 0);
        ++open[t];
      } else {
        EXPECT_EQ(open[t - 1], 1);
        --open[t - 1];
      }
    }
    status = next;
  }
  EXPECT_GT(transitions, 100);  // the walk was meaningful
}

TEST(PairLogic, ClearCutoffIsSafe) {
  const Settings s = dyadicSettings();
  EXPECT_EQ(clearCutoff(S::Clear, s), 0.0625);
  EXPECT_EQ(clearCutoff(S::Unknown, s), 0.0625);
  EXPECT_EQ(clearCutoff(S::Warning, s), 0.0703125);
  EXPECT_EQ(clearCutoff(S::Collision, s), 0.0703125);
  EXPECT_EQ(clearCutoffAny(s), 0.0703125);
  // Beyond the cutoff the verdict is CLEAR, for every previous status.
  for (S prev : {S::Clear, S::Warning, S::Collision, S::Unknown}) {
    for (int k = 0; k <= 4000; ++k) {
      const double d = -0.1 + k * 1e-4;
      if (d > clearCutoff(prev, s)) {
        EXPECT_EQ(nextStatus(prev, d, s), S::Clear) << d;
      }
    }
  }
  // Contact threshold above the warning one still yields a safe cutoff.
  Settings odd = s;
  odd.contact_distance = 0.125;
  EXPECT_EQ(clearCutoff(S::Clear, odd), 0.125);
  EXPECT_EQ(nextStatus(S::Clear, 0.125, odd), S::Collision);
  EXPECT_EQ(nextStatus(S::Collision, 0.1328125, odd), S::Collision);  // c + h exactly
  EXPECT_EQ(nextStatus(S::Collision, 0.14, odd), S::Clear);
}

PairResult headOn(double distance) {
  PairResult r;
  r.distance = distance;
  r.point_a = Vec3(1, 0, 0);
  r.point_b = Vec3(1 + distance, 0, 0);
  r.normal = Vec3(1, 0, 0);
  return r;
}

TEST(PairLogic, FlipPairSwapsRoles) {
  PairResult r = headOn(3.0);
  r.body_a = "a";
  r.body_b = "b";
  flipPair(&r);
  EXPECT_EQ(r.body_a, "b");
  EXPECT_EQ(r.body_b, "a");
  EXPECT_EQ(r.point_a, Vec3(4, 0, 0));
  EXPECT_EQ(r.point_b, Vec3(1, 0, 0));
  EXPECT_EQ(r.normal, Vec3(-1, 0, 0));
}

}  // namespace
}  // namespace world
}  // namespace collision_monitor
