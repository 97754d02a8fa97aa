// gjkDistance / gjkIntersect / EPA in 2D (footprints), 3D sub-algorithms, and 4D/5D: exact answers
// by hand, plus the optimality condition of the simplex sub-algorithms on random simplices.
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "collision_monitor/core/epa.h"
#include "collision_monitor/core/gjk.h"
#include "collision_monitor/core/shapes.h"

namespace cm = collision_monitor::core;
using cm::Vec;

namespace {

template <int D>
cm::Transform<D> shift(const Vec<D>& t) {
  cm::Transform<D> T;
  T.t = t;
  return T;
}
cm::Transform<2> rot2(double angle, const cm::Vec2& t) {
  cm::Transform<2> T;
  T.R = Eigen::Rotation2Dd(angle).toRotationMatrix();
  T.t = t;
  return T;
}
template <int D>
void expectVecNear(const Vec<D>& a, const Vec<D>& b, double tol) {
  for (int i = 0; i < D; ++i)
    EXPECT_NEAR(a[i], b[i], tol) << "i = " << i << " got " << a.transpose() << " want "
                                 << b.transpose();
}
cm::GjkSettings settings(double size) {
  cm::GjkSettings s;
  s.abs_tolerance = s.rel_tolerance * size;
  return s;
}
cm::EpaSettings epaSettings(double size) {
  cm::EpaSettings s;
  s.abs_tolerance = s.rel_tolerance * size;
  return s;
}

/// EPA on two overlapping segments on the x axis, [-1, 1] and [0, 0.5] moved by 0.2: A - B is the
/// segment [-1.7, 0.8] along x through the origin, so EPA must say flat, of dimension 1, depth 0.
template <int D>
cm::EpaResult<D> collinearSegmentsEpa() {
  const Vec<D> x = Vec<D>::UnitX();
  const cm::SegmentShape<D> a{-x, x};
  const cm::SegmentShape<D> b{Vec<D>::Zero(), 0.5 * x};
  const cm::MinkowskiDifference<D, cm::SegmentShape<D>, cm::SegmentShape<D>> md(a, b,
                                                                                shift<D>(0.2 * x));
  const auto g = cm::gjkDistance(md, settings(3));
  EXPECT_EQ(g.status, cm::GjkStatus::Intersecting);
  const cm::EpaResult<D> e = cm::epaPenetration(md, g.simplex, epaSettings(3));
  EXPECT_EQ(e.status, cm::EpaStatus::Flat);
  EXPECT_EQ(e.flat_dimension, 1);
  EXPECT_EQ(e.depth, 0.0);
  return e;
}

/// EPA from the triangle (-1, 0), (1, 0), (0, -1e-13) (first two coordinates; 0 beyond) of A - B
/// for A the segment [-1, 1] along x and B the segment from 0 to 1e-13 along y: A - B is the
/// rectangle [-1, 1] x [-1e-13, 0], thinner than EPA's tolerance (2e-12): a segment to it. The
/// triangle's height, 1e-13, is below the tolerance (twice its area 2e-13 <= 2e-12 x its longest
/// edge 2): EPA treats it as collinear, keeps its two far points, and finds nothing beyond the
/// tolerance off their line: flat, of dimension 1, along x, depth 0.
template <int D>
cm::EpaResult<D> thinRectangleEpa() {
  const Vec<D> x = Vec<D>::UnitX();
  const Vec<D> y = Vec<D>::UnitY();
  const cm::SegmentShape<D> a{-x, x};
  const cm::SegmentShape<D> b{Vec<D>::Zero(), 1e-13 * y};
  const cm::MinkowskiDifference<D, cm::SegmentShape<D>, cm::SegmentShape<D>> md(
      a, b, shift<D>(Vec<D>::Zero()));
  cm::Simplex<D> start;
  start.v[0] = md.fromLocal(-x, Vec<D>::Zero());         // w = (-1, 0)
  start.v[1] = md.fromLocal(x, Vec<D>::Zero());          // w = (1, 0)
  start.v[2] = md.fromLocal(Vec<D>::Zero(), 1e-13 * y);  // w = (0, -1e-13)
  start.size = 3;
  const cm::EpaResult<D> e = cm::epaPenetration(md, start, epaSettings(2));
  EXPECT_EQ(e.status, cm::EpaStatus::Flat);
  EXPECT_EQ(e.flat_dimension, 1);
  EXPECT_EQ(e.depth, 0.0);
  return e;
}

template <int D>
cm::Simplex<D> simplexOf(const std::vector<Vec<D>>& pts) {
  cm::Simplex<D> s;
  s.size = static_cast<int>(pts.size());
  for (int i = 0; i < s.size; ++i) {
    s.v[i].w = pts[i];
    s.v[i].a = pts[i];
    s.v[i].b = Vec<D>::Zero();
  }
  return s;
}
/// The support point of A - B made of a (on A) and b (on B).
cm::SupportPoint<3> supportPointOf(const cm::Vec3& a, const cm::Vec3& b) {
  cm::SupportPoint<3> q;
  q.a = a;
  q.b = b;
  q.w = a - b;
  return q;
}

/// The box [-1, 1]^3 (A) minus a point (B), unposed: A - B = [-1, 1]^3 - point, for seeds made by
/// hand. at(a): the point of A - B of the box point `a`.
struct CubeMinusPoint {
  explicit CubeMinusPoint(const cm::Vec3& p) : point{p} {}
  CubeMinusPoint(const CubeMinusPoint&) = delete;  // md refers to the two shapes
  CubeMinusPoint& operator=(const CubeMinusPoint&) = delete;
  cm::SupportPoint<3> at(const cm::Vec3& a) const { return supportPointOf(a, point.p); }

