// Warm starts: a PairCache from the previous cycle makes the next query converge in fewer GJK
// iterations after a 1 mm / 1 degree move, with the same answer as a cold query (to 1e-12), and a
// stale or unrelated cache never changes the answer.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "collision_monitor/core/query.h"

namespace cm = collision_monitor::core;
using cm::ContactResult;
using cm::ConvexShape;
using cm::PairCache;
using cm::Transform3;
using cm::Vec3;

namespace {

/// Icosahedron (12 vertices) of circumradius ~0.5: a small hull (linear-scan support).
ConvexShape icosahedron() {
  const double p = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3> v;
  for (const double s1 : {-1.0, 1.0})
    for (const double s2 : {-1.0, 1.0}) {
      v.emplace_back(0, s1, s2 * p);
      v.emplace_back(s1, s2 * p, 0);
      v.emplace_back(s2 * p, 0, s1);
    }
  for (Vec3& x : v)
    x *= 0.5 / std::sqrt(1 + p * p);
  return ConvexShape::convexHull(v);
}

/// 80 points on a stretched sphere: a larger hull (hill-climbing support over qhull adjacency).
ConvexShape blob() {
  std::vector<Vec3> v;
  for (int i = 0; i < 80; ++i) {
    const double z = -1.0 + (2.0 * i + 1.0) / 80.0;
    const double r = std::sqrt(1.0 - z * z);
    const double phi = 2.399963229728653 * i;
    v.emplace_back(0.4 * r * std::cos(phi), 0.3 * r * std::sin(phi), 0.25 * z);
  }
  return ConvexShape::convexHull(v);
}

Transform3 pose(double angle, const Vec3& axis, const Vec3& t) {
  Transform3 T;
  T.R = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  T.t = t;
  return T;
}

/// B moved by `step` mm along a fixed direction and turned by `step` degrees about a fixed axis.
Transform3 moved(const Transform3& T, int step) {
  const double deg = M_PI / 180.0;
  Transform3 M = T;
  M.R = Eigen::AngleAxisd(step * deg, Vec3(0.3, 1.0, 0.5).normalized()).toRotationMatrix() * T.R;
  M.t = T.t + step * 1e-3 * Vec3(1, -1, 0.5).normalized();
  return M;
}

void expectSame(const ContactResult& warm, const ContactResult& cold) {
  EXPECT_EQ(warm.status, cold.status);
  EXPECT_NEAR(warm.distance, cold.distance, 1e-12);
  EXPECT_NEAR((warm.normal - cold.normal).norm(), 0.0, 1e-9);
}

struct Scenario {
  const char* name;
  ConvexShape a, b;
  Transform3 pa, pb;
};

std::vector<Scenario> scenarios() {
  const Transform3 pa = pose(0.3, Vec3(1, 2, 3), Vec3(0.1, 0.2, 0.3));
  return {
      {"separated hulls", icosahedron(), blob(), pa,
       pose(1.1, Vec3(-1, 0.5, 2), Vec3(0.9, 0.3, 0.4))},
      {"penetrating hulls", icosahedron(), blob(), pa,
       pose(1.1, Vec3(-1, 0.5, 2), Vec3(0.55, 0.25, 0.35))},
      {"separated boxes", ConvexShape::box(Vec3(1, 0.5, 0.3)), ConvexShape::box(Vec3(0.4, 0.4, 2)),
       pa, pose(0.7, Vec3(1, 1, 0), Vec3(1.4, 0.1, 0.2))},
      {"capsule and hull", ConvexShape::capsule(1.0, 0.1), blob(), pa,
       pose(0.4, Vec3(0, 1, 1), Vec3(0.75, 0.2, 0.3))},
  };
}

}  // namespace

TEST(WarmStart, OneMillimetreOneDegreeConvergesFasterWithTheSameAnswer) {
  for (const Scenario& s : scenarios()) {
    SCOPED_TRACE(s.name);
    PairCache cache;
    const ContactResult first = cm::signedDistance(s.a, s.pa, s.b, s.pb, &cache);
    ASSERT_NE(first.status, cm::Status::FailedToConverge);
    ASSERT_GT(cache.size, 0);
    int warm_total = 0;
    int cold_total = 0;
    for (int step = 1; step <= 20; ++step) {
      const Transform3 pb = moved(s.pb, step);
      const ContactResult cold = cm::signedDistance(s.a, s.pa, s.b, pb);
      const ContactResult warm = cm::signedDistance(s.a, s.pa, s.b, pb, &cache);
      expectSame(warm, cold);
      warm_total += warm.gjk_iterations;
      cold_total += cold.gjk_iterations;
      if (step == 1) {
        EXPECT_LT(warm.gjk_iterations, cold.gjk_iterations);
        EXPECT_LE(warm.gjk_iterations, 3);
      }
    }
    EXPECT_LT(warm_total, cold_total);
    EXPECT_LE(warm_total, 3 * 20);  // "a few" iterations per cycle on average
  }
}

