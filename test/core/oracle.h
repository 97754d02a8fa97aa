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
