/// \file
/// Narrow-phase backends behind one interface, selectable at run time: our GJK/EPA ("gjk") and
/// libccd ("libccd": ccdGJKIntersect and ccdGJKPenetration, MPR selectable in CcdOptions). libccd
/// 2.1 has no distance query, so the libccd backend answers separation distances with our GJK
/// distance; and neither of libccd's verdicts is taken on trust (ccd_backend.cpp).
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "collision_monitor/core/query.h"

namespace collision_monitor {
namespace core {

enum class BackendType { Gjk, Libccd };

/// "gjk" or "libccd" -> type; anything else -> nullopt.
std::optional<BackendType> parseBackend(const std::string& name);
const char* toString(BackendType type);

class NarrowPhase {
 public:
  virtual ~NarrowPhase() = default;
  virtual BackendType type() const = 0;
  /// Same contract as core::intersect() (overlap or touch). Libccd: libccd's GJK first, its
  /// verdict confirmed (apart by our GJK's boolean query, contact by signedDistance()), so it
  /// agrees with signedDistance()'s sign.
  virtual bool intersect(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                         const Transform3& pose_b, PairCache* cache) const = 0;
  /// Same contract as core::signedDistance(), with libccd's accuracy for Libccd: its EPA's depth
  /// is exact on polytope cores but can be far off deep in curved cores (a point inside a unit
  /// ellipsoid: up to 0.13 m; shallow overlaps within 1e-5 of the size), and its witness points
  /// are only indicative (off the shapes by up to ~0.4 of the size); depth sign and normal hold.
  virtual ContactResult signedDistance(const ConvexShape& a, const Transform3& pose_a,
                                       const ConvexShape& b, const Transform3& pose_b,
                                       PairCache* cache) const = 0;
};

/// A backend instance. Instances hold no per-query state and are safe to share across threads.
std::unique_ptr<NarrowPhase> makeNarrowPhase(BackendType type, const QueryOptions& options = {});

}  // namespace core
}  // namespace collision_monitor
