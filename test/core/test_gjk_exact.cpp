// Exact answers for intersect / distance / signedDistance, worked out by hand (the comment beside
// each expected value shows the arithmetic). Nothing here is a recorded output of the code.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "collision_monitor/core/query.h"

namespace cm = collision_monitor::core;
using cm::ContactResult;
using cm::ConvexShape;
using cm::Status;
using cm::Transform3;
using cm::Vec3;

namespace {

constexpr double kTol = 1e-12;
const double kSqrt2 = std::sqrt(2.0);
const double kSqrt3 = std::sqrt(3.0);

Transform3 at(double x, double y, double z) {
  Transform3 T;
  T.t = Vec3(x, y, z);
  return T;
}
Transform3 rotAt(double angle, const Vec3& axis, const Vec3& t) {
  Transform3 T;
  T.R = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  T.t = t;
  return T;
}
void expectVecNear(const Vec3& a, const Vec3& b, double tol) {
  EXPECT_NEAR(a.x(), b.x(), tol) << "got (" << a.transpose() << ") want (" << b.transpose() << ")";
  EXPECT_NEAR(a.y(), b.y(), tol) << "got (" << a.transpose() << ") want (" << b.transpose() << ")";
  EXPECT_NEAR(a.z(), b.z(), tol) << "got (" << a.transpose() << ") want (" << b.transpose() << ")";
}
/// Invariants every result must satisfy: unit normal, finite fields, witness points consistent
/// with the signed distance along the normal.
void expectConsistent(const ContactResult& r, double tol) {
  ASSERT_TRUE(std::isfinite(r.distance));
  ASSERT_TRUE(r.point_a.allFinite() && r.point_b.allFinite() && r.normal.allFinite());
  EXPECT_NEAR(r.normal.norm(), 1.0, 1e-12);
  // point_b - point_a = distance * normal (for separation and for penetration).
  expectVecNear(r.point_b - r.point_a, r.distance * r.normal, tol);
}

const ConvexShape kUnitCube = ConvexShape::box(Vec3(1.0, 1.0, 1.0));

}  // namespace

// ---------------------------------------------------------------------------------------------
// Spheres
// ---------------------------------------------------------------------------------------------

TEST(ExactSphere, SeparatedDistanceWitnessNormal) {
  // Centres 5 apart (3-4-5), radii 1 and 0.5: 5 - 1.5 = 3.5.
  const ConvexShape a = ConvexShape::sphere(1.0);
  const ConvexShape b = ConvexShape::sphere(0.5);
  for (const bool signed_query : {false, true}) {
    const ContactResult r = signed_query ? cm::signedDistance(a, at(0, 0, 0), b, at(3, 4, 0))
                                         : cm::distance(a, at(0, 0, 0), b, at(3, 4, 0));
    EXPECT_EQ(r.status, Status::Separated);
    EXPECT_NEAR(r.distance, 3.5, kTol);
    expectVecNear(r.normal, Vec3(0.6, 0.8, 0.0), kTol);
    expectVecNear(r.point_a, Vec3(0.6, 0.8, 0.0), kTol);
    expectVecNear(r.point_b, Vec3(3.0 - 0.3, 4.0 - 0.4, 0.0), kTol);
    expectConsistent(r, kTol);
  }
  EXPECT_FALSE(cm::intersect(a, at(0, 0, 0), b, at(3, 4, 0)));
}

TEST(ExactSphere, OverlapDepthAndNormal) {
  // Radii 1 + 1, centres 1.2 apart on x: depth 0.8 along +x.
  const ConvexShape s = ConvexShape::sphere(1.0);
  const ContactResult r = cm::signedDistance(s, at(0, 0, 0), s, at(1.2, 0, 0));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -0.8, kTol);
  EXPECT_NEAR(r.depth(), 0.8, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  expectVecNear(r.point_a, Vec3(1.0, 0, 0), kTol);  // deepest point of A inside B
  expectVecNear(r.point_b, Vec3(0.2, 0, 0), kTol);  // deepest point of B inside A
  expectConsistent(r, kTol);
  EXPECT_TRUE(cm::intersect(s, at(0, 0, 0), s, at(1.2, 0, 0)));
  const ContactResult d = cm::distance(s, at(0, 0, 0), s, at(1.2, 0, 0));
  EXPECT_EQ(d.status, Status::Penetrating);
  EXPECT_EQ(d.distance, 0.0);
}

TEST(ExactSphere, ConcentricSpheresHaveFullDepthAndADefinedNormal) {
  // Regression: A - B of two point cores at the same place is the single point 0; the normal must
  // still be a unit vector (was the 0/0 direction of v). Depth = 1 + 0.5.
  const ConvexShape r1 = ConvexShape::sphere(1.0);
  const ConvexShape r2 = ConvexShape::sphere(0.5);
  const ContactResult r = cm::signedDistance(r1, at(7, 8, 9), r2, at(7, 8, 9));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -1.5, kTol);
  expectConsistent(r, kTol);
}

TEST(ExactSphere, TouchingIsTouching) {
  // Radii 1 + 1 with centres exactly 2 apart: distance 0.
  const ConvexShape s = ConvexShape::sphere(1.0);
  const ContactResult r = cm::signedDistance(s, at(0, 0, 0), s, at(0, 2, 0));
  EXPECT_EQ(r.status, Status::Touching);
  EXPECT_NEAR(r.distance, 0.0, kTol);
  expectVecNear(r.normal, Vec3::UnitY(), kTol);
  EXPECT_TRUE(cm::intersect(s, at(0, 0, 0), s, at(0, 2, 0)));
}

