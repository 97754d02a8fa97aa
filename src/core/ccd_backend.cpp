/// \file
/// libccd 2.1 adapter (see ccd_backend.h for the frame/scale conventions).
///
/// Measured choices (test_ccd_backend, against the exact oracle of test/core/oracle.h):
///   - intersect: ccdGJKIntersect. Its verdicts and ccdMPRIntersect's agree with the oracle
///     outside a thin band; GJK is the one whose terminal simplex matches its penetration query.
///   - penetration: ccdGJKPenetration (GJK + EPA). ccdMPRPenetration is not a minimum-depth
///     query (it refines the portal along the centre-to-centre ray), so its depth overestimates
///     the exact one by up to ~50 % of the size on boxes; EPA at epa_tolerance 1e-10 has depth
///     errors <= 3e-11 of the size on boxes and <= 2.2e-6 on random hulls (its second stopping
///     test compares a squared distance with the tolerance).
///   - known libccd 2.1 weakness, measured on full shapes (ccdPenetration): on shapes with a
///     radius (spheres, capsules) its GJK+EPA can end on a "touching contact" and report depth 0
///     for a deep overlap, or stop EPA on a wrong face (depth errors up to ~99 % of the size on
///     sphere pairs). The backend therefore gives libccd the cores only and adds the radii after
///     convergence, as our GJK does (measured through the backend: <= 3e-6 of the size on every
///     category, test_ccd_backend BackendKeepsRadiiOutOfLibccd).
///   - where libccd cannot be trusted the backend answers with our GJK/EPA instead: poses with
///     NaN/Inf (libccd dereferences a null pointer inside ccdGJKPenetration on them), and a
///     "touching contact" from ccdGJKPenetration (depth within the touching band), which is how
///     its EPA gives up on flat Minkowski differences and on some deep sphere/capsule overlaps
///     (e.g. a zero-thickness box 955 m deep inside a sphere: libccd depth 0).
///   - a libccd contact claim is checked against the supports (see contradicts()): along its own
///     normal and along the separating axis our GJK finds. libccd's GJK ends "inside" for thin,
///     long pairs that are apart (a 2.2 m needle 0.055 m from a 2875 m x 2.5 m disc: raw libccd
///     contact, depth 0.055 m; 1 mm thick: depth 0.96 m); the backend then answers with our GJK.
///   - precision: libccd's GJK uses absolute epsilons in the unit-size frame; on very thin or long
///     pairs its verdicts can be wrong within ~1e-5 of the size (fuzz_core: a 2e6 m triangle
///     3.13 m deep in a cylinder reported apart), on cone and sphere pairs up to 1.3e-4 (the
///     sixteenth session's audit, docs/reliability.md). A false "apart" is not refuted here
///     (libccd gives no evidence to check); our GJK (the default backend) is exact to 1e-9 of the
///     size.
///   - witness points: libccd's `pos` is a median of EPA polytope vertices, not a contact point;
///     point_a/point_b = pos +- depth/2 * normal are only indicative (off the surfaces by up to
///     ~0.4 of the size, measured).
#include "collision_monitor/core/ccd_backend.h"

#include <ccd/ccd.h>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <variant>

