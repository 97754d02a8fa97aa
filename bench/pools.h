/// \file
/// Benchmark pools: fixed-seed shape pairs that every library is fed with (the same hull
/// vertices, the same primitive sizes, the same poses), so the only difference between two
/// benchmark rows is the library.
///
/// A pool holds kPairs pairs. Shape A is fixed at its pose; shape B moves along a short
/// trajectory of kSteps poses, each 1 mm and 1 degree from the previous one (translation along a
/// random unit direction, rotation about a random unit axis through B's origin). A benchmark walks
/// the pool pair by pair and, after each full pass, advances every pair one step along its
/// trajectory (back and forth), so consecutive queries on one pair always differ by exactly
/// 1 mm / 1 degree: that is the motion a warm start (PairCache) sees. Cold benchmarks walk the
/// same sequence without a cache.
///
/// Units: metres and radians. All poses map shape frame -> world.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/core/math.h"
#include "collision_monitor/core/shapes.h"

namespace cm_bench {

namespace core = collision_monitor::core;
using core::Transform3;
using core::Vec3;

/// What a shape is, in the terms every library understands.
enum class Kind { Hull, Box, Sphere, Capsule, Cylinder, Cone };
const char* toString(Kind k);

/// One shape, described once and built for every library from this description.
struct ShapeSpec {
  Kind kind = Kind::Hull;
  /// Hull: the polytope from core::buildConvexHull (its vertices are what every library gets).
  std::shared_ptr<const core::Polytope<3>> hull;
  /// Hull: outward triangles (core::hullTriangles), for FCL's Convex faces.
  std::vector<std::array<int, 3>> triangles;
  Vec3 box_sides = Vec3::Zero();  ///< Box: full side lengths, m
  double radius = 0.0;            ///< Sphere / Capsule / Cylinder / Cone radius, m
  double length = 0.0;            ///< Capsule segment length, Cylinder / Cone height (z), m
  Vec3 centroid = Vec3::Zero();   ///< an interior point (shape frame), for MPR's centre
  double bounding_radius = 0.0;   ///< ball about the shape origin containing the shape, m
  /// Our runtime shape built from the same description.
  std::shared_ptr<const core::ConvexShape> ours;
};

/// A pool of pairs for one benchmark case ("hull12", "box_box", ...).
struct Pool {
  static constexpr int kPairs = 1000;  ///< pairs per pool
  static constexpr int kSteps = 8;     ///< trajectory poses per pair (walked back and forth)
  static constexpr double kStepTranslation = 1e-3;                         ///< m per step
  static constexpr double kStepRotation = 3.14159265358979323846 / 180.0;  ///< rad per step

  std::string name;
  Kind kind_a = Kind::Hull;
  Kind kind_b = Kind::Hull;
  std::vector<ShapeSpec> shapes;   ///< distinct shapes, shared by the pairs
  std::vector<int> shape_a;        ///< per pair: index into shapes
  std::vector<int> shape_b;        ///< per pair: index into shapes
  std::vector<Transform3> pose_a;  ///< per pair
  std::vector<Transform3> pose_b;  ///< per pair and step: pose_b[pair * kSteps + step]
  /// Mean hull vertex count (hull pools), for the report.
  double mean_vertices = 0.0;

  int size() const { return static_cast<int>(shape_a.size()); }
  const ShapeSpec& a(int pair) const { return shapes[shape_a[pair]]; }
  const ShapeSpec& b(int pair) const { return shapes[shape_b[pair]]; }
  const Transform3& poseA(int pair) const { return pose_a[pair]; }
  const Transform3& poseB(int pair, int step) const { return pose_b[pair * kSteps + step]; }
};

/// Walks a pool: pair 0..N-1, then every pair one trajectory step further (0,1,..,K-1,K-2,..,1,
/// 0,...). Cheap enough (an increment and a compare) to sit inside a timed loop.
struct Cursor {
  int pair = 0;
  int phase = 0;
  int n = Pool::kPairs;
  explicit Cursor(int pairs) : n(pairs) {}
  int step() const { return phase < Pool::kSteps ? phase : 2 * Pool::kSteps - 2 - phase; }
  void next() {
    if (++pair == n) {
      pair = 0;
      if (++phase == 2 * Pool::kSteps - 2) phase = 0;
    }
  }
};

/// Hull pool: pairs of random convex hulls of `vertices` points each (points on the surface of
/// random ellipsoids, so every point is a hull vertex; hulled by core::buildConvexHull).
/// About 45 % of the pairs overlap at step 0 (chosen with libccd GJK as the referee, see .cpp).
Pool makeHullPool(int vertices, unsigned seed);
/// Primitive pools: "box_box", "capsule_capsule", "sphere_box", "cylinder_cone".
Pool makePrimitivePool(const std::string& name, unsigned seed);

/// The pool names benchmarked, in report order.
std::vector<std::string> poolNames();
/// Builds the pool of that name (fixed seed per name).
Pool makePool(const std::string& name);

}  // namespace cm_bench