TEST(ExactSphere, NestedSphere) {
  // r 2 around r 0.5 whose centre is 0.5 off: it must move 2 - 0.5 + 0.5 = 2 along +x.
  const ContactResult r = cm::signedDistance(ConvexShape::sphere(2.0), at(0, 0, 0),
                                             ConvexShape::sphere(0.5), at(0.5, 0, 0));
  EXPECT_NEAR(r.distance, -2.0, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  expectConsistent(r, kTol);
}

// ---------------------------------------------------------------------------------------------
// Boxes
// ---------------------------------------------------------------------------------------------

TEST(ExactBox, FaceFace) {
  // Unit cube (x <= 0.5) and a 2-cube at x = 3 (x >= 2): gap 1.5 along +x.
  const ConvexShape b2 = ConvexShape::box(Vec3(2, 2, 2));
  const ContactResult r = cm::signedDistance(kUnitCube, at(0, 0, 0), b2, at(3, 0.2, 0.1));
  EXPECT_EQ(r.status, Status::Separated);
  EXPECT_NEAR(r.distance, 1.5, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  EXPECT_NEAR(r.point_a.x(), 0.5, kTol);
  EXPECT_NEAR(r.point_b.x(), 2.0, kTol);
  // Witnesses on the overlap of the faces: y, z in [-0.5, 0.5] (A) and equal on both.
  EXPECT_LE(std::abs(r.point_a.y()), 0.5 + kTol);
  EXPECT_LE(std::abs(r.point_a.z()), 0.5 + kTol);
  expectConsistent(r, kTol);
}

TEST(ExactBox, EdgeEdge) {
  // A turned 45 deg about y: its +x extreme is the edge x = sqrt2/2 parallel to y. B turned 45
  // deg about z at x = 3: its -x extreme is the edge x = 3 - sqrt2/2 parallel to z. Both edges
  // cross the x axis: distance 3 - sqrt2, witnesses on the x axis.
  const ContactResult r =
      cm::signedDistance(kUnitCube, rotAt(M_PI / 4, Vec3::UnitY(), Vec3::Zero()), kUnitCube,
                         rotAt(M_PI / 4, Vec3::UnitZ(), Vec3(3, 0, 0)));
  EXPECT_NEAR(r.distance, 3.0 - kSqrt2, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  expectVecNear(r.point_a, Vec3(kSqrt2 / 2, 0, 0), kTol);
  expectVecNear(r.point_b, Vec3(3.0 - kSqrt2 / 2, 0, 0), kTol);
}

TEST(ExactBox, VertexFace) {
  // B's body diagonal (1,1,1)/sqrt3 turned to -x: its vertex at 2 - sqrt3/2 faces A's face x=0.5.
  Transform3 pb;
  pb.R = Eigen::Quaterniond::FromTwoVectors(Vec3(1, 1, 1), Vec3(-1, 0, 0)).toRotationMatrix();
  pb.t = Vec3(2, 0, 0);
  const ContactResult r = cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, pb);
  EXPECT_NEAR(r.distance, 2.0 - kSqrt3 / 2 - 0.5, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  expectVecNear(r.point_a, Vec3(0.5, 0, 0), kTol);
  expectVecNear(r.point_b, Vec3(2.0 - kSqrt3 / 2, 0, 0), kTol);
}

TEST(ExactBox, PenetrationDepthAndNormal) {
  // Unit cubes, B at (0.8, 0.1, 0.05): overlaps 0.2 (x), 0.9 (y), 0.95 (z): depth 0.2 along +x.
  const ContactResult r = cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, at(0.8, 0.1, 0.05));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -0.2, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  EXPECT_NEAR(r.point_a.x(), 0.5, kTol);  // A's face inside B
  EXPECT_NEAR(r.point_b.x(), 0.3, kTol);  // B's face inside A
  expectConsistent(r, kTol);
  EXPECT_TRUE(cm::intersect(kUnitCube, at(0, 0, 0), kUnitCube, at(0.8, 0.1, 0.05)));
}

TEST(ExactBox, PenetrationQueryGivesTheDepthAndTheSeparation) {
  // penetration() (the name for the EPA query): the same cubes as above, depth 0.2 along
  // +x; moved to x = 1.3 they are apart by 1.3 - 1 = 0.3 (status Separated, as signedDistance()).
  const ContactResult r = cm::penetration(kUnitCube, at(0, 0, 0), kUnitCube, at(0.8, 0.1, 0.05));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.depth(), 0.2, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  EXPECT_GT(r.epa_iterations, 0);
  const ContactResult apart =
      cm::penetration(kUnitCube, at(0, 0, 0), kUnitCube, at(1.3, 0.1, 0.05));
  EXPECT_EQ(apart.status, Status::Separated);
  EXPECT_NEAR(apart.distance, 0.3, kTol);
  EXPECT_EQ(apart.depth(), 0.0);
}

TEST(ExactBox, IdenticalCubesHaveDepthOne) {
  // Two unit cubes at the same pose: any face direction separates them after a move of 1.
  const Transform3 p = rotAt(0.3, Vec3(1, 2, 3), Vec3(4, 5, 6));
  const ContactResult r = cm::signedDistance(kUnitCube, p, kUnitCube, p);
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -1.0, kTol);
  // The normal is one of the cube's face normals: in the body frame a signed unit axis.
  const Vec3 nb = p.R.transpose() * r.normal;
  EXPECT_NEAR(nb.cwiseAbs().maxCoeff(), 1.0, kTol);
  expectConsistent(r, kTol);
}

TEST(ExactBox, NestedBox) {
  // Unit cube (x in [0, 1]) inside a 4-cube (x in [-2, 2]): cheapest exit +x by 2 (vs 3, 2.5).
  const ContactResult r =
      cm::signedDistance(ConvexShape::box(Vec3(4, 4, 4)), at(0, 0, 0), kUnitCube, at(0.5, 0, 0));
  EXPECT_NEAR(r.distance, -2.0, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  expectConsistent(r, kTol);
}

TEST(ExactBox, TouchingFacesAreTouching) {
  // Unit cubes with centres 1 apart share the face x = 0.5.
  const ContactResult r = cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, at(1, 0.3, -0.2));
  EXPECT_EQ(r.status, Status::Touching);
  EXPECT_NEAR(r.distance, 0.0, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), 1e-9);
  EXPECT_TRUE(cm::intersect(kUnitCube, at(0, 0, 0), kUnitCube, at(1, 0.3, -0.2)));
  EXPECT_EQ(cm::distance(kUnitCube, at(0, 0, 0), kUnitCube, at(1, 0.3, -0.2)).status,
            Status::Touching);
}

TEST(ExactBox, NearlyParallelFaces) {
  // 2-cubes, B turned eps = 1e-6 about y at x = 2.5: B's lowest x is 2.5 - (cos eps + sin eps);
  // A's face is x = 1.
  const double eps = 1e-6;
  const ConvexShape b2 = ConvexShape::box(Vec3(2, 2, 2));
  const ContactResult r =
      cm::signedDistance(b2, at(0, 0, 0), b2, rotAt(eps, Vec3::UnitY(), Vec3(2.5, 0, 0)));
  EXPECT_NEAR(r.distance, 2.5 - (std::cos(eps) + std::sin(eps)) - 1.0, kTol);
  EXPECT_NEAR(r.normal.x(), 1.0, 1e-9);
  // ... and overlapping by about 0.25 (B at x = 1.75): depth 1 - (1.75 - cos eps - sin eps).
  const ContactResult p =
      cm::signedDistance(b2, at(0, 0, 0), b2, rotAt(eps, Vec3::UnitY(), Vec3(1.75, 0, 0)));
  // B's tilted face gives a candidate depth only ~9e-13 larger, with a normal eps away: both are
  // within tolerance, so the normal is checked to eps.
  EXPECT_NEAR(p.distance, 1.75 - (std::cos(eps) + std::sin(eps)) - 1.0, 1e-11);
  EXPECT_NEAR(p.normal.x(), 1.0, 1e-11);
  EXPECT_NEAR(p.normal.z(), 0.0, 2 * eps);
}

TEST(ExactBox, DistanceOfOverlappingBoxesHasTheNormalFromAsOriginTowardsBs) {
  // distance() computes no depth: for cores that overlap with GJK's simplex enclosing the origin
  // (a generic pose: no symmetry puts the origin on a segment or triangle of support points) its
  // normal is the direction from A's origin towards B's (query.h), here (0.3, 0.4, 0) / 0.5, not
  // a least-depth direction as EPA would give. Unit cubes with centres 0.5 apart (their inscribed
  // balls of radius 0.5 overlap, so the cubes do), turned about generic axes.
  const Transform3 pa = rotAt(0.7, Vec3(3, -1, 2), Vec3::Zero());
  const Transform3 pb = rotAt(0.3, Vec3(1, 2, 3), Vec3(0.3, 0.4, 0));
  for (const bool swap : {false, true}) {
    const ContactResult r = swap ? cm::distance(kUnitCube, pb, kUnitCube, pa)
                                 : cm::distance(kUnitCube, pa, kUnitCube, pb);
    EXPECT_EQ(r.status, Status::Penetrating);
    EXPECT_EQ(r.distance, 0.0);
    expectVecNear(r.normal, (swap ? -1.0 : 1.0) * Vec3(0.6, 0.8, 0.0), kTol);
  }
}

// ---------------------------------------------------------------------------------------------
// Capsules and sphere/box
// ---------------------------------------------------------------------------------------------

TEST(ExactCapsule, Parallel) {
  // Axes (z) 2 apart, radii 0.5 + 0.25: 1.25; witnesses at equal z within the overlap [-0.5, 1].
  const ContactResult r = cm::signedDistance(ConvexShape::capsule(2, 0.5), at(0, 0, 0),
                                             ConvexShape::capsule(2, 0.25), at(2, 0, 0.5));
  EXPECT_NEAR(r.distance, 1.25, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  EXPECT_NEAR(r.point_a.x(), 0.5, kTol);
  EXPECT_NEAR(r.point_b.x(), 1.75, kTol);
  EXPECT_NEAR(r.point_a.z(), r.point_b.z(), kTol);
  EXPECT_GE(r.point_a.z(), -0.5 - kTol);
  EXPECT_LE(r.point_a.z(), 1.0 + kTol);
}

TEST(ExactCapsule, Crossing) {
  // A along z, B along y (90 deg about x) at x = 1.5: axes cross at distance 1.5; 1.5 - 0.75.
  const ContactResult r =
      cm::signedDistance(ConvexShape::capsule(2, 0.5), at(0, 0, 0), ConvexShape::capsule(2, 0.25),
                         rotAt(M_PI / 2, Vec3::UnitX(), Vec3(1.5, 0, 0)));
  EXPECT_NEAR(r.distance, 0.75, kTol);
  expectVecNear(r.point_a, Vec3(0.5, 0, 0), kTol);
  expectVecNear(r.point_b, Vec3(1.25, 0, 0), kTol);
}

TEST(ExactCapsule, Skew) {
  // A: z in [-1, 1]; B along y through (1, ., 3): closest are A's end (0,0,1) and (1,0,3),
  // sqrt(1 + 4) apart; minus radii 0.75.
  const ContactResult r =
      cm::signedDistance(ConvexShape::capsule(2, 0.5), at(0, 0, 0), ConvexShape::capsule(2, 0.25),
                         rotAt(M_PI / 2, Vec3::UnitX(), Vec3(1, 0, 3)));
  const Vec3 n = Vec3(1, 0, 2) / std::sqrt(5.0);
  EXPECT_NEAR(r.distance, std::sqrt(5.0) - 0.75, kTol);
  expectVecNear(r.normal, n, kTol);
  expectVecNear(r.point_a, Vec3(0, 0, 1) + 0.5 * n, kTol);
  expectVecNear(r.point_b, Vec3(1, 0, 3) - 0.25 * n, kTol);
}

TEST(ExactCapsule, CrossingCoresGiveDepthRadiusSumExactly) {
  // Regression: the cores' A - B is a flat square through the origin (EPA on the cores has depth
  // 0); the depth must be exactly rA + rB = 0.75 with the square's normal (+-x).
  const ContactResult r =
      cm::signedDistance(ConvexShape::capsule(2, 0.5), at(0, 0, 0), ConvexShape::capsule(2, 0.25),
                         rotAt(M_PI / 2, Vec3::UnitX(), Vec3(0, 0, 0)));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -0.75, kTol);
  EXPECT_NEAR(std::abs(r.normal.x()), 1.0, kTol);
  expectConsistent(r, kTol);
}

