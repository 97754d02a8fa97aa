// ConvexShape factories, validation messages, support mappings, AABBs and bounding radii.
// Expected values are worked out by hand from the shape definitions.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "collision_monitor/core/convex_hull.h"
#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/core/gjk.h"
#include "collision_monitor/core/shapes.h"

namespace cm = collision_monitor::core;
using cm::ConvexShape;
using cm::Vec3;

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

/// Runs `make`, expects std::invalid_argument whose message contains every string in `parts`.
template <class F>
void expectRejected(F make, const std::vector<std::string>& parts) {
  try {
    make();
    ADD_FAILURE() << "no exception; expected one mentioning " << parts.front();
  } catch (const std::invalid_argument& e) {
    const std::string msg = e.what();
    for (const std::string& p : parts)
      EXPECT_NE(msg.find(p), std::string::npos) << "message '" << msg << "' lacks '" << p << "'";
  }
}

void expectVecNear(const Vec3& a, const Vec3& b, double tol) {
  EXPECT_NEAR(a.x(), b.x(), tol);
  EXPECT_NEAR(a.y(), b.y(), tol);
  EXPECT_NEAR(a.z(), b.z(), tol);
}

/// n points of the unit sphere on a golden-angle spiral: all of them vertices of their hull.
std::vector<Vec3> sphereSpiral(int n) {
  std::vector<Vec3> pts;
  for (int i = 0; i < n; ++i) {
    const double z = -1.0 + (2.0 * i + 1.0) / n;
    const double r = std::sqrt(1.0 - z * z);
    pts.emplace_back(r * std::cos(2.399963229728653 * i), r * std::sin(2.399963229728653 * i), z);
  }
  return pts;
}

}  // namespace

TEST(ShapeValidation, RejectsNegativeSizesNamingShapeAndValue) {
  expectRejected([] { ConvexShape::sphere(-1.0); }, {"sphere", "radius", "-1"});
  expectRejected([] { ConvexShape::box(Vec3(1.0, -2.5, 3.0)); }, {"box", "sides.y", "-2.5"});
  expectRejected([] { ConvexShape::capsule(-0.5, 1.0); }, {"capsule", "length", "-0.5"});
  expectRejected([] { ConvexShape::capsule(1.0, -3.0); }, {"capsule", "radius", "-3"});
  expectRejected([] { ConvexShape::cylinder(-1.0, 1.0); }, {"cylinder", "height", "-1"});
  expectRejected([] { ConvexShape::cone(1.0, -0.25); }, {"cone", "radius", "-0.25"});
  expectRejected([] { ConvexShape::ellipsoid(Vec3(1.0, 1.0, -4.0)); },
                 {"ellipsoid", "semi_axes.z", "-4"});
  expectRejected([] { ConvexShape::box(Vec3(1.0, 1.0, 1.0)).padded(-0.1); },
                 {"padded", "padding", "-0.1"});
}

TEST(ShapeValidation, RejectsANegativeSizeOnEveryAxis) {
  // Every axis of a box's sides and of an ellipsoid's semi-axes is checked, each by its name.
  static const char* const kAxis[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k) {
    Vec3 v = Vec3::Ones();
    v[k] = -2.0;
    expectRejected([v] { ConvexShape::box(v); }, {"box", std::string("sides.") + kAxis[k], "-2"});
    expectRejected([v] { ConvexShape::ellipsoid(v); },
                   {"ellipsoid", std::string("semi_axes.") + kAxis[k], "-2"});
  }
}

TEST(ShapeValidation, RejectsNaNAndInf) {
  expectRejected([] { ConvexShape::sphere(kNaN); }, {"sphere", "radius", "nan"});
  expectRejected([] { ConvexShape::sphere(kInf); }, {"sphere", "radius", "inf"});
  expectRejected([] { ConvexShape::box(Vec3(kNaN, 1.0, 1.0)); }, {"box", "sides.x", "nan"});
  expectRejected([] { ConvexShape::cylinder(1.0, kInf); }, {"cylinder", "radius", "inf"});
  expectRejected([] { ConvexShape::cone(-kInf, 1.0); }, {"cone", "height", "-inf"});
  expectRejected([] { ConvexShape::point(Vec3(0.0, kNaN, 0.0)); }, {"point", "p.y", "nan"});
  expectRejected([] { ConvexShape::segment(Vec3::Zero(), Vec3(0.0, 0.0, kInf)); },
                 {"segment", "b.z", "inf"});
  expectRejected([] { ConvexShape::sphere(1.0).padded(kNaN); }, {"padded", "padding", "nan"});
  // Finite, but the padded size overflows: queries returned +inf, FailedToConverge.
  expectRejected([] { ConvexShape::cylinder(1.0, 1e308).padded(1e308); },
                 {"padded", "padding", "1e+308", "finite"});
  expectRejected(
      [] {
        ConvexShape::polytope(std::make_shared<cm::Polytope<3>>(
            std::vector<Vec3>{Vec3::Zero(), Vec3(1.0, kNaN, 0.0)}));
      },
      {"polytope", "vertices[1].y", "nan"});
  expectRejected(
      [] {
        ConvexShape::convexHull({Vec3::Zero(), Vec3(kInf, 0.0, 0.0)});
      },
      {"convexHull", "points[1].x", "inf"});
}

