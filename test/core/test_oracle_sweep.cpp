// Fixed-seed random sweeps of our GJK/EPA (query.h) against the independent exact oracle of
// oracle.h: >= 100,000 pairs at CM_SWEEP_SCALE=1 over boxes, random hulls, spheres, capsules and
// padded polytopes, sizes 1 mm .. 10 m (ratios up to 1e4), random orientations, near-contact
// placements and positions ~1 km from the origin.
//
// Tolerance: tol = 1e-9 * size + 1e-14 * far, size = sum of the two circumradii, far = distance
// of the pair from the origin. The second term is the rounding of placing a body 1 km away
// (1e3 m * 1.1e-16 per coordinate, a few operations): a 1 mm pair at 1 km cannot be known to
// 1e-12 m in world coordinates.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "collision_monitor/core/query.h"
#include "oracle.h"

namespace cm = collision_monitor::core;
using oracle::Category;
using oracle::scaled;

namespace {

double tolerance(const oracle::Pair& p) {
  return 1e-9 * p.size + 1e-14 * p.far;
}

std::string vec(const cm::Vec3& v) {
  std::ostringstream s;
  s.precision(17);
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

/// Per-category tallies.
struct Tally {
  int pairs = 0, colliding = 0, failures = 0;
  double max_rel_err = 0.0;  // |ours - oracle| / size
  double max_abs_err = 0.0;  // m
  double max_witness_rel = 0.0, max_normal_rel = 0.0;
  int cross_checked = 0;            // pairs also solved by qhull on the Minkowski difference
  double max_oracle_gap_rel = 0.0;  // |solve - solveMinkowski| / size
  int distance_reports_depth = 0;   // distance() gave -depth instead of 0 on overlap
  std::uint64_t worst = 0;
  double seconds = 0.0;
};

/// All checks of one pair. Returns a description of the first failed check ("" when fine).
std::string checkPair(const oracle::Pair& p, Tally* t) {
  const oracle::Answer ans = oracle::solve(p.a.world, p.b.world);
  const double tol = tolerance(p);
  if (p.index % 16 == 0) {  // the two exact oracles must agree
    const oracle::Answer mink = oracle::solveMinkowski(p.a.world, p.b.world);
    const double gap = std::abs(mink.distance - ans.distance);
    ++t->cross_checked;
    t->max_oracle_gap_rel = std::max(t->max_oracle_gap_rel, gap / p.size);
    if (gap > 1e-12 * p.size + 1e-14 * p.far) {
      std::ostringstream s;
      s.precision(17);
      s << "oracles disagree: SAT/features " << ans.distance << ", qhull Minkowski "
        << mink.distance;
      return s.str();
    }
  }
  const cm::ConvexShape& a = *p.a.shape;
  const cm::ConvexShape& b = *p.b.shape;
  const bool hit = cm::intersect(a, p.a.pose, b, p.b.pose);
  const cm::ContactResult sd = cm::signedDistance(a, p.a.pose, b, p.b.pose);
  const cm::ContactResult dist = cm::distance(a, p.a.pose, b, p.b.pose);
  if (ans.distance < 0.0) ++t->colliding;

  std::ostringstream why;
  why.precision(17);
  auto fail = [&](const std::string& what) {
    why << what << " | oracle " << ans.distance << " normal " << vec(ans.normal)
        << " | ours: intersect " << hit << ", signedDistance " << sd.distance << " ("
        << cm::toString(sd.status) << ") normal " << vec(sd.normal) << " a " << vec(sd.point_a)
        << " b " << vec(sd.point_b) << ", distance " << dist.distance << " ("
        << cm::toString(dist.status) << ") | tol " << tol << " size " << p.size;
    return why.str();
  };

  // Verdicts outside the band.
  if (ans.distance > tol && hit) return fail("intersect() says overlap, oracle apart");
  if (ans.distance < -tol && !hit) return fail("intersect() says apart, oracle overlap");
  if (sd.status == cm::Status::FailedToConverge) return fail("signedDistance FailedToConverge");
  if (ans.distance > tol && sd.status != cm::Status::Separated) return fail("status not Separated");
  if (ans.distance < -tol && sd.status != cm::Status::Penetrating) {
    return fail("status not Penetrating");
  }
  // Values.
  if (!std::isfinite(sd.distance) || !sd.point_a.allFinite() || !sd.point_b.allFinite() ||
      !sd.normal.allFinite()) {
    return fail("non-finite result");
  }
  const double err = std::abs(sd.distance - ans.distance);
  if (err / p.size > t->max_rel_err) t->max_rel_err = err / p.size, t->worst = p.index;
  t->max_abs_err = std::max(t->max_abs_err, err);
  if (err > tol) return fail("signed distance error " + std::to_string(err));
  if (std::abs(sd.normal.norm() - 1.0) > 1e-12) return fail("normal not unit");
  // Witness points on the shapes, and consistent with the distance.
  const double wa = std::abs(p.a.world.signedDistanceTo(sd.point_a));
  const double wb = std::abs(p.b.world.signedDistanceTo(sd.point_b));
  t->max_witness_rel = std::max(t->max_witness_rel, std::max(wa, wb) / p.size);
  if (wa > tol) return fail("point_a off A's surface by " + std::to_string(wa));
  if (wb > tol) return fail("point_b off B's surface by " + std::to_string(wb));
  if (std::abs((sd.point_b - sd.point_a).norm() - std::abs(sd.distance)) > tol) {
    return fail("|point_b - point_a| != |distance|");
  }
  // The normal realises the signed distance: h_{A-B}(n) = -distance for the right n and larger
  // for any other. A normal is only as good as the cores' separation allows (radii are added
  // after GJK): from core witness points (or a simplex) known to ~1e-14 * size, its angle is known
  // to ~1e-14 * size / |core distance|, which moves h by up to size times that.
  const double h = p.a.world.supportValue(sd.normal) + p.b.world.supportValue(-sd.normal);
  const double core_distance = std::abs(ans.distance + p.a.radius + p.b.radius);
  const double normal_tol =
      tol + (1e-14 * p.size + 1e-14 * p.far) * p.size / std::max(core_distance, 1e-300);
  if (core_distance > 1e-6 * p.size) {
    t->max_normal_rel = std::max(t->max_normal_rel, std::abs(h + ans.distance) / p.size);
  }
  if (std::abs(h + ans.distance) > normal_tol) return fail("normal does not realise the distance");
  // distance(): the separation when apart; Penetrating when overlapping, with distance 0 as
  // query.h documents (a -depth that is exact is tolerated and counted).
  if (ans.distance > tol &&
      (dist.status != cm::Status::Separated || std::abs(dist.distance - ans.distance) > tol)) {
    return fail("distance() wrong on a separated pair");
  }
  if (ans.distance < -tol) {
    if (dist.status != cm::Status::Penetrating) return fail("distance() not Penetrating");
    if (dist.distance != 0.0) {
      ++t->distance_reports_depth;
      if (std::abs(dist.distance - ans.distance) > tol) {
        return fail("distance() on an overlapping pair neither 0 nor the signed distance");
      }
    }
  }
  return "";
}

void sweep(Category c, int pairs) {
  Tally t;
  std::vector<std::string> failures;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < pairs; ++i) {
    const oracle::Pair p = oracle::makePair(c, static_cast<std::uint64_t>(i));
    ++t.pairs;
    const std::string why = checkPair(p, &t);
    if (!why.empty()) {
      ++t.failures;
      if (failures.size() < 5) {
        failures.push_back(std::string(oracle::name(c)) + " index " + std::to_string(i) + " (" +
                           p.a.shape->describe() + " vs " + p.b.shape->describe() + "): " + why);
      }
    }
  }
  t.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double share = static_cast<double>(t.colliding) / t.pairs;
  std::printf(
      "[sweep] %-16s pairs %6d  colliding %6d (%.1f %%)  failures %d  max|err| %.2e m  "
      "max|err|/size %.2e (index %llu)  witness/size %.2e  normal/size %.2e  "
      "oracles cross-checked %d (max gap/size %.1e)  distance()=-depth %d  %.2f s\n",
      oracle::name(c), t.pairs, t.colliding, 100.0 * share, t.failures, t.max_abs_err,
      t.max_rel_err, static_cast<unsigned long long>(t.worst), t.max_witness_rel, t.max_normal_rel,
      t.cross_checked, t.max_oracle_gap_rel, t.distance_reports_depth, t.seconds);
  for (const auto& f : failures)
    ADD_FAILURE() << f;
  EXPECT_EQ(t.failures, 0) << oracle::name(c);
  EXPECT_GE(share, 0.3) << "sample not meaningful: too few collisions in " << oracle::name(c);
  EXPECT_LE(share, 0.7) << "sample not meaningful: too many collisions in " << oracle::name(c);
}

}  // namespace