namespace collision_monitor {
namespace core {
namespace {

/// Support calls of one query, both bodies (see CcdOptions::max_support_calls).
struct CcdBudget {
  unsigned long calls = 0;
  unsigned long limit = 0;
  bool exhausted = false;
};

/// One body as libccd sees it: the full shape (core + radius) posed in A's core frame (A's frame
/// moved to A's ConvexShape::offset()), scaled.
struct CcdBody {
  CcdBudget* budget = nullptr;
  bool first = false;  ///< libccd's obj1 (support1)
  const ConvexShape* shape = nullptr;
  Transform3 pose;         ///< shape frame -> A's frame
  double scale = 1.0;      ///< libccd coordinates = scale * A's-frame coordinates
  bool core_only = false;  ///< support of the core only (radius left out)
  Vec3 centre;             ///< an interior point, libccd coordinates
};

Vec3 toEigen(const ccd_vec3_t* v) {
  return Vec3(v->v[0], v->v[1], v->v[2]);
}
void toCcd(const Vec3& p, ccd_vec3_t* v) {
  ccdVec3Set(v, p.x(), p.y(), p.z());
}

/// A point inside the core, about the core's origin (ConvexShape::offset()); MPR needs an interior
/// point as its portal origin. Every core keeps one (a polytope its vertices' mean).
Vec3 coreInteriorPoint(const ConvexShape& s) {
  return std::visit(
      [](const auto& c) -> Vec3 {
        using T = std::decay_t<decltype(c)>;
        if constexpr (std::is_same_v<T, std::shared_ptr<const Polytope<3>>>) {
          return c ? c->interiorPoint() : Vec3::Zero();
        } else {
          return c.interiorPoint();
        }
      },
      s.core());
}

void support(const void* obj, const ccd_vec3_t* dir, ccd_vec3_t* out) {
  const CcdBody* body = static_cast<const CcdBody*>(obj);
  if (++body->budget->calls > body->budget->limit) {
    // Out of budget. libccd 2.1's EPA asks for the support along the nearest element's witness
    // w and stops when (s1(w) - s2(-w)) . w - |w|^2 < epa_tolerance: answering s1 = w, s2 = 0
    // makes that 0, so EPA ends on its current polytope; GJK/MPR end on max_iterations anyway.
    body->budget->exhausted = true;
    if (body->first) {
      *out = *dir;
    } else {
      ccdVec3Set(out, 0.0, 0.0, 0.0);
    }
    return;
  }
  const Vec3 d_local = body->pose.R.transpose() * toEigen(dir);
  const Vec3 s = body->shape->localSupport(d_local, body->core_only);
  toCcd(body->scale * (body->pose * s), out);
}

void centre(const void* obj, ccd_vec3_t* c) {
  toCcd(static_cast<const CcdBody*>(obj)->centre, c);
}

/// First GJK direction: centre of A to centre of B. (Measured: tilting it away from that line
/// made ccdGJKIntersect miss 5 of 2,000 overlapping sphere pairs; along it, none.)
void firstDir(const void* o1, const void* o2, ccd_vec3_t* dir) {
  const Vec3 d = static_cast<const CcdBody*>(o2)->centre - static_cast<const CcdBody*>(o1)->centre;
  toCcd(d.squaredNorm() > 0.0 ? d : Vec3::UnitX(), dir);
}

/// The pair in A's core frame (A's frame moved to A's offset()), scaled to unit size, and the
/// ccd_t to query it with. About the cores' offsets, as our GJK (query.cpp): with a hull given
/// 1e3 m from its frame's origin, sized by the radii about that origin, libccd saw 1 cm cubes as
/// 3.5e-6 of its unit frame, and its absolute EPA tolerance gave a depth of 2.26 mm for 2 mm.
struct CcdPair {
  CcdBody a, b;
  ccd_t ccd;
  /// max(localRadius(A) + localRadius(B), distance between the cores' origins), m
  double size = 1.0;
  mutable CcdBudget budget;  ///< a and b point here: not copyable
  CcdPair(const CcdPair&) = delete;
  CcdPair& operator=(const CcdPair&) = delete;