TEST(ShapeValidation, RejectsEmptyAndNullPolytopes) {
  expectRejected([] { ConvexShape::polytope(nullptr); }, {"polytope", "null"});
  expectRejected([] { ConvexShape::polytope(std::make_shared<cm::Polytope<3>>()); },
                 {"polytope", "no vertices"});
  expectRejected([] { ConvexShape::convexHull({}); }, {"convexHull", "no points"});
}

TEST(ShapeValidation, RejectsPolytopeAdjacencyThatIsNotTheHullsEdgeGraph) {
  // Audit (twenty-fifth session): only the vertices were checked. Neighbour lists all empty on a
  // 60-vertex polytope (which hill-climbs) were accepted and distances came out 2.9 mm short;
  // out-of-range neighbours would be read out of bounds.
  std::vector<Vec3> ball;
  for (int i = 0; i < 60; ++i) {
    const double z = -1.0 + (2.0 * i + 1.0) / 60.0;
    const double r = std::sqrt(1.0 - z * z);
    ball.emplace_back(r * std::cos(2.399963229728653 * i), r * std::sin(2.399963229728653 * i), z);
  }
  const auto hull = cm::buildConvexHull(ball);
  ASSERT_EQ(hull->size(), 60);
  ASSERT_FALSE(hull->usesLinearScan());
  EXPECT_NO_THROW(ConvexShape::polytope(hull));  // qhull's edge graph
  const std::vector<int>& off = hull->adjacencyOffsets();
  const std::vector<int>& adj = hull->adjacency();
  const auto make = [&](std::vector<int> o, std::vector<int> a) {
    return [&, o, a] {
      ConvexShape::polytope(std::make_shared<cm::Polytope<3>>(hull->vertices(), o, a));
    };
  };
  expectRejected(make(std::vector<int>(61, 0), {}), {"polytope", "not the hull's edge graph"});
  expectRejected(make({0, 1, 2}, {1, 0}), {"polytope", "offsets: 3 for 60 vertices"});
  expectRejected(make({}, adj), {"polytope", "neighbours but no offsets"});
  std::vector<int> a = adj;
  a[7] = 60;
  expectRejected(make(off, a), {"polytope", "neighbour 60 is not another vertex"});
  a[7] = -1;
  expectRejected(make(off, a), {"neighbour -1"});
  a = adj;
  a[off[3]] = 3;
  expectRejected(make(off, a), {"of vertex 3: neighbour 3"});
  std::vector<int> o = off;
  o[5] = o[6] + 1;
  expectRejected(make(o, adj), {"offsets decrease at vertex 5"});
  o = off;
  o[60] -= 1;
  expectRejected(make(o, adj), {"offsets must run from 0 to the neighbour count"});
  // A small polytope scans every vertex: its graph is checked for range only.
  std::vector<Vec3> few(ball.begin(), ball.begin() + 12);
  EXPECT_NO_THROW(ConvexShape::polytope(
      std::make_shared<cm::Polytope<3>>(few, std::vector<int>(13, 0), std::vector<int>{})));
}

TEST(ShapeValidation, RejectsAdjacencyOffsetsThatDoNotStartAtZero) {
  // The first offset must be 0 (else vertex 0's first neighbours are never read), also where the
  // graph is never climbed: a cube (8 vertices, scanned) whose nine offsets all read 1, ending at
  // its one neighbour entry, passes every other check.
  std::vector<Vec3> cube;
  for (int i = 0; i < 8; ++i)
    cube.emplace_back(i & 1 ? 0.5 : -0.5, i & 2 ? 0.5 : -0.5, i & 4 ? 0.5 : -0.5);
  expectRejected(
      [&cube] {
        ConvexShape::polytope(
            std::make_shared<cm::Polytope<3>>(cube, std::vector<int>(9, 1), std::vector<int>{1}));
      },
      {"polytope", "offsets must run from 0 to the neighbour count (1)"});
}

TEST(ShapeValidation, PolytopesOfUpTo48VerticesScanAndNeedNoEdgeGraph) {
  // Polytope::kLinearScanMax = 48: up to 48 vertices the support scans every vertex, so empty
  // neighbour lists are accepted (never climbed) and the support is still the farthest vertex;
  // from 49 vertices it hill-climbs, and the same lists are refused.
  const std::vector<Vec3> pts48 = sphereSpiral(48);
  const auto at =
      std::make_shared<cm::Polytope<3>>(pts48, std::vector<int>(49, 0), std::vector<int>{});
  EXPECT_TRUE(at->usesLinearScan());
  const ConvexShape shape = ConvexShape::polytope(at);
  for (int k = 0; k < 20; ++k) {
    const Vec3 d(std::cos(0.7 * k), std::sin(1.3 * k), std::cos(2.1 * k + 0.4));
    double best = -kInf;
    for (const Vec3& p : pts48)
      best = std::max(best, p.dot(d));
    EXPECT_EQ(shape.support(d).dot(d), best) << "direction " << k;
  }
  const auto over = std::make_shared<cm::Polytope<3>>(sphereSpiral(49), std::vector<int>(50, 0),
                                                      std::vector<int>{});
  EXPECT_FALSE(over->usesLinearScan());
  expectRejected([&over] { ConvexShape::polytope(over); },
                 {"polytope", "not the hull's edge graph"});
}