// 9 categories x 12,000 = 108,000 pairs at CM_SWEEP_SCALE=1.
constexpr int kPairsPerCategory = 12000;

TEST(OracleSweep, BoxBox) {
  sweep(Category::BoxBox, scaled(kPairsPerCategory));
}
TEST(OracleSweep, HullHull) {
  sweep(Category::HullHull, scaled(kPairsPerCategory));
}
TEST(OracleSweep, BoxHull) {
  sweep(Category::BoxHull, scaled(kPairsPerCategory));
}
TEST(OracleSweep, SphereSphere) {
  sweep(Category::SphereSphere, scaled(kPairsPerCategory));
}
TEST(OracleSweep, CapsuleCapsule) {
  sweep(Category::CapsuleCapsule, scaled(kPairsPerCategory));
}
TEST(OracleSweep, SphereCapsule) {
  sweep(Category::SphereCapsule, scaled(kPairsPerCategory));
}
TEST(OracleSweep, SpherePoly) {
  sweep(Category::SpherePoly, scaled(kPairsPerCategory));
}
TEST(OracleSweep, CapsulePoly) {
  sweep(Category::CapsulePoly, scaled(kPairsPerCategory));
}
TEST(OracleSweep, PaddedPoly) {
  sweep(Category::PaddedPoly, scaled(kPairsPerCategory));
}

