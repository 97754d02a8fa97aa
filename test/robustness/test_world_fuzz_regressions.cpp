// Replays every input of fuzz/regressions/world (inputs that once failed the world model's fuzzer)
// and the seed corpus fuzz/corpus/world through the fuzzer's own checks (fuzz/world_case.h),
// built with g++ in the normal suite. Each regression file has a line in
// fuzz/regressions/world/README.md on the bug it pins. Also checks the fuzzer's reference where it
// has a method of its own: its distances of boxes (coreDistance()) against qhull's Minkowski
// difference (oracle::solveMinkowski()).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "fuzz_inputs.h"
#include "world_case.h"

namespace fs = std::filesystem;

namespace {

using cm_fuzz_inputs::bytes;
using cm_fuzz_inputs::inputs;

struct Tally {
  int files = 0, exact = 0, frames = 0, turns = 0, clock_back = 0, capsules = 0, boxes = 0,
      hulls = 0, twists = 0, rates_twists = 0, checks = 0, events = 0, collisions = 0,
      ttc_checked = 0, ttc_finite = 0, ttc_rotating = 0, ttc_lower_bound = 0, ttc_skipped = 0;
  double ttc_least_fraction = 1.0, slowest = 0.0;
};

Tally replay(const std::string& dir) {
  Tally t;
  for (const fs::path& p : inputs(dir)) {
    const std::vector<std::uint8_t> data = bytes(p);
    const cm_fuzz_world::Outcome out = cm_fuzz_world::runCase(data.data(), data.size());
    EXPECT_EQ(out.failure, "") << p.filename().string();
    ++t.files;
    t.exact += out.exact;
    t.frames += out.frames;
    t.turns += out.turns && out.exact;
    t.clock_back += out.clock_back;
    t.capsules += out.capsules && out.exact;
    t.boxes += out.boxes && out.exact;
    t.hulls += out.hulls && out.exact;
    t.twists += out.twists && out.exact;
    t.rates_twists += out.twists && out.rates;
    t.ttc_checked += out.ttc_checked;
    t.ttc_finite += out.ttc_finite;
    t.ttc_rotating += out.ttc_rotating;
    t.ttc_lower_bound += out.ttc_lower_bound;
    t.ttc_skipped += out.ttc_skipped;
    t.ttc_least_fraction = std::min(t.ttc_least_fraction, out.ttc_least_fraction);
    t.checks += out.checks;
    t.events += out.events;
    t.collisions += out.collisions;
    t.slowest = std::max(t.slowest, out.seconds);
  }
  std::printf(
      "%s: %d inputs (%d against the reference model, %d of them in frames, %d of those with the "
      "clock going back, %d with bodies that turn, %d of capsules, %d with boxes (%d with hulls), "
      "%d with twists, "
      "%d of those in frames with rates), %d checks, %d events (%d COLLISION_BEGIN), %d times to "
      "collision held to the reference (%d finite and not 0; %d of a turning body, %d of those a "
      "lower bound, the least %.4f of the time to the contact; %d left unjudged), slowest %.1f "
      "ms\n",
      dir.c_str(), t.files, t.exact, t.frames, t.clock_back, t.turns, t.capsules, t.boxes, t.hulls,
      t.twists, t.rates_twists, t.checks, t.events, t.collisions, t.ttc_checked, t.ttc_finite,
      t.ttc_rotating, t.ttc_lower_bound, t.ttc_least_fraction, t.ttc_skipped, 1e3 * t.slowest);
  return t;
}

}  // namespace

TEST(WorldFuzzRegressions, EveryFailingInputPasses) {
  const Tally t = replay(CM_FUZZ_DIR "/regressions/world");
  // Regression inputs are only ever added (7 on 2026-11-30), and all but one (of the checks held
  // in every mode) reach the reference.
  EXPECT_GE(t.files, 7) << "regression inputs lost from " CM_FUZZ_DIR "/regressions/world";
  EXPECT_GE(t.exact, 6);
}

