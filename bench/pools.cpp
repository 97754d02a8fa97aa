#include "pools.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>

#include "ccd_adapter.h"
#include "collision_monitor/core/convex_hull.h"

namespace cm_bench {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kShapesPerSide = 64;      ///< distinct shapes for A and for B in every pool
constexpr double kOverlapShare = 0.45;  ///< share of overlapping pairs at step 0

/// Fixed-seed generator with its own uniform mapping, so pools do not depend on the standard
/// library's distribution implementations.
class Rng {
 public:
  explicit Rng(unsigned seed) : gen_(seed) {}
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) {
    const double u = static_cast<double>(gen_() >> 11) * (1.0 / 9007199254740992.0);  // 2^-53
    return lo + (hi - lo) * u;
  }
  /// Uniform on the unit sphere (Archimedes: z uniform, azimuth uniform).
  Vec3 unitVector() {
    const double z = uniform(-1.0, 1.0);
    const double phi = uniform(0.0, 2.0 * kPi);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return Vec3(r * std::cos(phi), r * std::sin(phi), z);
  }
  /// Uniform random rotation (Shoemake 1992, "Uniform random rotations").
  core::Mat3 rotation() {
    const double u1 = uniform(0.0, 1.0), u2 = uniform(0.0, 2.0 * kPi), u3 = uniform(0.0, 2.0 * kPi);
    const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
    const Eigen::Quaterniond q(b * std::cos(u3), a * std::sin(u2), a * std::cos(u2),
                               b * std::sin(u3));
    return q.normalized().toRotationMatrix();
  }

 private:
  std::mt19937_64 gen_;
};

ShapeSpec makeHullSpec(Rng& rng, int vertices) {
  // Points on a random ellipsoid's surface: every point is a hull vertex (an ellipsoid is strictly
  // convex), so the hull has `vertices` vertices unless qhull merges near-coplanar ones.
  const double scale = rng.uniform(0.05, 0.25);
  const Vec3 semi(scale * rng.uniform(0.5, 1.5), scale * rng.uniform(0.5, 1.5),
                  scale * rng.uniform(0.5, 1.5));
  std::vector<Vec3> points;
  points.reserve(vertices);
  for (int i = 0; i < vertices; ++i)
    points.push_back(semi.cwiseProduct(rng.unitVector()));
  ShapeSpec s;
  s.kind = Kind::Hull;
  s.hull = core::buildConvexHull(points);
  s.triangles = core::hullTriangles(*s.hull);
  Vec3 sum = Vec3::Zero();
  for (const Vec3& v : s.hull->vertices()) {
    sum += v;
    s.bounding_radius = std::max(s.bounding_radius, v.norm());
  }
  s.centroid = sum / static_cast<double>(s.hull->size());
  s.ours = std::make_shared<const core::ConvexShape>(core::ConvexShape::polytope(s.hull));
  return s;
}

ShapeSpec makePrimitiveSpec(Rng& rng, Kind kind) {
  ShapeSpec s;
  s.kind = kind;
  switch (kind) {
    case Kind::Box:
      s.box_sides = Vec3(rng.uniform(0.05, 0.4), rng.uniform(0.05, 0.4), rng.uniform(0.05, 0.4));
      s.bounding_radius = 0.5 * s.box_sides.norm();
      s.ours = std::make_shared<const core::ConvexShape>(core::ConvexShape::box(s.box_sides));
      break;
    case Kind::Sphere:
      s.radius = rng.uniform(0.03, 0.2);
      s.bounding_radius = s.radius;
      s.ours = std::make_shared<const core::ConvexShape>(core::ConvexShape::sphere(s.radius));
      break;
    case Kind::Capsule:
      s.length = rng.uniform(0.05, 0.4);
      s.radius = rng.uniform(0.02, 0.12);
      s.bounding_radius = 0.5 * s.length + s.radius;
      s.ours =
          std::make_shared<const core::ConvexShape>(core::ConvexShape::capsule(s.length, s.radius));
      break;
    case Kind::Cylinder:
      s.length = rng.uniform(0.05, 0.4);
      s.radius = rng.uniform(0.03, 0.2);
      s.bounding_radius = std::hypot(0.5 * s.length, s.radius);
      s.ours = std::make_shared<const core::ConvexShape>(
          core::ConvexShape::cylinder(s.length, s.radius));
      break;
    case Kind::Cone:
      s.length = rng.uniform(0.05, 0.4);
      s.radius = rng.uniform(0.03, 0.2);
      s.bounding_radius = std::hypot(0.5 * s.length, s.radius);
      s.ours =
          std::make_shared<const core::ConvexShape>(core::ConvexShape::cone(s.length, s.radius));
      break;
    case Kind::Hull:
      throw std::logic_error("makePrimitiveSpec: hull");
  }
  return s;
}