TEST(ShapeValidation, ZeroSizesAreValidDegenerateShapes) {
  EXPECT_NO_THROW(ConvexShape::sphere(0.0));
  EXPECT_NO_THROW(ConvexShape::box(Vec3::Zero()));
  EXPECT_NO_THROW(ConvexShape::capsule(0.0, 0.0));
  EXPECT_NO_THROW(ConvexShape::cylinder(0.0, 0.0));
  EXPECT_NO_THROW(ConvexShape::cone(0.0, 0.0));
  EXPECT_NO_THROW(ConvexShape::ellipsoid(Vec3::Zero()));
  EXPECT_NO_THROW(ConvexShape::sphere(1.0).padded(0.0));
  const ConvexShape zero_box = ConvexShape::box(Vec3::Zero());
  expectVecNear(zero_box.support(Vec3(1.0, -2.0, 3.0)), Vec3::Zero(), 0.0);
  EXPECT_EQ(zero_box.boundingRadius(), 0.0);
}

TEST(ShapeSupport, FullShapeAddsRadiusAlongDirection) {
  const ConvexShape s = ConvexShape::sphere(2.0);
  expectVecNear(s.support(Vec3(0.0, 3.0, 4.0)), Vec3(0.0, 1.2, 1.6), 1e-15);
  expectVecNear(s.coreSupport(Vec3(0.0, 3.0, 4.0)), Vec3::Zero(), 0.0);
  // Zero direction: a defined point (the core's), never NaN.
  expectVecNear(s.support(Vec3::Zero()), Vec3::Zero(), 0.0);

  const ConvexShape c = ConvexShape::capsule(2.0, 0.5);
  expectVecNear(c.coreSupport(Vec3(1.0, 0.0, 1.0)), Vec3(0.0, 0.0, 1.0), 0.0);
  const double h = 0.5 / std::sqrt(2.0);
  expectVecNear(c.support(Vec3(1.0, 0.0, -1.0)), Vec3(h, 0.0, -1.0 - h), 1e-15);

  const ConvexShape b = ConvexShape::box(Vec3(2.0, 4.0, 6.0));
  expectVecNear(b.support(Vec3(-1.0, 2.0, -3.0)), Vec3(-1.0, 2.0, -3.0), 0.0);

  const ConvexShape cyl = ConvexShape::cylinder(2.0, 3.0);
  expectVecNear(cyl.support(Vec3(3.0, 4.0, -1.0)), Vec3(1.8, 2.4, -1.0), 1e-15);

  const ConvexShape cone = ConvexShape::cone(2.0, 1.0);  // apex z=+1, base z=-1 radius 1
  expectVecNear(cone.support(Vec3(0.0, 0.0, 1.0)), Vec3(0.0, 0.0, 1.0), 0.0);
  expectVecNear(cone.support(Vec3(1.0, 0.0, -0.1)), Vec3(1.0, 0.0, -1.0), 0.0);

  const ConvexShape e = ConvexShape::ellipsoid(Vec3(1.0, 2.0, 3.0));
  // S^2 d / |S d| for d = (0, 1, 1): S d = (0, 2, 3), |S d| = sqrt(13).
  expectVecNear(e.support(Vec3(0.0, 1.0, 1.0)), Vec3(0.0, 4.0, 9.0) / std::sqrt(13.0), 1e-15);

  const ConvexShape seg = ConvexShape::segment(Vec3(1.0, 2.0, 3.0), Vec3(-1.0, 0.0, 5.0));
  expectVecNear(seg.support(Vec3(-1.0, 0.0, 0.0)), Vec3(-1.0, 0.0, 5.0), 0.0);
  expectVecNear(seg.support(Vec3(0.0, 1.0, 0.0)), Vec3(1.0, 2.0, 3.0), 0.0);

  const ConvexShape p = ConvexShape::point(Vec3(4.0, 5.0, 6.0)).padded(1.0);
  expectVecNear(p.support(Vec3(0.0, 0.0, -2.0)), Vec3(4.0, 5.0, 5.0), 0.0);
  EXPECT_EQ(p.radius(), 1.0);
}

TEST(ShapeSupport, EllipsoidAtTinyAndHugeScales) {
  // S^2 d / |S d| squares lengths: below about 1e-154 m they lose digits, above 1e154 m they
  // overflow (fuzz/regressions/core/gjk-ellipsoid-1e-161m-support-underflow: a 7.3e-161 m needle's
  // tip came out 7e-164 m short). The same answers as at unit size, scaled: d = (0, 1, 1) on
  // semi-axes k (1, 2, 3) gives k (0, 4, 9) / sqrt(13); d = (1, 0, 0) on k (1, 0, 0) gives k e_x.
  for (const double k : {7.318236270796776e-161, 1e-300, 1e200, 1e300}) {
    const ConvexShape e = ConvexShape::ellipsoid(Vec3(1.0, 2.0, 3.0) * k);
    const Vec3 got = e.support(Vec3(0.0, 1.0, 1.0));
    expectVecNear(got / k, Vec3(0.0, 4.0, 9.0) / std::sqrt(13.0), 1e-15);
    const ConvexShape needle = ConvexShape::ellipsoid(Vec3(k, 0.0, 0.0));
    EXPECT_EQ(needle.support(Vec3(1.0, 0.0, 0.0)), Vec3(k, 0.0, 0.0)) << k;
    EXPECT_TRUE(e.support(Vec3(1e-10, -1e-10, 0.0)).allFinite()) << k;
  }
}

