// Replays every input of fuzz/regressions/world (inputs that once failed the world model's fuzzer)
// and the seed corpus fuzz/corpus/world through the fuzzer's own checks (fuzz/world_case.h),
// built with g++ in the normal suite. Each regression file has a line in
// fuzz/regressions/world/README.md on the bug it pins. Also checks the fuzzer's reference where it
// has a method of its own: its distances of boxes and hulls (coreDistance()) against qhull's
// Minkowski difference (oracle::solveMinkowski()).
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
      hulls = 0, curved = 0, certified = 0, twists = 0, estimated = 0, rates_twists = 0, checks = 0,
      events = 0, collisions = 0, ttc_checked = 0, ttc_finite = 0, ttc_estimated = 0,
      ttc_rotating = 0, ttc_lower_bound = 0, ttc_skipped = 0;
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
    t.curved += out.curved && out.exact;
    t.certified += out.certified;
    t.twists += out.twists && out.exact;
    t.estimated += out.estimated && out.exact;
    t.rates_twists += out.twists && out.rates;
    t.ttc_checked += out.ttc_checked;
    t.ttc_finite += out.ttc_finite;
    t.ttc_estimated += out.ttc_estimated;
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
      "clock going back, %d with bodies that turn, %d of capsules, %d with boxes (%d with hulls, "
      "%d with cylinders, cones or ellipsoids: %d of their distances certified), "
      "%d with twists (%d with estimate_twists), "
      "%d of those in frames with rates), %d checks, %d events (%d COLLISION_BEGIN), %d times to "
      "collision held to the reference (%d finite and not 0, %d of them with an estimated twist; "
      "%d of a turning body, %d of those a lower bound, the least %.4f of the time to the "
      "contact; %d left unjudged), slowest %.1f ms\n",
      dir.c_str(), t.files, t.exact, t.frames, t.clock_back, t.turns, t.capsules, t.boxes, t.hulls,
      t.curved, t.certified, t.twists, t.estimated, t.rates_twists, t.checks, t.events,
      t.collisions, t.ttc_checked, t.ttc_finite, t.ttc_estimated, t.ttc_rotating, t.ttc_lower_bound,
      t.ttc_least_fraction, t.ttc_skipped, 1e3 * t.slowest);
  return t;
}

}  // namespace

TEST(WorldFuzzRegressions, EveryFailingInputPasses) {
  const Tally t = replay(CM_FUZZ_DIR "/regressions/world");
  // Regression inputs are only ever added (8 on 2026-12-03), and all but one (of the checks held
  // in every mode) reach the reference.
  EXPECT_GE(t.files, 8) << "regression inputs lost from " CM_FUZZ_DIR "/regressions/world";
  EXPECT_GE(t.exact, 7);
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
  // Cylinders, cones and ellipsoids: the core's distances of them certified (237 a seed).
  EXPECT_GE(t.curved, t.files / 40);
  EXPECT_GE(t.certified, 50 * t.files);
  EXPECT_GE(t.rates_twists, t.files / 40);
  EXPECT_GE(t.ttc_checked, 4 * t.files);
  EXPECT_GE(t.ttc_finite, t.files / 4);
  // estimate_twists: in about half of the cases with twists, finite times from estimated ones.
  EXPECT_GE(t.estimated, t.files / 80);
  EXPECT_GE(t.ttc_estimated, t.files / 8);
  EXPECT_GE(t.ttc_rotating, t.files / 2);
  // The reference's search seldom gives up: 109 of 5,718 in the seeds (1.9 %; a case's searches
  // run out of work sooner where its pairs have hulls, which weigh 20 to 360 units a distance).
  EXPECT_LE(100 * t.ttc_skipped, 3 * t.ttc_checked);
  EXPECT_GE(t.checks, 10 * t.files);
  EXPECT_GE(t.collisions, t.files);
}

// coreDistance() against oracle::solveMinkowski() (qhull on the Minkowski difference, nothing in
// common), each pair both ways round, to 1e-9 m.
namespace {

using cm_fuzz_world::PlacedCore;
using cm_fuzz_world::Vec3;

/// Random cores for the reference checks: positions within a 1 m cube, any rotation, box half
/// sides from 1 mm to 0.5 m.
class RandomCores {
 public:
  explicit RandomCores(std::uint64_t seed) : rng_(seed) {}