TEST(ExactCapsule, SphereOnCapsuleAxis) {
  // Regression: A - B of segment and point is a segment through the origin (1-D): depth rA + rB
  // = 0.75 along some direction perpendicular to the axis (z), never NaN.
  const ContactResult r = cm::signedDistance(ConvexShape::capsule(2, 0.5), at(0, 0, 0),
                                             ConvexShape::sphere(0.25), at(0, 0, 0.3));
  EXPECT_NEAR(r.distance, -0.75, kTol);
  EXPECT_NEAR(r.normal.z(), 0.0, kTol);
  expectConsistent(r, kTol);
}

TEST(ExactSphereBox, EdgeAndCorner) {
  // 2-cube, sphere r 0.5 at (2, 2, 0): nearest is the edge point (1, 1, 0), sqrt2 away.
  const ConvexShape box = ConvexShape::box(Vec3(2, 2, 2));
  const ConvexShape s = ConvexShape::sphere(0.5);
  ContactResult r = cm::signedDistance(box, at(0, 0, 0), s, at(2, 2, 0));
  const Vec3 n = Vec3(1, 1, 0) / kSqrt2;
  EXPECT_NEAR(r.distance, kSqrt2 - 0.5, kTol);
  expectVecNear(r.normal, n, kTol);
  expectVecNear(r.point_a, Vec3(1, 1, 0), kTol);
  expectVecNear(r.point_b, Vec3(2, 2, 0) - 0.5 * n, kTol);
  // Corner (1, 1, 1) to (2, 3, 4): (1, 2, 3), sqrt14.
  r = cm::signedDistance(box, at(0, 0, 0), s, at(2, 3, 4));
  EXPECT_NEAR(r.distance, std::sqrt(14.0) - 0.5, kTol);
  expectVecNear(r.point_a, Vec3(1, 1, 1), kTol);
  // Sphere centre inside the box, 0.3 under the face z = 1: depth 0.3 + 0.5 along +z.
  r = cm::signedDistance(box, at(0, 0, 0), s, at(0.2, -0.1, 0.7));
  EXPECT_NEAR(r.distance, -0.8, kTol);
  expectVecNear(r.normal, Vec3::UnitZ(), kTol);
  expectConsistent(r, kTol);
}

// ---------------------------------------------------------------------------------------------
// Points inside shapes
// ---------------------------------------------------------------------------------------------

TEST(ExactPoint, PointInsideBoxBothOrders) {
  // Point (0.1, 0.2, 0.3) in a 2-cube: nearest face z = 1 at 0.7.
  const ConvexShape box = ConvexShape::box(Vec3(2, 2, 2));
  const ConvexShape p = ConvexShape::point(Vec3(0.1, 0.2, 0.3));
  ContactResult r = cm::signedDistance(box, at(0, 0, 0), p, at(0, 0, 0));
  EXPECT_NEAR(r.distance, -0.7, kTol);
  expectVecNear(r.normal, Vec3::UnitZ(), kTol);  // B (the point) leaves through +z
  expectVecNear(r.point_b, Vec3(0.1, 0.2, 0.3), kTol);
  r = cm::signedDistance(p, at(0, 0, 0), box, at(0, 0, 0));
  EXPECT_NEAR(r.distance, -0.7, kTol);
  expectVecNear(r.normal, -Vec3::UnitZ(), kTol);  // the box moves -z to free the point
}

TEST(ExactPoint, PointInsideSphereAndCylinder) {
  // Point 0.3 from the centre of a unit sphere: depth 0.7 along +x.
  ContactResult r = cm::signedDistance(ConvexShape::sphere(1.0), at(0, 0, 0),
                                       ConvexShape::point(Vec3::Zero()), at(0.3, 0, 0));
  EXPECT_NEAR(r.distance, -0.7, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  // Cylinder h 2 r 1, point at (0.5, 0, 0.2): side at 0.5 (vs caps 0.8, 1.2).
  r = cm::signedDistance(ConvexShape::cylinder(2.0, 1.0), at(0, 0, 0),
                         ConvexShape::point(Vec3(0.5, 0, 0.2)), at(0, 0, 0));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -0.5, 1e-9);
  // On a curved side a depth error e tilts the normal by ~sqrt(2 e / r): 1e-12 -> ~1.4e-6.
  expectVecNear(r.normal, Vec3::UnitX(), 1e-5);
}

TEST(ExactPoint, DistanceOfAShapeAroundAPointOrAConcentricShapeIsPenetration) {
  // distance() (no depth): the origin on a segment or triangle of support points by symmetry is
  // inside A - B, not on its boundary. These were reported Touching.
  const Transform3 o = at(0, 0, 0);
  const ConvexShape point = ConvexShape::point(Vec3::Zero());
  for (const auto& [outer, inner] : std::vector<std::pair<ConvexShape, ConvexShape>>{
           {ConvexShape::cylinder(1.0, 1.0), point},
           {ConvexShape::cone(2.0, 1.0), point},
           {ConvexShape::ellipsoid(Vec3(1, 2, 3)), point},
           {ConvexShape::box(Vec3(1, 1, 1)), point},
           {ConvexShape::box(Vec3(2, 2, 2)), ConvexShape::box(Vec3(1, 1, 1))},
           {ConvexShape::cylinder(2.0, 2.0), ConvexShape::cylinder(1.0, 1.0)}}) {
    const ContactResult r = cm::distance(outer, o, inner, o);
    EXPECT_EQ(r.status, Status::Penetrating) << outer.describe() << " / " << inner.describe();
    EXPECT_EQ(r.distance, 0.0);
  }
  // On the boundary it stays touching, with the contact normal: a point on a box's face, a box
  // on another's face.
  const ContactResult on_face =
      cm::distance(ConvexShape::box(Vec3(1, 1, 1)), o, point, at(0.5, 0.3, 0.2));
  EXPECT_EQ(on_face.status, Status::Touching);
  expectVecNear(on_face.normal, Vec3::UnitX(), 1e-12);
  EXPECT_EQ(
      cm::distance(ConvexShape::box(Vec3(1, 1, 1)), o, ConvexShape::box(Vec3(1, 1, 1)), at(1, 0, 0))
          .status,
      Status::Touching);
}

TEST(ExactPoint, DistanceOfShapesWhoseCoresTouchButRadiiOverlapIsPenetration) {
  // distance() (no depth) where the cores only touch, so that GJK ends with the origin on A - B's
  // boundary (or A - B is a single point): the radii make the shapes overlap by rA + rB, so the
  // answer is Penetrating, never Touching. Concentric spheres 0.5 and 0.25 (cores: one point;
  // overlap 0.75), a sphere of radius 0.1 centred on the unit cube's face x = 0.5 (overlap 0.1),
  // two capsules of radius 0.1 whose core segments cross at their midpoints (overlap 0.2).
  const Transform3 o = at(0, 0, 0);
  const ConvexShape capsule = ConvexShape::capsule(2.0, 0.1);
  struct Case {
    ConvexShape a, b;
    Transform3 pb;
    double overlap;
  };
  for (const Case& c :
       std::vector<Case>{{ConvexShape::sphere(0.5), ConvexShape::sphere(0.25), at(0, 0, 0), 0.75},
                         {kUnitCube, ConvexShape::sphere(0.1), at(0.5, 0.3, 0.2), 0.1},
                         {capsule, capsule, rotAt(M_PI / 2, Vec3::UnitY(), Vec3::Zero()), 0.2}}) {
    const ContactResult r = cm::distance(c.a, o, c.b, c.pb);
    EXPECT_EQ(r.status, Status::Penetrating) << c.a.describe() << " / " << c.b.describe();
    EXPECT_EQ(r.distance, 0.0);
    EXPECT_TRUE(cm::intersect(c.a, o, c.b, c.pb));
    EXPECT_NEAR(cm::signedDistance(c.a, o, c.b, c.pb).distance, -c.overlap, kTol);
  }
}