TEST(OracleSweep, PairsAreReproducibleFromTheirIndex) {
  const oracle::Pair p = oracle::makePair(Category::HullHull, 1234);
  const oracle::Pair q = oracle::makePair(Category::HullHull, 1234);
  EXPECT_EQ(p.a.local_core, q.a.local_core);
  EXPECT_EQ(p.b.pose.t, q.b.pose.t);
  EXPECT_EQ(p.b.pose.R, q.b.pose.R);
}

// A support tie GJK must break as exact arithmetic would (fuzz/regressions/core/
// gjk-flat-cone-by-3218m-hull-tie): a flat disc (a 64-gon, then a cone of height 0) of radius R
// at the origin in the plane z = 0, and a hull with an edge of length L along z at x = d, y = 0
// (from z = 0 up). The edge is perpendicular to v near the end, the support along -v returned its
// far end, and the triangle with that point gains less than a rounding of |v|^2: GJK stopped
// 8.7e-6 m (64-gon) and 1.3e-5 m (disc) above the distance on the old code, for L = 3218.75 m.
// Oracle: qhull on the Minkowski difference (the polygon exactly; the disc between an inscribed
// and a circumscribed 1024-gon, 4.9e-9 m apart). Bound: 1e-12 of the size (GJK's relative
// tolerance), tighter than the sweep's 1e-9, which an error of 8.7e-6 m passes at L = 1e5 m.
TEST(OracleExact, SupportTieAlongAnEdgePerpendicularToV) {
  const double R = 0.00103125, d = 0.0020625;
  const auto polygon = [](int n, double radius) {
    std::vector<cm::Vec3> p;
    for (int i = 0; i < n; ++i) {
      const double a = 2.0 * M_PI * i / n;
      p.emplace_back(radius * std::cos(a), radius * std::sin(a), 0.0);
    }
    return p;
  };
  const auto oracleDistance = [](const std::vector<cm::Vec3>& a, const std::vector<cm::Vec3>& b) {
    std::vector<oracle::V3> diff;
    for (const cm::Vec3& x : a) {
      for (const cm::Vec3& y : b)
        diff.push_back(x - y);
    }
    return oracle::signedDistance(oracle::makeHull(diff), oracle::V3::Zero());
  };
  cm::Transform3 at_d;
  at_d.t = cm::Vec3(d, 0, 0);
  for (const double L : {3218.75, 1e5}) {
    SCOPED_TRACE("edge length " + std::to_string(L));
    const std::vector<cm::Vec3> hull{{0, 0, L},
                                     {4.984375, 0, 3.84375},
                                     {-R, -3.84375, 3.84375},
                                     {0, 0, 0},
                                     {3.84375, 0, 0},
                                     {3.84375, 3.84375, -3.84375},
                                     {3.84375, 3.84375, 3.859375},
                                     {3.34375, 3.84375, 0}};
    std::vector<cm::Vec3> hull_world;
    for (const cm::Vec3& x : hull)
      hull_world.push_back(x + at_d.t);
    const double tol = 1e-12 * L;
    const cm::ConvexShape b = cm::ConvexShape::convexHull(hull);
    const std::vector<cm::Vec3> gon = polygon(64, R);
    const double exact_gon = oracleDistance(gon, hull_world);
    const double disc_low = oracleDistance(polygon(1024, R / std::cos(M_PI / 1024)), hull_world);
    const double disc_high = oracleDistance(polygon(1024, R), hull_world);
    ASSERT_GT(exact_gon, 0.001);
    ASSERT_LT(disc_high - disc_low, 1e-8);
    const cm::ConvexShape a_gon = cm::ConvexShape::convexHull(gon);
    const cm::ConvexShape a_disc = cm::ConvexShape::cone(0.0, R);
    for (const bool swap : {false, true}) {
      SCOPED_TRACE(swap ? "hull first" : "disc first");
      const auto run = [&](const cm::ConvexShape& a) {
        return swap ? cm::distance(b, at_d, a, cm::Transform3()).distance
                    : cm::distance(a, cm::Transform3(), b, at_d).distance;
      };
      EXPECT_NEAR(run(a_gon), exact_gon, tol);
      const double disc = run(a_disc);
      EXPECT_GE(disc, disc_low - tol);
      EXPECT_LE(disc, disc_high + tol);
      // The boolean query stalled alike: the 64-gon padded past the distance by 2e-6 m was
      // "apart" (its estimate stayed 8.7e-6 m too far). Beyond the touching band (1e-10 of the
      // size), which counts as a hit.
      const double off = 2e-6 + 2e-10 * L;
      for (const double extra : {-off, off}) {
        const cm::ConvexShape padded = a_gon.padded(exact_gon + extra);
        const bool hit = swap ? cm::intersect(b, at_d, padded, cm::Transform3())
                              : cm::intersect(padded, cm::Transform3(), b, at_d);
        EXPECT_EQ(hit, extra > 0) << "padding " << exact_gon + extra;
      }
    }
  }
}

