/// \file
/// Backend selection: our GJK/EPA (forwarding to query.h) or libccd (ccd_backend.h).
#include "collision_monitor/core/backend.h"

#include "collision_monitor/core/ccd_backend.h"

namespace collision_monitor {
namespace core {
namespace {

/// Our GJK/EPA: a thin forwarder to core::intersect / core::signedDistance with fixed options.
class GjkNarrowPhase final : public NarrowPhase {
 public:
  explicit GjkNarrowPhase(const QueryOptions& options) : options_(options) {}
  BackendType type() const override { return BackendType::Gjk; }
  bool intersect(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                 const Transform3& pose_b, PairCache* cache) const override {
    return core::intersect(a, pose_a, b, pose_b, cache, options_);
  }
  ContactResult signedDistance(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                               const Transform3& pose_b, PairCache* cache) const override {
    return core::signedDistance(a, pose_a, b, pose_b, cache, options_);
  }

 private:
  QueryOptions options_;
};

}  // namespace

std::optional<BackendType> parseBackend(const std::string& name) {
  if (name == "gjk") return BackendType::Gjk;
  if (name == "libccd") return BackendType::Libccd;
  return std::nullopt;
}

const char* toString(BackendType type) {
  switch (type) {
    case BackendType::Gjk:
      return "gjk";
    case BackendType::Libccd:
      return "libccd";
  }
  return "unknown";
}

std::unique_ptr<NarrowPhase> makeNarrowPhase(BackendType type, const QueryOptions& options) {
  switch (type) {
    case BackendType::Gjk:
      return std::make_unique<GjkNarrowPhase>(options);
    case BackendType::Libccd:
      return makeLibccdNarrowPhase(options);
  }
  return nullptr;
}

}  // namespace core
}  // namespace collision_monitor