// ---------------------------------------------------------------------------------------------
// Curved shapes against box faces
// ---------------------------------------------------------------------------------------------

TEST(ExactCurved, CylinderAgainstBoxFace) {
  const ConvexShape cyl = ConvexShape::cylinder(2.0, 0.5);  // half height 1
  const ConvexShape box = ConvexShape::box(Vec3(2, 2, 2));
  // Upright: rim at x = 0.5, box face at x = 2 - 1: 0.5.
  EXPECT_NEAR(cm::signedDistance(cyl, at(0, 0, 0), box, at(2, 0, 0)).distance, 0.5, kTol);
  // Tilted 30 deg about y: x extent 1 * sin30 + 0.5 * cos30; face at x = 3 - 1.
  const ContactResult r =
      cm::signedDistance(cyl, rotAt(M_PI / 6, Vec3::UnitY(), Vec3::Zero()), box, at(3, 0, 0));
  EXPECT_NEAR(r.distance, 2.0 - (0.5 + 0.5 * kSqrt3 / 2), kTol);
  expectVecNear(r.normal, Vec3::UnitX(), 1e-9);
  // Overlapping the box face x = 0.3 by 0.2 (other exits cost >= 1.3).
  const ContactResult p = cm::signedDistance(cyl, at(0, 0, 0), box, at(1.3, 0, 0));
  EXPECT_EQ(p.status, Status::Penetrating);
  EXPECT_NEAR(p.distance, -0.2, 1e-9);
  expectVecNear(p.normal, Vec3::UnitX(), 1e-5);  // curved side: see PointInsideSphereAndCylinder
}

TEST(ExactCurved, CylinderThroughABoxFaceHasWitnessesOnBoth) {
  // fuzz_world's certificate of curved parts: a 0.01 m cylinder parallel to a box's faces, through
  // its -z face. A - B's face along the normal is made of coplanar triangles; EPA's nearest was
  // one that does not hold d n, and its extrapolated weights put the witness 6 mm off the box.
  // In the box's frame (half sides 0.08, 0.2, 0.2) the cylinder (half height 0.08) stands at
  // (-0.0505, -0.01625, -0.2125): x in [-0.0605, -0.0405], y in [-0.02625, -0.00625], z in
  // [-0.2925, -0.1325]. Exits: -x 0.08 - 0.0405 = 0.0395, -z 0.2 - 0.1325 = 0.0675, +x 0.1405,
  // -y 0.19375, +y 0.22625: depth 0.0395, B moved along -x. Witnesses: on the box's face x = -0.08
  // and the cylinder's line x = -0.0405, y = -0.01625, at one z where both are: [-0.2, -0.1325].
  const ConvexShape box = ConvexShape::box(Vec3(0.16, 0.4, 0.4));
  const ConvexShape cyl = ConvexShape::cylinder(0.16, 0.01);
  const Vec3 local(-0.0505, -0.01625, -0.2125);
  int n = 0;
  for (const double angle : {0.0, 0.7, 2.1, -0.4, 1.3}) {
    for (const Vec3& axis : {Vec3(1.0, -1.0, 0.5), Vec3(0.2, 1.0, 0.0), Vec3(0.0, 0.3, 1.0)}) {
      const Transform3 A = rotAt(angle, axis, Vec3(-0.3675, 0.5325, 0.16725));
      Transform3 B = A;
      B.t = A * local;
      for (const bool swap : {false, true}) {
        const ContactResult r =
            swap ? cm::signedDistance(cyl, B, box, A) : cm::signedDistance(box, A, cyl, B);
        EXPECT_NEAR(r.distance, -0.0395, 1e-9);
        expectConsistent(r, 1e-6);
        expectVecNear(A.R.transpose() * r.normal, Vec3(swap ? 1.0 : -1.0, 0.0, 0.0), 1e-9);
        const Vec3 on_box = A.inverse() * (swap ? r.point_b : r.point_a);
        const Vec3 on_cyl = A.inverse() * (swap ? r.point_a : r.point_b);
        // Across the cylinder's curved side its line is found to the square root of EPA's
        // tolerance (2.8e-8 m off y = -0.01625 here): 1e-6.
        EXPECT_NEAR(on_box.x(), -0.08, 1e-9);
        EXPECT_NEAR(on_box.y(), -0.01625, 1e-6);
        EXPECT_GE(on_box.z(), -0.2 - 1e-9) << "angle " << angle << " swap " << swap;
        EXPECT_LE(on_box.z(), -0.1325 + 1e-9) << "angle " << angle << " swap " << swap;
        EXPECT_NEAR(on_cyl.x(), -0.0405, 1e-9);
        EXPECT_NEAR(on_cyl.y(), on_box.y(), 1e-9);
        EXPECT_NEAR(on_cyl.z(), on_box.z(), 1e-9);
        ++n;
      }
    }
  }
  EXPECT_EQ(n, 30);
}

TEST(ExactCurved, ConeApexBaseAndRimAgainstBoxFaces) {
  const ConvexShape cone = ConvexShape::cone(2.0, 1.0);  // apex z = 1, base z = -1, radius 1
  const ConvexShape box = ConvexShape::box(Vec3(2, 2, 2));
  // Apex to the face z = 2.5 - 1.
  EXPECT_NEAR(cm::signedDistance(cone, at(0, 0, 0), box, at(0, 0, 2.5)).distance, 0.5, kTol);
  // Base to the face z = -2.5 + 1.
  EXPECT_NEAR(cm::signedDistance(cone, at(0, 0, 0), box, at(0, 0, -2.5)).distance, 0.5, kTol);
  // Rim (x = 1) to the face x = 3 - 1.
  EXPECT_NEAR(cm::signedDistance(cone, at(0, 0, 0), box, at(3, 0, 0)).distance, 1.0, kTol);
}

TEST(ExactCurved, EllipsoidAgainstBoxFace) {
  const ConvexShape e = ConvexShape::ellipsoid(Vec3(1, 2, 3));
  const ConvexShape box = ConvexShape::box(Vec3(2, 2, 2));
  // Semi-axis 2 along y, face y = 4 - 1: 1.
  EXPECT_NEAR(cm::signedDistance(e, at(0, 0, 0), box, at(0, 4, 0)).distance, 1.0, kTol);
  // Turned 30 deg about x: extent along world y is h(R^T e_y) = sqrt((2 cos30)^2 + (3 sin30)^2)
  // = sqrt(5.25).
  const ContactResult r =
      cm::signedDistance(e, rotAt(M_PI / 6, Vec3::UnitX(), Vec3::Zero()), box, at(0, 4, 0));
  EXPECT_NEAR(r.distance, 3.0 - std::sqrt(5.25), 1e-10);
  expectVecNear(r.normal, Vec3::UnitY(), 1e-5);
}

namespace {

/// How far B must move along the unit n (world frame) to clear A: h_{A-B}(n), from the shapes'
/// support functions only (no GJK or EPA).
double overlapAlong(const ConvexShape& a, const Transform3& pa, const ConvexShape& b,
                    const Transform3& pb, const Vec3& n) {
  const Vec3 sa = pa * a.support(pa.R.transpose() * n);
  const Vec3 sb = pb * b.support(pb.R.transpose() * -n);
  return n.dot(sa - sb);
}

/// A penetration answer on curved shapes, certified from outside: the reported depth d is the
/// overlap along the reported normal, and no direction tried (4,000 random, 600 near the normal)
/// clears the shapes with a shorter move. `tol`: 1e-9 of the size.
void expectMinimalDepth(const ConvexShape& a, const Transform3& pa, const ConvexShape& b,
                        const Transform3& pb, std::mt19937_64& rng) {
  const ContactResult r = cm::signedDistance(a, pa, b, pb);
  ASSERT_EQ(r.status, Status::Penetrating);
  const double d = -r.distance;
  const double tol = 1e-9 * (a.boundingRadius() + b.boundingRadius() + (pb.t - pa.t).norm());
  expectConsistent(r, tol);
  EXPECT_NEAR(overlapAlong(a, pa, b, pb, r.normal), d, tol);
  std::normal_distribution<double> g(0.0, 1.0);
  double least = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4600; ++k) {
    Vec3 u(g(rng), g(rng), g(rng));
    if (k >= 4000) u = r.normal + std::pow(10.0, -2.0 - (k % 6)) * u;  // 1e-2 .. 1e-7 off
    least = std::min(least, overlapAlong(a, pa, b, pb, u.normalized()));
  }
  EXPECT_GE(least, d - tol);
}

}  // namespace