  const cm::BoxShape<3> cube{cm::Vec3::Ones()};
  const cm::PointShape<3> point;
  const cm::MinkowskiDifference<3, cm::BoxShape<3>, cm::PointShape<3>> md{
      cube, point, shift<3>(cm::Vec3::Zero())};
};

using Box2 = cm::BoxShape<2>;
using Pt2 = cm::PointShape<2>;

}  // namespace

// ---------------------------------------------------------------------------------------------
// 2D footprints
// ---------------------------------------------------------------------------------------------

TEST(Gjk2D, SquaresFaceFace) {
  // Square half 1 (x <= 1) and half 0.5 at (3, 0.2) (x >= 2.5): 1.5.
  const Box2 a{cm::Vec2(1, 1)};
  const Box2 b{cm::Vec2(0.5, 0.5)};
  const cm::MinkowskiDifference<2, Box2, Box2> md(a, b, shift<2>(cm::Vec2(3, 0.2)));
  const auto r = cm::gjkDistance(md, settings(5));
  EXPECT_EQ(r.status, cm::GjkStatus::Separated);
  EXPECT_NEAR(r.distance, 1.5, 1e-12);
  EXPECT_NEAR(r.point_a.x(), 1.0, 1e-12);
  EXPECT_NEAR(r.point_b.x(), 2.5, 1e-12);
  EXPECT_NEAR(r.point_a.y(), r.point_b.y(), 1e-12);
  expectVecNear<2>(r.v, r.point_a - r.point_b, 1e-12);
}

TEST(Gjk2D, RotatedSquareVertex) {
  // Square half 0.5 turned 45 deg at (3, 0): leftmost vertex (3 - sqrt2/2, 0); A's face x = 1.
  const Box2 a{cm::Vec2(1, 1)};
  const Box2 b{cm::Vec2(0.5, 0.5)};
  const cm::MinkowskiDifference<2, Box2, Box2> md(a, b, rot2(M_PI / 4, cm::Vec2(3, 0)));
  const auto r = cm::gjkDistance(md, settings(5));
  EXPECT_NEAR(r.distance, 2.0 - std::sqrt(2.0) / 2, 1e-12);
  expectVecNear<2>(r.point_a, cm::Vec2(1, 0), 1e-12);
  expectVecNear<2>(r.point_b, cm::Vec2(3 - std::sqrt(2.0) / 2, 0), 1e-12);
}

TEST(Gjk2D, PolygonToPoint) {
  // Triangle (0,0), (2,0), (0,2) and the point (2, 2): sqrt2 to the hypotenuse, foot (1, 1).
  const cm::Polytope<2> tri({cm::Vec2(0, 0), cm::Vec2(2, 0), cm::Vec2(0, 2)});
  const cm::PolytopeSupport<2> a{&tri};
  const Pt2 p{cm::Vec2(2, 2)};
  const cm::MinkowskiDifference<2, cm::PolytopeSupport<2>, Pt2> md(a, p,
                                                                   shift<2>(cm::Vec2::Zero()));
  const auto r = cm::gjkDistance(md, settings(5));
  EXPECT_NEAR(r.distance, std::sqrt(2.0), 1e-12);
  expectVecNear<2>(r.point_a, cm::Vec2(1, 1), 1e-12);
}

TEST(Gjk2D, WitnessOfAFarPointIsThePointItself) {
  // A point 950 m from its frame's origin (three coincident vertices), 4 cm from a 3 mm 170-gon
  // in many placements: GJK's terminal simplex holds the point as every vertex's A side, so its
  // witness on A is the point, bit for bit. Summing weights times the vertices put it up to
  // 3.8e-11 m off (the weights of the point-edge segment sum to 1 only to 4e-14, the ratio of
  // A - B's size to B's edges times the rounding; test_gjk_2d_sweep pair 1734 before the sweep's
  // placement changed).
  const cm::Vec2 p(748.77440271237697, -581.19107608039621);
  const cm::Polytope<2> point({p, p, p});
  std::vector<cm::Vec2> ring;
  for (int i = 0; i < 170; ++i)
    ring.emplace_back(3e-3 * std::cos(2 * M_PI * i / 170), 3e-3 * std::sin(2 * M_PI * i / 170));
  const cm::Polytope<2> gon(ring);
  std::mt19937_64 rng(1734);
  std::uniform_real_distribution<double> u(0.0, 2 * M_PI);
  int off = 0;
  double worst = 0.0;
  for (int i = 0; i < 2000; ++i) {
    const double dir = u(rng);
    const cm::PolytopeSupport<2> a{&point}, b{&gon};
    const cm::MinkowskiDifference<2, cm::PolytopeSupport<2>, cm::PolytopeSupport<2>> md(
        a, b, rot2(u(rng), p + 0.043 * cm::Vec2(std::cos(dir), std::sin(dir))));
    const auto r = cm::gjkDistance(md, settings(1e3));
    ASSERT_EQ(r.status, cm::GjkStatus::Separated);
    // 43 mm minus the ring's 3 mm at a vertex, up to its sagitta 3 mm (1 - cos(pi / 170)) more.
    EXPECT_GT(r.distance, 0.04 - 1e-12);
    EXPECT_LT(r.distance, 0.04 + 5.13e-7);
    if (r.point_a != p) ++off;
    worst = std::max(worst, (r.point_a - p).norm());
  }
  EXPECT_EQ(off, 0) << "of 2000 placements, witnesses not exactly the point; up to " << worst
                    << " m off";
}