TEST(ShapeSupport, EllipsoidSupportDoesNotDependOnTheDirectionsLength) {
  // support(s d) = support(d) for s > 0: on semi-axes k (1, 2, 3) along d = (0, 1, 1) it is
  // k (0, 4, 9) / sqrt(13). With k = 1e200, s = 1e-60, |S d| = 3.6e140 is in range but
  // S^2 d = 1e340 (0, 4, 9) overflowed to inf (a 5e180 m ellipsoid along a direction 1e-46 long
  // made GJK call a unit box at its centre separated at +inf:
  // fuzz/regressions/ros/body-ellipsoid-5e180m-support-overflow); with k = 1e300, s = 1e200,
  // S d itself overflowed (the support was the centre). The other pairs (k, s) take either way of
  // computing it.
  const std::pair<double, double> cases[] = {{1e200, 1e-60},  {1e300, 1e200},  {1e200, 1e-48},
                                             {1e200, 1e-300}, {1e300, 1e-300}, {1e150, 1.0},
                                             {1e150, 1e-300}, {1.0, 1e-10},    {1.0, 1e100},
                                             {1e-150, 1.0},   {1e-150, 1e250}};
  for (const auto& [k, s] : cases) {
    const ConvexShape e = ConvexShape::ellipsoid(Vec3(1.0, 2.0, 3.0) * k);
    const Vec3 got = e.support(Vec3(0.0, s, s));
    expectVecNear(got / k, Vec3(0.0, 4.0, 9.0) / std::sqrt(13.0), 1e-15);
  }
}

TEST(ShapeSupport, EllipsoidSupportOfAnInfiniteDirectionIsAPointOfTheShape) {
  // A direction with an infinite component leaves S d / |S d| undefined (inf / inf): the answer is
  // still a point of the ellipsoid, never NaN.
  const cm::EllipsoidShape<3> e{Vec3(1.0, 2.0, 3.0)};
  for (const Vec3& d : {Vec3(kInf, 0.0, 0.0), Vec3(0.0, -kInf, 1.0), Vec3(kInf, kInf, -kInf)}) {
    const Vec3 p = e.support(d);
    ASSERT_TRUE(p.allFinite()) << d.transpose();
    EXPECT_LE(std::pow(p.x(), 2) + std::pow(p.y() / 2.0, 2) + std::pow(p.z() / 3.0, 2), 1.0);
  }
}

TEST(ShapeSupport, CylinderAndConeRimsForTinyDirections) {
  // radius * d.x / |d_xy| made radius * d.x sub-normal for a 1.3e-163 m rim and an 8.6e-159
  // direction (GJK's first direction on such a pair, in metres): the rim point came out 1e-3 of
  // the radius outside the cylinder (fuzz/regressions/core/gjk-point-by-1e-163m-cylinder-rim-
  // underflow). Along -x the rim point is exactly (-r, 0, .).
  const double r = 1.3075051467559381e-163;
  const Vec3 d(-8.5687349792650e-159, 0.0, -1e-170);
  EXPECT_EQ(ConvexShape::cylinder(r, r).support(d).x(), -r);
  EXPECT_EQ(ConvexShape::cone(r, r).support(d).x(), -r);
  EXPECT_EQ(ConvexShape::cylinder(1.0, 1.0).support(Vec3(-1e-300, 0.0, 0.0)).x(), -1.0);
}

