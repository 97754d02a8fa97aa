// Tests of buildConvexHull / hullTriangles / hullPlanes (qhull): exact vertex sets and edge
// graphs on known solids, hill-climbing support against a linear scan, degenerate input, errors,
// silence (qhull must not print) and concurrent use.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "collision_monitor/core/convex_hull.h"
#include "collision_monitor/core/polytope_pair.h"
#include "collision_monitor/core/query.h"
#include "oracle.h"

namespace cm = collision_monitor::core;
using cm::Vec3;

namespace {

std::vector<Vec3> cubeCorners(double h, const Vec3& c = Vec3::Zero()) {
  std::vector<Vec3> p;
  for (int i = 0; i < 8; ++i) {
    p.push_back(c + Vec3((i & 1) ? h : -h, (i & 2) ? h : -h, (i & 4) ? h : -h));
  }
  return p;
}

std::set<int> neighbours(const cm::Polytope<3>& poly, int i) {
  const auto& off = poly.adjacencyOffsets();
  const auto& adj = poly.adjacency();
  return std::set<int>(adj.begin() + off[i], adj.begin() + off[i + 1]);
}

/// Adjacency must be symmetric, without self loops or duplicates.
void expectWellFormedAdjacency(const cm::Polytope<3>& poly) {
  ASSERT_TRUE(poly.hasAdjacency());
  const auto& off = poly.adjacencyOffsets();
  for (int i = 0; i < poly.size(); ++i) {
    const std::set<int> nb = neighbours(poly, i);
    EXPECT_EQ(static_cast<int>(nb.size()), off[i + 1] - off[i]) << "duplicate neighbour of " << i;
    EXPECT_EQ(nb.count(i), 0u) << "self loop at " << i;
    for (int j : nb) {
      ASSERT_GE(j, 0);
      ASSERT_LT(j, poly.size());
      EXPECT_EQ(neighbours(poly, j).count(i), 1u) << "asymmetric edge " << i << "-" << j;
    }
  }
}

Vec3 randomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Vec3 v(g(rng), g(rng), g(rng));
  return v.normalized();
}

/// The hull's support (a climb from a cold hint) equals the brute-force maximum over `pts` in
/// `directions` random directions.
void expectSupportOfPoints(const cm::Polytope<3>& poly, const std::vector<Vec3>& pts,
                           std::mt19937_64& rng, int directions, const std::string& what) {
  for (int k = 0; k < directions; ++k) {
    const Vec3 d = randomUnit(rng);
    double best = -std::numeric_limits<double>::infinity();
    for (const Vec3& p : pts)
      best = std::max(best, p.dot(d));
    int hint = -1;
    EXPECT_EQ(poly.vertices()[poly.supportIndex(d, hint)].dot(d), best) << what << " k " << k;
  }
}

/// The 8 corners of a box with full side lengths `sides`, centred at the origin (as the fuzzer's
/// boxes: each coordinate is +-0.5 * side).
std::vector<Vec3> boxCorners(const Vec3& sides) {
  std::vector<Vec3> c;
  for (int i = 0; i < 8; ++i)
    c.emplace_back((i & 1 ? 0.5 : -0.5) * sides.x(), (i & 2 ? 0.5 : -0.5) * sides.y(),
                   (i & 4 ? 0.5 : -0.5) * sides.z());
  return c;
}

/// Every input point within `tol` of the hull of `poly`'s vertices, measured by the oracle's
/// qhull (test/core/oracle.h: thin sets mapped round by their singular vectors, independently of
/// the library's mapping); returns the largest distance outside. Every triangle of hullTriangles()
/// faces away from the vertices' centroid.
double expectPointsNearHull(const cm::Polytope<3>& poly, const std::vector<Vec3>& pts, double tol,
                            const std::string& what) {
  const oracle::Hull h = oracle::makeHull(poly.vertices());
  double worst = 0.0;
  for (const Vec3& p : pts)
    worst = std::max(worst, oracle::signedDistance(h, p));
  EXPECT_LE(worst, tol) << what;
  const auto tris = cm::hullTriangles(poly);
  EXPECT_FALSE(tris.empty()) << what;
  const std::vector<Vec3>& v = poly.vertices();
  Vec3 centroid = Vec3::Zero();
  for (const Vec3& x : v)
    centroid += x / static_cast<double>(v.size());
  for (const auto& t : tris) {
    const Vec3 n = (v[t[1]] - v[t[0]]).cross(v[t[2]] - v[t[0]]);
    EXPECT_LT(n.dot(centroid - v[t[0]]), 0.0) << what << ": a triangle facing inward";
  }
  return worst;
}

}  // namespace

TEST(ConvexHull, CubeWithInteriorPointsKeepsExactlyTheEightCorners) {
  std::vector<Vec3> pts = cubeCorners(0.5);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.49, 0.49);
  for (int i = 0; i < 200; ++i)
    pts.push_back(Vec3(u(rng), u(rng), u(rng)));
  // Points on faces and edges are not vertices either.
  pts.push_back(Vec3(0.5, 0.1, -0.2));
  pts.push_back(Vec3(0.5, 0.5, 0.0));
  std::shuffle(pts.begin(), pts.end(), rng);

  const auto poly = cm::buildConvexHull(pts);
  ASSERT_EQ(poly->size(), 8);
  std::set<std::array<double, 3>> got;
  for (const Vec3& v : poly->vertices())
    got.insert({v.x(), v.y(), v.z()});
  for (const Vec3& c : cubeCorners(0.5))
    EXPECT_EQ(got.count({c.x(), c.y(), c.z()}), 1u);
}

// qhull merges the two coplanar triangles of every face (default C-0 premerge) and the edges are
// taken from the ridges between merged facets: a cube vertex has exactly its 3 real edges, no
// face diagonals.
TEST(ConvexHull, CubeAdjacencyIsTheTwelveRealEdges) {
  const auto poly = cm::buildConvexHull(cubeCorners(1.0, Vec3(3.0, -2.0, 1.0)));
  ASSERT_EQ(poly->size(), 8);
  expectWellFormedAdjacency(*poly);
  EXPECT_EQ(poly->adjacency().size(), 24u);  // 12 edges, both directions
  for (int i = 0; i < 8; ++i) {
    const std::set<int> nb = neighbours(*poly, i);
    EXPECT_EQ(nb.size(), 3u);
    for (int j : nb) {
      // A real cube edge changes exactly one coordinate, by the side length 2.
      const Vec3 d = (poly->vertices()[j] - poly->vertices()[i]).cwiseAbs();
      EXPECT_EQ((d.array() == 2.0).count(), 1) << i << "-" << j;
      EXPECT_EQ((d.array() == 0.0).count(), 2) << i << "-" << j;
    }
  }
}