TEST(Gjk2D, IntersectWithMargins) {
  const Box2 a{cm::Vec2(1, 1)};
  const Box2 b{cm::Vec2(0.5, 0.5)};
  const cm::MinkowskiDifference<2, Box2, Box2> apart(a, b, shift<2>(cm::Vec2(3, 0.2)));  // 1.5
  EXPECT_FALSE(cm::gjkIntersect(apart, 0.0, settings(5)));
  EXPECT_FALSE(cm::gjkIntersect(apart, 1.4, settings(5)));
  EXPECT_TRUE(cm::gjkIntersect(apart, 1.6, settings(5)));
  const cm::MinkowskiDifference<2, Box2, Box2> overlap(a, b, shift<2>(cm::Vec2(1.2, -0.3)));
  int iterations = -1;
  EXPECT_TRUE(cm::gjkIntersect(overlap, 0.0, settings(5), nullptr, &iterations));
  EXPECT_GE(iterations, 0);
  EXPECT_EQ(cm::gjkDistance(overlap, settings(5)).status, cm::GjkStatus::Intersecting);
}

TEST(Gjk2D, IntersectAtExactlyTheMarginIsTrue) {
  // Pins gjkIntersect's early exit: a support plane at exactly the margin is not a separating
  // plane. The square of half side 1 and the point (2.5, 0) are 1.5 apart (the face x = 1); GJK
  // starts at the centres' difference (-2.5, 0), whose support point (-1.5, +-1) has
  // v.w / |v| = 3.75 / 2.5 = 1.5, the margin itself, and goes on to v = (-1.5, 0): |v| = 1.5 is
  // within a margin of 1.5 (no tolerance: abs_tolerance 0).
  const Box2 a{cm::Vec2(1, 1)};
  const Pt2 p{cm::Vec2(0, 0)};
  const cm::MinkowskiDifference<2, Box2, Pt2> md(a, p, shift<2>(cm::Vec2(2.5, 0)));
  const cm::GjkSettings exact;
  EXPECT_TRUE(cm::gjkIntersect(md, 1.5, exact));
  EXPECT_FALSE(cm::gjkIntersect(md, 1.25, exact));
  EXPECT_EQ(cm::gjkDistance(md, exact).distance, 1.5);
}

TEST(Gjk2D, IntersectOutOfIterationsIsConservativelyTrue) {
  // Pins gjkIntersect's answer when the iteration bound is hit undecided: true (contact assumed, as
  // a collision monitor must), even for squares 1.5 apart; with iterations left it is false.
  const Box2 a{cm::Vec2(1, 1)};
  const Box2 b{cm::Vec2(0.5, 0.5)};
  const cm::MinkowskiDifference<2, Box2, Box2> apart(a, b, shift<2>(cm::Vec2(3, 0.2)));
  cm::GjkSettings none = settings(5);
  none.max_iterations = 0;
  int iterations = -1;
  EXPECT_TRUE(cm::gjkIntersect(apart, 0.0, none, nullptr, &iterations));
  EXPECT_EQ(iterations, 0);
  EXPECT_EQ(cm::gjkDistance(apart, none).status, cm::GjkStatus::MaxIterations);
  EXPECT_FALSE(cm::gjkIntersect(apart, 0.0, settings(5)));
}

TEST(Epa3D, CollinearSegmentsAreFlatWithANormalAcrossTheLine) {
  // Pins EPA's answer for A - B a segment in 3D (flat_dimension 1): the line's direction in
  // flat_direction and a unit normal perpendicular to it.
  const auto e = collinearSegmentsEpa<3>();
  EXPECT_NEAR(std::abs(e.flat_direction.x()), 1.0, 1e-15);
  EXPECT_NEAR(e.normal.norm(), 1.0, 1e-15);
  EXPECT_NEAR(e.normal.x(), 0.0, 1e-15);
}

TEST(Epa3D, OnLineAllowsTheRoundingOfTheCoordinates) {
  // detail::onLine() (EPA's test for a horizon edge through the new point): on the line to within
  // 64 eps times the largest coordinate. a = 0, b = (1, 1, 1): p = (0.1 + 0.2, 0.3, 0.3) is off
  // the diagonal only by the rounding of 0.1 + 0.2 (0.30000000000000004 against 0.3: one ulp,
  // d = 2^-54), so u x p = (0, d, -d), |u x p|^2 = 2^-107, within (64 eps)^2 |u|^2 = 3 x 2^-92.
  const cm::Vec3 a = cm::Vec3::Zero();
  const cm::Vec3 b(1, 1, 1);
  EXPECT_TRUE(cm::detail::onLine(a, b, cm::Vec3(0.1 + 0.2, 0.3, 0.3)));
  EXPECT_TRUE(cm::detail::onLine(a, b, cm::Vec3(0.5, 0.5, 0.5)));  // exactly on it
  // 1e-6 off it is not rounding: |u x p|^2 = 2e-12.
  EXPECT_FALSE(cm::detail::onLine(a, b, cm::Vec3(0.3, 0.3, 0.3 + 1e-6)));
}

