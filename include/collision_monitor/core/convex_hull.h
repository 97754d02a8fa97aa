/// \file
/// Convex hulls by qhull (reentrant libqhull_r): point sets and meshes -> Polytope with the hull's
/// vertex adjacency (for hill-climbing support queries).
#pragma once

#include <array>
#include <memory>
#include <vector>

#include "collision_monitor/core/shapes.h"

namespace collision_monitor {
namespace core {

/// Convex hull of `points`. Keeps only hull vertices and builds their edge adjacency.
/// Degenerate input is valid: coincident points give a one-vertex polytope, collinear points a
/// segment, coplanar points a flat polygon (all without qhull's full-dimensional hull, which
/// would fail on them). Throws std::invalid_argument on empty input or non-finite coordinates.
std::shared_ptr<const Polytope<3>> buildConvexHull(const std::vector<Vec3>& points);

/// The hull's triangles (outward-facing, counter-clockwise) as vertex index triples into
/// poly.vertices(); for visualisation and for the exact test oracle. Flat or lower-dimensional
/// polytopes give an empty list.
std::vector<std::array<int, 3>> hullTriangles(const Polytope<3>& poly);

/// Facets of the convex hull of `points` as planes n.x <= offset with unit outward n (qhull).
/// The signed distance of a point inside a full-dimensional hull is max over facets of
/// (n.x - offset) (negative); outside it needs a projection onto the facets. Only for a
/// full-dimensional hull: coplanar points give the two faces of a slab of zero thickness (and
/// their edges' planes), collinear or coincident points no plane at all, which a membership test
/// would read as "everything inside".
struct HullPlane {
  Vec3 normal;
  double offset;
};
std::vector<HullPlane> hullPlanes(const std::vector<Vec3>& points);

}  // namespace core
}  // namespace collision_monitor