  CcdPair(const ConvexShape& sa, const Transform3& pose_a, const ConvexShape& sb,
          const Transform3& pose_b, const CcdOptions& o) {
    a.shape = &sa;
    a.pose = Transform3::Identity();
    b.shape = &sb;
    b.pose = pose_a.inverse() * pose_b;  // B's frame -> A's frame; then B's core -> A's core frame
    b.pose.t += b.pose.R * sb.offset() - sa.offset();
    // Or the distance between the cores' origins where that is larger (bounding balls apart: the
    // backend leaves such pairs to our GJK, libccdCanAnswer()): with the radii alone, a
    // 8.9e-308 m cylinder and a point 1140 m away were scaled by 2.2e307, B's points overflowed
    // to inf and ccdGJKPenetration dereferenced a null pointer (fuzz/regressions/core/
    // libccd-segv-point-1140m-from-8.9e-308m-cylinder). Every coordinate is at most about 1.
    size = std::max(sa.localRadius() + sb.localRadius(), b.pose.t.stableNorm());
    // Two points at one place (size 0) or sub-normal sizes (1/size overflows to inf and every
    // support point becomes NaN, on which ccdGJKPenetration dereferences a null pointer): any
    // finite scale works for those, so use 1.
    if (!(size > 0.0) || !std::isfinite(1.0 / size) || !std::isfinite(size)) size = 1.0;
    const double s = 1.0 / size;
    a.scale = b.scale = s;
    a.core_only = b.core_only = o.cores_only;
    budget.limit = o.max_support_calls;
    a.budget = b.budget = &budget;
    a.first = true;
    a.centre = s * coreInteriorPoint(sa);
    b.centre = s * (b.pose * coreInteriorPoint(sb));
    CCD_INIT(&ccd);
    ccd.first_dir = firstDir;
    ccd.support1 = support;
    ccd.support2 = support;
    ccd.center1 = centre;
    ccd.center2 = centre;
    ccd.max_iterations = o.max_iterations;
    ccd.epa_tolerance = o.epa_tolerance;
    ccd.mpr_tolerance = o.mpr_tolerance;
    ccd.dist_tolerance = o.dist_tolerance;
  }
};

/// Whether the supports contradict a claimed penetration `depth` >= 0 along unit `n` (A towards
/// B) of the posed cores: the projections on n are disjoint (a separating axis), or they overlap
/// by less than `depth` (the true depth is the smallest overlap over all axes). libccd's GJK can
/// end "inside" for thin, long cores that are apart (fuzz_core: 1.9e-5 of the size apart), and then
/// its EPA reports the distance as a depth, or a depth of 0.96 m for a gap of 0.05 m.
bool contradicts(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                 const Transform3& pose_b, const Vec3& n, double depth, double tolerance) {
  const auto extent = [&n](const ConvexShape& s, const Transform3& pose, double sign) {
    return sign * n.dot(pose * s.coreSupport(pose.R.transpose() * (sign * n)));
  };
  const double a_max = extent(a, pose_a, 1.0), a_min = -extent(a, pose_a, -1.0);
  const double b_max = extent(b, pose_b, 1.0), b_min = -extent(b, pose_b, -1.0);
  return b_min - a_max > tolerance || a_min - b_max > tolerance ||
         a_max - b_min < depth - tolerance;
}

bool finitePoses(const Transform3& pose_a, const Transform3& pose_b) {
  return pose_a.R.allFinite() && pose_a.t.allFinite() && pose_b.R.allFinite() &&
         pose_b.t.allFinite();
}

/// Pairs libccd is asked about: finite poses (libccd crashes on NaN), bounding balls that meet
/// (the distance between the cores' origins, ConvexShape::offset(), at most the sum of the radii
/// about them, localRadius(); else the shapes are apart, and libccd has no distance query) and a
/// size (that sum) of at most 1e9 m. libccd works in a frame scaled to unit size with absolute
/// epsilons; a box 8e165 m long by a 2.5 m box
/// (fuzz/regressions/core/libccd-segv-8e165m-box-by-subnormal-box) is a segment in that frame and
/// ccdGJKPenetration dereferenced a null pointer; so did a point 3e151 m from a 1e-163 m cylinder
/// (fuzz/regressions/core/libccd-segv-point-3e151m-from-cylinder) and one 1140 m from a 8.9e-308 m
/// cylinder (see CcdPair). No workspace is 1e9 m across; our GJK answers the rest.
bool libccdCanAnswer(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                     const Transform3& pose_b) {
  const double radii = a.localRadius() + b.localRadius();
  return finitePoses(pose_a, pose_b) && radii <= 1e9 &&
         (pose_b * b.offset() - pose_a * a.offset()).stableNorm() <= radii;
}

class LibccdNarrowPhase final : public NarrowPhase {
 public:
  LibccdNarrowPhase(const QueryOptions& query, const CcdOptions& ccd) : query_(query), ccd_(ccd) {}
  BackendType type() const override { return BackendType::Libccd; }
  bool intersect(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                 const Transform3& pose_b, PairCache* cache) const override {
    // Non-finite poses or an astronomic size: our defined answer; libccd would crash.
    if (!libccdCanAnswer(a, pose_a, b, pose_b)) {
      return core::intersect(a, pose_a, b, pose_b, cache, query_);
    }
    // Neither of libccd's answers is a certificate. Its GJK can claim contact for pairs that are
    // apart (see contradicts()); and it ends "apart" on a search direction shorter than its
    // epsilon or a flat simplex, where no support point failed to pass the origin: a sphere 3.2 mm
    // into a cone of 0.5 m (2 of 39,787 random near-contact pairs, all cone and sphere; test
    // LibccdIntersectConfirmsApartWithOurs), two points at one place. Apart is confirmed by our
    // GJK's boolean query, contact by the penetration query, which checks libccd's answer against
    // the supports: the answer is signedDistance()'s.
    if (!ccdIntersect(a, pose_a, b, pose_b, ccd_) &&
        !core::intersect(a, pose_a, b, pose_b, cache, query_)) {
      return false;
    }
    return signedDistance(a, pose_a, b, pose_b, cache).distance <= 0.0;
  }
  ContactResult signedDistance(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                               const Transform3& pose_b, PairCache* cache) const override {
    if (!libccdCanAnswer(a, pose_a, b, pose_b)) {
      return core::signedDistance(a, pose_a, b, pose_b, cache, query_);
    }
    // Radii stay out of libccd as out of our GJK: libccd's EPA is exact on polytope cores but
    // stops on wrong faces of curved (radius-swept) shapes. Cores overlapping: libccd's depth plus
    // the radii.
    CcdOptions cores = ccd_;
    cores.cores_only = true;
    ContactResult r;
    if (ccdPenetration(a, pose_a, b, pose_b, &r, cores, query_)) {
      // A "touching contact" is how libccd's EPA gives up (flat Minkowski differences, cores
      // that only touch): answer with our EPA rather than report depth 0.
      if (r.status != Status::Penetrating) {
        return core::signedDistance(a, pose_a, b, pose_b, cache, query_);
      }
      // libccd's answer stands unless the supports contradict it: along its own normal, or
      // along the separating axis our GJK finds (a certificate checked here, not a vote).
      const double tolerance = 1e-9 * (a.boundingRadius() + b.boundingRadius());
      if (contradicts(a, pose_a, b, pose_b, r.normal, -r.distance, tolerance)) {
        return core::signedDistance(a, pose_a, b, pose_b, cache, query_);
      }
      // And along our normal: for any axis the cores' overlap along it bounds the depth from
      // above, so a separating axis of ours, or an overlap along our EPA normal smaller than
      // libccd's depth, refutes libccd's answer.
      ContactResult ours = core::signedDistance(a, pose_a, b, pose_b, cache, query_);
      if (contradicts(a, pose_a, b, pose_b, ours.normal, -r.distance, tolerance)) return ours;
      r.distance -= a.radius() + b.radius();
      r.point_a += a.radius() * r.normal;
      r.point_b -= b.radius() * r.normal;
      return r;
    }
    // Cores apart: libccd 2.1 has no distance query, so the cores' distance (minus the radii,
    // negative when only the radii overlap) comes from our GJK.
    return core::signedDistance(a, pose_a, b, pose_b, cache, query_);
  }