TEST(ShapeSupport, PolytopeLinearScanAndHillClimbAgree) {
  // 40 points on a helix-like curve on the unit sphere: with adjacency from qhull the support
  // hill-climbs; without it, a linear scan. Both must find the same maximising vertex.
  std::vector<Vec3> pts;
  for (int i = 0; i < 40; ++i) {
    const double z = -1.0 + (2.0 * i + 1.0) / 40.0;
    const double r = std::sqrt(1.0 - z * z);
    const double phi = 2.399963229728653 * i;  // golden angle
    pts.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  const ConvexShape hull = ConvexShape::convexHull(pts);
  const ConvexShape scan = ConvexShape::polytope(std::make_shared<cm::Polytope<3>>(pts));
  EXPECT_EQ(scan.describe(), "polytope(40)");
  for (int k = 0; k < 50; ++k) {
    const Vec3 d(std::cos(0.7 * k), std::sin(1.3 * k), std::cos(2.1 * k + 0.4));
    double best = -1e300;
    for (const Vec3& p : pts)
      best = std::max(best, p.dot(d));
    EXPECT_DOUBLE_EQ(hull.support(d).dot(d), best);
    EXPECT_DOUBLE_EQ(scan.support(d).dot(d), best);
  }
}

TEST(ShapeSupport, ClimbStartsAtTheVertexOfTheDirectionsCell) {
  // Polytope::startVertex(d) is the extreme vertex of the centre direction of d's cube-map cell.
  // The cells split each face at 0, so a centre has the signs of d's components (and none zero).
  // On a box (+-2, +-1, +-0.5) the extreme vertex along a direction without zero components is
  // the corner with its signs: that corner is the start vertex. 44 points inside the box make it
  // 52 vertices with (empty) adjacency: a climbing polytope.
  std::vector<Vec3> pts;
  for (int i = 0; i < 8; ++i)
    pts.emplace_back(i & 1 ? 2.0 : -2.0, i & 2 ? 1.0 : -1.0, i & 4 ? 0.5 : -0.5);
  for (int i = 0; i < 44; ++i)
    pts.emplace_back(0.1 * (i % 5 - 2), 0.1 * (i % 7 - 3), 0.05 * (i % 3 - 1));
  const cm::Polytope<3> box(pts, std::vector<int>(53, 0), std::vector<int>{});
  ASSERT_FALSE(box.usesLinearScan());
  for (const Vec3& d : {Vec3(1.0, 0.3, -0.2), Vec3(-0.1, 0.9, 0.5), Vec3(0.2, -0.3, -1.0),
                        Vec3(-1.0, -0.999, 0.999), Vec3(1.0, -1.0, 0.5), Vec3(-3e-3, 2e-3, 1e-3),
                        Vec3(0.7, 0.05, 0.6), Vec3(-0.02, -0.5, -0.49)}) {
    const int corner = (d.x() > 0.0 ? 1 : 0) + (d.y() > 0.0 ? 2 : 0) + (d.z() > 0.0 ? 4 : 0);
    EXPECT_EQ(box.startVertex(d), corner) << d.transpose();
  }
}

TEST(ShapeAabb, ExactBoxesOfRotatedShapes) {
  // Unit cube rotated 45 degrees about z at (10, 0, 0): x, y half extents sqrt(2)/2, z 1/2.
  cm::Transform3 pose = cm::makeTransform(
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 4, Vec3::UnitZ())), Vec3(10.0, 0.0, 0.0));
  const cm::Aabb box = ConvexShape::box(Vec3(1.0, 1.0, 1.0)).aabb(pose);
  const double h = std::sqrt(2.0) / 2.0;
  expectVecNear(box.min, Vec3(10.0 - h, -h, -0.5), 1e-15);
  expectVecNear(box.max, Vec3(10.0 + h, h, 0.5), 1e-15);

  // Capsule (length 2, radius 0.5) lying along x (rotated 90 degrees about y), at (1, 2, 3).
  pose = cm::makeTransform(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Vec3::UnitY())),
                           Vec3(1.0, 2.0, 3.0));
  const cm::Aabb cap = ConvexShape::capsule(2.0, 0.5).aabb(pose);
  expectVecNear(cap.min, Vec3(1.0 - 1.5, 1.5, 2.5), 1e-15);
  expectVecNear(cap.max, Vec3(1.0 + 1.5, 2.5, 3.5), 1e-15);

  // Cylinder (h 2, r 1) tilted 30 degrees about y: x extent = sin30 * 1 + cos30 * 1.
  pose = cm::makeTransform(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 6, Vec3::UnitY())),
                           Vec3::Zero());
  const cm::Aabb cyl = ConvexShape::cylinder(2.0, 1.0).aabb(pose);
  EXPECT_NEAR(cyl.max.x(), 0.5 + std::sqrt(3.0) / 2.0, 1e-15);
  EXPECT_NEAR(cyl.min.x(), -(0.5 + std::sqrt(3.0) / 2.0), 1e-15);
  EXPECT_NEAR(cyl.max.y(), 1.0, 1e-15);
  EXPECT_NEAR(cyl.max.z(), std::sqrt(3.0) / 2.0 + 0.5, 1e-15);

  // Padded sphere: centre +- (radius + padding).
  const cm::Aabb sph = ConvexShape::sphere(1.0).padded(0.25).aabb(cm::Transform3::Identity());
  expectVecNear(sph.min, Vec3::Constant(-1.25), 0.0);
  expectVecNear(sph.max, Vec3::Constant(1.25), 0.0);
}

TEST(ShapeAabb, OnlyABoxWithoutPointsIsEmpty) {
  // An Aabb is empty until extended; one point makes a box of zero size, not an empty one.
  cm::Aabb box;
  EXPECT_TRUE(box.empty());
  box.extend(Vec3(1.0, -2.0, 3.0));
  EXPECT_FALSE(box.empty());
  EXPECT_EQ(box.min, Vec3(1.0, -2.0, 3.0));
  EXPECT_EQ(box.max, Vec3(1.0, -2.0, 3.0));
  box.extend(Vec3(4.0, -2.0, 0.0));  // flat in y
  EXPECT_FALSE(box.empty());
  EXPECT_EQ(box.min, Vec3(1.0, -2.0, 0.0));
  EXPECT_EQ(box.max, Vec3(4.0, -2.0, 3.0));
}

TEST(ShapeAabb, InflatedMovesEverySideOutByTheMargin) {
  // inflated(r): min - r and max + r on every axis.
  const cm::Aabb box{Vec3(0.0, -1.0, 2.0), Vec3(1.0, 1.0, 6.0)};
  const cm::Aabb big = box.inflated(0.5);
  EXPECT_EQ(big.min, Vec3(-0.5, -1.5, 1.5));
  EXPECT_EQ(big.max, Vec3(1.5, 1.5, 6.5));
}

