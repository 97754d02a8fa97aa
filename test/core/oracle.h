/// \file
/// Independent exact oracle for the geometry-core tests. Shares nothing with the GJK/EPA code:
/// closest points by the textbook routines of Ericson, "Real-Time Collision Detection" (2005),
/// section 5.1 (point-segment 5.1.2, point-triangle 5.1.5, segment-segment 5.1.9), and polytope
/// hulls by a direct qhull call.
///
/// Polytope pairs (cores that are points, segments or vertex sets, plus radii): the Minkowski
/// difference D = A - B of the world-frame core vertices is hulled by qhull. With the origin
/// inside D the penetration depth is the smallest distance from the origin to a facet plane
/// (exact for polytopes), the normal that facet's outward normal. With the origin outside, the
/// distance is the smallest origin-triangle distance over the triangulated hull. The full
/// shapes' signed distance is the cores' one minus both radii (exact for convex cores, also
/// when they overlap: the Minkowski difference of inflated shapes is D inflated by the radii).
///
/// Spheres and capsules whose cores are lower dimensional (point-point, point-segment,
/// segment-segment) use the closest-point routines directly.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

namespace oracle {

using V3 = Eigen::Vector3d;

inline double clamp01(double t) {
  return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
}

/// Closest point to p on segment ab (Ericson 5.1.2).
inline V3 closestPointSegment(const V3& p, const V3& a, const V3& b) {
  const V3 ab = b - a;
  const double den = ab.dot(ab);
  if (!(den > 0.0)) return a;
  return a + clamp01((p - a).dot(ab) / den) * ab;
}

/// Closest point to p on triangle abc (Ericson 5.1.5, Voronoi regions of the vertices, edges
/// and face).
inline V3 closestPointTriangle(const V3& p, const V3& a, const V3& b, const V3& c) {
  const V3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;  // vertex region A
  const V3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;  // vertex region B
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + (d1 / (d1 - d3)) * ab;  // edge AB
  const V3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;  // vertex region C
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + (d2 / (d2 - d6)) * ac;  // edge AC
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {  // edge BC
    return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  }
  const double denom = 1.0 / (va + vb + vc);  // face region
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// Closest points c1 on p1q1 and c2 on p2q2 (Ericson 5.1.9). Returns |c1 - c2|.
inline double closestSegmentSegment(const V3& p1, const V3& q1, const V3& p2, const V3& q2, V3* c1,
                                    V3* c2) {
  const V3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const double a = d1.dot(d1), e = d2.dot(d2), f = d2.dot(r);
  double s = 0.0, t = 0.0;
  if (a <= 0.0 && e <= 0.0) {
    s = t = 0.0;
  } else if (a <= 0.0) {
    s = 0.0;
    t = clamp01(f / e);
  } else {
    const double c = d1.dot(r);
    if (e <= 0.0) {
      t = 0.0;
      s = clamp01(-c / a);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > 0.0 ? clamp01((b * f - c * e) / denom) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = clamp01(-c / a);
      } else if (t > 1.0) {
        t = 1.0;
        s = clamp01((b - c) / a);
      }
    }
  }
  *c1 = p1 + d1 * s;
  *c2 = p2 + d2 * t;
  return (*c1 - *c2).norm();
}

/// A full-dimensional hull: triangles for distances from outside, facet planes for depths.
struct Hull {
  std::vector<V3> points;
  std::vector<std::array<int, 3>> triangles;
  std::vector<V3> normals;      ///< unit outward facet normals
  std::vector<double> offsets;  ///< plane: normal . x + offset = 0, interior negative
};

/// Hull of `pts` with qhull ("Qt": triangulated). Throws std::runtime_error if qhull fails
/// (flat input: the tests never feed it any).
inline Hull makeHull(const std::vector<V3>& pts) {
  Hull h;
  h.points = pts;
  std::vector<coordT> coords(3 * pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    for (int k = 0; k < 3; ++k)
      coords[3 * i + k] = pts[i][k];
  }
  char* text = nullptr;
  std::size_t size = 0;
  FILE* err = open_memstream(&text, &size);
  qhT qh_storage;
  qhT* qh = &qh_storage;
  qh_zero(qh, err);
  char cmd[] = "qhull Qt";
  const int code =
      qh_new_qhull(qh, 3, static_cast<int>(pts.size()), coords.data(), False, cmd, nullptr, err);
  if (code == 0) {
    facetT* facet;
    FORALLfacets {
      std::array<int, 3> t{};
      int k = 0;
      vertexT *vertex, **vertexp;
      FOREACHvertex_(facet->vertices) {
        if (k < 3) t[k] = qh_pointid(qh, vertex->point);
        ++k;
      }
      h.normals.emplace_back(facet->normal[0], facet->normal[1], facet->normal[2]);
      h.offsets.push_back(facet->offset);
      if (k == 3) h.triangles.push_back(t);
    }
  }
  qh_freeqhull(qh, !qh_ALL);
  int curlong = 0, totlong = 0;
  qh_memfreeshort(qh, &curlong, &totlong);
  std::fclose(err);
  const std::string msg = text != nullptr ? std::string(text, size) : std::string();
  std::free(text);
  if (code != 0 || h.triangles.empty()) throw std::runtime_error("oracle qhull failed: " + msg);
  return h;
}

/// Signed distance of x to the hull: > 0 outside (exact, nearest triangle), < 0 inside (exact,
/// nearest facet plane). `outward` (if given) is the unit direction in which moving x increases
/// the distance fastest (away from the nearest point / the nearest facet's normal).
inline double signedDistance(const Hull& h, const V3& x, V3* outward = nullptr) {
  double worst = -std::numeric_limits<double>::infinity();
  std::size_t worst_i = 0;
  for (std::size_t i = 0; i < h.normals.size(); ++i) {
    const double s = h.normals[i].dot(x) + h.offsets[i];
    if (s > worst) worst = s, worst_i = i;
  }
  if (worst <= 0.0) {
    if (outward != nullptr) *outward = h.normals[worst_i];
    return worst;  // max over planes of the (negative) plane distance = -depth
  }
  double best = std::numeric_limits<double>::infinity();
  V3 best_q = x;
  for (const auto& t : h.triangles) {
    const V3 q = closestPointTriangle(x, h.points[t[0]], h.points[t[1]], h.points[t[2]]);
    const double d = (x - q).norm();
    if (d < best) best = d, best_q = q;
  }
  if (outward != nullptr) {
    *outward = best > 0.0 ? V3((x - best_q) / best) : V3(h.normals[worst_i]);
  }
  return best;
}

/// A convex shape as the oracle sees it: world-frame core vertices and a radius.
///   Point:   one vertex (sphere core),
///   Segment: two vertices (capsule core),
///   Poly:    the generating points of a full-dimensional polytope (box corners, raw hull input).
struct Shape {
  enum Kind { Point, Segment, Poly };
  Kind kind = Point;
  std::vector<V3> core;  ///< world frame
  double radius = 0.0;
  Hull hull;  ///< Poly only: hull of `core` (for witness checks)

