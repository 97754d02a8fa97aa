/// \file
/// Support mappings: the one abstraction of the geometry core. Anything with
///   Vec<D> support(const Vec<D>& d) const
/// returning a point of the shape (in the shape's own frame) that maximises dot(d, x) is a
/// convex shape for GJK. A direction of zero length gets a defined answer (some point of the
/// shape), never NaN.
///
/// The shapes here are *cores*: a sphere is a PointShape with a radius, a capsule a SegmentShape
/// with a radius. The radius (and any padding) is kept out of the GJK iterations and added after
/// convergence (see query.h), as in Box2D and coal.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "collision_monitor/core/math.h"

namespace collision_monitor {
namespace core {

/// A single point (sphere and padding cores).
template <int D>
struct PointShape {
  Vec<D> p = Vec<D>::Zero();
  Vec<D> support(const Vec<D>& /*d*/) const { return p; }
};

/// Segment from a to b (capsule cores).
template <int D>
struct SegmentShape {
  Vec<D> a = Vec<D>::Zero();
  Vec<D> b = Vec<D>::Zero();
  Vec<D> support(const Vec<D>& d) const { return d.dot(b - a) > 0.0 ? b : a; }
};

/// Axis-aligned box centred at the origin with half extents `half` (each >= 0; 0 is a flat box).
template <int D>
struct BoxShape {
  Vec<D> half = Vec<D>::Zero();
  Vec<D> support(const Vec<D>& d) const {
    Vec<D> s;
    for (int i = 0; i < D; ++i)
      s[i] = d[i] < 0.0 ? -half[i] : half[i];
    return s;
  }
};

/// Ellipsoid centred at the origin with semi-axes `semi` along the frame axes (each >= 0).
/// support(d) = S^2 d / |S d| with S = diag(semi); for |S d| = 0 the centre.
template <int D>
struct EllipsoidShape {
  Vec<D> semi = Vec<D>::Ones();
  Vec<D> support(const Vec<D>& d) const {
    const Vec<D> sd = semi.cwiseProduct(d);
    const double n = sd.norm();
    if (!(n > 0.0)) return Vec<D>::Zero();
    return semi.cwiseProduct(sd) / n;
  }
};

/// Cylinder along z, centred at the origin: z in [-half_height, half_height], radius `radius`.
struct CylinderShape {
  double half_height = 0.0;
  double radius = 0.0;
  Vec3 support(const Vec3& d) const {
    const double r_xy = std::hypot(d.x(), d.y());
    Vec3 s(0.0, 0.0, d.z() < 0.0 ? -half_height : half_height);
    if (r_xy > 0.0) {
      s.x() = radius * d.x() / r_xy;
      s.y() = radius * d.y() / r_xy;
    }
    return s;
  }
};

/// Cone along z centred like shape_msgs/SolidPrimitive: base disc of radius `radius` at
/// z = -half_height, apex at z = +half_height.
struct ConeShape {
  double half_height = 0.0;
  double radius = 0.0;
  Vec3 support(const Vec3& d) const {
    const Vec3 apex(0.0, 0.0, half_height);
    const double r_xy = std::hypot(d.x(), d.y());
    Vec3 rim(0.0, 0.0, -half_height);
    if (r_xy > 0.0) {
      rim.x() = radius * d.x() / r_xy;
      rim.y() = radius * d.y() / r_xy;
    }
    return d.dot(apex) >= d.dot(rim) ? apex : rim;
  }
};

/// Convex polytope given by its vertices (all of them hull vertices when built by
/// buildConvexHull()), with the hull's vertex adjacency for hill-climbing support queries.
///
/// With an empty adjacency (or few vertices) the support query is a linear scan over a
/// structure-of-arrays copy of the vertices (x[], y[], z[] padded to a multiple of 4, four
/// independent running maxima; GCC 12 -O3 keeps it scalar). With adjacency, support(d, hint)
/// hill-climbs from vertex `hint` to a vertex maximising dot(d, x); on a convex polytope a local
/// maximum over the edge graph is the global one. `hint` is updated to the answer, so a caller
/// that keeps it (the warm-start cache) starts next to the answer. The climb starts at the better
/// (larger dot(d, x)) of `hint` and startVertex(d): the extreme vertex, computed once at
/// construction, of the nearest of 26 fixed directions (the cube's faces, edges and corners). A
/// `hint` outside [0, size()) (e.g. -1: no hint) is ignored.
template <int D>
class Polytope {
 public:
  /// Below this many vertices the linear scan beats hill-climbing (measured: see docs/benchmarks).
  static constexpr int kLinearScanMax = 24;

  Polytope() = default;
  /// `adjacency_offsets` has size vertices.size() + 1; neighbours of vertex i are
  /// adjacency[adjacency_offsets[i] .. adjacency_offsets[i+1]). Empty offsets: no adjacency.
  Polytope(std::vector<Vec<D>> vertices, std::vector<int> adjacency_offsets = {},
           std::vector<int> adjacency = {})
      : vertices_(std::move(vertices)),
        offsets_(std::move(adjacency_offsets)),
        adjacency_(std::move(adjacency)) {
    buildScanArrays();
    buildStartTable();
  }

  const std::vector<Vec<D>>& vertices() const { return vertices_; }
  int size() const { return static_cast<int>(vertices_.size()); }
  bool hasAdjacency() const { return offsets_.size() == vertices_.size() + 1; }
  const std::vector<int>& adjacencyOffsets() const { return offsets_; }
  const std::vector<int>& adjacency() const { return adjacency_; }

  /// True when supportIndex() is a linear scan (few vertices or no adjacency).
  bool usesLinearScan() const { return size() <= kLinearScanMax || !hasAdjacency(); }