TEST(ExactCurved, DeepConeInCylinderConvergesToACertifiedMinimum) {
  // Two cone-in-cylinder overlaps from the benchmark pool cylinder_cone (pair 460 step 0, pair
  // 544 step 6, poses as printed to 17 digits), then 300 random deep overlaps of the kind. The
  // first reported FailedToConverge with EPA's former settings (depth to 1e-12 of itself, 128
  // iterations); 13 of the pool's 8,000 (pair, step)s did.
  std::mt19937_64 rng(460);
  const auto pose = [](double w, double x, double y, double z, double tx, double ty, double tz) {
    return cm::makeTransform(Eigen::Quaterniond(w, x, y, z).normalized(), Vec3(tx, ty, tz));
  };
  expectMinimalDepth(
      ConvexShape::cylinder(2 * 0.19795033184787234, 0.12288875098482308),
      pose(0.23246770044814938, 0.60498887603297313, 0.70107938797395075, 0.29738009328598336,
           -0.3454059077748588, -0.34707318165739687, 0.88382594701650796),
      ConvexShape::cone(2 * 0.12803865744272205, 0.089967399349491106),
      pose(0.3531964097411312, -0.22445809447045492, 0.90773415883458963, -0.02982543977089526,
           -0.34754321080536682, -0.3465495932623322, 0.88076941191036262),
      rng);
  expectMinimalDepth(
      ConvexShape::cylinder(2 * 0.10443508364300455, 0.1515905352602962),
      pose(0.13408042526180636, 0.088657452041118703, 0.80852990227789645, 0.56607569536386682,
           0.28325955431926708, 0.26239474379831096, 0.64821978692883797),
      ConvexShape::cone(2 * 0.18028252685558874, 0.15038194084557183),
      pose(0.30802485637582816, 0.48487837871695405, 0.38862814782105892, 0.72040392033125544,
           0.091110735141318552, 0.35431727050239198, 0.61344609512169757),
      rng);
  std::uniform_real_distribution<double> size(0.04, 0.4), off(-0.03, 0.03);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int i = 0; i < 300; ++i) {
    const ConvexShape cyl = ConvexShape::cylinder(size(rng), 0.5 * size(rng));
    const ConvexShape cone = ConvexShape::cone(size(rng), 0.5 * size(rng));
    const Transform3 pa = pose(g(rng), g(rng), g(rng), g(rng), 0, 0, 0);
    const Transform3 pb = pose(g(rng), g(rng), g(rng), g(rng), off(rng), off(rng), off(rng));
    SCOPED_TRACE(i);
    expectMinimalDepth(cyl, pa, cone, pb, rng);
  }
}

TEST(ExactCurved, DepthReachedAlongACircleOfDirections) {
  // A point on the axis of a cone, of a cylinder taller than it is wide or of a prolate
  // ellipsoid, coaxial shapes: the depth is reached along a whole circle of directions (or nearly:
  // 1e-7 and 1e-4 off the axis), which EPA's polytope only closes in on all at once. Before the
  // upper bound's refinement (epa.h refineUpperBound()) these ended after 256 iterations 4.0e-5,
  // 1e-7 and 7.5e-5 m too deep with witness points off the shapes. EPA cannot certify such a depth
  // (its lower bound closes as 1 / iterations^2), so the status stays FailedToConverge: it stops
  // at its checkpoint of 128 iterations (epaStalls()).
  struct Case {
    const char* what;
    ConvexShape a;
    ConvexShape b;
    Transform3 pose_b;
    double depth;
    Vec3 normal;  // the unique deepest direction, or zero where a circle of them ties
    double (*off_a)(const Vec3&);  // how far a point is off A's side (0 on it)
  };
  const auto rho = [](const Vec3& p) { return std::hypot(p.x(), p.y()); };
  const ConvexShape point = ConvexShape::point(Vec3::Zero());
  const std::vector<Case> cases{
      {"point at a cone's centre", ConvexShape::cone(2.0, 1.0), point, at(0, 0, 0),
       1.0 / std::sqrt(5.0), Vec3::Zero(),
       [](const Vec3& p) {
         return (2.0 * std::hypot(p.x(), p.y()) + p.z() - 1.0) / std::sqrt(5.0);
       }},
      {"point 1e-7 off a needle cylinder's axis", ConvexShape::cylinder(2.0, 0.1), point,
       at(1e-7, 0, 0), 0.1 - 1e-7, Vec3::UnitX(),
       [](const Vec3& p) { return std::hypot(p.x(), p.y()) - 0.1; }},
      {"capsule 1e-4 off a cylinder's axis", ConvexShape::cylinder(2.0, 0.5),
       ConvexShape::capsule(1.0, 0.05), at(1e-4, 0, 0), 0.55 - 1e-4, Vec3::UnitX(),
       [](const Vec3& p) { return std::hypot(p.x(), p.y()) - 0.5; }},
      {"point at a prolate ellipsoid's centre", ConvexShape::ellipsoid(Vec3(0.3, 0.3, 1.0)), point,
       at(0, 0, 0), 0.3, Vec3::Zero(),
       [](const Vec3& p) { return 0.3 * (p.cwiseQuotient(Vec3(0.3, 0.3, 1.0)).norm() - 1.0); }},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    const ContactResult r = cm::signedDistance(c.a, at(0, 0, 0), c.b, c.pose_b);
    EXPECT_NEAR(r.distance, -c.depth, 1e-12);
    expectConsistent(r, 1e-12);
    EXPECT_EQ(r.status, Status::FailedToConverge);
    EXPECT_LE(r.epa_iterations, 128);
    // The reported normal realises the depth: B moved by it along the normal clears A.
    EXPECT_NEAR(overlapAlong(c.a, at(0, 0, 0), c.b, c.pose_b, r.normal), c.depth, 1e-12);
    if (!c.normal.isZero()) expectVecNear(r.normal, c.normal, 1e-3);
    // Witnesses on the shapes: B's on its surface (the point itself, the capsule's side), A's on
    // its side.
    const Vec3 b_local = r.point_b - c.pose_b.t;
    const double off_b = c.b.radius() > 0.0 ? rho(b_local) - c.b.radius() : b_local.norm();
    EXPECT_NEAR(off_b, 0.0, 1e-9) << r.point_b.transpose();
    EXPECT_NEAR(c.off_a(r.point_a), 0.0, 1e-9) << r.point_a.transpose();
  }
}

// ---------------------------------------------------------------------------------------------
// Degenerate shapes
// ---------------------------------------------------------------------------------------------

TEST(ExactDegenerate, ZeroSizeBox) {
  const ConvexShape zero = ConvexShape::box(Vec3::Zero());
  // A point-like box 1.5 from the unit cube's face.
  EXPECT_NEAR(cm::signedDistance(kUnitCube, at(0, 0, 0), zero, at(2, 0, 0)).distance, 1.5, kTol);
  // Inside, 0.3 from the face x = 0.5.
  const ContactResult r = cm::signedDistance(kUnitCube, at(0, 0, 0), zero, at(0.2, 0.1, 0));
  EXPECT_NEAR(r.distance, -0.3, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
  // Two zero-size boxes at the same place: touching, distance 0, unit normal.
  const ContactResult t = cm::signedDistance(zero, at(1, 2, 3), zero, at(1, 2, 3));
  EXPECT_EQ(t.status, Status::Touching);
  EXPECT_EQ(t.distance, 0.0);
  expectConsistent(t, kTol);
}

TEST(ExactDegenerate, FlatPolytopes) {
  // A 2x2 square in z = 0 (no adjacency needed).
  const auto square = std::make_shared<cm::Polytope<3>>(
      std::vector<Vec3>{Vec3(-1, -1, 0), Vec3(1, -1, 0), Vec3(1, 1, 0), Vec3(-1, 1, 0)});
  const ConvexShape sq = ConvexShape::polytope(square);
  // A point 1 above the square's interior.
  ContactResult r =
      cm::signedDistance(sq, at(0, 0, 0), ConvexShape::point(Vec3(0.2, 0.3, 1)), at(0, 0, 0));
  EXPECT_NEAR(r.distance, 1.0, kTol);
  expectVecNear(r.normal, Vec3::UnitZ(), kTol);
  // Two coplanar overlapping squares: A - B is flat through the origin: touching, normal +-z.
  r = cm::signedDistance(sq, at(0, 0, 0), sq, at(0.5, 0, 0));
  EXPECT_EQ(r.status, Status::Touching);
  EXPECT_NEAR(r.distance, 0.0, kTol);
  EXPECT_NEAR(std::abs(r.normal.z()), 1.0, kTol);
  // Regression: padded by 0.1 each the depth is exactly the padding sum 0.2.
  r = cm::signedDistance(sq.padded(0.1), at(0, 0, 0), sq.padded(0.1), at(0.5, 0, 0));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -0.2, kTol);
  EXPECT_NEAR(std::abs(r.normal.z()), 1.0, kTol);
  expectConsistent(r, kTol);
  // Squares in crossing planes: B turned 90 deg about y lies in x = 0.5 (y, z in [-1, 1]).
  // A - B = [-1.5, 0.5] x [-2, 2] x [-1, 1], a box around the origin: depth 0.5 along +x.
  r = cm::signedDistance(sq, at(0, 0, 0), sq, rotAt(M_PI / 2, Vec3::UnitY(), Vec3(0.5, 0, 0)));
  EXPECT_NEAR(r.distance, -0.5, kTol);
  expectVecNear(r.normal, Vec3::UnitX(), kTol);
}

