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

#include <cmath>
#include <cstdint>
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
    for (int i = 0; i < D; ++i) s[i] = d[i] < 0.0 ? -half[i] : half[i];
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
/// With an empty adjacency (or few vertices) the support query is a linear scan. With adjacency,
/// support(d, hint) hill-climbs from vertex `hint` to a vertex maximising dot(d, x); on a convex
/// polytope a local maximum over the edge graph is the global one. `hint` is updated to the
/// answer, so a caller that keeps it (the warm-start cache) starts next to the answer.
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
        adjacency_(std::move(adjacency)) {}

  const std::vector<Vec<D>>& vertices() const { return vertices_; }
  int size() const { return static_cast<int>(vertices_.size()); }
  bool hasAdjacency() const { return offsets_.size() == vertices_.size() + 1; }
  const std::vector<int>& adjacencyOffsets() const { return offsets_; }
  const std::vector<int>& adjacency() const { return adjacency_; }

  /// Index of a vertex maximising dot(d, x). `hint` (in/out) is the start vertex of the climb.
  int supportIndex(const Vec<D>& d, int& hint) const {
    const int n = size();
    if (n <= kLinearScanMax || !hasAdjacency()) {
      int best = 0;
      double best_dot = vertices_[0].dot(d);
      for (int i = 1; i < n; ++i) {
        const double v = vertices_[i].dot(d);
        if (v > best_dot) {
          best_dot = v;
          best = i;
        }
      }
      hint = best;
      return best;
    }
    int cur = (hint >= 0 && hint < n) ? hint : 0;
    double cur_dot = vertices_[cur].dot(d);
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
  /// Support without a kept hint (starts from vertex 0).
  Vec<D> support(const Vec<D>& d) const {
    int hint = 0;
    return support(d, hint);
  }

 private:
  std::vector<Vec<D>> vertices_;
  std::vector<int> offsets_;
  std::vector<int> adjacency_;
};

/// A polytope with its own hill-climbing hint: the per-query support object GJK uses, so the
/// shared Polytope stays immutable (and thread-safe) while each pair keeps its own hint.
template <int D>
struct PolytopeSupport {
  const Polytope<D>* poly = nullptr;
  mutable int hint = 0;
  Vec<D> support(const Vec<D>& d) const { return poly->support(d, hint); }
};

}  // namespace core
}  // namespace collision_monitor