TEST(WarmStart, SamePoseAgainNeedsAtMostOneIteration) {
  for (const Scenario& s : scenarios()) {
    SCOPED_TRACE(s.name);
    PairCache cache;
    const ContactResult first = cm::signedDistance(s.a, s.pa, s.b, s.pb, &cache);
    const ContactResult again = cm::signedDistance(s.a, s.pa, s.b, s.pb, &cache);
    EXPECT_LE(again.gjk_iterations, 1);
    expectSame(again, first);
  }
}

TEST(WarmStart, SamePoseAgainKeepsTheCachedPointsBitForBit) {
  // The seed settles the query (no support point added): the cache keeps its local points as they
  // were, instead of points mapped into A's frame and back (each round trip rounds).
  for (const Scenario& s : scenarios()) {
    SCOPED_TRACE(s.name);
    PairCache cache;
    cm::distance(s.a, s.pa, s.b, s.pb, &cache);
    const PairCache before = cache;
    for (int again = 0; again < 4; ++again) {
      if (again % 2 == 0) {
        const ContactResult r = cm::distance(s.a, s.pa, s.b, s.pb, &cache);
        EXPECT_LE(r.gjk_iterations, 1);
      } else {
        cm::intersect(s.a, s.pa, s.b, s.pb, &cache);
      }
      ASSERT_EQ(cache.size, before.size);
      for (int i = 0; i < cache.size; ++i) {
        EXPECT_EQ(cache.local_a[i], before.local_a[i]) << "i = " << i;
        EXPECT_EQ(cache.local_b[i], before.local_b[i]) << "i = " << i;
      }
    }
  }
}

TEST(WarmStart, DistanceAndIntersectUseTheCacheToo) {
  for (const Scenario& s : scenarios()) {
    SCOPED_TRACE(s.name);
    PairCache cache;
    cm::distance(s.a, s.pa, s.b, s.pb, &cache);
    const Transform3 pb = moved(s.pb, 1);
    const ContactResult warm = cm::distance(s.a, s.pa, s.b, pb, &cache);
    const ContactResult cold = cm::distance(s.a, s.pa, s.b, pb);
    expectSame(warm, cold);
    EXPECT_LT(warm.gjk_iterations, cold.gjk_iterations);
    EXPECT_EQ(cm::intersect(s.a, s.pa, s.b, moved(s.pb, 2), &cache),
              cm::intersect(s.a, s.pa, s.b, moved(s.pb, 2)));
    EXPECT_EQ(cm::intersect(s.a, s.pa, s.b, moved(s.pb, 3), &cache), cold.distance <= 0.0);
  }
}

TEST(WarmStart, StaleCacheFromAnotherConfigurationGivesTheColdAnswer) {
  // Regression: the seed is a set of points of A - B (re-evaluated from local points), never
  // trusted as support points; a cache of the same pair of shapes from a far-away, differently
  // turned configuration (penetrating or apart) must not change the answer. (A cache belongs to
  // one pair of shapes: points of other shapes are not points of this A - B.)
  const std::vector<Scenario> all = scenarios();
  for (const Scenario& s : all) {
    for (const Scenario& other : all) {
      for (const double angle : {0.0, 2.0, 3.0}) {
        SCOPED_TRACE(std::string(s.name) + " seeded at the poses of " + other.name);
        PairCache cache;
        cm::signedDistance(s.a, other.pa, s.b, pose(angle, Vec3(1, -1, 1), other.pb.t), &cache);
        ASSERT_GT(cache.size, 0);
        const ContactResult warm = cm::signedDistance(s.a, s.pa, s.b, s.pb, &cache);
        const ContactResult cold = cm::signedDistance(s.a, s.pa, s.b, s.pb);
        expectSame(warm, cold);
      }
    }
  }
}