TEST(ConvexHull, HillClimbingSupportEqualsLinearScanOn500VertexHull) {
  std::mt19937_64 rng(42);
  std::vector<Vec3> pts;
  for (int i = 0; i < 500; ++i) {
    Vec3 v = randomUnit(rng);
    pts.push_back(Vec3(2.0 * v.x(), 1.0 * v.y(), 0.5 * v.z()) + Vec3(10.0, 0.0, -3.0));
  }
  const auto poly = cm::buildConvexHull(pts);
  ASSERT_EQ(poly->size(), 500);  // every point of an ellipsoid surface is a hull vertex
  ASSERT_GT(poly->size(), cm::Polytope<3>::kLinearScanMax);
  expectWellFormedAdjacency(*poly);
  std::uniform_int_distribution<int> pick(0, poly->size() - 1);
  int warm = 0;
  for (int k = 0; k < 1000; ++k) {
    const Vec3 d = randomUnit(rng);
    double best = -std::numeric_limits<double>::infinity();
    for (const Vec3& v : poly->vertices())
      best = std::max(best, v.dot(d));
    int cold = pick(rng);
    EXPECT_EQ(poly->vertices()[poly->supportIndex(d, cold)].dot(d), best) << "direction " << k;
    EXPECT_EQ(poly->support(d, warm).dot(d), best) << "warm, direction " << k;
  }
}

TEST(ConvexHull, TinyAndHugeCubesKeepTheirCornersAndEdges) {
  // Hulls are built at about unit size and scaled back by a power of two: a cube 1.7e-273 m
  // across was a single point (its extent's square underflowed). Corners come back bit for bit,
  // subnormal ones too; the edges are the cube's twelve; planes and triangles too.
  for (const double h : {8.7350880895638318e-274, 1e-300, 3e-310, 1e-60, 1e60, 1e200, 1e300}) {
    SCOPED_TRACE(h);
    std::vector<Vec3> pts = cubeCorners(h, Vec3(0.5 * h, 0.0, 0.0));
    for (int i = 0; i < 20; ++i)  // interior points
      pts.push_back(Vec3(0.5 * h + 0.01 * i * h, 0.02 * i * h, -0.03 * i * h));
    const auto poly = cm::buildConvexHull(pts);
    ASSERT_EQ(poly->size(), 8);
    std::set<std::array<double, 3>> want, got;
    for (int i = 0; i < 8; ++i) {
      want.insert({pts[i].x(), pts[i].y(), pts[i].z()});
      const Vec3& v = poly->vertices()[i];
      got.insert({v.x(), v.y(), v.z()});
    }
    EXPECT_EQ(got, want);
    expectWellFormedAdjacency(*poly);
    for (int i = 0; i < 8; ++i)
      EXPECT_EQ(neighbours(*poly, i).size(), 3u) << "vertex " << i;
    EXPECT_EQ(cm::hullTriangles(*poly).size(), 12u);
    const auto planes = cm::hullPlanes(pts);
    ASSERT_EQ(planes.size(), 6u);
    for (const auto& pl : planes) {
      const double expected = h + pl.normal.x() * 0.5 * h;
      EXPECT_NEAR(pl.offset, expected, 1e-14 * h);
    }
  }
}

TEST(ConvexHull, PointOnATinyCubeTouchesIt) {
  // fuzz/regressions/core/hull-1e-273m-cube-collapsed-to-a-point, in closed form: a point on the
  // +x face of a cube of half size h, h = 8.7e-274 m, touches it (it was "2.1e-273 m apart").
  const double h = 8.7350880895638318e-274;
  const cm::ConvexShape cube = cm::ConvexShape::convexHull(cubeCorners(h));
  const cm::ConvexShape point = cm::ConvexShape::sphere(0.0);
  cm::Transform3 at;
  at.t = Vec3(h, 0.25 * h, 0.0);
  const auto r = cm::signedDistance(cube, cm::Transform3(), point, at);
  EXPECT_EQ(r.status, cm::Status::Touching);
  EXPECT_LE(std::abs(r.distance), 1e-9 * h);
  at.t = Vec3(3.0 * h, 0.0, 0.0);  // 2h from the face
  const auto apart = cm::signedDistance(cube, cm::Transform3(), point, at);
  EXPECT_EQ(apart.status, cm::Status::Separated);
  EXPECT_NEAR(apart.distance, 2.0 * h, 1e-9 * h);
}

TEST(ConvexHull, CoincidentPointsGiveOneVertex) {
  const Vec3 p(1.25, -3.0, 1e3);
  const auto poly = cm::buildConvexHull({p, p, p, p, p});
  ASSERT_EQ(poly->size(), 1);
  EXPECT_EQ(poly->vertices()[0], p);
  EXPECT_EQ(poly->support(Vec3(0.3, -1.0, 2.0)), p);
  EXPECT_EQ(poly->support(Vec3::Zero()), p);
  EXPECT_TRUE(cm::hullTriangles(*poly).empty());
}

TEST(ConvexHull, CollinearPointsGiveTheTwoExtremePoints) {
  const Vec3 a(1.0, 2.0, 3.0), dir(0.6, -0.8, 0.0);
  std::vector<Vec3> pts;
  for (double t : {0.5, -2.0, 1.0, 3.5, 0.0, 2.0, 3.5})
    pts.push_back(a + t * dir);
  const auto poly = cm::buildConvexHull(pts);
  ASSERT_EQ(poly->size(), 2);
  const Vec3 lo = a - 2.0 * dir, hi = a + 3.5 * dir;
  EXPECT_EQ(poly->support(-dir), lo);
  EXPECT_EQ(poly->support(dir), hi);
  EXPECT_EQ(neighbours(*poly, 0), std::set<int>{1});
  EXPECT_EQ(neighbours(*poly, 1), std::set<int>{0});
}

TEST(ConvexHull, PointsWithinTheRoundingFloorOfEachOtherGiveOneVertex) {
  // Pins the noise floor of the point test: 1000 and the next double above it differ by
  // 2^-43 = 1.1e-13, below the floor 16 eps * 1000 = 3.6e-12 of coordinates that size, so the set
  // is one point (the first input point), not a segment 1 ulp long.
  const Vec3 p(1000.0, -2.0, 5.0);
  const Vec3 q(std::nextafter(1000.0, 2000.0), -2.0, 5.0);
  ASSERT_NE(p, q);
  const auto poly = cm::buildConvexHull({p, q, p, q});
  ASSERT_EQ(poly->size(), 1);
  EXPECT_EQ(poly->vertices()[0], p);
}

TEST(ConvexHull, PointsWithinTheFlatnessThresholdOfALineGiveASegment) {
  // Pins kFlatRel for the line test: (1, 1e-11, 0) is 1e-11 off the line through (0, 0, 0) and
  // (2, 0, 0), below 1e-10 of the extent 2 (2e-10): the set is the segment between the two
  // extreme points, not a sliver triangle.
  const Vec3 a(0.0, 0.0, 0.0), b(2.0, 0.0, 0.0), c(1.0, 1e-11, 0.0);
  const auto poly = cm::buildConvexHull({a, c, b});
  ASSERT_EQ(poly->size(), 2);
  EXPECT_EQ(poly->support(Vec3::UnitX()), b);
  EXPECT_EQ(poly->support(-Vec3::UnitX()), a);
  EXPECT_EQ(neighbours(*poly, 0), std::set<int>{1});
}

