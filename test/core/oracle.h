/// \file
/// Independent exact oracle for the geometry-core tests. Shares nothing with the GJK/EPA code:
/// closest points by the textbook routines of Ericson, "Real-Time Collision Detection" (2005),
/// section 5.1 (point-segment 5.1.2, point-triangle 5.1.5, segment-segment 5.1.9), hulls by a
/// direct qhull call.
///
/// Two exact methods for pairs whose cores are polytopes (points, segments, vertex sets), plus
/// radii; the full shapes' signed distance is the cores' minus both radii (exact for convex cores,
/// also when they overlap: the Minkowski difference of inflated shapes is D = A - B inflated by the
/// radii):
///   - solveMinkowski(): D's points (all vertex differences, world frame) hulled by qhull. Origin
///     inside D: depth = smallest distance from the origin to a facet plane, normal = that
///     facet's normal. Origin outside: distance = smallest origin-triangle distance over the
///     triangulated hull. Exact, but one qhull run per pair (0.1 .. 1 ms).
///   - solve(): the same numbers without building D. D's facet normals are among the face normals
///     of A and B and the cross products of an edge of A with an edge of B, and for any unit n,
///     h_D(n) = h_A(n) + h_B(-n) >= depth with equality at the nearest facet: so the depth is the
///     minimum of h_D over those axes (both signs), and a negative minimum is a separating axis
///     (SAT). When apart, the distance is the smallest vertex-triangle or edge-edge distance
///     between the two hulls (a closest pair of convex polytopes always has such a feature pair).
///     Tens of microseconds per pair; the sweeps cross-check it against solveMinkowski().
///
/// Spheres and capsules whose cores are both lower dimensional (point-point, point-segment,
/// segment-segment) use the closest-point routines directly.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SVD>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

#include "oracle2d.h"