TEST(WarmStart, CacheOfOtherShapesOrTheOtherOrderStartsCold) {
  // Audit (twenty-fifth session): the cache's points were trusted as points of whatever shapes it
  // was given: one cache for (a, b) then (b, a) was 0.38 m off, one shared by two pairs 1.08 m
  // off and intersect() wrong. Now a query binds the cache to its shapes (coreId(), in order);
  // given others it starts cold: the cold answer, bit for bit. Copies and padded() keep the id.
  const std::vector<Scenario> all = scenarios();
  int rebound = 0;
  for (const Scenario& s : all) {
    for (const Scenario& other : all) {
      for (const bool swapped : {false, true}) {
        SCOPED_TRACE(std::string(s.name) + (swapped ? " swapped" : "") + ", cache of " +
                     other.name);
        if (&s == &other && !swapped) continue;
        PairCache cache;
        cm::signedDistance(other.a, other.pa, other.b, other.pb, &cache);
        ASSERT_GT(cache.size, 0);
        const ConvexShape& a = swapped ? s.b : s.a;
        const ConvexShape& b = swapped ? s.a : s.b;
        const Transform3& pa = swapped ? s.pb : s.pa;
        const Transform3& pb = swapped ? s.pa : s.pb;
        for (const bool signed_query : {true, false}) {
          PairCache c = cache;
          const ContactResult cold =
              signed_query ? cm::signedDistance(a, pa, b, pb) : cm::distance(a, pa, b, pb);
          const ContactResult used =
              signed_query ? cm::signedDistance(a, pa, b, pb, &c) : cm::distance(a, pa, b, pb, &c);
          EXPECT_EQ(used.status, cold.status);
          EXPECT_EQ(used.distance, cold.distance);
          EXPECT_EQ(used.gjk_iterations, cold.gjk_iterations);
          EXPECT_EQ(c.core_a, a.coreId());
          EXPECT_EQ(c.core_b, b.coreId());
          PairCache d = cache;
          EXPECT_EQ(cm::intersect(a, pa, b, pb, &d), cm::intersect(a, pa, b, pb));
        }
        ++rebound;
      }
    }
  }
  EXPECT_EQ(rebound, 28);
  // The same shapes, copied and padded: the cache stays warm.
  const Scenario& s = all[0];
  PairCache cache;
  cm::distance(s.a, s.pa, s.b, s.pb, &cache);
  const ConvexShape a_copy = s.a;
  const ConvexShape b_padded = s.b.padded(0.01);
  EXPECT_EQ(a_copy.coreId(), s.a.coreId());
  EXPECT_EQ(b_padded.coreId(), s.b.coreId());
  EXPECT_NE(s.a.coreId(), s.b.coreId());
  const Transform3 pb = moved(s.pb, 1);
  const ContactResult warm = cm::distance(a_copy, s.pa, b_padded, pb, &cache);
  const ContactResult cold = cm::distance(a_copy, s.pa, b_padded, pb);
  expectSame(warm, cold);
  EXPECT_LT(warm.gjk_iterations, cold.gjk_iterations);
}

TEST(WarmStart, PolytopeHintsAreKept) {
  // The 80-vertex hull hill-climbs; its hint is stored in the cache and is a valid vertex index.
  const ConvexShape b = blob();
  const auto& poly = std::get<std::shared_ptr<const cm::Polytope<3>>>(b.core());
  ASSERT_GT(poly->size(), cm::Polytope<3>::kLinearScanMax);
  ASSERT_TRUE(poly->hasAdjacency());
  PairCache cache;
  cache.hint_b = -5;  // garbage in: must be tolerated
  cm::signedDistance(ConvexShape::sphere(0.1), pose(0, Vec3::UnitX(), Vec3::Zero()), b,
                     pose(0, Vec3::UnitX(), Vec3(0.6, 0, 0)), &cache);
  EXPECT_GE(cache.hint_b, 0);
  EXPECT_LT(cache.hint_b, poly->size());
  // The last support query on B was in a direction close to -x (towards A): the hint is a vertex
  // on B's -x side.
  EXPECT_LT(poly->vertices()[cache.hint_b].x(), 0.0);
}