TEST(ConvexHull, CoplanarPointsGiveThePolygonCycle) {
  // A 5x5 grid on a tilted plane far from the origin: the hull is the 4 corners, a 4-cycle.
  const Vec3 o(100.0, -50.0, 7.0);
  const Vec3 u = Vec3(1.0, 1.0, 0.0).normalized(), v = Vec3(-1.0, 1.0, 1.0).normalized();
  std::vector<Vec3> pts;
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j)
      pts.push_back(o + 0.25 * i * u + 0.25 * j * v);
  }
  const auto poly = cm::buildConvexHull(pts);
  ASSERT_EQ(poly->size(), 4);
  expectWellFormedAdjacency(*poly);
  std::set<int> corner_ids;
  for (int k = 0; k < 4; ++k) {
    const Vec3& p = poly->vertices()[k];
    const auto it = std::find(pts.begin(), pts.end(), p);
    ASSERT_NE(it, pts.end()) << "vertices must be input points";
    const int idx = static_cast<int>(it - pts.begin());
    corner_ids.insert(idx);
    // Polygon cycle: the two neighbours are the adjacent corners, never the opposite one.
    const std::set<int> nb = neighbours(*poly, k);
    ASSERT_EQ(nb.size(), 2u);
    for (int j : nb) {
      const double len = (poly->vertices()[j] - p).norm();
      EXPECT_NEAR(len, 1.0, 1e-12);
    }
  }
  EXPECT_EQ(corner_ids, (std::set<int>{0, 4, 20, 24}));
  EXPECT_TRUE(cm::hullTriangles(*poly).empty());
}

TEST(ConvexHull, FlatPolygonHillClimbingEqualsLinearScan) {
  // 200 points on a tilted circle (all hull vertices) + interior: cycle adjacency of 200.
  std::mt19937_64 rng(3);
  const Vec3 u = Vec3(1.0, 2.0, 3.0).normalized(), v = u.cross(Vec3::UnitX()).normalized();
  std::vector<Vec3> pts;
  for (int i = 0; i < 200; ++i) {
    const double a = 2.0 * M_PI * i / 200.0;
    pts.push_back(std::cos(a) * u + std::sin(a) * v);
    pts.push_back(0.5 * std::cos(a) * u + 0.3 * std::sin(a) * v);
  }
  const auto poly = cm::buildConvexHull(pts);
  ASSERT_EQ(poly->size(), 200);
  expectWellFormedAdjacency(*poly);
  int hint = 0;
  for (int k = 0; k < 1000; ++k) {
    const Vec3 d = randomUnit(rng);
    double best = -std::numeric_limits<double>::infinity();
    for (const Vec3& p : pts)
      best = std::max(best, p.dot(d));
    EXPECT_EQ(poly->support(d, hint).dot(d), best) << "direction " << k;
  }
}

TEST(ConvexHull, NearlyFlatInputDoesNotFailAndStaysClose) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double thickness : {0.0, 1e-15, 1e-12, 1e-10, 1e-9, 1e-7, 1e-5}) {
    std::vector<Vec3> pts;
    for (int i = 0; i < 100; ++i)
      pts.push_back(Vec3(u(rng), u(rng), thickness * u(rng)));
    testing::internal::CaptureStdout();
    testing::internal::CaptureStderr();
    std::shared_ptr<const cm::Polytope<3>> poly;
    EXPECT_NO_THROW(poly = cm::buildConvexHull(pts)) << "thickness " << thickness;
    EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
    EXPECT_EQ(testing::internal::GetCapturedStderr(), "") << "qhull must not print";
    ASSERT_TRUE(poly);
    ASSERT_GE(poly->size(), 3);
    // The hull's support matches the point set's within the thickness, in every direction.
    for (int k = 0; k < 200; ++k) {
      const Vec3 d = randomUnit(rng);
      double best = -std::numeric_limits<double>::infinity();
      for (const Vec3& p : pts)
        best = std::max(best, p.dot(d));
      EXPECT_NEAR(poly->support(d).dot(d), best, 2.0 * thickness + 1e-15);
      EXPECT_LE(poly->support(d).dot(d), best);  // vertices are input points
    }
  }
}

TEST(ConvexHull, ThinSlabAboveTheFlatnessThresholdKeepsBothFaces) {
  // A set counts as flat when its thickness is at most 1e-10 of its extent (plus the coordinates'
  // rounding floor). The corners of a 2 x 2 x 2e-8 slab are 1e-8 of its extent thick: a solid,
  // whose hull keeps all 8 corners and both faces z = +-1e-8; a polygon would keep one of each
  // pair and lose the thickness.
  std::vector<Vec3> pts;
  for (const double x : {-1.0, 1.0})
    for (const double y : {-1.0, 1.0})
      for (const double z : {-1e-8, 1e-8})
        pts.emplace_back(x, y, z);
  const auto poly = cm::buildConvexHull(pts);
  ASSERT_TRUE(poly);
  EXPECT_EQ(poly->size(), 8);
  EXPECT_EQ(poly->support(Vec3::UnitZ()).z(), 1e-8);
  EXPECT_EQ(poly->support(-Vec3::UnitZ()).z(), -1e-8);
  // A point 1 above the slab's centre is 1 - 1e-8 from it.
  const cm::ConvexShape slab = cm::ConvexShape::convexHull(pts);
  const cm::ContactResult r =
      cm::signedDistance(slab, cm::Transform3::Identity(), cm::ConvexShape::point(Vec3(0, 0, 1)),
                         cm::Transform3::Identity());
  EXPECT_NEAR(r.distance, 1.0 - 1e-8, 1e-15);
}