TEST(Epa3D, AStartTetrahedronWithoutVolumeIsLiftedAgain) {
  // A start simplex of four points with volume 0 (three of them on a line: (2, 2, 1.5), (-2, -2,
  // -0.5) and their midpoint (0, 0, 0.5)) is not used as EPA's first polytope (its faces through
  // the line have no area): the lift starts again from its first face, here cut back to the two
  // far points of the line. A point A at the origin in the box B with half sides (2, 2, 1) at
  // (0, 0, -0.5), i.e. [-2, 2]^2 x [-1.5, 0.5]: A - B = -B = [-2, 2]^2 x [-0.5, 1.5], the four
  // points above are points of it. Its nearest face is z = -0.5: depth 0.5 along (0, 0, -1) (B
  // moved down by 0.5 clears the point), witnesses the point and B's top-face point (0, 0, 0.5).
  const cm::PointShape<3> point{cm::Vec3::Zero()};
  const cm::BoxShape<3> box{cm::Vec3(2, 2, 1)};
  const cm::Vec3 t(0, 0, -0.5);
  const cm::MinkowskiDifference<3, cm::PointShape<3>, cm::BoxShape<3>> md(point, box, shift<3>(t));
  const std::array<cm::Vec3, 4> w{cm::Vec3(2, 2, 1.5), cm::Vec3(-2, -2, -0.5), cm::Vec3(0, 0, 0.5),
                                  cm::Vec3(2, -2, -0.5)};
  cm::Simplex<3> start;
  for (int i = 0; i < 4; ++i)
    start.v[i] = md.fromLocal(cm::Vec3::Zero(), -w[i] - t);  // b = -w, in B's frame b - t
  start.size = 4;
  const auto e = cm::epaPenetration(md, start, epaSettings(4));
  EXPECT_EQ(e.status, cm::EpaStatus::Converged);
  EXPECT_NEAR(e.depth, 0.5, 1e-12);
  expectVecNear<3>(e.normal, cm::Vec3(0, 0, -1), 1e-12);
  expectVecNear<3>(e.point_a, cm::Vec3::Zero(), 1e-12);
  expectVecNear<3>(e.point_b, cm::Vec3(0, 0, 0.5), 1e-12);
}

TEST(Epa3D, ATriangleThinnerThanTheToleranceIsALine) {
  const auto e = thinRectangleEpa<3>();
  EXPECT_NEAR(std::abs(e.flat_direction.x()), 1.0, 1e-15);
}

TEST(Epa2D, SquaresDepthNormalWitness) {
  // Squares half 1, B at (1.5, 0.2): overlaps 0.5 (x), 1.8 (y): depth 0.5 along +x.
  const Box2 a{cm::Vec2(1, 1)};
  const cm::MinkowskiDifference<2, Box2, Box2> md(a, a, shift<2>(cm::Vec2(1.5, 0.2)));
  const auto g = cm::gjkDistance(md, settings(5));
  ASSERT_EQ(g.status, cm::GjkStatus::Intersecting);
  const auto e = cm::epaPenetration(md, g.simplex, epaSettings(5));
  EXPECT_EQ(e.status, cm::EpaStatus::Converged);
  EXPECT_NEAR(e.depth, 0.5, 1e-12);
  expectVecNear<2>(e.normal, cm::Vec2(1, 0), 1e-12);
  EXPECT_NEAR(e.point_a.x(), 1.0, 1e-12);
  EXPECT_NEAR(e.point_b.x(), 0.5, 1e-12);
}

TEST(Epa2D, PointAtOrNearADiscCentre) {
  // Every direction ties at the centre (and nearly so 1e-7 and 1e-4 off it): EPA's polygon closes
  // in on the whole circle at once. Before the upper bound's refinement (epa.h
  // refineUpperBound()) the 1e-4 case ended after 256 iterations 7.5e-9 too deep; now the depth
  // is exact and EPA stops at its checkpoint (uncertified: its lower bound lags).
  const cm::EllipsoidShape<2> disc{cm::Vec2(1, 1)};
  const Pt2 point{cm::Vec2::Zero()};
  for (const double off : {0.0, 1e-7, 1e-4}) {
    SCOPED_TRACE(off);
    const cm::MinkowskiDifference<2, cm::EllipsoidShape<2>, Pt2> md(disc, point,
                                                                    shift<2>(cm::Vec2(off, 0)));
    const auto g = cm::gjkDistance(md, settings(2));
    ASSERT_EQ(g.status, cm::GjkStatus::Intersecting);
    const auto e = cm::epaPenetration(md, g.simplex, epaSettings(2));
    EXPECT_NEAR(e.depth, 1.0 - off, 1e-12);
    EXPECT_LE(e.iterations, 128);
    EXPECT_NEAR(e.point_a.norm(), 1.0, 1e-12);  // on the circle
    // The point, to 1e-9 of the size: where the depth is flat to rounding along the circle (1e-4
    // off: 1e-4 (1 - cos a) < 1e-16 for a < 1.4e-6 rad) the normal is known to that angle only.
    expectVecNear<2>(e.point_b, cm::Vec2(off, 0), 1e-9);
    expectVecNear<2>(e.point_a - e.point_b, e.depth * e.normal, 1e-12);
    if (off > 0.0) expectVecNear<2>(e.normal, cm::Vec2(1, 0), 1e-3);
  }
}

