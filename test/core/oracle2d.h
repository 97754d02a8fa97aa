/// \file
/// The 2D oracle: convex hull (Andrew's monotone chain) and the origin's signed distance to it, in
/// long double. For test_gjk_2d_sweep (A - B of two polygons) and for oracle.h's flat sets (a
/// Minkowski difference flat to rounding, projected into its plane).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace oracle2d {

using LD = long double;
struct P2 {
  LD x, y;
};
inline P2 operator-(const P2& a, const P2& b) {
  return {a.x - b.x, a.y - b.y};
}
inline LD cross(const P2& a, const P2& b) {
  return a.x * b.y - a.y * b.x;
}
inline LD dot(const P2& a, const P2& b) {
  return a.x * b.x + a.y * b.y;
}
inline LD norm(const P2& a) {
  return std::sqrt(dot(a, a));
}

/// Convex hull, counter-clockwise, collinear points dropped (1 point for a single point, 2 for a
/// segment; empty for no points).
inline std::vector<P2> hull(std::vector<P2> p) {
  std::sort(p.begin(), p.end(),
            [](const P2& a, const P2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
  p.erase(std::unique(p.begin(), p.end(),
                      [](const P2& a, const P2& b) { return a.x == b.x && a.y == b.y; }),
          p.end());
  if (p.size() < 3) return p;
  std::vector<P2> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 1] - h[k - 2], p[i] - h[k - 2]) <= 0)
      --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 1] - h[k - 2], p[i] - h[k - 2]) <= 0)
      --k;
    h[k++] = p[i];
  }
  h.resize(k - 1);
  return h;
}

/// Distance from the origin to segment a-b.
inline LD originToSegment(const P2& a, const P2& b) {
  const P2 e = b - a;
  const LD ee = dot(e, e);
  LD t = ee > 0 ? -dot(a, e) / ee : 0;
  t = std::clamp<LD>(t, 0, 1);
  return norm({a.x + t * e.x, a.y + t * e.y});
}

/// Signed distance of the origin to polygon h (from hull(), not empty): negative inside.
inline LD signedDistance(const std::vector<P2>& h) {
  if (h.size() == 1) return norm(h[0]);
  LD d = std::numeric_limits<LD>::infinity();
  bool inside = h.size() >= 3;
  for (std::size_t i = 0; i < h.size(); ++i) {
    const P2& a = h[i];
    const P2& b = h[(i + 1) % h.size()];
    d = std::min(d, originToSegment(a, b));
    // On an edge's line is not inside: d is then the distance to the boundary. A sliver along the
    // origin's line (three collinear points, SVD axes 5e-17 off) had every cross exactly 0 and
    // took the origin 1.16e-5 m from it for inside
    // (fuzz/regressions/core/oracle-collinear-axis-hull-point-on-its-line).
    if (cross(b - a, P2{0, 0} - a) <= 0) inside = false;
  }
  return inside ? -d : d;
}

}  // namespace oracle2d