TEST(ConvexHull, EmptyOrNonFiniteInputThrowsWithAClearMessage) {
  try {
    cm::buildConvexHull({});
    FAIL() << "no exception on empty input";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
  for (double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    std::vector<Vec3> pts = cubeCorners(1.0);
    pts[2].y() = bad;
    try {
      cm::buildConvexHull(pts);
      FAIL() << "no exception on " << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("point 2"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("non-finite"), std::string::npos) << e.what();
    }
    EXPECT_THROW(cm::hullPlanes(pts), std::invalid_argument);
  }
  EXPECT_THROW(cm::hullPlanes({}), std::invalid_argument);
}

TEST(ConvexHull, TrianglesOfACubeAreOutwardAndClosed) {
  const Vec3 c(0.0, 1e3, -1e3);
  const auto poly = cm::buildConvexHull(cubeCorners(0.25, c));
  const auto tris = cm::hullTriangles(*poly);
  ASSERT_EQ(tris.size(), 12u);
  std::map<std::pair<int, int>, int> directed;
  for (const auto& t : tris) {
    const Vec3 &a = poly->vertices()[t[0]], &b = poly->vertices()[t[1]],
               &d = poly->vertices()[t[2]];
    const Vec3 n = (b - a).cross(d - a);
    EXPECT_NEAR(n.norm(), 0.25, 1e-9);  // half of a 0.5 x 0.5 face
    EXPECT_GT(n.dot((a + b + d) / 3.0 - c), 0.0) << "inward triangle";
    for (int k = 0; k < 3; ++k)
      ++directed[{t[k], t[(k + 1) % 3]}];
  }
  // Closed and consistently oriented: every directed edge once, its reverse once.
  for (const auto& e : directed) {
    EXPECT_EQ(e.second, 1);
    EXPECT_EQ(directed.count({e.first.second, e.first.first}), 1u);
  }
}

TEST(ConvexHull, PlanesOfACubeAndOfRandomPoints) {
  const auto planes = cm::hullPlanes(cubeCorners(2.0, Vec3(1.0, 0.0, 0.0)));
  ASSERT_EQ(planes.size(), 6u);
  for (const auto& pl : planes) {
    EXPECT_NEAR(pl.normal.norm(), 1.0, 1e-15);
    EXPECT_NEAR(pl.normal.cwiseAbs().maxCoeff(), 1.0, 1e-15);  // axis aligned
    const double expected = 2.0 + pl.normal.x() * 1.0;         // |half| + n . centre
    EXPECT_NEAR(pl.offset, expected, 1e-14);
  }
  std::mt19937_64 rng(5);
  std::vector<Vec3> pts;
  for (int i = 0; i < 300; ++i)
    pts.push_back(3.0 * randomUnit(rng) * std::cbrt(0.5 + i / 600.0));
  const auto rp = cm::hullPlanes(pts);
  ASSERT_GE(rp.size(), 4u);
  for (const auto& pl : rp) {
    double top = -std::numeric_limits<double>::infinity();
    for (const Vec3& p : pts)
      top = std::max(top, pl.normal.dot(p));
    EXPECT_NEAR(top, pl.offset, 1e-13) << "plane must touch the set and bound it";
  }
}

TEST(ConvexHull, PlanesOfAFlatSquareAreTheSlabAndTheEdges) {
  const std::vector<Vec3> sq{{0, 0, 1}, {2, 0, 1}, {2, 2, 1}, {0, 2, 1}, {1, 1, 1}};
  const auto planes = cm::hullPlanes(sq);
  ASSERT_EQ(planes.size(), 6u);
  int z_up = 0, z_down = 0;
  for (const auto& pl : planes) {
    if (pl.normal.isApprox(Vec3::UnitZ())) {
      ++z_up;
      EXPECT_DOUBLE_EQ(pl.offset, 1.0);
    }
    if (pl.normal.isApprox(-Vec3::UnitZ())) {
      ++z_down;
      EXPECT_DOUBLE_EQ(pl.offset, -1.0);
    }
    for (const Vec3& p : sq)
      EXPECT_LE(pl.normal.dot(p), pl.offset + 1e-15);
  }
  EXPECT_EQ(z_up, 1);
  EXPECT_EQ(z_down, 1);
  EXPECT_TRUE(cm::hullPlanes({Vec3(1, 2, 3), Vec3(2, 2, 3)}).empty());  // segment: no H-form
}

TEST(ConvexHull, TheOracleAgreesWithHullPlanesAndTriangles) {
  // Two independent qhull paths over the same random set: the oracle's hull (triangulated) and
  // buildConvexHull + hullTriangles must see the same surface.
  std::mt19937_64 rng(9);
  std::vector<Vec3> pts;
  for (int i = 0; i < 60; ++i)
    pts.push_back(randomUnit(rng) * (1.0 + 0.1 * i / 60.0));
  const auto poly = cm::buildConvexHull(pts);
  const oracle::Hull h = oracle::makeHull(pts);
  std::set<int> oracle_vertices;
  for (const auto& t : h.triangles)
    oracle_vertices.insert(t.begin(), t.end());
  EXPECT_EQ(static_cast<int>(oracle_vertices.size()), poly->size());
  EXPECT_EQ(cm::hullTriangles(*poly).size(), h.triangles.size());
  for (const Vec3& v : poly->vertices())
    EXPECT_NEAR(oracle::signedDistance(h, v), 0.0, 1e-14);
}

TEST(ConvexHull, ConcurrentCallsGiveIdenticalResults) {
  std::mt19937_64 rng(13);
  std::vector<Vec3> pts;
  for (int i = 0; i < 400; ++i)
    pts.push_back(randomUnit(rng) * std::cbrt((i + 1) / 400.0));
  const auto ref = cm::buildConvexHull(pts);
  std::vector<int> ok(4, 0);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&, t] {
      for (int k = 0; k < 20; ++k) {
        const auto p = cm::buildConvexHull(pts);
        ok[t] += p->vertices() == ref->vertices() && p->adjacency() == ref->adjacency();
      }
    });
  }
  for (auto& th : threads)
    th.join();
  for (int t = 0; t < 4; ++t)
    EXPECT_EQ(ok[t], 20) << "thread " << t;
}

// ---------------------------------------------------------------------------------------------
// The oracle itself on cases with known answers (it must be right before it judges GJK).
// ---------------------------------------------------------------------------------------------
namespace {

oracle::Shape polyShape(const std::vector<Vec3>& pts, double radius = 0.0) {
  oracle::Shape s;
  s.kind = oracle::Shape::Poly;
  s.core = pts;
  s.radius = radius;
  s.finish();
  return s;
}
oracle::Shape pointShape(const Vec3& c, double radius) {
  oracle::Shape s;
  s.kind = oracle::Shape::Point;
  s.core = {c};
  s.radius = radius;
  return s;
}
oracle::Shape segmentShape(const Vec3& a, const Vec3& b, double radius) {
  oracle::Shape s;
  s.kind = oracle::Shape::Segment;
  s.core = {a, b};
  s.radius = radius;
  return s;
}

void expectAnswer(const oracle::Answer& got, double distance, const Vec3& normal) {
  EXPECT_NEAR(got.distance, distance, 1e-14);
  EXPECT_NEAR((got.normal - normal).norm(), 0.0, 1e-12) << got.normal.transpose();
}

}  // namespace

TEST(Oracle, ClosestPointOnTriangleInEveryVoronoiRegion) {
  const Vec3 a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
  using oracle::closestPointTriangle;
  EXPECT_EQ(closestPointTriangle(Vec3(-1, -1, 3), a, b, c), a);
  EXPECT_EQ(closestPointTriangle(Vec3(3, -1, -1), a, b, c), b);
  EXPECT_EQ(closestPointTriangle(Vec3(-1, 3, 0), a, b, c), c);
  EXPECT_TRUE(closestPointTriangle(Vec3(1, -5, 1), a, b, c).isApprox(Vec3(1, 0, 0)));
  EXPECT_TRUE(closestPointTriangle(Vec3(-5, 1, 1), a, b, c).isApprox(Vec3(0, 1, 0)));
  EXPECT_TRUE(closestPointTriangle(Vec3(2, 2, 7), a, b, c).isApprox(Vec3(1, 1, 0)));
  EXPECT_TRUE(closestPointTriangle(Vec3(0.5, 0.25, -4), a, b, c).isApprox(Vec3(0.5, 0.25, 0)));
  // A point 1.4e30 m from a 1 m triangle, 5 m off its plane: the edge vectors from the projection
  // round to the same vector and all three weights to 0 (fuzz/regressions/core/
  // oracle-tiny-triangle-inside): the closest point is vertex b or c, not the projection 5 m away.
  const Vec3 far(1e30, 1e30, 5.0);
  EXPECT_GT((closestPointTriangle(far, a, b, c) - far).norm(), 1e30);
  // A sliver 1.4e6 m long and 1.5e-6 m wide (a hull's far vertex and two of a cluster's points),
  // 18.5 m from a point beside its middle: the rounded normal tilts its plane, and the projection
  // onto it was 0.028 m off the triangle: a distance 0.023 m short (fuzz/regressions/core/
  // oracle-sliver-triangle-projection-off-plane). The closest point must lie on the triangle,
  // within its 1.5e-6 m width of its long edge, and be as near as that edge's closest point.
  const Vec3 tip(805222.54798228352, 805222.54798228352, 805199.26673228352);
  const Vec3 b6(-18.59375, -18.593748755536417, -41.874999824311026);
  const Vec3 b45(-18.59374910691437, -18.59375, -41.875);
  const Vec3 p(0, 0, -0.5625);
  const Vec3 q = closestPointTriangle(p, tip, b6, b45);
  const Vec3 on_edge = oracle::closestPointSegment(q, tip, b6);
  EXPECT_LT((q - on_edge).norm(), 1.6e-6);  // was 0.028 m
  EXPECT_NEAR((q - p).norm(), (oracle::closestPointSegment(p, tip, b6) - p).norm(), 1.6e-6);
}