  /// Index of the first vertex maximising dot(d, x) by a linear scan over all vertices.
  int scanIndex(const Vec<D>& d) const {
    const int np = padded_;
    const double* c = soa_.data();
    std::array<double, D> dd;
    for (int k = 0; k < D; ++k)
      dd[k] = d[k];
    // Four lanes, each keeping its first maximum; a pad slot repeats vertex 0, so it can only tie
    // with vertex 0 and loses the tie (larger index).
    double best[4] = {-kInf, -kInf, -kInf, -kInf};
    int idx[4] = {0, 0, 0, 0};
    for (int i = 0; i < np; i += 4) {
      for (int l = 0; l < 4; ++l) {
        double x = c[i + l] * dd[0];
        for (int k = 1; k < D; ++k)
          x += c[k * np + i + l] * dd[k];
        const bool better = x > best[l];
        best[l] = better ? x : best[l];
        idx[l] = better ? i + l : idx[l];
      }
    }
    int b = idx[0];
    double bv = best[0];
    for (int l = 1; l < 4; ++l) {
      if (best[l] > bv || (best[l] == bv && idx[l] < b)) {
        bv = best[l];
        b = idx[l];
      }
    }
    return b;
  }

  /// Start vertex of a cold hill-climb: the precomputed extreme vertex of the fixed direction
  /// (one of 26 in 3D, 8 in 2D) nearest to d. 0 for a zero or non-finite d.
  int startVertex(const Vec<D>& d) const {
    if (start_.empty()) return 0;
    return start_[directionCell(d)];
  }

  /// Index of a vertex maximising dot(d, x). `hint` (in/out): a candidate start vertex of the
  /// climb (the better of it and startVertex(d) is used; outside [0, size()): ignored).
  int supportIndex(const Vec<D>& d, int& hint) const {
    const int n = size();
    if (usesLinearScan()) {
      hint = scanIndex(d);
      return hint;
    }
    // Start at the better of the hint and the direction table's vertex: a kept hint is near the
    // answer for small changes of d, the table for large ones (GJK's first iterations).
    int cur = startVertex(d);
    double cur_dot = vertices_[cur].dot(d);
    if (hint >= 0 && hint < n && hint != cur) {
      const double h = vertices_[hint].dot(d);
      if (h >= cur_dot) {
        cur = hint;
        cur_dot = h;
      }
    }
    // Steepest ascent: move to the best neighbour while it strictly improves. Strict improvement
    // bounds the walk by the vertex count, so it always terminates.
    for (;;) {
      int next = cur;
      double next_dot = cur_dot;
      for (int k = offsets_[cur], end = offsets_[cur + 1]; k < end; ++k) {
        const int nb = adjacency_[k];
        const double v = vertices_[nb].dot(d);
        if (v > next_dot) {
          next_dot = v;
          next = nb;
        }
      }
      if (next == cur) break;
      cur = next;
      cur_dot = next_dot;
    }
    hint = cur;
    return cur;
  }
  Vec<D> support(const Vec<D>& d, int& hint) const { return vertices_[supportIndex(d, hint)]; }
  /// Support without a kept hint (a climb starts at startVertex(d)).
  Vec<D> support(const Vec<D>& d) const {
    int hint = -1;
    return support(d, hint);
  }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();

  /// Cell of d among the 3^D - 1 directions with components in {-1, 0, 1}: component k counts
  /// when |d_k| > (sqrt(2) - 1) max |d_j| (the boundary between an axis and an edge direction).
  static int directionCell(const Vec<D>& d) {
    const double m = d.cwiseAbs().maxCoeff();
    if (!(m > 0.0) || !(m < kInf)) return 0;
    const double th = 0.41421356237309503 * m;
    int cell = 0;
    for (int k = 0; k < D; ++k)
      cell = 3 * cell + (d[k] > th ? 2 : (d[k] < -th ? 0 : 1));
    return cell;
  }

  void buildScanArrays() {
    const int n = size();
    padded_ = (n + 3) / 4 * 4;
    soa_.assign(static_cast<std::size_t>(D) * padded_, 0.0);
    for (int i = 0; i < padded_; ++i) {
      const Vec<D>& p = vertices_[i < n ? i : 0];
      for (int k = 0; k < D; ++k)
        soa_[static_cast<std::size_t>(k) * padded_ + i] = p[k];
    }
  }

  void buildStartTable() {
    if (vertices_.empty() || usesLinearScan()) return;
    int cells = 1;
    for (int k = 0; k < D; ++k)
      cells *= 3;
    start_.assign(cells, 0);
    for (int cell = 0; cell < cells; ++cell) {
      Vec<D> dir;
      int c = cell;
      for (int k = D - 1; k >= 0; --k) {
        dir[k] = static_cast<double>(c % 3 - 1);
        c /= 3;
      }
      start_[cell] = scanIndex(dir);
    }
  }

  std::vector<Vec<D>> vertices_;
  std::vector<int> offsets_;
  std::vector<int> adjacency_;
  std::vector<double> soa_;  ///< coordinates k of vertex i at [k * padded_ + i]
  int padded_ = 0;           ///< vertex count rounded up to a multiple of 4
  std::vector<int> start_;   ///< extreme vertex per direction cell (climbing polytopes only)
};

/// A polytope with its own hill-climbing hint: the per-query support object GJK uses, so the
/// shared Polytope stays immutable (and thread-safe) while each pair keeps its own hint.
template <int D>
struct PolytopeSupport {
  const Polytope<D>* poly = nullptr;
  mutable int hint = -1;  ///< -1: cold (the climb starts at Polytope::startVertex)
  Vec<D> support(const Vec<D>& d) const { return poly->support(d, hint); }
};

}  // namespace core
}  // namespace collision_monitor