  void finish() {
    if (kind == Poly) hull = makeHull(core);
  }
  /// Support value max over the full shape of n . x, for unit n.
  double supportValue(const V3& n) const {
    double m = -std::numeric_limits<double>::infinity();
    for (const V3& v : core)
      m = std::max(m, n.dot(v));
    return m + radius;
  }
  /// Signed distance of the point x to the full shape (core inflated by radius).
  double signedDistanceTo(const V3& x) const {
    switch (kind) {
      case Point:
        return (x - core[0]).norm() - radius;
      case Segment:
        return (x - closestPointSegment(x, core[0], core[1])).norm() - radius;
      case Poly:
        return signedDistance(hull, x) - radius;
    }
    return std::numeric_limits<double>::quiet_NaN();
  }
};

/// Exact answer for a pair.
struct Answer {
  double distance = 0.0;    ///< signed: > 0 apart, < 0 overlap (-depth)
  V3 normal = V3::UnitX();  ///< unit, from A towards B
};

/// Exact signed distance and normal of the full shapes A and B.
inline Answer solve(const Shape& a, const Shape& b) {
  Answer ans;
  const double r = a.radius + b.radius;
  if (a.kind != Shape::Poly && b.kind != Shape::Poly) {
    V3 ca, cb;
    const V3& p1 = a.core[0];
    const V3& q1 = a.kind == Shape::Segment ? a.core[1] : a.core[0];
    const V3& p2 = b.core[0];
    const V3& q2 = b.kind == Shape::Segment ? b.core[1] : b.core[0];
    const double d = closestSegmentSegment(p1, q1, p2, q2, &ca, &cb);
    ans.distance = d - r;
    if (d > 0.0) ans.normal = (cb - ca) / d;
    return ans;
  }
  std::vector<V3> diff;
  diff.reserve(a.core.size() * b.core.size());
  for (const V3& va : a.core) {
    for (const V3& vb : b.core)
      diff.push_back(va - vb);
  }
  const Hull h = makeHull(diff);
  V3 out;
  // Outward from D at the origin: moving B along it (D shifts by -t) separates, i.e. A -> B.
  ans.distance = signedDistance(h, V3::Zero(), &out) - r;
  ans.normal = out;
  return ans;
}

}  // namespace oracle