  Eigen::Matrix3d turn() {
    return Eigen::Quaterniond(g_(rng_), g_(rng_), g_(rng_), g_(rng_))
        .normalized()
        .toRotationMatrix();
  }
  Vec3 position() { return Vec3(u_(rng_), u_(rng_), u_(rng_)); }
  Vec3 half() { return Vec3(side_(rng_), side_(rng_), side_(rng_)); }
  bool coin() { return coin_(rng_); }

  void box(PlacedCore* core, oracle::Shape* shape) {
    core->box = true;
    core->centre = position();
    core->axes = turn();
    core->half = half();
    polytope(core->vertices(), shape);
  }
  /// A hull as fuzz_world makes one (hullPoints(), RefPart::hull, placed as placedCore() does:
  /// qhull's hull, moved without a new qhull run): of a box's corners or four of them (a
  /// tetrahedron), each pulled in at random.
  void hull(PlacedCore* core, oracle::Shape* shape) {
    const Vec3 h = half();
    const bool tetrahedron = coin();
    const std::vector<Vec3> points =
        cm_fuzz_world::hullPoints(h, tetrahedron, static_cast<std::uint8_t>(byte_(rng_)));
    const Eigen::Matrix3d R = turn();
    const Vec3 t = position();
    core->hull = oracle::makeHull(points).transformed(R, t);
    polytope(core->hull->points, shape);
  }
  /// A segment, or a point when `point`.
  void segment(bool point, PlacedCore* core, oracle::Shape* shape) {
    core->a = position();
    core->b = point ? core->a : position();
    shape->kind = point ? oracle::Shape::Point : oracle::Shape::Segment;
    shape->core = core->vertices();
  }

 private:
  static void polytope(const std::vector<Vec3>& points, oracle::Shape* shape) {
    shape->kind = oracle::Shape::Poly;
    shape->core = points;
    shape->finish();
  }
  std::mt19937_64 rng_;
  std::uniform_real_distribution<double> u_{-0.5, 0.5}, side_{0.001, 0.5};
  std::normal_distribution<double> g_;
  std::bernoulli_distribution coin_;
  std::uniform_int_distribution<int> byte_{0, 255};
};

/// `pairs` pairs made by make(k, &p, &sp, &q, &sq): coreDistance() both ways round against
/// oracle::solveMinkowski(), to 1e-9 m, a tenth to nine tenths of them overlapping.
template <class Make>
void expectMinkowskiDistances(int pairs, Make make) {
  int overlapping = 0, worst_at = -1;
  double worst = 0.0;
  for (int k = 0; k < pairs; ++k) {
    PlacedCore p, q;
    oracle::Shape sp, sq;
    make(k, &p, &sp, &q, &sq);
    const double want = oracle::solveMinkowski(sp, sq).distance;
    const double error = std::max(std::abs(cm_fuzz_world::coreDistance(p, q) - want),
                                  std::abs(cm_fuzz_world::coreDistance(q, p) - want));
    overlapping += want < 0.0;
    if (error > worst) worst = error, worst_at = k;
  }
  std::printf("%d pairs, %d overlapping; largest difference %.3g m (pair %d)\n", pairs, overlapping,
              worst, worst_at);
  EXPECT_LE(worst, 1e-9) << "pair " << worst_at;
  EXPECT_GE(overlapping, pairs / 10);
  EXPECT_LE(overlapping, pairs * 9 / 10);
}

}  // namespace

// Boxes against boxes, segments and points.
TEST(WorldFuzzReference, BoxDistancesMatchTheMinkowskiDifferencesHull) {
  RandomCores r(46);
  expectMinkowskiDistances(
      6000, [&](int k, PlacedCore* p, oracle::Shape* sp, PlacedCore* q, oracle::Shape* sq) {
        r.box(p, sp);
        if (k % 3 == 0) {
          r.box(q, sq);
        } else {
          r.segment(k % 3 == 2, q, sq);
        }
      });
}

// Hulls against hulls, boxes, segments and points.
TEST(WorldFuzzReference, HullDistancesMatchTheMinkowskiDifferencesHull) {
  RandomCores r(48);
  expectMinkowskiDistances(
      4000, [&](int k, PlacedCore* p, oracle::Shape* sp, PlacedCore* q, oracle::Shape* sq) {
        r.hull(p, sp);
        if (k % 4 == 0) {
          r.hull(q, sq);
        } else if (k % 4 == 1) {
          r.box(q, sq);
        } else {
          r.segment(k % 4 == 3, q, sq);
        }
      });
}