TEST(WorldFuzzRegressions, SeedCorpusPassesAndIsMeaningful) {
  const Tally t = replay(CM_FUZZ_DIR "/corpus/world");
  ASSERT_GE(t.files, 100);
  // The seeds reach the reference model (catch-up too: frames, in some with the clock going
  // back; bodies that turn; capsules; boxes; twists, in frames with rates too, their times to
  // collision finite and of turning bodies among them) and the events, collisions among them.
  EXPECT_GE(t.exact, t.files / 4);
  EXPECT_GE(t.frames, t.files / 8);
  EXPECT_GE(t.clock_back, t.files / 40);
  EXPECT_GE(t.turns, t.files / 16);
  EXPECT_GE(t.capsules, t.files / 40);
  EXPECT_GE(t.twists, t.files / 40);
  EXPECT_GE(t.boxes, t.files / 40);
  EXPECT_GE(t.hulls, t.files / 40);
  EXPECT_GE(t.rates_twists, t.files / 40);
  EXPECT_GE(t.ttc_checked, 4 * t.files);
  EXPECT_GE(t.ttc_finite, t.files / 4);
  EXPECT_GE(t.ttc_rotating, t.files / 2);
  EXPECT_LE(100 * t.ttc_skipped, t.ttc_checked);  // the reference's search seldom gives up
  EXPECT_GE(t.checks, 10 * t.files);
  EXPECT_GE(t.collisions, t.files);
}

// coreDistance() against oracle::solveMinkowski() (qhull on the Minkowski difference, nothing in
// common): boxes (half sides 1 mm to 0.5 m, any rotation) against boxes,
// segments and points (all within a 1 m cube), to 1e-9 m.
TEST(WorldFuzzReference, BoxDistancesMatchTheMinkowskiDifferencesHull) {
  std::mt19937_64 rng(46);
  std::uniform_real_distribution<double> u(-0.5, 0.5), side(0.001, 0.5);
  std::normal_distribution<double> g;
  const auto box = [&](cm_fuzz_world::PlacedCore* core, oracle::Shape* shape) {
    core->box = true;
    core->centre = cm_fuzz_world::Vec3(u(rng), u(rng), u(rng));
    core->axes = Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
    core->half = cm_fuzz_world::Vec3(side(rng), side(rng), side(rng));
    shape->kind = oracle::Shape::Poly;
    shape->core = core->vertices();
    shape->finish();
  };
  int overlapping = 0, worst_at = -1;
  double worst = 0.0;
  constexpr int kPairs = 6000;
  for (int k = 0; k < kPairs; ++k) {
    cm_fuzz_world::PlacedCore p, q;
    oracle::Shape sp, sq;
    box(&p, &sp);
    if (k % 3 == 0) {
      box(&q, &sq);
    } else {
      q.a = cm_fuzz_world::Vec3(u(rng), u(rng), u(rng));
      q.b = k % 3 == 1 ? cm_fuzz_world::Vec3(u(rng), u(rng), u(rng)) : q.a;
      sq.kind = q.a == q.b ? oracle::Shape::Point : oracle::Shape::Segment;
      sq.core = q.vertices();
    }
    const double got = cm_fuzz_world::coreDistance(p, q);
    const double want = oracle::solveMinkowski(sp, sq).distance;
    // Both ways round.
    const double back = cm_fuzz_world::coreDistance(q, p);
    overlapping += want < 0.0;
    const double error = std::max(std::abs(got - want), std::abs(back - want));
    if (error > worst) worst = error, worst_at = k;
  }
  std::printf("%d pairs, %d overlapping; largest difference %.3g m (pair %d)\n", kPairs,
              overlapping, worst, worst_at);
  EXPECT_LE(worst, 1e-9) << "pair " << worst_at;
  EXPECT_GE(overlapping, kPairs / 10);
  EXPECT_LE(overlapping, kPairs * 9 / 10);
}