TEST(Epa2D, TriangleInSquare) {
  // Square half 2 (x <= 2); triangle (0,0), (1,0), (0,1) at (1.5, -0.5): spans x in [1.5, 2.5]:
  // exits +x by 0.5 (others: 4.5 (-x), 2.5 (+y), 3.5 (-y)).
  const Box2 sq{cm::Vec2(2, 2)};
  const cm::Polytope<2> tri({cm::Vec2(0, 0), cm::Vec2(1, 0), cm::Vec2(0, 1)});
  const cm::PolytopeSupport<2> t{&tri};
  const cm::MinkowskiDifference<2, Box2, cm::PolytopeSupport<2>> md(sq, t,
                                                                    shift<2>(cm::Vec2(1.5, -0.5)));
  const auto g = cm::gjkDistance(md, settings(6));
  ASSERT_EQ(g.status, cm::GjkStatus::Intersecting);
  const auto e = cm::epaPenetration(md, g.simplex, epaSettings(6));
  EXPECT_NEAR(e.depth, 0.5, 1e-12);
  expectVecNear<2>(e.normal, cm::Vec2(1, 0), 1e-12);
}

TEST(Epa2D, CollinearSegmentsAreFlat) {
  // A - B a segment through the origin: flat, depth 0, normal +-y (a defined answer, not a
  // degenerate polygon).
  const auto e = collinearSegmentsEpa<2>();
  EXPECT_NEAR(std::abs(e.normal.y()), 1.0, 1e-15);
}

TEST(Epa2D, ATriangleThinnerThanTheToleranceIsALine) {
  const auto e = thinRectangleEpa<2>();
  EXPECT_NEAR(std::abs(e.normal.y()), 1.0, 1e-15);  // across the line
}

TEST(Epa2D, CrossingSegmentsFormASquare) {
  // Segment along x and one along y, crossing at their midpoints: A - B is the square
  // [-1, 1]^2: depth 1.
  const cm::SegmentShape<2> a{cm::Vec2(-1, 0), cm::Vec2(1, 0)};
  const cm::SegmentShape<2> b{cm::Vec2(0, -1), cm::Vec2(0, 1)};
  const cm::MinkowskiDifference<2, cm::SegmentShape<2>, cm::SegmentShape<2>> md(
      a, b, shift<2>(cm::Vec2::Zero()));
  const auto g = cm::gjkDistance(md, settings(3));
  ASSERT_EQ(g.status, cm::GjkStatus::Intersecting);
  const auto e = cm::epaPenetration(md, g.simplex, epaSettings(3));
  EXPECT_EQ(e.status, cm::EpaStatus::Converged);
  EXPECT_NEAR(e.depth, 1.0, 1e-12);
}

