/// \file
/// The libccd 2.1 narrow phase (internal to the core; the public door is backend.h). Exposed so
/// that tests and benchmarks can compare libccd's algorithms with each other and with the exact
/// oracle.
///
/// libccd never sees our shapes: it calls support/centre callbacks on `void*` objects that wrap a
/// ConvexShape (full shape, core + radius) and its pose. Every query runs in A's frame and scaled
/// by 1 / (boundingRadius(A) + boundingRadius(B)) (or by the distance between their origins where
/// that is larger: every coordinate within about 1), because libccd's thresholds are absolute
/// (ccdIsZero compares squared lengths with DBL_EPSILON; the EPA/MPR tolerances are lengths or
/// squared lengths): in that unit-sized frame they become relative to the shapes' size and the
/// far-from-origin translation drops out. Results are mapped back to the common frame and unit.
///
/// Polarity of libccd's return codes: ccdGJKIntersect/ccdMPRIntersect return true (1) on
/// contact; ccdGJKPenetration/ccdMPRPenetration return 0 on contact, -1 when apart, -2 when out
/// of memory.
#pragma once

#include <memory>

#include "collision_monitor/core/backend.h"
#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/core/math.h"
#include "collision_monitor/core/query.h"

namespace collision_monitor {
namespace core {

/// libccd algorithm for one query.
enum class CcdAlgorithm {
  Gjk,  ///< ccdGJKIntersect / ccdGJKPenetration (GJK + EPA)
  Mpr,  ///< ccdMPRIntersect / ccdMPRPenetration (Minkowski portal refinement)
};

/// libccd settings. Tolerances are relative to boundingRadius(A) + boundingRadius(B).
struct CcdOptions {
  CcdAlgorithm intersect = CcdAlgorithm::Gjk;    ///< for intersect() (see ccd_backend.cpp)
  CcdAlgorithm penetration = CcdAlgorithm::Gjk;  ///< for the depth (see ccd_backend.cpp)
  /// Give libccd the cores only (radii and padding left out, as in our GJK): the penetration
  /// result is then the cores' (depth and witness points of the cores; the caller adds radii).
  bool cores_only = false;
  /// ccd_t::epa_tolerance. libccd stops EPA when a new support point gains less than this (it
  /// compares a length times the current depth, and a squared length, against it). Measured
  /// against the exact oracle: 1e-6 -> box depth errors 8e-4 of the size, 1e-8 -> 4e-5,
  /// 1e-10 -> 1e-11 (exact up to rounding); padded boxes 7e-6 at 1e-10, 9e-7 at 1e-12 (at 1.5x
  /// the time). libccd's EPA has no iteration bound, so curved shapes make small values slow.
  double epa_tolerance = 1e-10;
  /// ccd_t::mpr_tolerance: MPR portal refinement stops when the portal moves less than this.
  double mpr_tolerance = 1e-9;
  /// ccd_t::dist_tolerance (used by libccd's GJK distance helpers).
  double dist_tolerance = 1e-12;
  /// ccd_t::max_iterations: GJK and MPR iteration bound (libccd's EPA has none of its own).
  unsigned long max_iterations = 500;
  /// Bound on support calls per body and query, which bounds libccd's EPA: it can loop for ever
  /// (found by fuzz_core: a capsule core and a flat box at the same place, > 30 s). Past it the
  /// support functions answer so that EPA's progress test stops it, and the query reports
  /// FailedToConverge (the backend then answers with our GJK/EPA). Most used by a converging
  /// query in test_ccd_backend and the oracle sweep: 2,490 (curved cores at epa_tolerance 1e-10).
  unsigned long max_support_calls = 4000;
};

/// libccd's intersection test of the full shapes.
bool ccdIntersect(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                  const Transform3& pose_b, const CcdOptions& options = {});

/// libccd's penetration query. Returns false when libccd reports the shapes apart (`out`
/// untouched). On contact fills `out`: status Penetrating (Touching when the depth is within
/// `query.touch_tolerance` of the size, FailedToConverge when libccd runs out of memory or of
/// `options.max_support_calls`),
/// distance = -depth (m), normal (unit, common frame, A -> B: moving B along it by the depth
/// separates the shapes), and witness points (common frame) derived from libccd's contact
/// position `pos`: point_a = pos + depth/2 * normal, point_b = pos - depth/2 * normal, so that
/// point_b - point_a = distance * normal as for separated shapes. libccd reports no iteration
/// counts (both stay 0).
bool ccdPenetration(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                    const Transform3& pose_b, ContactResult* out, const CcdOptions& options = {},
                    const QueryOptions& query = {});

/// The libccd NarrowPhase: intersect() by `ccd.intersect`; signedDistance() by
/// `ccd.penetration` when libccd finds contact, and by our GJK core::distance() when it finds
/// the shapes apart (libccd 2.1 has no distance query). Pairs whose bounding balls do not meet,
/// non-finite poses and sizes above 1e9 m go to our GJK directly. `query` supplies
/// touch_tolerance and the options of the GJK distance fallback.
std::unique_ptr<NarrowPhase> makeLibccdNarrowPhase(const QueryOptions& query = {},
                                                   const CcdOptions& ccd = {});

}  // namespace core
}  // namespace collision_monitor