/// Draws pair poses until the pool holds exactly kOverlapShare overlapping pairs at step 0.
/// The referee for "overlapping" while building is libccd GJK (independent of our core); every
/// library's verdict is checked against the others later, outside the timed loops.
void makePairs(Pool& pool, Rng& rng) {
  const int n = Pool::kPairs;
  const int want_overlap = static_cast<int>(std::lround(kOverlapShare * n));
  int overlap = 0, separate = 0;
  const ccd_t ccd = makeCcd();
  pool.pose_a.reserve(n);
  pool.pose_b.reserve(static_cast<size_t>(n) * Pool::kSteps);
  while (overlap + separate < n) {
    const int ia = static_cast<int>(rng.uniform(0.0, kShapesPerSide));
    const int ib = kShapesPerSide + static_cast<int>(rng.uniform(0.0, kShapesPerSide));
    const ShapeSpec& a = pool.shapes[ia];
    const ShapeSpec& b = pool.shapes[ib];
    Transform3 pa;
    pa.R = rng.rotation();
    pa.t = Vec3(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
    Transform3 pb;
    pb.R = rng.rotation();
    const double d = rng.uniform(0.0, 1.1) * (a.bounding_radius + b.bounding_radius);
    pb.t = pa.t + d * rng.unitVector();
    const bool hit = ccdGjkIntersect(ccd, a, pa, b, pb);
    if (hit ? overlap >= want_overlap : separate >= n - want_overlap) continue;
    (hit ? overlap : separate)++;
    pool.shape_a.push_back(ia);
    pool.shape_b.push_back(ib);
    pool.pose_a.push_back(pa);
    // Trajectory: 1 mm along a random direction and 1 degree about a random axis per step.
    const Vec3 dir = rng.unitVector();
    const Vec3 axis = rng.unitVector();
    for (int k = 0; k < Pool::kSteps; ++k) {
      Transform3 p;
      p.R = Eigen::AngleAxisd(k * Pool::kStepRotation, axis).toRotationMatrix() * pb.R;
      p.t = pb.t + (k * Pool::kStepTranslation) * dir;
      pool.pose_b.push_back(p);
    }
  }
}

}  // namespace

const char* toString(Kind k) {
  switch (k) {
    case Kind::Hull:
      return "hull";
    case Kind::Box:
      return "box";
    case Kind::Sphere:
      return "sphere";
    case Kind::Capsule:
      return "capsule";
    case Kind::Cylinder:
      return "cylinder";
    case Kind::Cone:
      return "cone";
  }
  return "?";
}

Pool makeHullPool(int vertices, unsigned seed) {
  Rng rng(seed);
  Pool pool;
  pool.name = "hull" + std::to_string(vertices);
  pool.kind_a = pool.kind_b = Kind::Hull;
  double total = 0.0;
  for (int i = 0; i < 2 * kShapesPerSide; ++i) {
    pool.shapes.push_back(makeHullSpec(rng, vertices));
    total += pool.shapes.back().hull->size();
  }
  pool.mean_vertices = total / pool.shapes.size();
  makePairs(pool, rng);
  return pool;
}

Pool makePrimitivePool(const std::string& name, unsigned seed) {
  Rng rng(seed);
  Pool pool;
  pool.name = name;
  if (name == "box_box") {
    pool.kind_a = Kind::Box, pool.kind_b = Kind::Box;
  } else if (name == "capsule_capsule") {
    pool.kind_a = Kind::Capsule, pool.kind_b = Kind::Capsule;
  } else if (name == "sphere_box") {
    pool.kind_a = Kind::Sphere, pool.kind_b = Kind::Box;
  } else if (name == "cylinder_cone") {
    pool.kind_a = Kind::Cylinder, pool.kind_b = Kind::Cone;
  } else {
    throw std::invalid_argument("makePrimitivePool: unknown pool '" + name + "'");
  }
  for (int i = 0; i < kShapesPerSide; ++i)
    pool.shapes.push_back(makePrimitiveSpec(rng, pool.kind_a));
  for (int i = 0; i < kShapesPerSide; ++i)
    pool.shapes.push_back(makePrimitiveSpec(rng, pool.kind_b));
  makePairs(pool, rng);
  return pool;
}

std::vector<std::string> poolNames() {
  return {"hull12",  "hull32",          "hull100",    "hull500",
          "box_box", "capsule_capsule", "sphere_box", "cylinder_cone"};
}

Pool makePool(const std::string& name) {
  // One fixed seed per pool name: the pools are identical from run to run and machine to machine.
  if (name.rfind("hull", 0) == 0) {
    const int n = std::stoi(name.substr(4));
    return makeHullPool(n, 1000u + static_cast<unsigned>(n));
  }
  unsigned seed = 7;
  for (char c : name)
    seed = seed * 31u + static_cast<unsigned char>(c);
  return makePrimitivePool(name, seed);
}

}  // namespace cm_bench