TEST(ShapeAabb, TouchingBoxesOverlapInBothOrders) {
  // Closed boxes: sharing a face counts as overlapping, either way round; any gap does not.
  const cm::Aabb a{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 1.0, 1.0)};
  const cm::Aabb touching{Vec3(1.0, 0.5, -0.5), Vec3(2.0, 1.5, 0.5)};
  const cm::Aabb apart{Vec3(1.0 + 1e-12, 0.5, -0.5), Vec3(2.0, 1.5, 0.5)};
  EXPECT_TRUE(a.overlaps(touching));
  EXPECT_TRUE(touching.overlaps(a));
  EXPECT_FALSE(a.overlaps(apart));
  EXPECT_FALSE(apart.overlaps(a));
}

TEST(ShapeAabb, DistanceIsTheGapBetweenTheBoxesOrZero) {
  // The Euclidean length of the per-axis gaps, in either order; 0 for overlapping boxes. Unit
  // cubes at (0, 0, 0) and (4, -5, 0.5): gaps 3, 4 and none: 5.
  const cm::Aabb a{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 1.0, 1.0)};
  const cm::Aabb b{Vec3(4.0, -5.0, 0.5), Vec3(5.0, -4.0, 1.5)};
  EXPECT_EQ(a.distance(b), 5.0);
  EXPECT_EQ(b.distance(a), 5.0);
  const cm::Aabb inside{Vec3(0.25, 0.25, 0.25), Vec3(2.0, 0.5, 0.75)};
  EXPECT_EQ(a.distance(inside), 0.0);
  EXPECT_EQ(inside.distance(a), 0.0);
}

TEST(ShapeAabb, DistanceOfGapsWhoseSquaresOverflowIsFinite) {
  // Gaps of 3 * 2^600 and 4 * 2^600 m (about 1.2e181 and 1.6e181 m; their squares overflow): the
  // distance is 5 * 2^600, exactly, as for gaps 3 and 4. It was +inf, above any finite reach, so a
  // broad phase with a warning_distance that large dropped the pair. (Adding 1 m to 3 * 2^600
  // rounds back to it, so the gap is exact.)
  const double unit = std::ldexp(1.0, 600);
  const cm::Aabb a{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 1.0, 1.0)};
  const cm::Aabb b{Vec3(3.0 * unit, -5.0 * unit, 0.5), Vec3(5.0 * unit, -4.0 * unit, 1.5)};
  EXPECT_EQ(a.distance(b), 5.0 * unit);
  EXPECT_EQ(b.distance(a), 5.0 * unit);
  // The largest finite gap, on one axis (huge - 1 rounds to huge).
  const double huge = std::numeric_limits<double>::max();
  const cm::Aabb far{Vec3(huge, 0.0, 0.0), Vec3(huge, 1.0, 1.0)};
  EXPECT_EQ(a.distance(far), huge);
  EXPECT_EQ(far.distance(a), huge);
}

TEST(ShapeBoundingRadius, ContainsTheFullShape) {
  EXPECT_DOUBLE_EQ(ConvexShape::sphere(2.0).boundingRadius(), 2.0);
  EXPECT_DOUBLE_EQ(ConvexShape::box(Vec3(2.0, 4.0, 4.0)).boundingRadius(), 3.0);
  EXPECT_DOUBLE_EQ(ConvexShape::capsule(2.0, 0.5).boundingRadius(), 1.5);
  EXPECT_DOUBLE_EQ(ConvexShape::cylinder(6.0, 4.0).boundingRadius(), 5.0);
  EXPECT_DOUBLE_EQ(ConvexShape::cone(6.0, 4.0).boundingRadius(), 5.0);
  EXPECT_DOUBLE_EQ(ConvexShape::ellipsoid(Vec3(1.0, 3.0, 2.0)).boundingRadius(), 3.0);
  EXPECT_DOUBLE_EQ(ConvexShape::point(Vec3(3.0, 4.0, 0.0)).padded(1.0).boundingRadius(), 6.0);
}

TEST(ShapeBoundingRadius, ASegmentIsBoundedByItsFartherEndAlsoFarOut) {
  // boundingRadius() about the shape frame's origin, localRadius() about offset(), each to the
  // farther end. Near the origin: (0, 0, 0) to (3, 4, 0), 5 for both. Far out: (1000, 0, 0) to
  // (1001, 1, 0) has offset() (1000.5, 0, 0), core (-0.5, 0, 0) to (0.5, 1, 0): local radius
  // |(0.5, 1, 0)| = sqrt(1.25), bounding radius |(1001, 1, 0)| = sqrt(1002002).
  const ConvexShape near = ConvexShape::segment(Vec3::Zero(), Vec3(3.0, 4.0, 0.0));
  EXPECT_DOUBLE_EQ(near.boundingRadius(), 5.0);
  EXPECT_DOUBLE_EQ(near.localRadius(), 5.0);
  const ConvexShape far = ConvexShape::segment(Vec3(1000.0, 0.0, 0.0), Vec3(1001.0, 1.0, 0.0));
  ASSERT_EQ(far.offset(), Vec3(1000.5, 0.0, 0.0));
  EXPECT_DOUBLE_EQ(far.localRadius(), std::sqrt(1.25));
  EXPECT_DOUBLE_EQ(far.boundingRadius(), std::sqrt(1002002.0));
  EXPECT_DOUBLE_EQ(far.padded(0.5).boundingRadius(), std::sqrt(1002002.0) + 0.5);
}