TEST(Epa2D, OutOfIterationsWithinToleranceOfItsUpperBoundIsConverged) {
  // EPA stopped by its iteration bound, but with its least support depth seen (the upper bound)
  // within the tolerance of its nearest edge (the lower bound): the depth is known, so the
  // answer is that bound, Converged, not an estimate (epa.h EpaProgress::settle(),
  // EpaUpperBound::applyTo()). A point A at the centre of the square B = [-1, 1]^2: A - B = -B,
  // the same square, depth 1 along each axis. Start triangle (points w = -b of A - B):
  // (-1, -1/2), (1, -1/2), (0, 1), holding the origin; its edges: the bottom one at distance 1/2
  // (normal (0, -1)), the two sides at 1 / sqrt(1.5^2 + 1) = 2 / sqrt(13) = 0.5547 (normals
  // (+-3, 2) / sqrt(13)). One iteration: along (0, -1) the support point is a corner (+-1, -1)
  // of depth 1 (the upper bound, exact: 0 x +-1 + (-1) x (-1)), a gain of 1 - 1/2 = 1/2 over the
  // edge, more than need = 0.9 x 1/2 = 0.45: the corner joins the polygon. Its new edges are at
  // 1 (on x = +-1) and 3 / sqrt(17) = 0.728 (to the far end of the bottom edge), so the nearest
  // edge is a side, 2 / sqrt(13). Out of iterations there: 1 - 2 / sqrt(13) = 0.445 <= need =
  // 0.9 x 2 / sqrt(13) = 0.499, so the bound 1 is certified: depth 1 along (0, -1), witnesses A's
  // point and B's bottom-face point (0, 1) (B moved by (0, -1) touches A there).
  const Pt2 point{cm::Vec2::Zero()};
  const Box2 square{cm::Vec2(1, 1)};
  const cm::MinkowskiDifference<2, Pt2, Box2> md(point, square, shift<2>(cm::Vec2::Zero()));
  cm::Simplex<2> start;
  const std::array<cm::Vec2, 3> w{cm::Vec2(-1, -0.5), cm::Vec2(1, -0.5), cm::Vec2(0, 1)};
  for (int i = 0; i < 3; ++i)
    start.v[i] = md.fromLocal(cm::Vec2::Zero(), -w[i]);
  start.size = 3;
  cm::EpaSettings st;
  st.rel_tolerance = 0.9;
  st.abs_tolerance = 0.0;
  st.max_iterations = 1;
  const auto e = cm::epaPenetration(md, start, st);
  EXPECT_EQ(e.status, cm::EpaStatus::Converged);
  EXPECT_FALSE(e.depth_is_upper_bound);
  EXPECT_EQ(e.iterations, 1);
  EXPECT_EQ(e.depth, 1.0);
  EXPECT_EQ(e.normal, cm::Vec2(0, -1));
  EXPECT_EQ(e.point_a, cm::Vec2(0, 0));
  EXPECT_EQ(e.point_b, cm::Vec2(0, 1));
  // Asked to 1e-12 instead, the same iteration leaves the gap 0.445 open: an upper bound only.
  st.rel_tolerance = 1e-12;
  const auto u = cm::epaPenetration(md, start, st);
  EXPECT_EQ(u.status, cm::EpaStatus::MaxIterations);
  EXPECT_TRUE(u.depth_is_upper_bound);
  EXPECT_NEAR(u.depth, 1.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Higher dimensions
// ---------------------------------------------------------------------------------------------

TEST(GjkHighD, HypercubeToPoints4D) {
  using Box4 = cm::BoxShape<4>;
  using Pt4 = cm::PointShape<4>;
  const Box4 cube{Vec<4>::Ones()};
  {
    // Only x is outside: 3 - 1.
    const Pt4 p{Vec<4>(3, 0.5, 0.2, -0.1)};
    const cm::MinkowskiDifference<4, Box4, Pt4> md(cube, p, shift<4>(Vec<4>::Zero()));
    const auto r = cm::gjkDistance(md, settings(6));
    EXPECT_EQ(r.status, cm::GjkStatus::Separated);
    EXPECT_NEAR(r.distance, 2.0, 1e-12);
    expectVecNear<4>(r.point_a, Vec<4>(1, 0.5, 0.2, -0.1), 1e-12);
  }
  {
    // Corner (1,1,1,1) to (2,2,2,2): |(1,1,1,1)| = 2.
    const Pt4 p{Vec<4>::Constant(2)};
    const cm::MinkowskiDifference<4, Box4, Pt4> md(cube, p, shift<4>(Vec<4>::Zero()));
    const auto r = cm::gjkDistance(md, settings(6));
    EXPECT_NEAR(r.distance, 2.0, 1e-12);
    expectVecNear<4>(r.point_a, Vec<4>::Ones(), 1e-12);
  }
}

TEST(GjkHighD, HypercubesAndHypersphere4D) {
  using Box4 = cm::BoxShape<4>;
  const Box4 a{Vec<4>::Ones()};
  const Box4 b{Vec<4>::Constant(0.5)};
  // Gaps 1.5 in x and y: 1.5 sqrt2.
  const cm::MinkowskiDifference<4, Box4, Box4> apart(a, b, shift<4>(Vec<4>(3, 3, 0, 0)));
  EXPECT_NEAR(cm::gjkDistance(apart, settings(7)).distance, 1.5 * std::sqrt(2.0), 1e-12);
  EXPECT_FALSE(cm::gjkIntersect(apart, 0.0, settings(7)));
  EXPECT_TRUE(cm::gjkIntersect(apart, 2.2, settings(7)));  // margin > 2.1213
  // Overlapping hypercubes: the 5-vertex simplex must enclose the origin.
  const cm::MinkowskiDifference<4, Box4, Box4> overlap(a, b, shift<4>(Vec<4>(1, 0.5, 0, -0.2)));
  EXPECT_TRUE(cm::gjkIntersect(overlap, 0.0, settings(4)));
  EXPECT_EQ(cm::gjkDistance(overlap, settings(4)).status, cm::GjkStatus::Intersecting);
  // Unit hypersphere to the point (3, 4, 0, 0): 5 - 1; foot (0.6, 0.8, 0, 0).
  const cm::EllipsoidShape<4> ball{Vec<4>::Ones()};
  const cm::PointShape<4> p{Vec<4>(3, 4, 0, 0)};
  const cm::MinkowskiDifference<4, cm::EllipsoidShape<4>, cm::PointShape<4>> md(
      ball, p, shift<4>(Vec<4>::Zero()));
  const auto r = cm::gjkDistance(md, settings(6));
  EXPECT_NEAR(r.distance, 4.0, 1e-10);
  expectVecNear<4>(r.point_a, Vec<4>(0.6, 0.8, 0, 0), 1e-5);
}

TEST(GjkHighD, HypercubeToPoint5D) {
  using Box5 = cm::BoxShape<5>;
  const Box5 cube{Vec<5>::Ones()};
  const cm::PointShape<5> p{Vec<5>::Constant(2)};
  const cm::MinkowskiDifference<5, Box5, cm::PointShape<5>> md(cube, p, shift<5>(Vec<5>::Zero()));
  const auto r = cm::gjkDistance(md, settings(7));
  EXPECT_NEAR(r.distance, std::sqrt(5.0), 1e-12);
  expectVecNear<5>(r.point_a, Vec<5>::Ones(), 1e-12);
  // A point inside the 5-cube: intersecting.
  const cm::PointShape<5> q{Vec<5>(0.1, -0.2, 0.3, -0.4, 0.5)};
  const cm::MinkowskiDifference<5, Box5, cm::PointShape<5>> in(cube, q, shift<5>(Vec<5>::Zero()));
  EXPECT_TRUE(cm::gjkIntersect(in, 0.0, settings(4)));
  EXPECT_EQ(cm::gjkDistance(in, settings(4)).status, cm::GjkStatus::Intersecting);
}

TEST(GjkSeed, SeedKeptNamesTheSeedVerticesOfTheTerminalSimplex) {
  // Box [-1, 1]^3 minus the point (3, 0.5, 0.2): the distance is 2 along x, realised by the
  // face x = 1 of the difference (w = box vertex - point). Seeds are points of A - B.
  const CubeMinusPoint pair(cm::Vec3(3, 0.5, 0.2));
  const auto& md = pair.md;
  const auto corner = [&](double y, double z) { return pair.at(cm::Vec3(1, y, z)); };
  cm::Simplex<3> seed;
  // The face's triangle (the origin projects into it) plus a vertex on the far side: GJK keeps
  // vertices 1, 2, 3, certifies with one support point and adds none.
  seed.size = 4;
  seed.v[0] = pair.at(cm::Vec3(-1, -1, -1));
  seed.v[1] = corner(1, 1);
  seed.v[2] = corner(-1, 1);
  seed.v[3] = corner(0, -1);
  const auto r = cm::gjkDistance(md, settings(5), &seed);
  EXPECT_EQ(r.status, cm::GjkStatus::Separated);
  EXPECT_NEAR(r.distance, 2.0, 1e-12);
  EXPECT_EQ(r.iterations, 1);
  EXPECT_EQ(r.seed_kept, 0b1110u);
  ASSERT_EQ(r.simplex.size, 3);
  for (int k = 0; k < 3; ++k)
    EXPECT_EQ(r.simplex.v[k].w, seed.v[k + 1].w) << "k = " << k;

  // A seed segment on the face's edge y = -1 is not the closest feature: GJK adds support points.
  cm::Simplex<3> edge;
  edge.size = 2;
  edge.v[0] = corner(-1, -1);
  edge.v[1] = corner(-1, 1);
  const auto grown = cm::gjkDistance(md, settings(5), &edge);
  EXPECT_NEAR(grown.distance, 2.0, 1e-12);
  EXPECT_GE(grown.iterations, 2);
  EXPECT_EQ(grown.seed_kept, 0u);

  // No seed: nothing to name.
  EXPECT_EQ(cm::gjkDistance(md, settings(5)).seed_kept, 0u);
}

TEST(GjkSeed, SegmentSeedWhoseNearEndIsClosestKeepsThatEnd) {
  // Box [-1, 1]^3 minus the point (3, 0.5, 0.2): A - B = [-4, -2] x [-1.5, 0.5] x [-1.2, 0.8],
  // closest point w = (-2, 0, 0), distance 2. A seed segment along x from that point, w0 =
  // (-2, 0, 0) (a = (1, 0.5, 0.2) on the box), to w1 = (-4, 0, 0) (a = (-1, 0.5, 0.2)): with
  // t = w1 - w0 = (-2, 0, 0) the origin projects before w0 (w1.t = 8 > 0, -w0.t = -4 < 0), so
  // the seed's closest point is w0 alone. The support along -w0 = (2, 0, 0) is a corner of the
  // face x = 1, w = (-2, 0.5, 0.8), with v.w = 4 = |v|^2: certified at once, seed vertex 0 kept.
  const CubeMinusPoint pair(cm::Vec3(3, 0.5, 0.2));
  cm::Simplex<3> seed;
  seed.size = 2;
  seed.v[0] = pair.at(cm::Vec3(1, 0.5, 0.2));
  seed.v[1] = pair.at(cm::Vec3(-1, 0.5, 0.2));
  const auto r = cm::gjkDistance(pair.md, settings(5), &seed);
  EXPECT_EQ(r.status, cm::GjkStatus::Separated);
  EXPECT_EQ(r.distance, 2.0);
  EXPECT_EQ(r.iterations, 1);
  EXPECT_EQ(r.seed_kept, 0b01u);
  ASSERT_EQ(r.simplex.size, 1);
  EXPECT_EQ(r.simplex.v[0].w, cm::Vec3(-2, 0, 0));
}

TEST(GjkSeed, TetrahedronSeedWithTheOriginBeyondItsFirstFaceIsNotAnIntersection) {
  // Box [-1, 1]^3 minus the point (3, 0, 0): A - B = [-4, -2] x [-1, 1]^2, distance 2 along x,
  // closest point w = (-2, 0, 0) (witnesses (1, 0, 0) on the box, the point itself on B). A seed
  // tetrahedron of points of A - B whose face 0-1-2 lies in the face x = -2 and whose vertex 3 is
  // on the far face x = -4: the origin is (2/3) (w0 + w1 + w2) - w3 (weights 2/3, 2/3, 2/3, -1),
  // beyond the face 0-1-2 only. That face is the one the loop's lean sub-algorithm leaves out
  // (it holds no newest vertex), so the seed's closest point must come from the full one.
  const CubeMinusPoint pair(cm::Vec3(3, 0, 0));
  const auto& md = pair.md;
  cm::Simplex<3> seed;
  seed.size = 4;
  seed.v[0] = pair.at(cm::Vec3(1, -1, -1));
  seed.v[1] = pair.at(cm::Vec3(1, 1, -1));
  seed.v[2] = pair.at(cm::Vec3(1, -1, 1));
  seed.v[3] = pair.at(cm::Vec3(-1, -2.0 / 3.0, -2.0 / 3.0));
  const auto r = cm::gjkDistance(md, settings(5), &seed);
  EXPECT_EQ(r.status, cm::GjkStatus::Separated);
  EXPECT_NEAR(r.distance, 2.0, 1e-12);
  expectVecNear<3>(r.v, cm::Vec3(-2, 0, 0), 1e-12);
  EXPECT_NEAR(r.point_a.x(), 1.0, 1e-12);
  expectVecNear<3>(r.point_b, cm::Vec3(3, 0, 0), 1e-12);
  // gjkIntersect from the same seed: 2 apart, not within a margin of 1.9.
  cm::Simplex<3> s = seed;
  EXPECT_FALSE(cm::gjkIntersect(md, 1.9, settings(5), &s));
  s = seed;
  EXPECT_TRUE(cm::gjkIntersect(md, 2.1, settings(5), &s));
}

// ---------------------------------------------------------------------------------------------
// Simplex sub-algorithms
// ---------------------------------------------------------------------------------------------

namespace {

/// Both sub-algorithms on `pts`: closest point and number of kept vertices must match `want`.
void expectClosest(const std::vector<cm::Vec3>& pts, const cm::Vec3& want, int want_size) {
  for (const bool generic : {false, true}) {
    cm::Simplex<3> s = simplexOf<3>(pts);
    const cm::Vec3 v = cm::solveSimplex<3>(s, generic);
    expectVecNear<3>(v, want, 1e-14);
    EXPECT_EQ(s.size, want_size) << (generic ? "generic" : "signed volumes");
    expectVecNear<3>(s.closest(), want, 1e-14);
  }
}

}  // namespace

TEST(SimplexSolver, ExactCases) {
  const double third = 1.0 / 3.0;
  expectClosest({cm::Vec3(1, 0, 0), cm::Vec3(0, 1, 0), cm::Vec3(0, 0, 1)},
                cm::Vec3(third, third, third), 3);
  // Regular tetrahedron around the origin.
  expectClosest({cm::Vec3(1, 1, 1), cm::Vec3(-1, -1, 1), cm::Vec3(-1, 1, -1), cm::Vec3(1, -1, -1)},
                cm::Vec3::Zero(), 4);
  // Segment whose line passes the origin beyond its end: the nearer end.
  expectClosest({cm::Vec3(2, 0, 0), cm::Vec3(1, 0, 0)}, cm::Vec3(1, 0, 0), 1);
  // Tetrahedron with the origin below its face z = 1 ... (0,0,1) inside that face.
  expectClosest({cm::Vec3(-1, -1, 1), cm::Vec3(1, -1, 1), cm::Vec3(0, 1, 1), cm::Vec3(0, 0, 3)},
                cm::Vec3(0, 0, 1), 3);
}

TEST(SimplexSolver, DegenerateSimplicesNeverNaN) {
  // Regression: a flat tetrahedron (all in z = 1) has volume 0; the closest point is found on a
  // face, (0, 0, 1) inside the triangle (-1,-1,1), (1,-1,1), (0,1,1).
  expectClosest({cm::Vec3(-1, -1, 1), cm::Vec3(1, -1, 1), cm::Vec3(0, 1, 1), cm::Vec3(0, 0.5, 1)},
                cm::Vec3(0, 0, 1), 3);
  // Collinear triangle: the middle of the line x = 1.
  expectClosest({cm::Vec3(1, -1, 0), cm::Vec3(1, 0.5, 0), cm::Vec3(1, 1, 0)}, cm::Vec3(1, 0, 0), 2);
  // All vertices equal.
  expectClosest({cm::Vec3(1, 2, 3), cm::Vec3(1, 2, 3), cm::Vec3(1, 2, 3), cm::Vec3(1, 2, 3)},
                cm::Vec3(1, 2, 3), 1);
  // Duplicate pair in a triangle.
  expectClosest({cm::Vec3(1, 0, 0), cm::Vec3(1, 0, 0), cm::Vec3(0, 1, 0)}, cm::Vec3(0.5, 0.5, 0),
                2);
}

TEST(SimplexSolver, RandomSimplicesAreOptimal) {
  // v is the closest point of conv(w_i) iff v is in the hull and v.w_i >= |v|^2 for all i (the
  // hull lies beyond the plane through v normal to v). Checked for both sub-algorithms on random
  // triangles and tetrahedra (fixed seed), including ones enclosing the origin.
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int enclosing = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const int n = 3 + trial % 2;
    std::vector<cm::Vec3> pts;
    const cm::Vec3 offset = (trial % 3 == 0) ? cm::Vec3::Zero() : cm::Vec3(u(rng), u(rng), u(rng));
    for (int i = 0; i < n; ++i)
      pts.push_back(cm::Vec3(u(rng), u(rng), u(rng)) + offset);
    cm::Vec3 v_sv;
    for (const bool generic : {false, true}) {
      cm::Simplex<3> s = simplexOf<3>(pts);
      const cm::Vec3 v = cm::solveSimplex<3>(s, generic);
      double sum = 0.0;
      cm::Vec3 combo = cm::Vec3::Zero();  // v in the hull: the weights' combination of the kept
      for (int i = 0; i < s.size; ++i) {
        EXPECT_GT(s.bary[i], 0.0);
        sum += s.bary[i];
        combo += s.bary[i] * s.v[i].w;
      }
      EXPECT_NEAR(sum, 1.0, 1e-12);
      expectVecNear<3>(v, combo, 1e-12);
      for (const cm::Vec3& w : pts)
        EXPECT_GE(v.dot(w) - v.squaredNorm(), -1e-12);
      if (!generic) {
        v_sv = v;
        enclosing += s.size == 4;
      } else {
        expectVecNear<3>(v, v_sv, 1e-12);
      }
    }
  }
  // The sample must be meaningful: some tetrahedra enclose the origin, most do not.
  EXPECT_GT(enclosing, 20);
  EXPECT_LT(enclosing, 900);
}