// ---------------------------------------------------------------------------------------------
// Random pairs for the sweeps: each pair is a pure function of (category, index), so any failure
// is reproduced by oracle::makePair(category, index).
// ---------------------------------------------------------------------------------------------
#include <cstdint>
#include <optional>
#include <random>

#include "collision_monitor/core/convex_shape.h"

namespace oracle {

namespace cmc = collision_monitor::core;

/// Shape-pair categories of the sweeps. "Poly" means a box or a random hull (coin flip).
enum class Category {
  BoxBox,
  HullHull,
  BoxHull,
  SphereSphere,
  CapsuleCapsule,
  SphereCapsule,
  SpherePoly,
  CapsulePoly,
  PaddedPoly,  ///< padded box/hull vs padded box/hull
  Count
};

inline const char* name(Category c) {
  switch (c) {
    case Category::BoxBox:
      return "box-box";
    case Category::HullHull:
      return "hull-hull";
    case Category::BoxHull:
      return "box-hull";
    case Category::SphereSphere:
      return "sphere-sphere";
    case Category::CapsuleCapsule:
      return "capsule-capsule";
    case Category::SphereCapsule:
      return "sphere-capsule";
    case Category::SpherePoly:
      return "sphere-poly";
    case Category::CapsulePoly:
      return "capsule-poly";
    case Category::PaddedPoly:
      return "padded-poly";
    case Category::Count:
      break;
  }
  return "?";
}

/// One body: the shape under test, its pose, and the oracle's view of it.
struct Body {
  std::optional<cmc::ConvexShape> shape;
  std::vector<V3> local_core;  ///< core vertices in the shape frame
  Shape::Kind kind = Shape::Poly;
  double radius = 0.0;        ///< sphere/capsule radius + padding, m
  double circumradius = 0.0;  ///< max |x| over the full shape, shape frame, m
  cmc::Transform3 pose;
  Shape world;  ///< oracle shape (world frame), filled by place()

  /// Support value of the full shape about its frame origin along world direction n.
  double reach(const V3& n) const {
    double m = -std::numeric_limits<double>::infinity();
    for (const V3& v : local_core)
      m = std::max(m, n.dot(pose.R * v));
    return m + radius;
  }
  void place() {
    world.kind = kind;
    world.radius = radius;
    world.core.clear();
    for (const V3& v : local_core)
      world.core.push_back(pose * v);
    world.finish();
  }
};

struct Pair {
  Category category = Category::BoxBox;
  std::uint64_t index = 0;
  Body a, b;
  double size = 0.0;  ///< a.circumradius + b.circumradius, m
  double far = 0.0;   ///< |translation of A| (0 or ~1e3 m)
};

enum class Kind { Box, Hull, Sphere, Capsule };

inline V3 randomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  for (;;) {
    const V3 v(g(rng), g(rng), g(rng));
    const double n = v.norm();
    if (n > 1e-6) return v / n;
  }
}