TEST(ExactDegenerate, FlatOverlapNormalPointsTowardsBsOrigin) {
  // A 2x2 square in the plane z = 1 of its frame (the frame's origin 1 below it; no core offset:
  // the centre (0, 0, 1) is within 4 half-sizes) and a sphere of radius 0.1 centred in the square
  // at (0.2, 0.3, 1). The cores' A - B is flat (the plane z = 0) through the origin: the depth is
  // the radius, 0.1, out of either side of the plane. query.cpp breaks that tie towards B's origin:
  // A -> B is (0.2, 0.3, 1), so the normal is +z; in the other order A -> B is (-0.2, -0.3, -1)
  // and the normal -z.
  const auto square = std::make_shared<cm::Polytope<3>>(
      std::vector<Vec3>{Vec3(-1, -1, 1), Vec3(1, -1, 1), Vec3(1, 1, 1), Vec3(-1, 1, 1)});
  const ConvexShape sq = ConvexShape::polytope(square);
  const ConvexShape ball = ConvexShape::sphere(0.1);
  ContactResult r = cm::signedDistance(sq, at(0, 0, 0), ball, at(0.2, 0.3, 1));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -0.1, kTol);
  expectVecNear(r.normal, Vec3::UnitZ(), kTol);
  expectVecNear(r.point_a, Vec3(0.2, 0.3, 1.0), kTol);  // the sphere's centre, on the square
  expectVecNear(r.point_b, Vec3(0.2, 0.3, 0.9), kTol);  // 0.1 below it along -normal
  expectConsistent(r, kTol);
  r = cm::signedDistance(ball, at(0.2, 0.3, 1), sq, at(0, 0, 0));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -0.1, kTol);
  expectVecNear(r.normal, -Vec3::UnitZ(), kTol);
  expectVecNear(r.point_a, Vec3(0.2, 0.3, 0.9), kTol);
  expectVecNear(r.point_b, Vec3(0.2, 0.3, 1.0), kTol);
  expectConsistent(r, kTol);
}

TEST(ExactDegenerate, CollinearOverlapNormalIsPerpendicularToTheLineTowardsBsOrigin) {
  // Two padded segments on the x axis of the common frame, overlapping on x in [-0.5, 1]. A's
  // segment runs through its frame's origin; B's lies 1 below its frame's origin (z = -1 in B's
  // frame; no core offset: the centre (0, 0, -1) is within 4 half-sizes) and B's frame is at
  // (0.5, 0, 1). The cores' A - B is a segment along x through the origin (EPA: flat, dimension
  // 1): every direction across x gives depth 0 for the cores, rA + rB = 0.1 + 0.2 = 0.3 for the
  // padded shapes. query.cpp breaks the tie towards B's origin with the part of A -> B = (0.5, 0,
  // 1) across the line: (0, 0, 1). Witnesses: a common point of the cores (y = z = 0, x in the
  // overlap) plus 0.1 along the normal on A, minus 0.2 on B. In the other order the normal is
  // -z.
  const ConvexShape a = ConvexShape::segment(Vec3(-1, 0, 0), Vec3(1, 0, 0)).padded(0.1);
  const ConvexShape b = ConvexShape::segment(Vec3(-1, 0, -1), Vec3(1, 0, -1)).padded(0.2);
  for (const bool swap : {false, true}) {
    SCOPED_TRACE(swap ? "B first" : "A first");
    const ContactResult r = swap ? cm::signedDistance(b, at(0.5, 0, 1), a, at(0, 0, 0))
                                 : cm::signedDistance(a, at(0, 0, 0), b, at(0.5, 0, 1));
    const double s = swap ? -1.0 : 1.0;
    const Vec3& pa = swap ? r.point_b : r.point_a;  // the witness on a (padded 0.1)
    const Vec3& pb = swap ? r.point_a : r.point_b;
    EXPECT_EQ(r.status, Status::Penetrating);
    EXPECT_NEAR(r.distance, -0.3, kTol);
    expectVecNear(r.normal, s * Vec3::UnitZ(), kTol);
    EXPECT_NEAR(pa.z(), 0.1, kTol);
    EXPECT_NEAR(pb.z(), -0.2, kTol);
    EXPECT_NEAR(pa.y(), 0.0, kTol);
    EXPECT_NEAR(pb.y(), 0.0, kTol);
    EXPECT_GE(pa.x(), -0.5 - kTol);
    EXPECT_LE(pa.x(), 1.0 + kTol);
    EXPECT_NEAR(pa.x(), pb.x(), kTol);
    expectConsistent(r, kTol);
  }
}

TEST(ExactDegenerate, CoincidentPointsAndSinglePoint) {
  // Three coincident vertices: a one-point polytope at p = (0.1, 0.2, 0.3) inside a unit sphere.
  const Vec3 p(0.1, 0.2, 0.3);
  const ConvexShape pts =
      ConvexShape::polytope(std::make_shared<cm::Polytope<3>>(std::vector<Vec3>{p, p, p}));
  ContactResult r = cm::signedDistance(ConvexShape::sphere(1.0), at(0, 0, 0), pts, at(0, 0, 0));
  EXPECT_NEAR(r.distance, std::sqrt(0.14) - 1.0, kTol);
  expectVecNear(r.normal, p / std::sqrt(0.14), kTol);
  // Two single points.
  r = cm::signedDistance(ConvexShape::point(Vec3(1, 2, 3)), at(0, 0, 0),
                         ConvexShape::point(Vec3(4, 6, 3)), at(0, 0, 0));
  EXPECT_NEAR(r.distance, 5.0, kTol);
  expectVecNear(r.normal, Vec3(0.6, 0.8, 0), kTol);
  // The same point twice: touching.
  r = cm::signedDistance(ConvexShape::point(Vec3(1, 2, 3)), at(0, 0, 0),
                         ConvexShape::point(Vec3(1, 2, 3)), at(0, 0, 0));
  EXPECT_EQ(r.status, Status::Touching);
  EXPECT_EQ(r.distance, 0.0);
  expectConsistent(r, kTol);
}

TEST(ExactDegenerate, CrossingSegmentsTouch) {
  // Segments along x and y through the origin intersect with zero depth.
  const ContactResult r =
      cm::signedDistance(ConvexShape::segment(Vec3(-1, 0, 0), Vec3(1, 0, 0)), at(0, 0, 0),
                         ConvexShape::segment(Vec3(0, -1, 0), Vec3(0, 1, 0)), at(0, 0, 0));
  EXPECT_EQ(r.status, Status::Touching);
  EXPECT_NEAR(r.distance, 0.0, kTol);
  EXPECT_NEAR(std::abs(r.normal.z()), 1.0, kTol);
  EXPECT_TRUE(cm::intersect(ConvexShape::segment(Vec3(-1, 0, 0), Vec3(1, 0, 0)), at(0, 0, 0),
                            ConvexShape::segment(Vec3(0, -1, 0), Vec3(0, 1, 0)), at(0, 0, 0)));
}

// ---------------------------------------------------------------------------------------------
// Scale and frames
// ---------------------------------------------------------------------------------------------

