/// \file
/// Queries between two placed ConvexShapes: the public door of the geometry core.
///
/// Poses map shape frame -> world (any common frame). Internally every query works in A's frame
/// (one relative transform per query, not per support call); every result field below is in the
/// common frame the poses are given in, in the same length unit (metres in ROS).
///
/// Algorithms: GJK (Gilbert, Johnson, Keerthi 1988; van den Bergen 1999 termination) with the
/// signed-volumes simplex sub-algorithm (Montanari, Petrinic, Barbieri 2017), EPA (van den Bergen
/// 2001) for penetration. Radii and padding stay out of the iterations and are applied after
/// convergence: the signed distance of inflated shapes equals the cores' signed distance minus the
/// radii, exactly, for convex cores.
#pragma once

#include <array>
#include <cstdint>
#include <limits>

#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/core/math.h"

namespace collision_monitor {
namespace core {

/// Outcome of a query.
enum class Status {
  Separated,    ///< distance > 0
  Touching,     ///< |distance| within the tolerance band
  Penetrating,  ///< distance < 0 (overlap); depth = -distance
  /// Iteration bound hit; fields hold the best estimate found. From EPA (signedDistance() of
  /// overlapping shapes): the depth is the best upper bound found, not certified to the
  /// tolerance. Symmetric deep overlaps of curved shapes end so with the right depth (a point at
  /// a cylinder's or an ellipsoid's centre: depth to 1e-12, but the inscribed polytope's lower
  /// bound cannot close on a curved surface); the distance is then negative, so a caller can
  /// still tell apart from overlapping.
  FailedToConverge,
};
const char* toString(Status s);

/// Tolerances and bounds. Relative tolerances scale with the shapes' size.
struct QueryOptions {
  double rel_tolerance = 1e-12;  ///< GJK convergence and EPA's length unit, of the shapes' size
  /// EPA stops once the depth is known to this fraction of itself (plus rel_tolerance of the
  /// size). Not 1e-12: on curved shapes EPA's faces reach rounding first (17 of 20,000 deep
  /// cylinder/cone overlaps never got there, 0 at 1e-10; the core's accuracy goal is 1e-9).
  double epa_rel_tolerance = 1e-10;
  int max_iterations = 128;      ///< per GJK run
  int max_epa_iterations = 256;  ///< per EPA run (at most kEpaMaxIterations, epa.h)
  /// |signed distance| <= touch_tolerance * size counts as Touching.
  double touch_tolerance = 1e-10;
};

/// Result of distance / signedDistance / penetration.
struct ContactResult {
  Status status = Status::FailedToConverge;
  /// Signed distance in metres: > 0 separation, < 0 penetration depth; status Touching: within
  /// touch_tolerance of 0 (often 0 or -0, not always: 2.6e-14 for a 10 m box and a 1 mm sphere
  /// 1e3 m out; the libccd backend's penetration gives 0). Decide on `status`, not `== 0`.
  /// For distance() on overlapping shapes: 0 (status Penetrating, depth not computed).
  double distance = std::numeric_limits<double>::infinity();
  Vec3 point_a = Vec3::Zero();  ///< witness point on A, common frame
  Vec3 point_b = Vec3::Zero();  ///< witness point on B, common frame
  /// Unit vector from A towards B, common frame: the direction in which to move B (or -A) to
  /// increase the distance. Defined (not NaN) even when the shapes touch.
  Vec3 normal = Vec3::UnitX();
  /// GJK iterations of all the query's runs: at most QueryOptions::max_iterations in A's frame
  /// (restarts included), as many again where the query is retried in B's frame (distance()).
  int gjk_iterations = 0;
  /// EPA iterations, likewise: at most twice QueryOptions::max_epa_iterations.
  int epa_iterations = 0;
  double depth() const { return distance < 0.0 ? -distance : 0.0; }
};

/// Warm-start cache for one pair of shapes: the last GJK simplex (as support points in each
/// shape's own frame, so it stays valid after the shapes move) and the polytope hill-climbing
/// hints. Keep one per ordered (part, part) pair across cycles; a default-constructed cache is
/// cold. A query binds the cache to its two shapes (ConvexShape::coreId(), in order): given
/// another pair, or the same pair swapped, the cache starts cold and is bound to that pair (its
/// points would not lie on those shapes), so sharing one cache is slow, never wrong.
struct PairCache {
  int size = 0;                   ///< simplex vertices cached (0 = cold)
  std::array<Vec3, 4> local_a{};  ///< support points on A's core, A's frame
  std::array<Vec3, 4> local_b{};  ///< support points on B's core, B's frame
  int hint_a = -1;                ///< polytope hill-climbing start on A (-1: none, direction table)
  int hint_b = -1;                ///< polytope hill-climbing start on B (-1: none, direction table)
  std::uint64_t core_a = 0;       ///< coreId() of the A the cache holds points of (0: none)
  std::uint64_t core_b = 0;       ///< coreId() of that B
  void reset() { size = 0; }
};

/// True when the full shapes (cores + radii) overlap or touch. Early exit as soon as a support
/// point fails to pass the origin (separated) or the simplex encloses it (overlap).
bool intersect(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
               const Transform3& pose_b, PairCache* cache = nullptr,
               const QueryOptions& options = {});

/// Separation distance and witness points; 0 with status Penetrating when the shapes overlap. No
/// EPA runs, except where GJK ends on a segment or triangle through the origin: the origin is then
/// on A - B's boundary (Touching) or inside it by symmetry (a point at a cylinder's centre), which
/// EPA tells apart, and its normal is reported (a touching pair's contact normal). Elsewhere the
/// normal of overlapping shapes points from A's origin towards B's. GJK runs in A's frame; where
/// rounding leaves its answer uncertain by more than the touching band (its best lower bound, or
/// its witness points' distance, that far from it), the query runs once more in B's frame and keeps
/// that answer unless the first one's upper bound is lower by more than the band (also in
/// signedDistance()): rare, and at most twice the cost.
ContactResult distance(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                       const Transform3& pose_b, PairCache* cache = nullptr,
                       const QueryOptions& options = {});

/// Signed distance in one call: the distance when apart, minus the penetration depth (EPA on
/// the GJK terminal simplex) when overlapping. Witness points and normal in both cases. EPA keeps
/// its polytope on the stack (about 80 kB): threads with small stacks (below ~128 kB) must not
/// call it. Poses must be rigid (Transform: not checked here).
ContactResult signedDistance(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                             const Transform3& pose_b, PairCache* cache = nullptr,
                             const QueryOptions& options = {});

/// Penetration depth and normal by EPA. Same result as signedDistance() (when the shapes are
/// apart it reports the separation, status Separated).
inline ContactResult penetration(const ConvexShape& a, const Transform3& pose_a,
                                 const ConvexShape& b, const Transform3& pose_b,
                                 PairCache* cache = nullptr, const QueryOptions& options = {}) {
  return signedDistance(a, pose_a, b, pose_b, cache, options);
}

}  // namespace core
}  // namespace collision_monitor