TEST(Oracle, ClosestPointOnATriangleFlatToRoundingIsNoFartherThanItsEdges) {
  // Three points 1.66 mm along one line through (0.1, 0, 0), given there as A's hull's vertices
  // plus (0.1, 0, 0) (so flat to rounding, 1e-17 of its length wide), and the point (0.1, 0, 0),
  // all times 1024 (the oracle's scale): the weights passed for inside with a point 2.0e-7 from
  // p, where the edges come within 2.2e-16 (1.96e-10 m and 2e-19 m unscaled; fuzz/regressions/
  // core/oracle-near-collinear-triangle-0.1m-out). Each candidate is a point of the triangle:
  // the nearer one is the answer.
  const Vec3 t(0.1, 0, 0);
  const Vec3 a =
      (Vec3(-0.00033458851292702581, 0.00019471913943827887, 0.00010171895343790688) + t) * 1024;
  const Vec3 b =
      (Vec3(0.00020911782057939115, -0.00012169946214892429, -6.3574345898691795e-05) + t) * 1024;
  const Vec3 c =
      (Vec3(-0.001449883556017112, 0.00084378293756587504, 0.00044078213156426314) + t) * 1024;
  const Vec3 p = t * 1024;
  double edges = (oracle::closestPointSegment(p, a, b) - p).norm();
  edges = std::min(edges, (oracle::closestPointSegment(p, b, c) - p).norm());
  edges = std::min(edges, (oracle::closestPointSegment(p, c, a) - p).norm());
  EXPECT_LT(edges, 1e-15);
  EXPECT_LE((oracle::closestPointTriangle(p, a, b, c) - p).norm(), edges);  // was 2.0e-7
}

TEST(Oracle, OriginBesideACollinearSetOnItsLineIsOutside) {
  // Three points on the x axis, the nearest 1.164e-5 m from the origin, times 4096 (the oracle's
  // scale): flat, they are measured in their plane (oracle2d.h), where the SVD's axes (5e-17 off)
  // made them a sliver along the origin's line, every edge's cross product with the origin
  // exactly 0: "inside", distance 0 (fuzz/regressions/core/
  // oracle-collinear-axis-hull-point-on-its-line).
  const double near = 1.1640402187054374e-05;
  const std::vector<Vec3> points = {Vec3(6.9842413122326238e-05 * 4096, 0, 0),
                                    Vec3(0.00043069488092101183 * 4096, 0, 0),
                                    Vec3(near * 4096, 0, 0)};
  EXPECT_NEAR(oracle::originSignedDistance(points) / 4096, near, 1e-15);  // was 0
}

TEST(Oracle, SegmentSegmentClosestPoints) {
  Vec3 c1, c2;
  // Nearly parallel: two 16.875 m segments, the second 1.7e-8 rad off the first in the plane
  // y = 4.5e-10 m, crossing it in projection at x = 0: the distance is that offset. In double,
  // a e - b^2 kept a third of its value and the parameter went to an end: 8.3e-8 m
  // (fuzz/regressions/core/oracle-nearly-parallel-plate-edges).
  {
    const double g = 4.5e-10, h = 1.4232e-7;
    EXPECT_NEAR(oracle::closestSegmentSegment(Vec3(-8.4375, 0, 0), Vec3(8.4375, 0, 0),
                                              Vec3(-8.4375, g, h), Vec3(8.4375, g, -h), &c1, &c2),
                g, 1e-13);
    EXPECT_NEAR(c1.x(), 0.0, 1e-3);
  }
  // Skew, crossing at distance 2.
  EXPECT_DOUBLE_EQ(oracle::closestSegmentSegment(Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, -1, 2),
                                                 Vec3(0, 1, 2), &c1, &c2),
                   2.0);
  EXPECT_EQ(c1, Vec3(0, 0, 0));
  EXPECT_EQ(c2, Vec3(0, 0, 2));
  // Parallel, overlapping span: distance 1.
  EXPECT_DOUBLE_EQ(oracle::closestSegmentSegment(Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(1, 1, 0),
                                                 Vec3(3, 1, 0), &c1, &c2),
                   1.0);
  // End-point to end-point, and both degenerate (points).
  EXPECT_DOUBLE_EQ(oracle::closestSegmentSegment(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(4, 4, 0),
                                                 Vec3(4, 8, 0), &c1, &c2),
                   5.0);
  EXPECT_DOUBLE_EQ(oracle::closestSegmentSegment(Vec3(1, 1, 1), Vec3(1, 1, 1), Vec3(1, 1, 4),
                                                 Vec3(1, 1, 4), &c1, &c2),
                   3.0);
}

TEST(Oracle, UnitCubesKnownDistancesAndDepths) {
  const auto a = polyShape(cubeCorners(0.5));
  expectAnswer(oracle::solve(a, polyShape(cubeCorners(0.5, Vec3(1.5, 0, 0)))), 0.5, Vec3::UnitX());
  expectAnswer(oracle::solve(a, polyShape(cubeCorners(0.5, Vec3(0, -0.8, 0)))), -0.2,
               -Vec3::UnitY());
  expectAnswer(oracle::solve(a, polyShape(cubeCorners(0.5, Vec3(0.1, 0.2, 0.9)))), -0.1,
               Vec3::UnitZ());
  expectAnswer(oracle::solve(a, polyShape(cubeCorners(0.5, Vec3(1.5, 1.5, 0)))), std::sqrt(0.5),
               Vec3(1, 1, 0).normalized());
  expectAnswer(oracle::solve(a, polyShape(cubeCorners(0.5, Vec3(1.2, 1.3, 1.4)))),
               std::sqrt(0.04 + 0.09 + 0.16), Vec3(0.2, 0.3, 0.4).normalized());
  // A cube turned 45 degrees about z reaches 0.5 * sqrt(2) along x.
  std::vector<Vec3> turned;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ()).toRotationMatrix();
  for (const Vec3& v : cubeCorners(0.5))
    turned.push_back(R * v);
  expectAnswer(oracle::solve(polyShape(turned), polyShape(cubeCorners(0.5, Vec3(3, 0, 0)))),
               3.0 - 0.5 - 0.5 * std::sqrt(2.0), Vec3::UnitX());
}