TEST(ExactDegenerate, SegmentThroughANanometreFlatBoxIsANeedle) {
  // fuzz/regressions/core/epa-needle-tetrahedron-volume-sign: a capsule whose 1.77 m axis passes
  // through the centre of a flat 5e-9 x 2.8e-9 m box. A - B is a parallelepiped spanned by the
  // box's sides and the axis u (box frame); its faces across the axis have normals along u x x
  // and u x z, so the depth of the cores is min(hz |n1.z|, hx |n2.x|). EPA's first tetrahedron
  // had three vertices at the needle's far end; its volume, taken from the near vertex, had the
  // wrong sign (FailedToConverge, depth 2x too large). The fuzzer's poses, then generic ones.
  const double hx = 2.4921875000000003e-09, hz = 1.3828125000000001e-09;
  const double length = 1.765625, radius = 2.28125;
  const ConvexShape box = ConvexShape::box(Vec3(2 * hx, 1.9762625833649862e-323, 2 * hz));
  const ConvexShape capsule = ConvexShape::capsule(length, radius);
  Transform3 box_fuzz = at(0, -15.15625, 49.53125);
  box_fuzz.R << 1, 0, 0, 0, -2.2204460492503131e-16, 1, 0, -1, -2.2204460492503131e-16;
  Transform3 capsule_fuzz = at(-0.0, -15.15625, 49.53125);
  capsule_fuzz.R << 0.99428271396067902, 0.052272329502362776, 0.093110086926083677,
      -0.052272329502362776, -0.52208155883554053, 0.85129222332419363, 0.093110086926083677,
      -0.85129222332419363, -0.51636427279621966;
  Transform3 capsule_generic = at(0, 0, 0);
  capsule_generic.R =
      Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), Vec3(0.1, 0.5, 0.8).normalized())
          .toRotationMatrix();
  const std::vector<std::pair<Transform3, Transform3>> poses{{box_fuzz, capsule_fuzz},
                                                             {at(0, 0, 0), capsule_generic}};
  for (const auto& [pa, pb] : poses) {
    const Vec3 u = (pa.R.transpose() * pb.R.col(2)).normalized();  // the axis in the box's frame
    const Vec3 n1 = u.cross(Vec3::UnitX()).normalized();
    const Vec3 n2 = u.cross(Vec3::UnitZ()).normalized();
    const double depth = std::min(hz * std::abs(n1.z()), hx * std::abs(n2.x()));
    for (const bool swap : {false, true}) {
      SCOPED_TRACE(swap ? "capsule first" : "box first");
      const ContactResult r = swap ? cm::signedDistance(capsule, pb, box, pa)
                                   : cm::signedDistance(box, pa, capsule, pb);
      EXPECT_EQ(r.status, Status::Penetrating);
      EXPECT_NEAR(r.distance, -(radius + depth), 1e-12 * length);
      EXPECT_NEAR(std::abs(r.normal.dot(pa.R * n1)), 1.0, 1e-9);
    }
  }
}

TEST(ExactScale, LargeCoordinatesAndARotatedCommonFrame) {
  // The face-face and penetration cases moved 1 km away and turned: same distances, normals and
  // witnesses carried by the common transform.
  const Transform3 T = rotAt(0.7, Vec3(1, 2, 3), Vec3(1e3, -2e3, 5e2));
  const ConvexShape b2 = ConvexShape::box(Vec3(2, 2, 2));
  ContactResult r = cm::signedDistance(kUnitCube, T * at(0, 0, 0), b2, T * at(3, 0.2, 0.1));
  EXPECT_NEAR(r.distance, 1.5, 1e-10);
  expectVecNear(r.normal, T.R * Vec3::UnitX(), 1e-10);
  EXPECT_NEAR((T.inverse() * r.point_a).x(), 0.5, 1e-10);
  r = cm::signedDistance(kUnitCube, T * at(0, 0, 0), kUnitCube, T * at(0.8, 0.1, 0.05));
  EXPECT_NEAR(r.distance, -0.2, 1e-10);
  expectVecNear(r.normal, T.R * Vec3::UnitX(), 1e-10);
  EXPECT_NEAR((T.inverse() * r.point_a).x(), 0.5, 1e-10);
  EXPECT_NEAR((T.inverse() * r.point_b).x(), 0.3, 1e-10);
  // Spheres 1 km out: exact separation.
  r = cm::signedDistance(ConvexShape::sphere(1.0), T * at(0, 0, 0), ConvexShape::sphere(0.5),
                         T * at(3, 4, 0));
  EXPECT_NEAR(r.distance, 3.5, 1e-10);
}

TEST(ExactScale, WitnessOfAFarPointIsThePointItself) {
  // A hull of one point 1.2 km from its frame's origin, 4 cm from a 3 mm hull of 60 points, in
  // many placements: the witness on A is the point, bit for bit (as Gjk2D's test of the same).
  const cm::Vec3 p(748.77440271237697, -581.19107608039621, 702.5);
  const cm::ConvexShape a = cm::ConvexShape::convexHull({p});
  std::mt19937_64 rng(1734);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<cm::Vec3> ball;
  for (int i = 0; i < 60; ++i)
    ball.push_back(3e-3 * cm::Vec3(n(rng), n(rng), n(rng)).normalized());
  const cm::ConvexShape b = cm::ConvexShape::convexHull(ball);
  int off = 0;
  double worst = 0.0;
  for (int i = 0; i < 2000; ++i) {
    cm::Transform3 pose_b;
    pose_b.R = Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized().toRotationMatrix();
    pose_b.t = p + 0.043 * cm::Vec3(n(rng), n(rng), n(rng)).normalized();
    const cm::ContactResult r = cm::distance(a, cm::Transform3(), b, pose_b);
    ASSERT_EQ(r.status, cm::Status::Separated);
    EXPECT_GT(r.distance, 0.04 - 1e-12);
    EXPECT_LT(r.distance, 0.041);
    if (r.point_a != p) ++off;
    worst = std::max(worst, (r.point_a - p).norm());
  }
  EXPECT_EQ(off, 0) << "of 2000 placements, witnesses not exactly the point; up to " << worst
                    << " m off";
}

TEST(ExactScale, MillimetreSphereAgainstTenMetreBox) {
  // Box 10 m (face x = 5), sphere r = 1 mm centred 2 mm off the face: 1 mm gap.
  const ConvexShape box = ConvexShape::box(Vec3(10, 10, 10));
  const ConvexShape s = ConvexShape::sphere(0.001);
  ContactResult r = cm::signedDistance(box, at(0, 0, 0), s, at(5.002, 1, 2));
  EXPECT_EQ(r.status, Status::Separated);
  EXPECT_NEAR(r.distance, 0.001, 1e-11);
  expectVecNear(r.normal, Vec3::UnitX(), 1e-9);
  // Centre 0.5 mm inside: depth 0.5 mm + 1 mm.
  r = cm::signedDistance(box, at(0, 0, 0), s, at(5.0 - 0.0005, 1, 2));
  EXPECT_EQ(r.status, Status::Penetrating);
  EXPECT_NEAR(r.distance, -0.0015, 1e-11);
  expectVecNear(r.normal, Vec3::UnitX(), 1e-9);
  // And the other way round.
  r = cm::signedDistance(s, at(5.002, 1, 2), box, at(0, 0, 0));
  EXPECT_NEAR(r.distance, 0.001, 1e-11);
  expectVecNear(r.normal, -Vec3::UnitX(), 1e-9);
}

TEST(ExactScale, UnitBoxNearTheCentreOfAHugeEllipsoidIsInside) {
  // The ellipsoid's support overflowed along GJK's first direction, 1e-46 long: a unit box
  // 1e-46 m off the centre of a 5e180 m ball-shaped ellipsoid was separated at +inf, and NaN in
  // the other order (fuzz/regressions/ros/body-ellipsoid-5e180m-support-overflow). The box is
  // inside: depth k + 0.5 (out through a face of the box), which is k to the queries' tolerance
  // of the size. A deep overlap of a curved shape may end unconverged with that depth (query.h).
  for (const double k : {5e180, 1e300}) {
    const ConvexShape ball = ConvexShape::ellipsoid(Vec3(k, k, k));
    EXPECT_TRUE(cm::intersect(ball, at(0, 1e-46, 0), kUnitCube, at(0, 0, 0))) << k;
    EXPECT_TRUE(cm::intersect(kUnitCube, at(0, 0, 0), ball, at(0, 1e-46, 0))) << k;
    for (const ContactResult& r :
         {cm::signedDistance(ball, at(0, 1e-46, 0), kUnitCube, at(0, 0, 0)),
          cm::signedDistance(kUnitCube, at(0, 0, 0), ball, at(0, 1e-46, 0))}) {
      EXPECT_TRUE(r.status == Status::Penetrating || r.status == Status::FailedToConverge)
          << static_cast<int>(r.status);
      EXPECT_NEAR(r.distance / k, -1.0, 1e-9) << k;
    }
  }
}