// The same for hulls as fuzz_world makes them (RefPart::hull, placed as placedCore() does: qhull's
// hull of 4 to 8 points, moved without a new qhull run): the convex hull of a box's corners (half
// sides 1 mm to 0.5 m), each pulled in to 40 % at random, or of four of them (a tetrahedron),
// turned and moved at random, against hulls, boxes, segments and points, to 1e-9 m.
TEST(WorldFuzzReference, HullDistancesMatchTheMinkowskiDifferencesHull) {
  std::mt19937_64 rng(48);
  std::uniform_real_distribution<double> u(-0.5, 0.5), side(0.001, 0.5);
  std::normal_distribution<double> g;
  std::bernoulli_distribution coin;
  const auto turn = [&] {
    return Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix();
  };
  const auto hull = [&](cm_fuzz_world::PlacedCore* core, oracle::Shape* shape) {
    const cm_fuzz_world::Vec3 half(side(rng), side(rng), side(rng));
    const bool tetrahedron = coin(rng);
    std::vector<cm_fuzz_world::Vec3> points;
    for (int c = 0; c < 8; ++c) {
      if (tetrahedron && ((c & 1) + ((c >> 1) & 1) + ((c >> 2) & 1)) % 2) continue;
      const cm_fuzz_world::Vec3 sign(c & 1 ? 1.0 : -1.0, c & 2 ? 1.0 : -1.0, c & 4 ? 1.0 : -1.0);
      points.push_back((coin(rng) ? 0.4 : 1.0) * sign.cwiseProduct(half));
    }
    core->hull =
        oracle::makeHull(points).transformed(turn(), cm_fuzz_world::Vec3(u(rng), u(rng), u(rng)));
    shape->kind = oracle::Shape::Poly;
    shape->core = core->hull->points;
    shape->finish();
  };
  const auto box = [&](cm_fuzz_world::PlacedCore* core, oracle::Shape* shape) {
    core->box = true;
    core->centre = cm_fuzz_world::Vec3(u(rng), u(rng), u(rng));
    core->axes = turn();
    core->half = cm_fuzz_world::Vec3(side(rng), side(rng), side(rng));
    shape->kind = oracle::Shape::Poly;
    shape->core = core->vertices();
    shape->finish();
  };
  int overlapping = 0, worst_at = -1;
  double worst = 0.0;
  constexpr int kPairs = 4000;
  for (int k = 0; k < kPairs; ++k) {
    cm_fuzz_world::PlacedCore p, q;
    oracle::Shape sp, sq;
    hull(&p, &sp);
    if (k % 4 == 0) {
      hull(&q, &sq);
    } else if (k % 4 == 1) {
      box(&q, &sq);
    } else {
      q.a = cm_fuzz_world::Vec3(u(rng), u(rng), u(rng));
      q.b = k % 4 == 2 ? cm_fuzz_world::Vec3(u(rng), u(rng), u(rng)) : q.a;
      sq.kind = q.a == q.b ? oracle::Shape::Point : oracle::Shape::Segment;
      sq.core = q.vertices();
    }
    const double got = cm_fuzz_world::coreDistance(p, q);
    const double want = oracle::solveMinkowski(sp, sq).distance;
    const double back = cm_fuzz_world::coreDistance(q, p);
    overlapping += want < 0.0;
    const double error = std::max(std::abs(got - want), std::abs(back - want));
    if (error > worst) worst = error, worst_at = k;
  }
  std::printf("%d pairs, %d overlapping; largest difference %.3g m (pair %d)\n", kPairs,
              overlapping, worst, worst_at);
  EXPECT_LE(worst, 1e-9) << "pair " << worst_at;
  EXPECT_GE(overlapping, kPairs / 10);
  EXPECT_LE(overlapping, kPairs * 9 / 10);
}