TEST(Oracle, SpheresCapsulesAndPaddingKnownAnswers) {
  expectAnswer(oracle::solve(pointShape(Vec3(1, 1, 1), 1.0), pointShape(Vec3(1, 4, 1), 0.5)), 1.5,
               Vec3::UnitY());
  // Crossed capsules: core distance 2, radii 0.25 + 0.5.
  expectAnswer(oracle::solve(segmentShape(Vec3(0, 0, -1), Vec3(0, 0, 1), 0.25),
                             segmentShape(Vec3(-1, 2, 0), Vec3(1, 2, 0), 0.5)),
               1.25, Vec3::UnitY());
  // Sphere near a cube edge: sqrt(1.5^2 + 1.5^2) - 0.5.
  const auto cube = polyShape(cubeCorners(0.5));
  expectAnswer(oracle::solve(cube, pointShape(Vec3(2, 2, 0.1), 0.5)), std::sqrt(4.5) - 0.5,
               Vec3(1, 1, 0).normalized());
  // Sphere core inside the cube: depth 0.2 of the centre plus the radius.
  expectAnswer(oracle::solve(cube, pointShape(Vec3(0.3, 0, 0), 0.1)), -0.3, Vec3::UnitX());
  // Padded cubes: 1.0 apart minus 0.1 + 0.05 of padding.
  expectAnswer(oracle::solve(polyShape(cubeCorners(0.5), 0.1),
                             polyShape(cubeCorners(0.5, Vec3(0, 0, -2)), 0.05)),
               0.85, -Vec3::UnitZ());
  // Capsule lying on a box face, overlapping by 0.05 (segment vs polytope Minkowski hull).
  expectAnswer(oracle::solve(cube, segmentShape(Vec3(-2, 0, 0.7), Vec3(2, 0, 0.7), 0.25)), -0.05,
               Vec3::UnitZ());
  // Point-to-shape signed distances used by the witness checks.
  EXPECT_NEAR(polyShape(cubeCorners(0.5), 0.1).signedDistanceTo(Vec3(0.6, 0, 0)), 0.0, 1e-15);
  EXPECT_NEAR(cube.signedDistanceTo(Vec3(0.1, 0.2, 0.3)), -0.2, 1e-15);
  EXPECT_NEAR(cube.signedDistanceTo(Vec3(1.5, 1.5, 0.0)), std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(segmentShape(Vec3(0, 0, 0), Vec3(0, 0, 1), 0.5).signedDistanceTo(Vec3(0, 2, 2)),
              std::sqrt(5.0) - 0.5, 1e-15);
  EXPECT_NEAR(cube.supportValue(Vec3(1, 1, 0).normalized()), std::sqrt(0.5), 1e-15);
}

TEST(ConvexHull, SupportFromDirectionTableAndAnyHintEqualsBruteForce) {
  // Climbing hulls start at the better of the hint and the 26-direction table vertex; small ones
  // use the structure-of-arrays scan. Every start (no hint, garbage, each vertex) must give a
  // vertex maximising dot(d, x), and the scan the first such vertex.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int n : {4, 5, 12, 23, 24, 25, 40, 300}) {
    std::vector<Vec3> pts;
    for (int i = 0; i < n; ++i)
      pts.push_back(Vec3(0.3 * g(rng), 1.0 * g(rng), 2.0 * g(rng)));
    const auto poly = cm::buildConvexHull(pts);
    const auto& vs = poly->vertices();
    const int m = poly->size();
    for (int k = 0; k < 300; ++k) {
      Vec3 d = randomUnit(rng);
      if (k % 50 == 0) d = Vec3(k % 100 == 0 ? 1.0 : 0.0, 0.0, k % 100 == 0 ? 0.0 : -1.0);
      double best = -std::numeric_limits<double>::infinity();
      int first = -1;
      for (int i = 0; i < m; ++i) {
        if (vs[i].dot(d) > best) {
          best = vs[i].dot(d);
          first = i;
        }
      }
      EXPECT_EQ(poly->scanIndex(d), first) << "n " << n << " direction " << k;
      EXPECT_EQ(poly->scanIndex<false>(d), first) << "n " << n << " direction " << k;
      const int sv = poly->startVertex(d);
      EXPECT_GE(sv, 0);
      EXPECT_LT(sv, m);
      for (int h : {-1, -7, m, m + 5, k % m}) {
        int hint = h;
        const int idx = poly->supportIndex(d, hint);
        ASSERT_GE(idx, 0);
        ASSERT_LT(idx, m);
        EXPECT_EQ(hint, idx);
        EXPECT_EQ(vs[idx].dot(d), best) << "n " << n << " direction " << k << " hint " << h;
      }
    }
    // Zero and non-finite directions: a defined vertex, never out of range.
    for (const Vec3& d : {Vec3(Vec3::Zero()), Vec3(std::nan(""), 0.0, 1.0),
                          Vec3(std::numeric_limits<double>::infinity(), 0.0, 0.0)}) {
      int hint = -1;
      const int idx = poly->supportIndex(d, hint);
      EXPECT_GE(idx, 0);
      EXPECT_LT(idx, m);
    }
  }
}

TEST(ConvexHull, DuplicatePointsLoseNoVertexAndNoEdge) {
  // Bug (found by fuzz_core): qhull keeps complete ridge sets only for merged facets; reading
  // edges from ridges lost a vertex of a tetrahedron given with a duplicate point. The support
  // of the hull must equal the brute-force maximum over the input in every direction, and the
  // climb must agree with it (adjacency complete), for inputs full of duplicates.
  const std::vector<Vec3> fuzz_case = {
      Vec3(-15.3125, 0.0017470472440944884, 0),
      Vec3(-15.3125, 0, 0),
      Vec3(-15.3125, 0, 0),
      Vec3(-15.3125, 0, -0.10831692913385828),
      Vec3(-15.232135826771653, -0.10569635826771653, -0.055905511811023628),
      Vec3(-15.3125, 0.0061146653543307089, 0.056779035433070869)};
  const auto tet = cm::buildConvexHull(fuzz_case);
  EXPECT_EQ(tet->size(), 4);
  expectWellFormedAdjacency(*tet);
  for (int i = 0; i < tet->size(); ++i)
    EXPECT_EQ(neighbours(*tet, i).size(), 3u) << "vertex " << i;

  std::mt19937_64 rng(29);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_int_distribution<int> pick(0, 1 << 20);
  for (int n : {4, 6, 12, 40, 200}) {
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<Vec3> pts;
      for (int i = 0; i < n; ++i)
        pts.push_back(Vec3(g(rng), 0.5 * g(rng), 2.0 * g(rng)));
      for (int i = 0; i < n; ++i)
        pts.push_back(pts[pick(rng) % pts.size()]);  // as many duplicates again
      const auto poly = cm::buildConvexHull(pts);
      expectWellFormedAdjacency(*poly);
      expectSupportOfPoints(*poly, pts, rng, 100,
                            "n " + std::to_string(n) + " trial " + std::to_string(trial));
    }
  }
}