TEST(ExactQuery, IntersectAgreesWithSignedDistanceOnAGrid) {
  // A box and a capsule walked across each other on a grid: intersect() is true exactly when the
  // hand-computed distance is <= 0. Capsule (axis z, length 1, r 0.25) beside a unit cube face:
  // distance = x - 0.5 - 0.25 for |y|, |z| small enough that the face is nearest.
  for (int i = 0; i <= 20; ++i) {
    const double x = 0.5 + 0.05 * i;  // 0.5 .. 1.5
    const double expected = x - 0.75;
    const bool hit =
        cm::intersect(kUnitCube, at(0, 0, 0), ConvexShape::capsule(1, 0.25), at(x, 0.1, 0.0));
    const ContactResult r =
        cm::signedDistance(kUnitCube, at(0, 0, 0), ConvexShape::capsule(1, 0.25), at(x, 0.1, 0.0));
    EXPECT_NEAR(r.distance, expected, kTol) << "x = " << x;
    if (std::abs(expected) > 1e-9) {
      EXPECT_EQ(hit, expected < 0.0) << "x = " << x;
    }
  }
}

TEST(ExactQuery, NonFinitePosesGiveADefinedFailure) {
  // Regression: a NaN pose ran GJK to the iteration bound and returned a NaN normal; now the
  // query reports FailedToConverge with a finite unit normal, and intersect() says true
  // (conservative).
  Transform3 bad = at(0, 0, 0);
  bad.t.x() = std::numeric_limits<double>::quiet_NaN();
  for (const bool signed_query : {false, true}) {
    const ContactResult r = signed_query
                                ? cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, bad)
                                : cm::distance(kUnitCube, bad, kUnitCube, at(0, 0, 0));
    EXPECT_EQ(r.status, Status::FailedToConverge);
    EXPECT_TRUE(r.normal.allFinite());
    EXPECT_NEAR(r.normal.norm(), 1.0, 1e-15);
  }
  EXPECT_TRUE(cm::intersect(kUnitCube, at(0, 0, 0), kUnitCube, bad));
  EXPECT_STREQ(cm::toString(Status::FailedToConverge), "FailedToConverge");
  EXPECT_STREQ(cm::toString(Status::Touching), "Touching");
}

TEST(ExactQuery, NonFiniteRotationOfBAloneGivesADefinedFailure) {
  // A NaN or Inf only in B's rotation (A at the identity, both translations finite) reaches the
  // relative rotation R_A^T R_B but not the relative translation R_A^T (t_B - t_A): the queries
  // must still see the pose as non-finite and give the defined failure (FailedToConverge, finite
  // unit normal; intersect() true, conservative), for shapes far apart or overlapping.
  for (const double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    for (const double x : {0.5, 5.0}) {
      Transform3 pose_b = at(x, 0, 0);
      pose_b.R(1, 2) = bad;
      for (const bool signed_query : {false, true}) {
        const ContactResult r = signed_query
                                    ? cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, pose_b)
                                    : cm::distance(kUnitCube, at(0, 0, 0), kUnitCube, pose_b);
        EXPECT_EQ(r.status, Status::FailedToConverge) << "x = " << x << " bad = " << bad;
        EXPECT_TRUE(r.normal.allFinite());
        EXPECT_NEAR(r.normal.norm(), 1.0, 1e-15);
      }
      EXPECT_TRUE(cm::intersect(kUnitCube, at(0, 0, 0), kUnitCube, pose_b)) << "x = " << x;
    }
  }
}

TEST(ExactQuery, GjkOutOfIterationsIsReportedAsFailedToConverge) {
  // With no GJK iterations allowed (QueryOptions::max_iterations = 0) GJK stops on its starting
  // point, unconverged: the answer is FailedToConverge, never Separated, with the starting
  // point's distance as the estimate, which is an upper bound on the true gap 3 - 0.5 - 0.5 = 2
  // (every point of A - B is at least that far from the origin). Unit cubes 3 apart along x.
  cm::QueryOptions o;
  o.max_iterations = 0;
  const Transform3 pb = at(3, 0.2, -0.1);
  for (const bool signed_query : {false, true}) {
    const ContactResult r =
        signed_query ? cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, pb, nullptr, o)
                     : cm::distance(kUnitCube, at(0, 0, 0), kUnitCube, pb, nullptr, o);
    EXPECT_EQ(r.status, Status::FailedToConverge) << (signed_query ? "signed" : "distance");
    EXPECT_GE(r.distance, 2.0 - kTol);
    EXPECT_TRUE(r.normal.allFinite());
  }
  // The same pair with the default bound converges: the gap.
  EXPECT_NEAR(cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, pb).distance, 2.0, kTol);
}

TEST(ExactQuery, EpaWithoutAnUpperBoundOnTheDepthNeverSettles) {
  // With no EPA iterations allowed (QueryOptions::max_epa_iterations = 0), EPA stops on GJK's
  // enclosing tetrahedron before any support call: it has only the lower bound of its nearest
  // face (0 <= bound <= the depth), no upper bound. Even with a touching band as wide as the
  // pair (touch_tolerance = 1) that lower bound proves nothing about the depth: the answer is
  // FailedToConverge, not Touching. Unit cubes overlapping deeply (centres 0.365 apart) at a
  // generic pose; with the default options the same pair converges (Penetrating).
  cm::QueryOptions o;
  o.max_epa_iterations = 0;
  o.touch_tolerance = 1.0;
  const Transform3 pb = rotAt(0.3, Vec3(1, 2, 3), Vec3(0.31, 0.17, 0.09));
  const ContactResult r = cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, pb, nullptr, o);
  EXPECT_EQ(r.status, Status::FailedToConverge);
  EXPECT_EQ(r.epa_iterations, 0);
  EXPECT_EQ(cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, pb).status, Status::Penetrating);
}

TEST(ExactQuery, UnconvergedEpaWhoseUpperBoundIsInTheTouchingBandSettlesAsTouching) {
  // A point at the centre of a unit cube: depth 0.5 (every face). GJK ends on a segment of
  // support points through the origin (symmetry), so EPA blows it up to a tetrahedron with
  // support calls along known directions: their least overlap is an upper bound on the depth
  // (>= 0.5). With no EPA iterations allowed (max_epa_iterations = 0) EPA stops unconverged, its
  // lower bound (nearest face of the tetrahedron) not within tolerance of that upper bound. With
  // a touching band as wide as the pair (touch_tolerance = 1: band = size = sqrt(3) / 2 = 0.866,
  // the cube's half-diagonal) the upper bound lies in the band, so the signed distance is known to
  // be in [-band, 0]: Touching (query.cpp: "settled"), not FailedToConverge, with the bound as
  // the depth.
  cm::QueryOptions o;
  o.max_epa_iterations = 0;
  o.touch_tolerance = 1.0;
  const ContactResult r = cm::signedDistance(
      kUnitCube, at(0, 0, 0), ConvexShape::point(Vec3::Zero()), at(0, 0, 0), nullptr, o);
  EXPECT_EQ(r.status, Status::Touching);
  EXPECT_LE(r.distance, -0.5 + kTol);
  EXPECT_GE(r.distance, -0.5 * kSqrt3 - kTol);
}

TEST(ExactQuery, UnconvergedEpaReportsItsUpperBoundWithWitnessesOnBothSupportingPlanes) {
  // EPA out of iterations (max_epa_iterations = 2) reports the least overlap it saw along a
  // support direction n: an upper bound on the depth, with witness points on A's supporting plane
  // along n and on B's along -n, one depth apart along n. Checked against the cubes' 8 vertices
  // each (brute force): the depth is the overlap of the two vertex sets' projections on n, and it
  // is at least the converged query's depth (the safe side). The pair is the deep overlap at a
  // generic pose of EpaWithoutAnUpperBoundOnTheDepthNeverSettles.
  cm::QueryOptions o;
  o.max_epa_iterations = 2;
  const Transform3 pb = rotAt(0.3, Vec3(1, 2, 3), Vec3(0.31, 0.17, 0.09));
  const ContactResult r = cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, pb, nullptr, o);
  EXPECT_EQ(r.status, Status::FailedToConverge);
  EXPECT_EQ(r.epa_iterations, 2);
  expectConsistent(r, kTol);
  const Vec3& n = r.normal;
  double max_a = -1e300;
  double min_b = 1e300;
  for (int i = 0; i < 8; ++i) {
    const Vec3 v((i & 1) ? 0.5 : -0.5, (i & 2) ? 0.5 : -0.5, (i & 4) ? 0.5 : -0.5);
    max_a = std::max(max_a, n.dot(v));
    min_b = std::min(min_b, n.dot(pb * v));
  }
  EXPECT_NEAR(n.dot(r.point_a), max_a, kTol);
  EXPECT_NEAR(n.dot(r.point_b), min_b, kTol);
  EXPECT_NEAR(r.distance, min_b - max_a, kTol);
  const ContactResult exact = cm::signedDistance(kUnitCube, at(0, 0, 0), kUnitCube, pb);
  ASSERT_EQ(exact.status, Status::Penetrating);
  EXPECT_LE(r.distance, exact.distance + kTol);
}