 private:
  QueryOptions query_;
  CcdOptions ccd_;
};

}  // namespace

bool ccdIntersect(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                  const Transform3& pose_b, const CcdOptions& options) {
  const CcdPair p(a, pose_a, b, pose_b, options);
  return options.intersect == CcdAlgorithm::Mpr ? ccdMPRIntersect(&p.a, &p.b, &p.ccd) != 0
                                                : ccdGJKIntersect(&p.a, &p.b, &p.ccd) != 0;
}

bool ccdPenetration(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                    const Transform3& pose_b, ContactResult* out, const CcdOptions& options,
                    const QueryOptions& query) {
  const CcdPair p(a, pose_a, b, pose_b, options);
  ccd_real_t depth = 0.0;
  ccd_vec3_t dir, pos;
  ccdVec3Set(&dir, 0.0, 0.0, 0.0);
  ccdVec3Set(&pos, 0.0, 0.0, 0.0);
  const int rc = options.penetration == CcdAlgorithm::Mpr
                     ? ccdMPRPenetration(&p.a, &p.b, &p.ccd, &depth, &dir, &pos)
                     : ccdGJKPenetration(&p.a, &p.b, &p.ccd, &depth, &dir, &pos);
  ContactResult r;
  r.gjk_iterations = 0;
  r.epa_iterations = 0;
  if (p.budget.exhausted || (rc != 0 && rc != -1)) {  // -2: out of memory inside libccd
    r.status = Status::FailedToConverge;
    r.distance = 0.0;
    *out = r;
    return true;
  }
  if (rc == -1) return false;  // apart
  // Back to A's frame and metres.
  Vec3 n = toEigen(&dir);
  const double n_len = n.norm();
  if (std::isfinite(n_len) && n_len > 0.0) {
    n /= n_len;
  } else {
    // Touching contact: libccd returns no direction; centre to centre is defined.
    const Vec3 c = p.b.centre - p.a.centre;
    n = c.squaredNorm() > 0.0 ? Vec3(c.normalized()) : Vec3::UnitX();
  }
  const double d = std::isfinite(depth) ? std::max(0.0, static_cast<double>(depth)) * p.size : 0.0;
  const Vec3 c = toEigen(&pos) * p.size + a.offset();  // A's frame
  r.distance = -d;
  r.normal = pose_a.R * n;
  r.point_a = pose_a * (c + 0.5 * d * n);
  r.point_b = pose_a * (c - 0.5 * d * n);
  r.status = d <= query.touch_tolerance * p.size ? Status::Touching : Status::Penetrating;
  if (r.status == Status::Touching) r.distance = 0.0;
  *out = r;
  return true;
}

std::unique_ptr<NarrowPhase> makeLibccdNarrowPhase(const QueryOptions& query,
                                                   const CcdOptions& ccd) {
  return std::make_unique<LibccdNarrowPhase>(query, ccd);
}

}  // namespace core
}  // namespace collision_monitor