inline Body makeBody(Kind kind, bool padded, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto uni = [&](double lo, double hi) { return lo + (hi - lo) * u01(rng); };
  const double s = std::pow(10.0, uni(-3.0, 1.0));  // 1 mm .. 10 m
  Body body;
  switch (kind) {
    case Kind::Box: {
      const V3 half(s * uni(0.1, 1.0), s * uni(0.1, 1.0), s * uni(0.1, 1.0));
      body.shape = cmc::ConvexShape::box(2.0 * half);
      for (int i = 0; i < 8; ++i) {
        body.local_core.emplace_back((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(),
                                     (i & 4) ? half.z() : -half.z());
      }
      body.kind = Shape::Poly;
      break;
    }
    case Kind::Hull: {
      const int n = 4 + static_cast<int>(u01(rng) * 17);  // 4 .. 20 points
      const V3 stretch(uni(0.2, 1.0), uni(0.2, 1.0), uni(0.2, 1.0));
      const V3 shift = s * V3(uni(-0.3, 0.3), uni(-0.3, 0.3), uni(-0.3, 0.3));  // off-centre
      for (int i = 0; i < n; ++i) {
        const V3 p = randomUnit(rng) * std::cbrt(uni(0.05, 1.0));
        body.local_core.push_back(shift + s * p.cwiseProduct(stretch));
      }
      body.shape = cmc::ConvexShape::convexHull(body.local_core);
      body.kind = Shape::Poly;
      break;
    }
    case Kind::Sphere:
      body.shape = cmc::ConvexShape::sphere(s);
      body.local_core = {V3::Zero()};
      body.radius = s;
      body.kind = Shape::Point;
      break;
    case Kind::Capsule: {
      const double len = s * uni(0.2, 3.0), r = s * uni(0.1, 1.0);
      body.shape = cmc::ConvexShape::capsule(len, r);
      body.local_core = {V3(0, 0, -0.5 * len), V3(0, 0, 0.5 * len)};
      body.radius = r;
      body.kind = Shape::Segment;
      break;
    }
  }
  if (padded) {
    const double pad = s * uni(0.01, 0.5);
    body.shape = body.shape->padded(pad);
    body.radius += pad;
  }
  double cr = 0.0;
  for (const V3& v : body.local_core)
    cr = std::max(cr, v.norm());
  body.circumradius = cr + body.radius;
  return body;
}

inline cmc::Transform3 randomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return cmc::makeTransform(q, V3::Zero());
}

inline std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

/// The pair number `index` of `category` (fixed seeds: the sweep is the same on every run).
/// B is placed along a random direction u at f * (reach_A(u) + reach_B(-u)) from A: f >= 1 is
/// apart (a separating plane exists), f < 1 mostly overlapping; 10 % of the pairs are then slid
/// to near contact; 20 % sit 0.5 .. 1 km from the origin.
inline Pair makePair(Category category, std::uint64_t index) {
  std::mt19937_64 rng(splitmix64(0xC0111DE5ull * (static_cast<std::uint64_t>(category) + 1)) ^
                      splitmix64(index));
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  Pair p;
  p.category = category;
  p.index = index;
  auto poly = [&]() { return u01(rng) < 0.5 ? Kind::Box : Kind::Hull; };
  Kind ka = Kind::Box, kb = Kind::Box;
  bool padded = false;
  switch (category) {
    case Category::BoxBox:
      break;
    case Category::HullHull:
      ka = kb = Kind::Hull;
      break;
    case Category::BoxHull:
      kb = Kind::Hull;
      break;
    case Category::SphereSphere:
      ka = kb = Kind::Sphere;
      break;
    case Category::CapsuleCapsule:
      ka = kb = Kind::Capsule;
      break;
    case Category::SphereCapsule:
      ka = Kind::Sphere;
      kb = Kind::Capsule;
      break;
    case Category::SpherePoly:
      ka = Kind::Sphere;
      kb = poly();
      break;
    case Category::CapsulePoly:
      ka = Kind::Capsule;
      kb = poly();
      break;
    case Category::PaddedPoly:
      ka = poly();
      kb = poly();
      padded = true;
      break;
    case Category::Count:
      break;
  }
  if (u01(rng) < 0.5) std::swap(ka, kb);  // both orders
  p.a = makeBody(ka, padded, rng);
  p.b = makeBody(kb, padded, rng);
  p.a.pose = randomRotation(rng);
  p.b.pose = randomRotation(rng);
  if (u01(rng) < 0.2) {
    p.a.pose.t = 1e3 * randomUnit(rng) * (0.5 + 0.5 * u01(rng));
    p.far = p.a.pose.t.norm();
  }
  const V3 u = randomUnit(rng);
  const double reach = p.a.reach(u) + p.b.reach(-u);
  const bool near_contact = u01(rng) < 0.1;
  const double f = near_contact ? 1.0 : 1.15 * u01(rng);
  p.b.pose.t = p.a.pose.t + f * reach * u;
  p.a.place();
  p.b.place();
  p.size = p.a.circumradius + p.b.circumradius;
  if (near_contact) {
    // Slide B along the exact normal to a signed distance of about +-1e-12 .. 1e-3 of the size
    // (moving closer by delta lowers the distance by at most delta: the oracle has the last word).
    const Answer ans = solve(p.a.world, p.b.world);
    const double target =
        (u01(rng) < 0.5 ? -1.0 : 1.0) * p.size * std::pow(10.0, -3.0 - 9.0 * u01(rng));
    p.b.pose.t += (target - ans.distance) * ans.normal;
    p.b.place();
  }
  return p;
}

}  // namespace oracle