TEST(ShapeOffset, FarCoordinatesAreKeptAboutTheirCentreExactly) {
  // A 1 cm hull written 1e5 m out: its core is about the bounding box's centre, and core plus
  // offset() gives back every given point bit for bit (no rounding: Sterbenz).
  const Vec3 c(1.2345678901234e5, -6.5e4, 3.25);
  std::vector<Vec3> pts;
  for (int i = 0; i < 8; ++i)
    pts.push_back(c + 0.005 * Vec3(i & 1 ? 1.0 : -1.0, i & 2 ? 1.0 : -0.7, i & 4 ? 1.0 : -0.3));
  const ConvexShape hull = ConvexShape::convexHull(pts);
  // x and y lie out by more than four half-extents; z (3.25 m, 5 mm across) too.
  EXPECT_NE(hull.offset().x(), 0.0);
  EXPECT_NE(hull.offset().y(), 0.0);
  EXPECT_NE(hull.offset().z(), 0.0);
  const auto& poly = std::get<std::shared_ptr<const cm::Polytope<3>>>(hull.core());
  ASSERT_EQ(poly->size(), 8);
  for (const Vec3& v : poly->vertices()) {
    const Vec3 back = v + hull.offset();
    EXPECT_TRUE(std::find(pts.begin(), pts.end(), back) != pts.end()) << back.transpose();
  }
  for (const Vec3& d : {Vec3(1, 0, 0), Vec3(-1, 2, 3), Vec3(0.3, -1, -0.2)}) {
    const Vec3 s = hull.support(d);
    EXPECT_TRUE(std::find(pts.begin(), pts.end(), s) != pts.end()) << s.transpose();
  }
  EXPECT_LT(hull.localRadius(), 0.01);
  EXPECT_GE(hull.boundingRadius(), c.norm());
  EXPECT_LE(hull.boundingRadius(), c.norm() + 0.01);
  EXPECT_NEAR(hull.padded(0.5).localRadius(), hull.localRadius() + 0.5, 1e-15);
  // A polytope built elsewhere is recentred alike.
  const ConvexShape again = ConvexShape::polytope(std::make_shared<const cm::Polytope<3>>(pts));
  EXPECT_EQ(again.offset(), hull.offset());
  // A point is its own offset; a far segment is about its midpoint.
  const ConvexShape p = ConvexShape::point(c);
  EXPECT_EQ(p.offset(), c);
  EXPECT_EQ(p.support(Vec3(0.3, 0.4, -1.0)), c);
  EXPECT_EQ(p.localRadius(), 0.0);
  const ConvexShape sg = ConvexShape::segment(c, c + Vec3(0.01, 0.0, 0.0));
  EXPECT_EQ(sg.support(Vec3(1, 0, 0)), c + Vec3(0.01, 0.0, 0.0));
  EXPECT_EQ(sg.support(Vec3(-1, 0, 0)), c);
  EXPECT_NEAR(sg.localRadius(), 0.005, 1e-10);  // c + 0.01 rounds to 1.5e-11 m
  // Near their origin, shapes keep their coordinates: a unit box moved by 0.3 m.
  std::vector<Vec3> box;
  for (int i = 0; i < 8; ++i)
    box.push_back(Vec3(0.3, 0.0, 0.0) +
                  Vec3(i & 1 ? 0.5 : -0.5, i & 2 ? 0.5 : -0.5, i & 4 ? 0.5 : -0.5));
  EXPECT_EQ(ConvexShape::convexHull(box).offset(), Vec3::Zero());
  EXPECT_EQ(ConvexShape::segment(Vec3(0.1, 0, 0), Vec3(-0.3, 0.2, 0.5)).offset(), Vec3::Zero());
  EXPECT_EQ(ConvexShape::box(Vec3(1, 2, 3)).offset(), Vec3::Zero());
}

TEST(ShapeOffset, OnlyTheAxesFarOutAreOffset) {
  // offset() moves an axis only where the bounding box's centre lies further out than four
  // half-extents. A box 1e5 m out along x but across y in [-0.3, 0.7] and z in [-1.1, 2.9]
  // (centres 0.2 and 0.9, within 4 x 0.5 and 4 x 2) is offset along x only, and its core plus
  // offset() is every corner again, bit for bit.
  std::vector<Vec3> pts;
  for (int i = 0; i < 8; ++i)
    pts.emplace_back(i & 1 ? 100000.5 : 99999.5, i & 2 ? 0.7 : -0.3, i & 4 ? 2.9 : -1.1);
  const ConvexShape hull = ConvexShape::convexHull(pts);
  EXPECT_EQ(hull.offset(), Vec3(1e5, 0.0, 0.0));
  const auto& poly = std::get<std::shared_ptr<const cm::Polytope<3>>>(hull.core());
  ASSERT_EQ(poly->size(), 8);
  for (const Vec3& v : poly->vertices()) {
    const Vec3 back = v + hull.offset();
    EXPECT_TRUE(std::find(pts.begin(), pts.end(), back) != pts.end()) << back.transpose();
  }
}