namespace oracle {

using V3 = Eigen::Vector3d;

template <class T>
T clamp01(T t) {
  return t < T(0) ? T(0) : (t > T(1) ? T(1) : t);
}

/// The power of two that brings a largest coordinate magnitude `m` to about 1 (exact to multiply
/// by; at most 2^1000, since 2^1074 would overflow), 1 for m = 0 or not finite.
inline double unitScale(double m) {
  const int e = m > 0.0 && std::isfinite(m) ? std::ilogb(m) : 0;
  return std::ldexp(1.0, std::clamp(-e, -1000, 1000));
}

/// Closest point to p on segment ab (Ericson 5.1.2).
inline V3 closestPointSegment(const V3& p, const V3& a, const V3& b) {
  const V3 ab = b - a;
  const double den = ab.dot(ab);
  if (!(den > 0.0)) return a;
  return a + clamp01((p - a).dot(ab) / den) * ab;
}

/// Distances of a point x (in the solid's frame, its axis z) to curved solids, 0 inside: for the
/// fuzzers' checks that witness points lie on their shapes. A cylinder of radius r, z in
/// [-hh, hh]: exact.
inline double outsideCylinder(const V3& x, double r, double hh) {
  return std::hypot(std::max(0.0, std::hypot(x.x(), x.y()) - r),
                    std::max(0.0, std::abs(x.z()) - hh));
}
/// A cone centred like shape_msgs (base of radius r at z = -hh, apex at z = hh): exact, in the
/// section through its axis (the triangle (0, -hh), (r, -hh), (0, hh) in (rho, z)).
inline double outsideCone(const V3& x, double r, double hh) {
  const double rho = std::hypot(x.x(), x.y());
  if (std::abs(x.z()) <= hh && rho * 2.0 * hh <= r * (hh - x.z())) return 0.0;
  const V3 q(rho, x.z(), 0.0), base(0.0, -hh, 0.0), rim(r, -hh, 0.0), apex(0.0, hh, 0.0);
  return std::min((q - closestPointSegment(q, base, rim)).norm(),
                  (q - closestPointSegment(q, rim, apex)).norm());
}
/// An ellipsoid of semi-axes `semi` (all > 0): a lower bound, (|S^-1 x| - 1) m with m the least
/// semi-axis (S^-1 shrinks lengths by at most 1 / m), computed as |x m S^-1| - m (ratios of at
/// most 1: S^-1 x overflows on semi-axes of 4.9e-324 m).
inline double outsideEllipsoid(const V3& x, const V3& semi) {
  const double m = semi.minCoeff();
  return std::max(0.0, x.cwiseProduct(V3(m / semi.array())).stableNorm() - m);
}

/// Closest point to p on triangle abc: the projection of p onto the plane when it lies inside
/// (signs of the three sub-triangle areas, long double) and is nearer than the nearest point of
/// the three edges (closestPointSegment), else that point. On a triangle flat to rounding (1e-17
/// of its length wide) the weights passed for inside with a point 1.96e-10 m along it from the
/// nearest: fuzz/regressions/core/oracle-near-collinear-triangle-0.1m-out.
/// Not Ericson 5.1.5's dot-product regions: on a needle triangle they difference products of dot
/// products that cancel by up to 12 digits (a point on a 1 m x 3.4e6 m box face came out
/// 0.0029 m away in double and 0.06 m in long double; a point 1.47e-6 m from a 1.02 m x 1.3e-6 m
/// face, 1.4756e-6 m for 1.4734375e-6 m: fuzz/regressions/core/oracle-needle-*). The areas
/// multiply long edges by short ones.
inline V3 closestPointTriangle(const V3& p_, const V3& a_, const V3& b_, const V3& c_) {
  using L = long double;
  using LV = Eigen::Matrix<L, 3, 1>;
  const LV p = p_.cast<L>(), a = a_.cast<L>(), b = b_.cast<L>(), c = c_.cast<L>();
  std::optional<V3> inside;
  const LV n = (b - a).cross(c - a);
  const L nn = n.squaredNorm();
  if (nn > 0) {
    const LV q = p - ((p - a).dot(n) / nn) * n;
    const L u = n.dot((b - q).cross(c - q)), v = n.dot((c - q).cross(a - q)),
            w = n.dot((a - q).cross(b - q));
    // Inside when the three weights are >= 0 and sum to nn, as they do exactly (to 1e-6: they
    // lose digits on needles). A triangle tiny next to its distance from p rounded all three to 0
    // ((b - q) x (c - q) is then q x q): "inside", with q far from the triangle
    // (fuzz/regressions/core/oracle-tiny-triangle-inside).
    // The point returned is the weights' combination of the vertices, on the triangle, not q: on
    // a sliver the rounded normal tilts the plane, and q lies off the triangle by that tilt times
    // its distance from the vertices. A capsule 18.5 m from a 1.4e6 m x 1.5e-6 m sliver got q
    // 0.028 m off it along n, and a distance 0.023 m short
    // (fuzz/regressions/core/oracle-sliver-triangle-projection-off-plane).
    const L sum = u + v + w;
    if (u >= 0 && v >= 0 && w >= 0 && std::abs(sum - nn) <= 1e-6L * nn)
      inside = ((u * a + v * b + w * c) / sum).template cast<double>();
  }
  V3 best = closestPointSegment(p_, a_, b_);
  for (const V3& e : {closestPointSegment(p_, b_, c_), closestPointSegment(p_, c_, a_)})
    if ((e - p_).squaredNorm() < (best - p_).squaredNorm()) best = e;
  // Both candidates are points of the triangle (upper bounds); the nearer one is the answer.
  if (inside && (*inside - p_).squaredNorm() < (best - p_).squaredNorm()) best = *inside;
  return best;
}

/// Closest points c1 on p1q1 and c2 on p2q2 (Ericson 5.1.9). Returns |c1 - c2|. In long double
/// (x86: 64-bit mantissa): the denominator a e - b^2 = a e sin^2 of the segments' angle keeps
/// eps / sin^2 of itself, and in double two 16.9 m edges 1.7e-8 rad apart (sin^2 = 3e-16) got a
/// parameter 35 % off and a distance of 8.3e-8 m for 4.5e-10 m
/// (fuzz/regressions/core/oracle-nearly-parallel-plate-edges).
inline double closestSegmentSegment(const V3& p1_in, const V3& q1_in, const V3& p2_in,
                                    const V3& q2_in, V3* c1, V3* c2) {
  using L = long double;
  using L3 = Eigen::Matrix<L, 3, 1>;
  // Scaled by a power of two (exact) to coordinates of about 1: squared lengths underflow below
  // about 1e-162 m (a point 7.1e-198 m from a radius-0 sphere was "0 m" apart, and a 3.1e-212 m
  // segment through a point was a point 3.1e-212 m away:
  // fuzz/regressions/core/oracle-point-7e-198-from-point-underflow).
  const double m = std::max({p1_in.cwiseAbs().maxCoeff(), q1_in.cwiseAbs().maxCoeff(),
                             p2_in.cwiseAbs().maxCoeff(), q2_in.cwiseAbs().maxCoeff()});
  const double k = unitScale(m);
  const L3 p1 = (p1_in * k).cast<L>(), q1 = (q1_in * k).cast<L>(), p2 = (p2_in * k).cast<L>(),
           q2 = (q2_in * k).cast<L>();
  const L3 d1 = q1 - p1, d2 = q2 - p2, r = p1 - p2;
  const L a = d1.dot(d1), e2 = d2.dot(d2), f = d2.dot(r);
  L s = 0, t = 0;
  if (a <= 0 && e2 <= 0) {
    s = t = 0;
  } else if (a <= 0) {
    s = 0;
    t = clamp01(f / e2);
  } else {
    const L c = d1.dot(r);
    if (e2 <= 0) {
      t = 0;
      s = clamp01(-c / a);
    } else {
      const L b = d1.dot(d2), denom = a * e2 - b * b;
      s = denom > 0 ? clamp01((b * f - c * e2) / denom) : L(0);
      t = (b * s + f) / e2;
      if (t < 0) {
        t = 0;
        s = clamp01(-c / a);
      } else if (t > 1) {
        t = 1;
        s = clamp01((b - c) / a);
      }
    }
  }
  const L3 x1 = p1 + d1 * s, x2 = p2 + d2 * t;
  *c1 = x1.cast<double>() / k;
  *c2 = x2.cast<double>() / k;
  return static_cast<double>((x1 - x2).norm()) / k;
}

/// A full-dimensional hull: triangles for distances from outside, facet planes for depths.
struct Hull {
  std::vector<V3> points;
  std::vector<std::array<int, 3>> triangles;
  std::vector<V3> normals;                 ///< unit outward facet normals
  std::vector<double> offsets;             ///< plane: normal . x + offset = 0, interior negative
  std::vector<std::pair<int, int>> edges;  ///< triangle edges (incl. diagonals of merged facets)
  std::vector<int> vertices;               ///< indices of the points that are hull vertices