// Hulls given in far-off coordinates with identity poses (a CONVEX body written in map
// coordinates, a mesh exported in a site frame): 1 to 12 mm hulls 1e3 to 1e6 m from their frame's
// origin, a few millimetres apart or overlapping. The shapes are exactly the doubles given, so the
// answers owe nothing to the distance from the origin: 1e-9 of the pair's own size, as the sweep
// above. Until the tenth session of 2026-11-25 tolerances scaled with the vertices' distance from
// their origin (ConvexShape::offset()): 2.5e-5 of the size at 1e5 m. The same pairs moved by one
// rigid transform to near the world origin (the pose then carries 1e5 m and rounds at 1e-14 of
// it, the sweep's `far` term).
TEST(OracleFar, HullsGivenFarFromTheirOrigin) {
  std::mt19937_64 rng(20261125);
  const int pairs = oracle::scaled(500);
  int all_colliding = 0;
  for (const double far : {1e3, 1e4, 1e5, 1e6}) {
    SCOPED_TRACE("far " + std::to_string(far));
    int failures = 0, colliding = 0;
    double worst[2] = {0.0, 0.0};  // in place, moved home
    for (int i = 0; i < pairs; ++i) {
      const oracle::FarPair p = oracle::makeFarPair(rng, far);
      const cm::Vec3& c = p.centre;
      const double exact = p.exact, size = p.size;
      if (exact < 0.0) ++colliding;
      const cm::ConvexShape a = cm::ConvexShape::convexHull(p.a);
      const cm::ConvexShape b = cm::ConvexShape::convexHull(p.b);
      cm::Transform3 home;  // the pair brought near the world origin, turned
      home.R = Eigen::Quaterniond(oracle::randomUnit(rng).x(), 0.3, -0.5, 0.7)
                   .normalized()
                   .toRotationMatrix();
      home.t = -(home.R * c);
      for (const bool moved : {false, true}) {
        const cm::Transform3 pose = moved ? home : cm::Transform3();
        const double tol = 1e-9 * size + (moved ? 1e-14 * far : 0.0);
        // A witness point in coordinates 1e6 m out is a double: 1.2e-10 m apart (4 ulps here).
        const double tol_w = tol + 5e-16 * far;
        const cm::ContactResult r = cm::signedDistance(a, pose, b, pose);
        const bool hit = cm::intersect(a, pose, b, pose);
        const cm::Transform3 back = pose.inverse();
        const double wa = std::abs(oracle::signedDistance(p.ha, back * r.point_a - c));
        const double wb = std::abs(oracle::signedDistance(p.hb, back * r.point_b - c));
        const double err = std::abs(r.distance - exact);
        worst[moved] = std::max(worst[moved], err / size);
        const bool ok =
            err <= tol && wa <= tol_w && wb <= tol_w &&
            (std::abs(exact) <= 2e-10 * size + tol || hit == (exact < 0.0)) &&
            (std::abs(exact) <= 2e-10 * size + tol ||
             r.status == (exact < 0.0 ? cm::Status::Penetrating : cm::Status::Separated));
        if (!ok && ++failures <= 3) {
          ADD_FAILURE() << "pair " << i << (moved ? " moved home" : " in place") << ": oracle "
                        << exact << " ours " << r.distance << " (" << cm::toString(r.status)
                        << "), intersect " << hit << ", witnesses off " << wa << " / " << wb
                        << ", size " << size;
        }
      }
    }
    std::printf(
        "[far] %.0e m: %d pairs, %d colliding, failures %d, max|err|/size %.2e in place, %.2e "
        "moved\n",
        far, pairs, colliding, failures, worst[0], worst[1]);
    EXPECT_EQ(failures, 0);
    all_colliding += colliding;
  }
  // A meaningful sample over all four distances (31.9 % of 2,000; 29.5 % of the sanitizer
  // build's 200).
  EXPECT_GT(all_colliding, 4 * pairs / 5);
  EXPECT_LT(all_colliding, 4 * pairs / 2);
}