namespace {

/// The megametre hull cases below: buildConvexHull keeps `vertices` vertices with a well-formed
/// adjacency, its support is the points' brute-force maximum in 1000 random directions (`seed`),
/// and every point is within `tol` of it (expectPointsNearHull; the largest distance printed).
void expectMegametreHull(const std::vector<Vec3>& pts, int vertices, unsigned seed, double tol,
                         const std::string& what) {
  const auto poly = cm::buildConvexHull(pts);
  EXPECT_EQ(poly->size(), vertices) << what;
  expectWellFormedAdjacency(*poly);
  std::mt19937_64 rng(seed);
  expectSupportOfPoints(*poly, pts, rng, 1000, what);
  std::printf("%s: points at most %.3g m outside\n", what.c_str(),
              expectPointsNearHull(*poly, pts, tol, what));
}

}  // namespace

TEST(ConvexHull, BoxSweptAlongAMegametreSegmentFinishes) {
  // Bug (found by fuzz_core as a timeout, fuzz/regressions/core/hull-box-swept-1e6m-qhull-hang):
  // the 16 corners of a 1.4 x 3.5 x 4.7 m box at both ends of a segment 1.05e6 m long (the
  // oracle's Minkowski difference of a box and a segment). qhull with its default initial simplex
  // never left its facet merging (qh_mergefacet; 30 s here, 4 minutes in the oracle, stopped);
  // a node would hang on such a mesh. "Qs" (initial simplex from all points): 0.3 ms. Checked:
  // the hull's support equals the brute-force maximum over the points in every direction tried;
  // every point within 1e-10 m of the hull (the oracle's qhull). 12 vertices (14 in exact
  // rational arithmetic, the other two 6e-15 m out): 4 of the other 8 corners lie up to 5e-9 m
  // outside the swept prism's long edges. qhull merged them away (8 vertices) until the set went
  // to it mapped round (kRoundRel, eighth session of 2026-11-24), where 5e-9 m is 1e-9 of the
  // width instead of 5e-15 of the length.
  const Vec3 s0(-0.0011093750000000001, 1.390625e-09, -9.9999999999999995e-07), s1(0, 0, 1046875);
  std::vector<Vec3> pts;
  for (const Vec3& c : boxCorners(Vec3(1.375, 3.46875, 4.703125))) {
    pts.push_back(c - s0);
    pts.push_back(c - s1);
  }
  expectMegametreHull(pts, 12, 31, 1e-10, "swept box");
}

TEST(ConvexHull, SlantedMegametrePrismFinishes) {
  // Bug (found by fuzz_core as a timeout,
  // fuzz/regressions/core/hull-slanted-1e6m-prism-qhull-hang): the 64 vertex differences (16
  // distinct) of a flat 1.08 x 4.66 m plate and a flat 2.14 m x 1e6 m plate 6.7e5 m away, tilted by
  // 8e-9 rad: a slanted prism 1e6 m long and 3.2 x 4.7 m across. qhull 2020.2 looped for ever
  // merging and re-partitioning its facets ("Qs", "Qt", "Qt Qs", "C-0", "Q12" alike), in
  // buildConvexHull, hullTriangles and hullPlanes; a node would hang on such a mesh. Sets thinner
  // than 1e-3 of their extent now go to qhull mapped round (kRoundRel): 0.07 ms. Checked: the
  // hull's support equals the brute-force maximum over the points; every point within 2e-8 m of the
  // hull (the oracle's qhull); every point is inside every plane, which touches one.
  cm::Mat3 R;
  R << 1, -1.7064143387928344e-11, 7.9274386713863995e-09, 1.7064151909187178e-11, 1,
      -1.0749069384241901e-09, -7.927438671368056e-09, 1.0749069385594651e-09, 1;
  const Vec3 t(0, 0, 671875.00000001141);
  // The fuzzer's boxes: half of a 4.9e-324 m side rounds to 0 (two plates, corners twice).
  std::vector<Vec3> pts;
  for (const Vec3& x : boxCorners(Vec3(1.078125, 4.65625, 4.9406564584124654e-324)))
    for (const Vec3& y : boxCorners(Vec3(2.140625, 4.9406564584124654e-324, 1e6)))
      pts.push_back(x - (R * y + t));
  // Exact rational arithmetic (every facet plane of the 16 points) gives 14 vertices: the 8
  // corners and 6 points up to 1e-8 m outside the long edges. qhull keeps 13: one is left
  // 8.6e-9 m outside (8.6e-15 of the length; the library drops up to 1e-10 of it, kFlatRel).
  expectMegametreHull(pts, 13, 37, 2e-8, "slanted prism");
  // Every point inside every plane (to the rounding of 1e6 m coordinates), which touches one.
  const auto planes = cm::hullPlanes(pts);
  EXPECT_GE(planes.size(), 6u);
  for (const cm::HullPlane& h : planes) {
    EXPECT_NEAR(h.normal.norm(), 1.0, 1e-12);
    double top = -std::numeric_limits<double>::infinity();
    for (const Vec3& p : pts)
      top = std::max(top, h.normal.dot(p));
    EXPECT_NEAR(top, h.offset, 1e-9) << "a plane off the points";
  }
}

TEST(Polytope, ScanIndexFirstMaximumOnTies) {
  // Both lane reductions of the scan (folded in vector registers, or scalar) must return the
  // first maximum when several vertices tie, in whichever lanes they sit (and whatever the pad
  // slots, copies of vertex 0, hold). Vertices i >= first with odd i - first lie on x = 1.
  // From 48 vertices the four-lane scan keeps two maxima (even and odd blocks of four): ties
  // across them, and an odd number of blocks, too.
  std::vector<int> sizes;
  for (int n = 2; n <= 13; ++n)
    sizes.push_back(n);
  for (int n : {44, 47, 48, 49, 52, 56, 100, 121})
    sizes.push_back(n);
  for (const int n : sizes) {
    for (int first = 0; first < n; ++first) {
      std::vector<Vec3> vs;
      for (int i = 0; i < n; ++i) {
        const bool top = i >= first && (i - first) % 2 == 0;
        vs.emplace_back(top ? 1.0 : 0.25 * (i % 3), 0.1 * i, -0.05 * i);
      }
      const cm::Polytope<3> poly(vs);
      const Vec3 d(1, 0, 0);
      EXPECT_EQ(poly.scanIndex(d), first) << "n " << n;
      EXPECT_EQ(poly.scanIndex<false>(d), first) << "n " << n;
    }
  }
}

#if defined(CM_HAVE_AVX2_SCAN) && !defined(__SANITIZE_ADDRESS__)  // as query.cpp
/// GJK on BasicPolytopePairDifference<true, kMapB> compiled as query.cpp compiles it.
template <bool kMapB>
__attribute__((target("avx2"), flatten)) cm::GjkResult<3> gjkDistanceAvx2(
    const cm::Polytope<3>& a, const cm::Polytope<3>& b, const cm::Transform3& T,
    const cm::GjkSettings& st) {
  return cm::gjkDistance(cm::BasicPolytopePairDifference<true, kMapB>(a, b, T), st);
}
#endif

