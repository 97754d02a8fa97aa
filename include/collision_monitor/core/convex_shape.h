/// \file
/// The runtime 3D convex shape used by the world model and the ROS layer: a core support
/// mapping (one of the shapes in shapes.h) plus a radius (sphere/capsule radius + padding).
/// Construction validates its input and throws std::invalid_argument with a clear message;
/// a constructed ConvexShape is always valid (finite, non-negative sizes).
///
/// Shapes given by coordinates (points, segments, hulls) far from their frame's origin are kept
/// about their own centre (offset()): a hull written in map coordinates 1e5 m out answers to 1e-9
/// of its own size, as one given about its origin and placed by its pose.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "collision_monitor/core/math.h"
#include "collision_monitor/core/shapes.h"

namespace collision_monitor {
namespace core {

class ConvexShape {
 public:
  /// The core support mapping. Polytopes are shared and immutable (cheap copies of shapes).
  using Core = std::variant<PointShape<3>, SegmentShape<3>, BoxShape<3>, CylinderShape, ConeShape,
                            EllipsoidShape<3>, std::shared_ptr<const Polytope<3>>>;

  /// Sphere of `radius` (m, >= 0) at the origin: a point core plus radius.
  static ConvexShape sphere(double radius);
  /// Box with full side lengths (m, each >= 0), centred (as shape_msgs/SolidPrimitive).
  static ConvexShape box(const Vec3& sides);
  /// Capsule: segment of `length` on z centred at the origin, swept by `radius`.
  static ConvexShape capsule(double length, double radius);
  /// Cylinder of `height` along z, centred, with `radius`.
  static ConvexShape cylinder(double height, double radius);
  /// Cone of `height` along z, centred like shape_msgs (base at -height/2, apex at +height/2).
  static ConvexShape cone(double height, double radius);
  /// Ellipsoid with semi-axes (a, b, c) along x, y, z.
  static ConvexShape ellipsoid(const Vec3& semi_axes);
  /// A single point (its core is the point at offset() = p).
  static ConvexShape point(const Vec3& p);
  /// Segment from a to b (its core about offset(), see there).
  static ConvexShape segment(const Vec3& a, const Vec3& b);
  /// Convex hull of `points` (qhull). Degenerate sets (coincident, collinear, coplanar points)
  /// are valid and give a flat or lower-dimensional polytope. Throws on empty input or on
  /// non-finite coordinates. The core is the hull of the points less offset() (see there).
  static ConvexShape convexHull(const std::vector<Vec3>& points);
  /// A polytope built elsewhere (e.g. by buildConvexHull()); used as it is unless its vertices lie
  /// far from its origin (offset()): then the core is a copy less offset(). Its adjacency, if it
  /// has one, must be the hull's edge graph (support hill-climbs on it above
  /// Polytope::kLinearScanMax vertices): malformed offsets or neighbours, or a graph that a climb
  /// from vertex 0 does not lead to the extreme vertex along one of 96 directions, throw.
  static ConvexShape polytope(std::shared_ptr<const Polytope<3>> poly);

  /// This shape inflated by `padding` (m, >= 0): Minkowski sum with a sphere.
  ConvexShape padded(double padding) const;

  /// The core support mapping, about offset(): the shape is core() moved by offset(), inflated by
  /// radius().
  const Core& core() const { return core_; }
  /// Where the core's origin lies in the shape frame. Zero for the centred primitives and for
  /// coordinates near their origin. For points, segments and polytopes whose bounding box's centre
  /// lies further from the origin than four half-diagonals, that centre along each axis where it
  /// lies further out than four half-extents (there, subtracting it from a coordinate is exact, so
  /// the core plus offset() is the given point set, bit for bit): the queries run about it, and
  /// their tolerances follow localRadius() instead of the distance from the origin.
  const Vec3& offset() const { return offset_; }
  /// offset() is not zero.
  bool hasOffset() const { return has_offset_; }
  /// Radius added to the core after GJK converges (sphere/capsule radius plus padding), m.
  double radius() const { return radius_; }

  /// Support point of the full shape (core + radius) in the shape frame.
  Vec3 support(const Vec3& d) const;
  /// Support point of the core only, in the shape frame (offset() included).
  Vec3 coreSupport(const Vec3& d) const;
  /// Support point about offset(): support(d) - offset(), or coreSupport(d) - offset() when
  /// `core_only`, without the rounding of that subtraction (for frames centred on the core).
  Vec3 localSupport(const Vec3& d, bool core_only = false) const;
  /// Exact axis-aligned bounding box of the full shape placed at `pose` (6 support queries).
  Aabb aabb(const Transform3& pose) const;
  /// Radius of a ball about the shape-frame origin that contains the full shape.
  double boundingRadius() const { return bounding_radius_; }
  /// Radius of a ball about offset() that contains the full shape (the queries' size scale).
  double localRadius() const { return local_radius_; }
  /// Short human-readable name of the core type ("sphere", "box", "polytope(42)", ...).
  std::string describe() const;
  /// Identity of the core, unique per constructed shape (never 0); copies and padded() keep it,
  /// as they keep the core. A PairCache is bound to the two shapes' ids (see there).
  std::uint64_t coreId() const { return core_id_; }

 private:
  ConvexShape(Core core, double radius, std::string kind, const Vec3& offset = Vec3::Zero());
  /// A polytope core (non-empty, finite vertices) at `offset`.
  static ConvexShape polytopeAt(std::shared_ptr<const Polytope<3>> poly, const Vec3& offset);
  Core core_;
  Vec3 offset_ = Vec3::Zero();
  bool has_offset_ = false;
  double radius_ = 0.0;
  double bounding_radius_ = 0.0;
  double local_radius_ = 0.0;
  std::uint64_t core_id_ = 0;
  std::string kind_;
};

}  // namespace core
}  // namespace collision_monitor