TEST(WarmStart, NeedleTriangleKeepsItsDirection) {
  // fuzz/regressions/core/gjk-needle-triangle-projection-warm: a 1.97 m ellipsoid whose rim
  // touches the edge of a plate 1094 m long and 1.1e-9 m thin (truly about 2e-16 m apart). GJK's
  // triangles span the plate's length (vertices 547 m from the origin) and |v| falls to 1e-10 m.
  // v as sum(lambda_i w_i) carried 5e-14 m of rounding across the plate, a direction 7e-8 rad
  // off, enough to pick the plate's wrong end: the cold query stopped on a duplicate at 7.3e-7 m
  // (8 times the 1e-9 accuracy of this 551 m pair) and the warm one elsewhere. The origin's
  // projection onto the triangle's plane keeps the normal's direction.
  const ConvexShape a = ConvexShape::ellipsoid(Vec3(1.96875, 1.375, 1.671875));
  const ConvexShape b = ConvexShape::box(Vec3(1.0937500000000001e-09, 1093.75, 1.921875));
  Transform3 pa, pb;
  pa.R << 0.99999999999999967, -1.4303285894560248e-08, 2.3344677445330141e-08,
      1.430328295170061e-08, 0.99999999999999201, 1.2606126324007882e-07, -2.334467924842024e-08,
      -1.2606126290617324e-07, 0.99999999999999178;
  pa.t = Vec3(0, -0.001, 0);
  pb.R << 2.2204460492503131e-16, 0, 1, 0, 1, 0, -1, 0, 2.2204460492503131e-16;
  pb.t = Vec3(2.9296875, -0.001, 0);
  const double gjk_tolerance = 1e-12 * 551.8;  // rel_tolerance x the pair's size
  for (const bool swap : {false, true}) {
    SCOPED_TRACE(swap ? "plate first" : "ellipsoid first");
    PairCache cache;
    const ContactResult cold =
        swap ? cm::signedDistance(b, pb, a, pa, &cache) : cm::signedDistance(a, pa, b, pb, &cache);
    const ContactResult warm =
        swap ? cm::signedDistance(b, pb, a, pa, &cache) : cm::signedDistance(a, pa, b, pb, &cache);
    EXPECT_EQ(cold.status, cm::Status::Touching);
    EXPECT_NEAR(cold.distance, 0.0, gjk_tolerance);
    EXPECT_EQ(warm.status, cold.status);
    EXPECT_NEAR(warm.distance, cold.distance, gjk_tolerance);
    EXPECT_LE(warm.gjk_iterations, 1);
  }
}

TEST(WarmStart, WarmQueryThatFailsToConvergeRunsAgainCold) {
  // signedDistance() with a warm cache whose answer is FailedToConverge runs the query again cold
  // (query.cpp): the answer is the cold one. Options under which the seed matters: no EPA
  // iterations (max_epa_iterations = 0) and a touching band as wide as the pair
  // (touch_tolerance = 1). A point at a unit cube's centre, cold: GJK ends on a segment through
  // the origin (symmetry), EPA's blow-up support calls bound the depth (0.5) from above inside
  // the band: Touching. Warm from a cache holding the regular tetrahedron of four cube corners
  // (support points of the cube) against the point (their centroid is the cube's centre, so the
  // seed encloses the origin): GJK starts enclosed, EPA makes no support call and has no upper
  // bound: FailedToConverge, unless the query falls back to the cold run.
  cm::QueryOptions o;
  o.max_epa_iterations = 0;
  o.touch_tolerance = 1.0;
  const ConvexShape cube = ConvexShape::box(Vec3(1, 1, 1));
  const ConvexShape point = ConvexShape::point(Vec3::Zero());
  const ContactResult cold =
      cm::signedDistance(cube, Transform3(), point, Transform3(), nullptr, o);
  ASSERT_EQ(cold.status, cm::Status::Touching);
  PairCache cache;
  cache.core_a = cube.coreId();
  cache.core_b = point.coreId();
  cache.size = 4;
  cache.local_a = {Vec3(0.5, 0.5, 0.5), Vec3(0.5, -0.5, -0.5), Vec3(-0.5, 0.5, -0.5),
                   Vec3(-0.5, -0.5, 0.5)};
  cache.local_b = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  const ContactResult warm = cm::signedDistance(cube, Transform3(), point, Transform3(), &cache, o);
  EXPECT_EQ(warm.status, cold.status);
  EXPECT_NEAR(warm.distance, cold.distance, 1e-12);
}