TEST(ShapeOffset, AFarPolytopeKeepsItsEdgeGraph) {
  // A hill-climbing polytope given far out is recentred as a copy less offset() that keeps the
  // adjacency: it still climbs, and its support is the farthest given point.
  const auto ball = cm::buildConvexHull(sphereSpiral(60));
  std::vector<Vec3> far = ball->vertices();
  for (Vec3& v : far)
    v += Vec3(1e5, 0.0, 0.0);
  const ConvexShape shape = ConvexShape::polytope(
      std::make_shared<cm::Polytope<3>>(far, ball->adjacencyOffsets(), ball->adjacency()));
  ASSERT_NE(shape.offset().x(), 0.0);
  const auto& core = std::get<std::shared_ptr<const cm::Polytope<3>>>(shape.core());
  EXPECT_EQ(core->adjacencyOffsets(), ball->adjacencyOffsets());
  EXPECT_EQ(core->adjacency(), ball->adjacency());
  EXPECT_FALSE(core->usesLinearScan());
  for (int k = 0; k < 20; ++k) {
    const Vec3 d(std::cos(0.7 * k), std::sin(1.3 * k), std::cos(2.1 * k + 0.4));
    const Vec3 s = shape.support(d);
    EXPECT_TRUE(std::find(far.begin(), far.end(), s) != far.end()) << s.transpose();
    for (const Vec3& p : far)
      EXPECT_GE(s.dot(d), p.dot(d)) << "direction " << k;
  }
}

TEST(ShapeDescribe, NamesTheCore) {
  EXPECT_EQ(ConvexShape::sphere(1.0).describe(), "sphere");
  EXPECT_EQ(ConvexShape::box(Vec3::Ones()).describe(), "box");
  EXPECT_EQ(ConvexShape::capsule(1.0, 1.0).describe(), "capsule");
  EXPECT_EQ(ConvexShape::cylinder(1.0, 1.0).describe(), "cylinder");
  EXPECT_EQ(ConvexShape::cone(1.0, 1.0).describe(), "cone");
  EXPECT_EQ(ConvexShape::ellipsoid(Vec3::Ones()).describe(), "ellipsoid");
  EXPECT_EQ(ConvexShape::point(Vec3::Zero()).describe(), "point");
  EXPECT_EQ(ConvexShape::segment(Vec3::Zero(), Vec3::Ones()).describe(), "segment");
}

TEST(SupportAdapters, TransformedSumPadded) {
  const cm::BoxShape<3> box{Vec3(1.0, 2.0, 3.0)};
  cm::Transform3 T;
  T.R = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();  // x -> y, y -> -x
  T.t = Vec3(10.0, 0.0, 0.0);
  const cm::Transformed<3, cm::BoxShape<3>> placed(box, T);
  // World direction +x is body -y: body support (., -2, .) -> world x = 10 + 2.
  EXPECT_NEAR(placed.support(Vec3(1.0, 0.0, 0.0)).x(), 12.0, 1e-15);
  EXPECT_NEAR(placed.support(Vec3(0.0, 1.0, 0.0)).y(), 1.0, 1e-15);

  const cm::SegmentShape<3> seg{Vec3::Zero(), Vec3(0.0, 0.0, 5.0)};
  const cm::MinkowskiSum<3, cm::BoxShape<3>, cm::SegmentShape<3>> sum(box, seg);
  expectVecNear(sum.support(Vec3(1.0, 1.0, 1.0)), Vec3(1.0, 2.0, 8.0), 0.0);

  const cm::Padded<3, cm::BoxShape<3>> pad(box, 2.0);
  expectVecNear(pad.support(Vec3(0.0, 0.0, -7.0)), Vec3(1.0, 2.0, -5.0), 0.0);
  expectVecNear(pad.support(Vec3::Zero()), Vec3(1.0, 2.0, 3.0), 0.0);  // defined, no NaN
}

TEST(MathHelpers, IsValidRotationRefusesReflectionsAndNonOrthonormalMatrices) {
  // A rotation is orthonormal with determinant +1 (within the tolerance, 1e-6 by default).
  EXPECT_TRUE(cm::isValidRotation<3>(cm::Mat3::Identity()));
  const cm::Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  EXPECT_TRUE(cm::isValidRotation<3>(R));
  EXPECT_FALSE(cm::isValidRotation<3>(cm::Mat3(Vec3(1.0, 1.0, -1.0).asDiagonal())));  // mirror
  EXPECT_FALSE(cm::isValidRotation<3>(cm::Mat3(-R)));  // orthonormal, determinant -1
  EXPECT_FALSE(cm::isValidRotation<3>(cm::Mat3(1.01 * R)));
  cm::Mat3 bad = R;
  bad(1, 2) = kNaN;
  EXPECT_FALSE(cm::isValidRotation<3>(bad));
}

TEST(MathHelpers, TransformProductAppliesTheRightOperandFirst) {
  // (A B) x = A (B x). B: a quarter turn about x, (x, y, z) -> (x, -z, y), then + (0, 0, 2);
  // A: a quarter turn about z, (x, y, z) -> (-y, x, z), then + (1, 0, 0). x = (1, 2, 3):
  // B x = (1, -3, 4), A B x = (4, 1, 4).
  cm::Transform3 A, B;
  A.R << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  A.t = Vec3(1.0, 0.0, 0.0);
  B.R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  B.t = Vec3(0.0, 0.0, 2.0);
  EXPECT_EQ((A * B) * Vec3(1.0, 2.0, 3.0), Vec3(4.0, 1.0, 4.0));
  EXPECT_EQ((A * B).inverse() * Vec3(4.0, 1.0, 4.0), Vec3(1.0, 2.0, 3.0));
}