  /// The same hull moved by x -> R x + t (exact combinatorics, no new qhull run).
  Hull transformed(const Eigen::Matrix3d& R, const V3& t) const {
    Hull h = *this;
    for (V3& p : h.points)
      p = R * p + t;
    for (std::size_t i = 0; i < h.normals.size(); ++i) {
      h.normals[i] = R * normals[i];
      h.offsets[i] = offsets[i] - h.normals[i].dot(t);
    }
    return h;
  }
};

/// The singular value decomposition (Jacobi: the small values to about 1e-16 of the large one)
/// of a point set's coordinates about their mean: `sv` descending, `axes` their directions.
struct Spread {
  V3 mean = V3::Zero();
  Eigen::Vector3d sv = Eigen::Vector3d::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
};

inline Spread spread(const std::vector<V3>& pts) {
  Spread r;
  if (pts.empty()) return r;
  for (const V3& p : pts)
    r.mean += p;
  r.mean /= static_cast<double>(pts.size());
  Eigen::MatrixX3d m(pts.size(), 3);
  for (std::size_t i = 0; i < pts.size(); ++i)
    m.row(static_cast<Eigen::Index>(i)) = (pts[i] - r.mean).transpose();
  const Eigen::JacobiSVD<Eigen::MatrixX3d> svd(m, Eigen::ComputeFullV);
  r.sv = svd.singularValues();
  r.axes = svd.matrixV();
  return r;
}

/// Thinner than this (smallest singular value over the largest, spread()), makeHull() runs qhull
/// on the set mapped to its principal axes and scaled to about round, and maps the planes back (an
/// invertible affine map keeps a hull's combinatorics). qhull 8.0 can loop for ever merging the
/// facets of such a set with every option but joggling: the 16 vertex differences of a box
/// 2.6e-9 x 4e-9 x 4.98 m by a 1000 m segment (thickness 2.7e-12 of the width) ran "Qt Qs" past
/// 2 minutes, stopped there (fuzz/regressions/core/oracle-qhull-hang-needle-box-by-1000m-segment);
/// the same set 0.1 or 10 times as thick took 0.2 ms, and mapped round 0.6 ms (on a busy machine).
/// Until the eighth session of 2026-11-24 the limit was 1e-10; then a slanted prism 1e6 m x 3.2 m
/// x 4.7 m (singular values 2.4e-6 of each other) looped alike, raw, with any of five option sets
/// tried, and mapped took 0.07 ms (fuzz/regressions/core/hull-slanted-1e6m-prism-qhull-hang). The
/// library maps its thin sets too (convex_hull.cpp, kRoundRel, from its own frame); this is an
/// independent computation of the same idea.
constexpr double kThinSpread = 1e-3;

/// Hull of `pts` with qhull ("Qt": triangulated; a thin set mapped round, kThinSpread). Throws
/// std::runtime_error if qhull fails or the set is flat (the tests never feed them any; the fuzz
/// checks take flat sets in their plane, originSignedDistance()).
/// `sp`: spread(pts), when the caller has it.
inline Hull makeHull(const std::vector<V3>& pts, const Spread& sp) {
  // A thin set goes to qhull as M (x - c): about the mean c, along its principal axes, each
  // divided by its spread.
  const bool mapped = sp.sv[0] > 0.0 && sp.sv[2] < kThinSpread * sp.sv[0];
  if (mapped && !(sp.sv[2] > 0.0)) throw std::runtime_error("oracle qhull: flat input");
  const Eigen::Matrix3d M =
      mapped ? Eigen::Matrix3d(sp.sv.cwiseInverse().asDiagonal() * sp.axes.transpose())
             : Eigen::Matrix3d::Identity();
  Hull h;
  h.points = pts;
  std::vector<coordT> coords(3 * pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const V3 x = mapped ? V3(M * (pts[i] - sp.mean)) : pts[i];
    for (int k = 0; k < 3; ++k)
      coords[3 * i + k] = x[k];
  }
  char* text = nullptr;
  std::size_t size = 0;
  FILE* err = open_memstream(&text, &size);
  qhT qh_storage;
  qhT* qh = &qh_storage;
  qh_zero(qh, err);
  char cmd[] = "qhull Qt Qs";  // Qs: see buildConvexHull (qhull's default start can hang)
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
      V3 n(facet->normal[0], facet->normal[1], facet->normal[2]);
      double offset = facet->offset;
      if (mapped) {  // n . M (x - c) + offset = 0 is m . x + offset - m . c = 0, m = M^T n
        const V3 m = M.transpose() * n;
        n = m / m.norm();
        offset = (offset - m.dot(sp.mean)) / m.norm();
      }
      h.normals.push_back(n);
      h.offsets.push_back(offset);
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
  for (const auto& t : h.triangles) {
    for (int k = 0; k < 3; ++k) {
      h.edges.emplace_back(std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]));
      h.vertices.push_back(t[k]);
    }
  }
  std::sort(h.edges.begin(), h.edges.end());
  h.edges.erase(std::unique(h.edges.begin(), h.edges.end()), h.edges.end());
  std::sort(h.vertices.begin(), h.vertices.end());
  h.vertices.erase(std::unique(h.vertices.begin(), h.vertices.end()), h.vertices.end());
  return h;
}
inline Hull makeHull(const std::vector<V3>& pts) {
  return makeHull(pts, spread(pts));
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

/// Thinner than this (smallest singular value over the largest, spread()), a set is flat to
/// rounding for originSignedDistance(): mapped round (kThinSpread) for qhull, its rounding noise
/// becomes the thickness, the mapped-back planes of its sides turn towards its normal, and the
/// origin beside it came out inside. The difference of a 7e-10 m segment and a 3.7 mm segment
/// (singular values 4.6e-22 of each other), 9.42e-11 m apart, was "-3.4e-27 m"
/// (fuzz/regressions/core/oracle-flat-difference-of-two-segments).
constexpr double kFlatSpread = 1e-12;

/// Signed distance of the origin to the convex hull of `pts`: qhull (makeHull()) for a solid set;
/// for a set flat to rounding (kFlatSpread; also exactly flat, collinear or a single point) the
/// distance to the polygon it spans, found in its plane (the first two principal axes, oracle2d.h,
/// long double) and combined with the offset along the third (never negative: no interior).
/// Throws std::runtime_error if qhull fails.
inline double originSignedDistance(const std::vector<V3>& pts) {
  const Spread sp = spread(pts);
  if (!(sp.sv[2] <= kFlatSpread * sp.sv[0])) return signedDistance(makeHull(pts, sp), V3::Zero());
  using L = long double;
  const auto along = [&sp](const V3& x, int k) {
    L s = 0;
    for (int i = 0; i < 3; ++i)
      s += (static_cast<L>(x[i]) - sp.mean[i]) * sp.axes(i, k);
    return s;
  };
  const V3 origin = V3::Zero();
  const L u0 = along(origin, 0), v0 = along(origin, 1), w0 = along(origin, 2);
  std::vector<oracle2d::P2> flat;
  flat.reserve(pts.size());
  for (const V3& p : pts)
    flat.push_back({along(p, 0) - u0, along(p, 1) - v0});
  const L in_plane = std::max<L>(0, oracle2d::signedDistance(oracle2d::hull(flat)));
  return static_cast<double>(std::sqrt(in_plane * in_plane + w0 * w0));
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

  /// Computes `hull` from `core` (Poly only; one qhull run).
  void finish() {
    if (kind == Poly) hull = makeHull(core);
  }
  /// Vertices: the hull's for Poly, the core points otherwise.
  std::vector<V3> vertexList() const {
    if (kind != Poly) return core;
    std::vector<V3> v;
    for (int i : hull.vertices)
      v.push_back(hull.points[i]);
    return v;
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

namespace detail {

/// Point/segment pairs (both cores lower dimensional): closest points directly.
inline Answer solveLowDim(const Shape& a, const Shape& b) {
  Answer ans;
  V3 ca, cb;
  const V3& p1 = a.core[0];
  const V3& q1 = a.kind == Shape::Segment ? a.core[1] : a.core[0];
  const V3& p2 = b.core[0];
  const V3& q2 = b.kind == Shape::Segment ? b.core[1] : b.core[0];
  const double d = closestSegmentSegment(p1, q1, p2, q2, &ca, &cb);
  ans.distance = d - a.radius - b.radius;
  if (d > 0.0) ans.normal = (cb - ca) / d;
  return ans;
}

/// Features of a core: vertices, edges (vertex index pairs), triangles, face normals.
struct Features {
  std::vector<V3> v;
  std::vector<std::pair<int, int>> e;
  std::vector<std::array<int, 3>> t;
  std::vector<V3> n;
};

inline Features features(const Shape& s) {
  Features f;
  if (s.kind == Shape::Poly) {
    f.v = s.hull.points;  // indices of e/t refer to these; interior points are harmless
    f.e = s.hull.edges;
    f.t = s.hull.triangles;
    f.n = s.hull.normals;
  } else {
    f.v = s.core;
    if (s.kind == Shape::Segment) f.e = {{0, 1}};
  }
  return f;
}

/// max and min of n . v over the hull vertices of a feature set.
inline void extent(const Features& f, const std::vector<int>& idx, const V3& n, double* hi,
                   double* lo) {
  *hi = -std::numeric_limits<double>::infinity();
  *lo = std::numeric_limits<double>::infinity();
  for (int i : idx) {
    const double d = n.dot(f.v[i]);
    *hi = std::max(*hi, d);
    *lo = std::min(*lo, d);
  }
}

}  // namespace detail

/// Exact signed distance and normal by qhull on the Minkowski difference (see the file comment).
inline Answer solveMinkowski(const Shape& a, const Shape& b) {
  if (a.kind != Shape::Poly && b.kind != Shape::Poly) return detail::solveLowDim(a, b);
  Answer ans;
  std::vector<V3> diff;
  const std::vector<V3> va = a.vertexList(), vb = b.vertexList();
  diff.reserve(va.size() * vb.size());
  for (const V3& x : va) {
    for (const V3& y : vb)
      diff.push_back(x - y);
  }
  const Hull h = makeHull(diff);
  V3 out;
  // Outward from D at the origin: moving B along it (D shifts by -t) separates, i.e. A -> B.
  ans.distance = signedDistance(h, V3::Zero(), &out) - a.radius - b.radius;
  ans.normal = out;
  return ans;
}

/// Exact signed distance and normal of the full shapes A and B by SAT axes and closest features
/// (see the file comment).
inline Answer solve(const Shape& a, const Shape& b) {
  if (a.kind != Shape::Poly && b.kind != Shape::Poly) return detail::solveLowDim(a, b);
  const detail::Features fa = detail::features(a), fb = detail::features(b);
  std::vector<int> ia, ib;  // vertex indices used for support values
  if (a.kind == Shape::Poly) {
    ia = a.hull.vertices;
  } else {
    for (int i = 0; i < static_cast<int>(fa.v.size()); ++i)
      ia.push_back(i);
  }
  if (b.kind == Shape::Poly) {
    ib = b.hull.vertices;
  } else {
    for (int i = 0; i < static_cast<int>(fb.v.size()); ++i)
      ib.push_back(i);
  }
  // Penetration: min over candidate axes of h_D(n) = h_A(n) + h_B(-n), both signs.
  double best = std::numeric_limits<double>::infinity();
  V3 best_n = V3::UnitX();
  auto axis = [&](const V3& n) {
    double ah, al, bh, bl;
    detail::extent(fa, ia, n, &ah, &al);
    detail::extent(fb, ib, n, &bh, &bl);
    const double plus = ah - bl;   // h_D(n)
    const double minus = bh - al;  // h_D(-n)
    if (plus < best) best = plus, best_n = n;
    if (minus < best) best = minus, best_n = -n;
  };
  for (const V3& n : fa.n)
    axis(n);
  for (const V3& n : fb.n)
    axis(n);
  for (const auto& ea : fa.e) {
    const V3 da = fa.v[ea.second] - fa.v[ea.first];
    for (const auto& eb : fb.e) {
      const V3 db = fb.v[eb.second] - fb.v[eb.first];
      const V3 c = da.cross(db);
      const double len = c.norm();
      if (len > 1e-13 * da.norm() * db.norm()) axis(c / len);  // parallel edges: no facet
    }
  }
  Answer ans;
  if (best > 0.0) {  // no separating axis: overlap, depth = best
    ans.distance = -best - a.radius - b.radius;
    ans.normal = best_n;
    return ans;
  }
  // Apart: nearest vertex-triangle or edge-edge pair.
  double dmin = std::numeric_limits<double>::infinity();
  V3 pa = V3::Zero(), pb = V3::Zero();
  auto vertexTriangles = [&](const detail::Features& fv, const std::vector<int>& iv,
                             const detail::Features& ft, bool v_is_a) {
    for (int i : iv) {
      const V3& x = fv.v[i];
      for (const auto& t : ft.t) {
        const V3 q = closestPointTriangle(x, ft.v[t[0]], ft.v[t[1]], ft.v[t[2]]);
        const double d = (x - q).norm();
        if (d < dmin) dmin = d, pa = v_is_a ? x : q, pb = v_is_a ? q : x;
      }
    }
  };
  vertexTriangles(fa, ia, fb, true);
  vertexTriangles(fb, ib, fa, false);
  for (const auto& ea : fa.e) {
    for (const auto& eb : fb.e) {
      V3 c1, c2;
      const double d = closestSegmentSegment(fa.v[ea.first], fa.v[ea.second], fb.v[eb.first],
                                             fb.v[eb.second], &c1, &c2);
      if (d < dmin) dmin = d, pa = c1, pb = c2;
    }
  }
  ans.distance = dmin - a.radius - b.radius;
  ans.normal = dmin > 0.0 ? V3((pb - pa) / dmin) : best_n;
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
#include "sweep_scale.h"

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
  Hull local_hull;             ///< Poly only: hull of local_core, shape frame
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
    if (kind == Shape::Poly) world.hull = local_hull.transformed(pose.R, pose.t);
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

/// Two small hulls given far from their frame's origin (a mesh exported in a site frame): 6 to 16
/// points on random ellipsoids 1 to 12 mm across, about a point `far` metres out in a random
/// direction, their centres 5 to 55 % of the sizes' sum apart. The exact signed distance is that
/// of the given doubles (qhull on their differences).
struct FarPair {
  std::vector<V3> a, b;  ///< the points as given
  V3 centre;             ///< the point they lie about (A's centre)
  Hull ha, hb;           ///< the hulls about `centre` (rounding of 1e-16 of 12 mm there)
  double exact = 0.0;    ///< signed distance, m
  double size = 0.0;     ///< the sizes plus the distance between the centres, m
};
inline FarPair makeFarPair(std::mt19937_64& rng, double far) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const auto unit = [&rng] { return randomUnit(rng); };
  const auto blob = [&](const V3& centre, double size) {
    const V3 semi(size * (0.2 + 0.8 * u01(rng)), size * (0.2 + 0.8 * u01(rng)),
                  size * (0.2 + 0.8 * u01(rng)));
    std::vector<V3> pts;
    const int n = 6 + static_cast<int>(u01(rng) * 11);
    for (int i = 0; i < n; ++i)
      pts.push_back(centre + semi.cwiseProduct(unit()));
    return pts;
  };
  const auto minus = [](const std::vector<V3>& pts, const V3& c) {
    std::vector<V3> out;
    for (const V3& q : pts)
      out.push_back(q - c);
    return out;
  };
  FarPair p;
  p.centre = far * unit();
  const double ra = 1e-3 + 11e-3 * u01(rng), rb = 1e-3 + 11e-3 * u01(rng);
  const double gap = (0.05 + 0.5 * u01(rng)) * (ra + rb);  // between the centres
  p.a = blob(p.centre, 0.5 * ra);
  p.b = blob(p.centre + gap * unit(), 0.5 * rb);
  p.ha = makeHull(minus(p.a, p.centre));
  p.hb = makeHull(minus(p.b, p.centre));
  std::vector<V3> diff;
  for (const V3& x : p.a) {
    for (const V3& y : p.b)
      diff.push_back(x - y);
  }
  p.exact = originSignedDistance(diff);
  p.size = ra + rb + gap;
  return p;
}

/// 1 mm .. 10 m, log-uniform.
inline double randomSize(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-3.0, 1.0);
  return std::pow(10.0, u(rng));
}

/// A polytope body built once (its qhull runs are the slow part of a pair).
struct PoolEntry {
  cmc::ConvexShape shape;
  std::vector<V3> core;
  Hull hull;
  double circumradius;
};

/// 256 boxes or 256 random hulls (4 .. 20 points, stretched, off-centre), fixed seed, sizes
/// 1 mm .. 10 m. Pairs draw two entries and pose them at random.
inline const std::vector<PoolEntry>& pool(Kind kind) {
  auto build = [](Kind k) {
    std::vector<PoolEntry> out;
    std::mt19937_64 rng(k == Kind::Box ? 0xB0B0ull : 0x4011ull);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    auto uni = [&](double lo, double hi) { return lo + (hi - lo) * u01(rng); };
    for (int e = 0; e < 256; ++e) {
      const double s = randomSize(rng);
      std::vector<V3> core;
      std::optional<cmc::ConvexShape> shape;
      if (k == Kind::Box) {
        const V3 half(s * uni(0.1, 1.0), s * uni(0.1, 1.0), s * uni(0.1, 1.0));
        for (int i = 0; i < 8; ++i) {
          core.emplace_back((i & 1) ? half.x() : -half.x(), (i & 2) ? half.y() : -half.y(),
                            (i & 4) ? half.z() : -half.z());
        }
        shape = cmc::ConvexShape::box(2.0 * half);
      } else {
        const int n = 4 + static_cast<int>(u01(rng) * 17);
        const V3 stretch(uni(0.2, 1.0), uni(0.2, 1.0), uni(0.2, 1.0));
        const V3 shift = s * V3(uni(-0.3, 0.3), uni(-0.3, 0.3), uni(-0.3, 0.3));
        for (int i = 0; i < n; ++i) {
          const V3 p = randomUnit(rng) * std::cbrt(uni(0.05, 1.0));
          core.push_back(shift + s * p.cwiseProduct(stretch));
        }
        shape = cmc::ConvexShape::convexHull(core);
      }
      double cr = 0.0;
      for (const V3& v : core)
        cr = std::max(cr, v.norm());
      out.push_back(PoolEntry{*shape, core, makeHull(core), cr});
    }
    return out;
  };
  static const std::vector<PoolEntry> boxes = build(Kind::Box);
  static const std::vector<PoolEntry> hulls = build(Kind::Hull);
  return kind == Kind::Box ? boxes : hulls;
}

inline Body makeBody(Kind kind, bool padded, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto uni = [&](double lo, double hi) { return lo + (hi - lo) * u01(rng); };
  Body body;
  double s = 0.0;
  switch (kind) {
    case Kind::Box:
    case Kind::Hull: {
      const auto& entries = pool(kind);
      const PoolEntry& e = entries[static_cast<std::size_t>(u01(rng) * entries.size())];
      body.shape = e.shape;
      body.local_core = e.core;
      body.local_hull = e.hull;
      body.kind = Shape::Poly;
      s = e.circumradius;
      break;
    }
    case Kind::Sphere:
      s = randomSize(rng);
      body.shape = cmc::ConvexShape::sphere(s);
      body.local_core = {V3::Zero()};
      body.radius = s;
      body.kind = Shape::Point;
      break;
    case Kind::Capsule: {
      s = randomSize(rng);
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

/// Upper end of the placement factor f per category, measured so that about half of the pairs
/// overlap (spheres overlap for every f < 1, thin random hulls only for f < ~0.4).
inline double spread(Category c) {
  switch (c) {
    case Category::BoxBox:
      return 1.45;
    case Category::HullHull:
      return 0.85;
    case Category::BoxHull:
      return 1.15;
    case Category::SphereSphere:
      return 2.0;
    case Category::CapsuleCapsule:
      return 1.5;
    case Category::SphereCapsule:
      return 1.7;
    case Category::SpherePoly:
      return 1.5;
    case Category::CapsulePoly:
      return 1.35;
    case Category::PaddedPoly:
      return 1.55;
    case Category::Count:
      break;
  }
  return 1.0;
}

/// The pair number `index` of `category` (fixed seeds: the sweep is the same on every run).
/// B is placed along a random direction u at f * (reach_A(u) + reach_B(-u)) from A, f uniform in
/// [0, spread(category)]: f >= 1 is apart (a separating plane exists), f < 1 often overlapping; 10
/// % of the pairs are then slid to near contact; 20 % sit 0.5 .. 1 km from the origin.
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
  const double f = near_contact ? 1.0 : spread(category) * u01(rng);
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