TEST(PolytopePair, SupportAndTransformMatchTheGenericDifference) {
  // PolytopePairDifference maps B into A's frame once and scans both in one call. Its support
  // points must be the generic MinkowskiDifference's, bit for bit: B's vertices come out as
  // mulAdd() gives them, and each scan picks the first maximum. Both vector widths are checked
  // (the two-lane one is what a CPU without AVX2 runs), and GJK on both differences must agree.
  // Unmapped (kMapB = false, B scanned in its own frame): the generic difference's arithmetic.
  std::mt19937_64 rng(23);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int na : {4, 12, 30}) {
    for (int nb : {4, 9, 12, 48, 120}) {
      std::vector<Vec3> pa, pb;
      for (int i = 0; i < na; ++i)
        pa.push_back(Vec3(0.5 * g(rng), g(rng), 0.3 * g(rng)));
      for (int i = 0; i < nb; ++i)
        pb.push_back(Vec3(g(rng), 0.2 * g(rng), 0.7 * g(rng)));
      const auto a = cm::buildConvexHull(pa);
      const auto b = cm::buildConvexHull(pb);
      ASSERT_TRUE(cm::PolytopePairDifference::applies(*a, *b));
      const cm::Transform3 T = cm::makeTransform(Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)),
                                                 Vec3(g(rng), g(rng), g(rng)));
      const cm::PolytopePairDifference pair(*a, *b, T);
      const cm::BasicPolytopePairDifference<false, false> unmapped(*a, *b, T);
      const cm::MinkowskiDifference<3, cm::Polytope<3>, cm::Polytope<3>> generic(*a, *b, T);
      // Where the generic difference scans B too (no climbing), the same vertex.
      const bool b_scans = b->usesLinearScan();

      // B in A's frame with both widths, against mulAdd() per vertex.
      const int np = b->paddedSize();
      const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R = T.R;
      std::vector<double> two(3 * np), four(3 * np);
      cm::detail::transformBlocks<3, cm::detail::V2d>(b->scanData(), np, R.data(), T.t.data(),
                                                      two.data());
#ifdef CM_HAVE_AVX2_SCAN
      if (cm::detail::cpuHasAvx2())
        cm::detail::transformAvx2<3>(b->scanData(), np, R.data(), T.t.data(), four.data());
      else
#endif
        four = two;
      for (int i = 0; i < np; ++i) {
        const Vec3 want = cm::mulAdd<3>(T.R, b->vertices()[i < b->size() ? i : 0], T.t);
        for (int k = 0; k < 3; ++k) {
          EXPECT_EQ(two[k * np + i], want[k]) << "vertex " << i;
          EXPECT_EQ(four[k * np + i], want[k]) << "vertex " << i;
        }
      }

      for (int k = 0; k < 200; ++k) {
        const Vec3 d = k == 0 ? Vec3(0.0, 0.0, 0.0) : randomUnit(rng);
        const double dd[3] = {d.x(), d.y(), d.z()};
        const double nd[3] = {-d.x(), -d.y(), -d.z()};
        const auto i2 = cm::detail::scanPairBlocks<3, cm::detail::V2d>(
            a->scanData(), a->paddedSize(), two.data(), np, dd, nd);
        const cm::SupportPoint<3> s = pair.support(d);
        EXPECT_EQ(s.a, a->vertices()[i2[0]]);
        EXPECT_EQ(s.b, Vec3(two[i2[1]], two[np + i2[1]], two[2 * np + i2[1]]));
        EXPECT_EQ(s.w, s.a - s.b);
        // The generic difference scans B in its own frame: the same maximum value (a tie may
        // pick another vertex, the rotated direction rounds differently).
        const cm::SupportPoint<3> r = generic.support(d);
        EXPECT_EQ(s.a, r.a);
        EXPECT_NEAR(d.dot(s.b), d.dot(r.b), 1e-14) << "direction " << k;
        const cm::SupportPoint<3> u = unmapped.support(d);
        EXPECT_EQ(u.a, r.a);
        EXPECT_EQ(u.w, u.a - u.b);
        if (b_scans) {
          EXPECT_EQ(u.b, r.b) << "direction " << k;
        } else {
          EXPECT_NEAR(d.dot(u.b), d.dot(r.b), 1e-14) << "direction " << k;
        }
      }

      cm::GjkSettings st;
      st.abs_tolerance = 1e-12 * 10.0;
      const auto gp = cm::gjkDistance(pair, st);
      const auto gg = cm::gjkDistance(generic, st);
      EXPECT_EQ(gp.status, gg.status) << na << " x " << nb;
      EXPECT_NEAR(gp.distance, gg.distance, 1e-12) << na << " x " << nb;
      const auto gu = cm::gjkDistance(unmapped, st);
      EXPECT_EQ(gu.status, gg.status) << na << " x " << nb;
      EXPECT_NEAR(gu.distance, gg.distance, 1e-12) << na << " x " << nb;
      if (b_scans) {
        EXPECT_EQ(gu.point_b, gg.point_b) << na << " x " << nb;
      }
#if defined(CM_HAVE_AVX2_SCAN) && !defined(__SANITIZE_ADDRESS__)
      // The AVX2-compiled query (four lanes inlined, VEX code, no FMA) gives the same bits.
      if (cm::detail::cpuHasAvx2()) {
        const auto g4 = gjkDistanceAvx2<true>(*a, *b, T, st);
        EXPECT_EQ(g4.status, gp.status);
        EXPECT_EQ(g4.iterations, gp.iterations);
        EXPECT_EQ(g4.distance, gp.distance);
        EXPECT_EQ(g4.point_a, gp.point_a);
        EXPECT_EQ(g4.point_b, gp.point_b);
        const auto u4 = gjkDistanceAvx2<false>(*a, *b, T, st);
        EXPECT_EQ(u4.iterations, gu.iterations);
        EXPECT_EQ(u4.distance, gu.distance);
        EXPECT_EQ(u4.point_a, gu.point_a);
        EXPECT_EQ(u4.point_b, gu.point_b);
      }
#endif
    }
  }
  // Not for climbing polytopes or a B over the buffer.
  std::vector<Vec3> many;
  for (int i = 0; i < 200; ++i)
    many.push_back(randomUnit(rng));
  const auto big = cm::buildConvexHull(many);
  const auto small = cm::buildConvexHull(cubeCorners(1.0));
  EXPECT_FALSE(cm::PolytopePairDifference::applies(*big, *small));
  EXPECT_FALSE(cm::PolytopePairDifference::applies(*small, *big));
  EXPECT_TRUE(cm::PolytopePairDifference::applies(*small, *small));
  // The size limit: kMaxVerticesAvx2 on AVX2, Polytope::kLinearScanMax (where climbing starts)
  // without; points on a sphere are all hull vertices.
  const auto onSphere = [&rng](int n) {
    std::vector<Vec3> p;
    for (int i = 0; i < n; ++i)
      p.push_back(randomUnit(rng));
    return cm::buildConvexHull(p);
  };
  const int limit = small->scansAvx2() ? cm::PolytopePairDifference::kMaxVerticesAvx2
                                       : cm::Polytope<3>::kLinearScanMax;
  const auto at = onSphere(limit);
  const auto over = onSphere(limit + 1);
  ASSERT_EQ(at->size(), limit);
  ASSERT_EQ(over->size(), limit + 1);
  EXPECT_TRUE(cm::PolytopePairDifference::applies(*at, *at));
  EXPECT_FALSE(cm::PolytopePairDifference::applies(*over, *small));
  EXPECT_FALSE(cm::PolytopePairDifference::applies(*small, *over));
}
