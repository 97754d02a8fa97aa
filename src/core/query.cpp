/// \file
/// intersect / distance / signedDistance: one std::visit over the two cores per query, then a
/// fully typed GJK (and EPA) instantiation in A's frame. Radii are applied after convergence.
#include "collision_monitor/core/query.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <type_traits>
#include <variant>

#include "collision_monitor/core/epa.h"
#include "collision_monitor/core/gjk.h"
#include "collision_monitor/core/polytope_pair.h"

// Polytope pairs run their whole query compiled for AVX2 (runAvx2() below) where the CPU has it.
// Not in sanitizer builds: with ASan + UBSan, GCC compiled query.cpp for over 16 minutes with it
// (2 min 52 s without, then); they run the BasicPolytopePairDifference<false> path instead, and
// without forced inlining (CM_ALWAYS_INLINE, math.h).
#if defined(CM_HAVE_AVX2_SCAN) && !defined(__SANITIZE_ADDRESS__)
#define CM_AVX2_QUERY 1
#endif

namespace collision_monitor {
namespace core {

const char* toString(Status s) {
  switch (s) {
    case Status::Separated:
      return "Separated";
    case Status::Touching:
      return "Touching";
    case Status::Penetrating:
      return "Penetrating";
    case Status::FailedToConverge:
      return "FailedToConverge";
  }
  return "Unknown";
}

namespace {

/// Per-query support object of a polytope core with this pair's hill-climbing hint (-1: cold,
/// the climb starts at the polytope's direction table). Small polytopes are a structure-of-arrays
/// linear scan (Polytope::scanIndex), larger ones hill-climb.
struct PolytopeCore {
  const Polytope<3>* poly = nullptr;
  mutable int hint = -1;
  CM_ALWAYS_INLINE Vec3 support(const Vec3& d) const {
    return poly->vertices()[poly->supportIndex(d, hint)];
  }
  const Vec3& interiorPoint() const { return poly->interiorPoint(); }
};

template <class C>
const C& makeSupport(const C& c, int /*hint*/) {
  return c;
}
inline PolytopeCore makeSupport(const std::shared_ptr<const Polytope<3>>& p, int hint) {
  PolytopeCore s;
  s.poly = p.get();
  s.hint = hint;
  return s;
}
template <class S>
int hintOf(const S& /*s*/, int old) {
  return old;
}
inline int hintOf(const PolytopeCore& s, int /*old*/) {
  return s.hint;
}

/// A type-erased Minkowski difference: one function pointer per support call. EPA is not the hot
/// path (it only runs on penetrating pairs of signedDistance()), so it is compiled once for this
/// type instead of once per core-type pair (49 instantiations): query.cpp compiles several times
/// faster, and the indirect call is small next to EPA's own work per support point.
struct ErasedDifference {
  static constexpr int kDim = 3;
  const void* md = nullptr;
  SupportPoint<3> (*fn)(const void*, const Vec3&) = nullptr;
  SupportPoint<3> (*from_local)(const void*, const Vec3&, const Vec3&) = nullptr;
  Vec3 (*to_local_b)(const void*, const Vec3&) = nullptr;
  Vec3 initial = Vec3::UnitX();
  SupportPoint<3> support(const Vec3& d) const { return fn(md, d); }
  SupportPoint<3> fromLocal(const Vec3& a, const Vec3& b) const { return from_local(md, a, b); }
  Vec3 toLocalB(const Vec3& b) const { return to_local_b(md, b); }
  Vec3 initialDirection() const { return initial; }
};

template <class MD>
ErasedDifference eraseDifference(const MD& md) {
  ErasedDifference e;
  e.md = &md;
  e.fn = [](const void* p, const Vec3& d) { return static_cast<const MD*>(p)->support(d); };
#ifdef CM_AVX2_QUERY
  if constexpr (std::is_same_v<MD, BasicPolytopePairDifference<true>> ||
                std::is_same_v<MD, BasicPolytopePairDifference<true, false>>) {
    // Its four-lane scans are fast only inside AVX2 code (runAvx2()); elsewhere GCC splits them
    // into scalar code (hull100 signed distance: 7.3 us per query that way).
    e.fn = [](const void* p, const Vec3& d) __attribute__((target("avx2"))) {
      return static_cast<const MD*>(p)->support(d);
    };
  }
#endif
  e.from_local = [](const void* p, const Vec3& a, const Vec3& b) {
    return static_cast<const MD*>(p)->fromLocal(a, b);
  };
  e.to_local_b = [](const void* p, const Vec3& b) {
    return static_cast<const MD*>(p)->toLocalB(b);
  };
  e.initial = md.initialDirection();
  return e;
}

/// A - B scaled by `k`, a power of two (exact), for pairs so small or so large that squared
/// lengths or their squares leave the normal range (|v|^2 is subnormal below about 1e-154 m and 0
/// below about 1e-162 m: a box 2.8e-289 m from a point was reported touching, GJK ending at once
/// on |v|^2 = 0: fuzz/regressions/core/gjk-underflow-box-2.8e-289-from-point; see kTinySize).
/// One instantiation for every core type (through ErasedDifference); results are divided by k
/// again (query()).
struct ScaledDifference {
  static constexpr int kDim = 3;
  const ErasedDifference* md;
  double k;
  SupportPoint<3> support(const Vec3& d) const { return scaled(md->support(d)); }
  SupportPoint<3> fromLocal(const Vec3& a, const Vec3& b) const {
    return scaled(md->fromLocal(a, b));
  }
  Vec3 toLocalA(const Vec3& a) const { return a / k; }
  Vec3 toLocalB(const Vec3& b) const { return md->toLocalB(b / k); }
  Vec3 initialDirection() const { return md->initialDirection(); }
  SupportPoint<3> scaled(SupportPoint<3> p) const {
    p.a *= k;
    p.b *= k;
    p.w = p.a - p.b;
    return p;
  }
};

/// Pairs smaller than kTinySize or larger than kHugeSize (PairFrame::size, m) run scaled to a
/// size of about 1 (ScaledDifference). Triangle normals' squared norms (in GJK and EPA) are
/// fourth powers of lengths: they underflow below about 1e-77 m and overflow above about 1e77 m.
/// A 3e-86 m disc and box got a normal 0.2 rad off (fuzz/regressions/core/
/// gjk-tiny-pair-1e-86-triangle-underflow); with 1e-100 as the bound only squared lengths
/// were covered.
constexpr double kTinySize = 1e-60;
constexpr double kHugeSize = 1e60;

/// EPA on the erased difference: the one instantiation of epa3 in the library.
[[gnu::noinline]] EpaResult<3> runEpa(const ErasedDifference& md, const Simplex<3>& simplex,
                                      const EpaSettings& es) {
  return epa3(md, simplex, es);
}

/// What every query needs about the pair: the relative transform and the size scale.
struct PairFrame {
  const ConvexShape* a;
  const ConvexShape* b;
  const Transform3* pose_a;
  const Transform3* pose_b;
  Transform3 T_AB;  ///< B's core frame -> A's core frame (ConvexShape::offset())
  double rA, rB;    ///< radii (m)
  double size;      ///< local radii + |relative translation| (m): the tolerance scale
  /// Power of two the Minkowski difference is scaled by (1 unless the size is outside [kTinySize,
  /// kHugeSize]): GJK and EPA lengths are size-proportional by this factor, results are divided by
  /// it.
  double scale;
  bool finite;  ///< false when a pose has NaN/Inf entries (no query is run then)
  /// An uncertain answer may be retried in B's frame (retryInFrameOfB(); false there).
  bool may_swap;
  /// The size in the units GJK and EPA work in (size * scale): the scale of their tolerances.
  double workSize() const { return size * scale; }
};

/// 0 for finite x, NaN for NaN or +-Inf (0 * Inf = NaN): summed over a matrix, NaN propagates.
template <class M>
double nonFinite(const M& m) {
  double s = 0.0;
  for (int i = 0; i < m.size(); ++i)
    s += 0.0 * m.data()[i];
  return s;
}

PairFrame makeFrame(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                    const Transform3& pose_b, bool may_swap = true) {
  PairFrame f;
  f.a = &a;
  f.b = &b;
  f.pose_a = &pose_a;
  f.pose_b = &pose_b;
  f.may_swap = may_swap;
  // T_AB = T_A^-1 T_B = (R_A^T R_B, R_A^T (t_B - t_A)), written out (Eigen's products were calls).
  for (int c = 0; c < 3; ++c)
    f.T_AB.R.col(c) = mulTransposed<3>(pose_a.R, pose_b.R.col(c));
  f.T_AB.t = mulTransposed<3>(pose_a.R, pose_b.t - pose_a.t);
  // Between the cores' frames (ConvexShape::offset()): (T_A O_A)^-1 T_B O_B.
  if (__builtin_expect(a.hasOffset() || b.hasOffset(), 0))
    f.T_AB.t += f.T_AB.R * b.offset() - a.offset();
  f.rA = a.radius();
  f.rB = b.radius();
  double tn = f.T_AB.t.norm();
  if (!(tn >= 1e-150 && tn <= 1e150)) tn = f.T_AB.t.stableNorm();  // |t|^2 under- or overflowed
  f.size = a.localRadius() + b.localRadius() + tn;
  // A NaN or Inf in either pose reaches T_AB (0 * NaN and 0 * Inf are NaN): checking T_AB.R and
  // the size (which holds |T_AB.t|) covers both poses.
  f.finite = nonFinite(f.T_AB.R) == 0.0 && std::isfinite(f.size);
  // Brings the size to about 1 (at most 2^1000: a 5e-324 m pair becomes 5e-23 m, enough).
  f.scale = f.size > 0.0 && (f.size < kTinySize || f.size > kHugeSize)
                ? std::ldexp(1.0, std::clamp(-std::ilogb(f.size), -1000, 1000))
                : 1.0;
  return f;
}

GjkSettings gjkSettings(const PairFrame& f, const QueryOptions& o) {
  GjkSettings s;
  s.rel_tolerance = o.rel_tolerance;
  s.abs_tolerance = o.rel_tolerance * f.workSize();
  s.max_iterations = o.max_iterations;
  return s;
}

/// EPA's: its own relative tolerance and bound, GJK's length unit.
EpaSettings epaSettings(const PairFrame& f, const QueryOptions& o) {
  EpaSettings s;
  s.rel_tolerance = o.epa_rel_tolerance;
  s.abs_tolerance = gjkSettings(f, o).abs_tolerance;
  s.max_iterations = o.max_epa_iterations;
  return s;
}

/// fn(MD(args...)) with the whole query (GJK loop, sub-algorithm, supports) inlined into one
/// function compiled for AVX2, for small polytope pairs where the CPU has it (cpuHasAvx2()): VEX
/// three-operand instructions instead of SSE2's register copies, and
/// BasicPolytopePairDifference<true>'s four-lane scans without a call. No FMA (target "avx2"
/// does not enable it), so every result is the baseline build's, bit for bit (tested in
/// test_convex_hull). Measured per hull12 distance query: 3,395 -> 2,829 instructions, 293 ->
/// 274 ns. Not for the other pairs: compiled for all 49 core-type pairs, query.cpp took 5 minutes
/// and 11 MB, and the climbing polytopes (hull100, hull500) did not get faster.
#ifdef CM_AVX2_QUERY
template <class MD, class Fn, class... Args>
__attribute__((target("avx2"), flatten)) auto runAvx2(Fn& fn, const Args&... args) {
  return fn(MD(args...));
}
#endif

/// Visit the two cores once and run `fn(md)` on their typed Minkowski difference (A's frame).
/// Keeps the polytope hints in the cache.
template <class Fn>
auto withPair(const ConvexShape& a, const ConvexShape& b, const PairFrame& frame, PairCache* cache,
              Fn&& fn) {
  const int ha = cache != nullptr ? cache->hint_a : -1;
  const int hb = cache != nullptr ? cache->hint_b : -1;
  return std::visit(
      [&](const auto& ca, const auto& cb) {
        // A tiny or huge pair (kTinySize, kHugeSize): rare, one instantiation for all.
        if (frame.scale != 1.0) {
          const auto& sa = makeSupport(ca, -1);
          const auto& sb = makeSupport(cb, -1);
          const MinkowskiDifference<3, std::decay_t<decltype(sa)>, std::decay_t<decltype(sb)>> md(
              sa, sb, frame.T_AB);
          const ErasedDifference erased = eraseDifference(md);
          return fn(ScaledDifference{&erased, frame.scale});
        }
        using Poly = std::shared_ptr<const Polytope<3>>;
        if constexpr (std::is_same_v<std::decay_t<decltype(ca)>, Poly> &&
                      std::is_same_v<std::decay_t<decltype(cb)>, Poly>) {
          // This path scans and keeps no hints: the cache's hints stay as they are.
          if (PolytopePairDifference::applies(*ca, *cb)) {
#ifdef CM_AVX2_QUERY
            // Two instantiations per query, B mapped into A's frame or not (kMapMax): query.cpp
            // compiles in 36 s instead of 30 s at -O3.
            if (ca->scansAvx2()) {
              if (cb->size() <= PolytopePairDifference::kMapMax)
                return runAvx2<BasicPolytopePairDifference<true>>(fn, *ca, *cb, frame.T_AB);
              return runAvx2<BasicPolytopePairDifference<true, false>>(fn, *ca, *cb, frame.T_AB);
            }
#endif
            return fn(PolytopePairDifference(*ca, *cb, frame.T_AB));
          }
        }
        const auto& sa = makeSupport(ca, ha);
        const auto& sb = makeSupport(cb, hb);
        using SA = std::decay_t<decltype(sa)>;
        using SB = std::decay_t<decltype(sb)>;
        const MinkowskiDifference<3, SA, SB> md(sa, sb, frame.T_AB);
        auto result = fn(md);
        if (cache != nullptr) {
          cache->hint_a = hintOf(sa, cache->hint_a);
          cache->hint_b = hintOf(sb, cache->hint_b);
        }
        return result;
      },
      a.core(), b.core());
}

/// Warm-start seed: the cached local support points re-evaluated for the current poses (they are
/// still points of A - B).
template <class MD>
const Simplex<3>* seedFromCache(const MD& md, const PairCache* cache, Simplex<3>& seed) {
  if (cache == nullptr || cache->size <= 0 || cache->size > 4) return nullptr;
  seed.size = cache->size;
  for (int i = 0; i < cache->size; ++i)
    seed.v[i] = md.fromLocal(cache->local_a[i], cache->local_b[i]);
  return &seed;
}

/// `seed_kept` (GjkResult::seed_kept): nonzero when `s` is the seed reduced to those vertices;
/// the cached points are then reduced alike, with no mapping back (and no rounding added).
template <class MD>
void storeCache(const MD& md, const Simplex<3>& s, unsigned seed_kept, PairCache* cache) {
  if (cache == nullptr) return;
  if (seed_kept != 0) {
    int n = 0;
    for (int i = 0; i < cache->size; ++i) {
      if (((seed_kept >> i) & 1u) == 0) continue;
      cache->local_a[n] = cache->local_a[i];
      cache->local_b[n] = cache->local_b[i];
      ++n;
    }
    cache->size = n;
    return;
  }
  cache->size = s.size;
  for (int i = 0; i < s.size; ++i) {
    cache->local_a[i] = md.toLocalA(s.v[i].a);
    cache->local_b[i] = md.toLocalB(s.v[i].b);
  }
}

/// x / |x|, or `fallback` when x is 0 or not finite. Scaled by its largest component first, so
/// that |x|^2 neither underflows nor overflows (a 3.4e-161 m offset gave a "unit" normal of length
/// 0.9987: fuzz/regressions/core/distance-normal-subnormal-offset).
Vec3 unitOr(const Vec3& x, const Vec3& fallback) {
  const double m = x.cwiseAbs().maxCoeff();
  if (!(m > 0.0) || !(m < std::numeric_limits<double>::infinity())) return fallback;
  const Vec3 s = x / m;
  return s / s.norm();
}

/// Normal (A's frame, A towards B) for cores whose Minkowski difference is flat and contains the
/// origin: every direction out of the flat set gives depth 0 for the cores, so depth rA + rB for
/// the full shapes. Ties are broken towards B's origin (t_AB); never NaN.
Vec3 flatNormal(const EpaResult<3>& e, const Vec3& t_AB) {
  if (e.flat_dimension == 2) {
    return e.normal.dot(t_AB) < 0.0 ? Vec3(-e.normal) : e.normal;
  }
  if (e.flat_dimension == 1) {
    const Vec3& u = e.flat_direction;
    const Vec3 c = t_AB - t_AB.dot(u) * u;
    return unitOr(c, u.unitOrthogonal());
  }
  return unitOr(t_AB, Vec3::UnitX());
}

/// Fill the common-frame fields from A-frame core results (in GJK/EPA units: scaled by f.scale,
/// divided back here, exactly: a power of two) plus radii.
void finish(const PairFrame& f, const QueryOptions& o, double core_signed, const Vec3& pa_core,
            const Vec3& pb_core, const Vec3& n, bool failed, ContactResult& r) {
  const Transform3& Ta = *f.pose_a;
  const Vec3& oA = f.a->offset();
  const double unscale = 1.0 / f.scale;
  r.distance = core_signed * unscale - (f.rA + f.rB);
  r.normal = Ta.R * n;
  r.point_a = Ta * Vec3(pa_core * unscale + f.rA * n + oA);
  r.point_b = Ta * Vec3(pb_core * unscale - f.rB * n + oA);
  const double band = o.touch_tolerance * f.size;
  if (failed) {
    r.status = Status::FailedToConverge;
  } else if (std::abs(r.distance) <= band) {
    r.status = Status::Touching;
  } else {
    r.status = r.distance > 0.0 ? Status::Separated : Status::Penetrating;
  }
}

void retryInFrameOfB(const PairFrame& f, const QueryOptions& o, bool want_depth, ContactResult& r);

/// GJK (and EPA) on one pair's Minkowski difference.
template <class MD>
ContactResult query(const MD& md, const PairFrame& f, PairCache* cache, const QueryOptions& o,
                    bool want_depth) {
  ContactResult r;
  Simplex<3> seed;
  const GjkSettings gs = gjkSettings(f, o);
  const GjkResult<3> g = gjkDistance(md, gs, seedFromCache(md, cache, seed));
  storeCache(md, g.simplex, g.seed_kept, cache);
  r.gjk_iterations = g.iterations;
  if (g.status != GjkStatus::Intersecting) {
    // g.distance = |g.v| > abs_tolerance >= 0 here; unitOr() only where |v|^2 may have lost
    // digits to underflow (one division instead of six and a square root on the common path),
    // or where a stalled run reports its normal along another direction (GjkResult::cert_v).
    const Vec3& dir = g.normalDirection();
    const Vec3 n = g.distance > 1e-150 && &dir == &g.v ? Vec3(g.v * (-1.0 / g.distance))
                                                       : unitOr(-dir, Vec3::UnitX());
    finish(f, o, g.distance, g.point_a, g.point_b, n, g.status == GjkStatus::MaxIterations, r);
    // distance() reports 0 for overlapping shapes (query.h), even when the depth came for free
    // (separated cores, overlapping radii).
    if (!want_depth && r.status == Status::Penetrating) r.distance = 0.0;
    // Retried in B's frame where GJK's answer is uncertain by more than the touching band: a stall
    // in rounding left its lower bound that far below |v|, or rounding left v that far from its
    // witness points' difference (a sliver's weights; then |v| need not bound the distance).
    const double band = o.touch_tolerance * f.workSize();
    if (f.may_swap &&
        ((__builtin_expect(g.uncertified, 0) && g.distance - certifiedLower(g) > band) ||
         (g.point_a - g.point_b - g.v).squaredNorm() > band * band))
      retryInFrameOfB(f, o, want_depth, r);
    return r;
  }
  if (!want_depth) {
    // distance(): the cores overlap (or touch within the GJK tolerance). A full simplex encloses
    // the origin (penetration); with radii beyond the band the shapes overlap. A smaller simplex
    // has the origin on it: on A - B's boundary (touching), or inside A - B on a segment or
    // triangle of support points by symmetry (a point at a cylinder's centre, concentric boxes:
    // both were reported touching). EPA tells them apart, only here.
    // The normal: EPA's where it ran (the contact normal of touching shapes), else from A's origin
    // towards B's.
    const double band = o.touch_tolerance * f.size;
    bool enclosed = g.simplex.size == 4 || f.rA + f.rB > band;
    Vec3 n = unitOr(f.T_AB.t, Vec3::UnitX());
    if (!enclosed) {
      const EpaResult<3> e = runEpa(eraseDifference(md), g.simplex, epaSettings(f, o));
      r.epa_iterations = e.iterations;
      enclosed = e.status != EpaStatus::Flat && e.depth > o.touch_tolerance * f.workSize();
      if (e.status == EpaStatus::Converged) n = e.normal;
    }
    finish(f, o, 0.0, g.point_a, g.point_b, n, false, r);
    r.distance = 0.0;
    r.status = enclosed ? Status::Penetrating : Status::Touching;
    return r;
  }
  const EpaSettings es = epaSettings(f, o);
  const EpaResult<3> e = runEpa(eraseDifference(md), g.simplex, es);
  r.epa_iterations = e.iterations;
  if (e.status == EpaStatus::Flat) {
    finish(f, o, 0.0, e.point_a, e.point_b, flatNormal(e, f.T_AB.t), false, r);
    return r;
  }
  // Unconverged EPA still settles the answer when its upper bound on the depth is inside the
  // touching band: the cores' signed distance is then within [-band, GJK tolerance]. A bound
  // below -(GJK tolerance) contradicts GJK's verdict (support rounding on extreme shapes, e.g. a
  // 1.4 m x 3.3e6 m cone: fuzz_core) and settles nothing.
  const bool settled = e.depth_is_upper_bound && e.depth <= o.touch_tolerance * f.workSize() &&
                       e.depth >= -es.abs_tolerance;
  const bool failed = e.status != EpaStatus::Converged && !settled;
  finish(f, o, -e.depth, e.point_a, e.point_b, e.normal, failed, r);
  return r;
}

/// distance() and signedDistance() (kWantDepth); `may_swap`: PairFrame::may_swap.
template <bool kWantDepth>
CM_ALWAYS_INLINE ContactResult distanceIn(const ConvexShape& a, const Transform3& pose_a,
                                          const ConvexShape& b, const Transform3& pose_b,
                                          PairCache* cache, const QueryOptions& options,
                                          bool may_swap);

/// What an answer proves the signed distance is at most: its distance, or where its witness
/// points are further apart than that (rounding), their distance.
double upperBound(const ContactResult& r) {
  return r.status == Status::Separated ? std::max(r.distance, (r.point_b - r.point_a).norm())
                                       : r.distance;
}

/// After a query in A's frame (`r`) whose GJK answer is uncertain by more than the touching band
/// (see query()): the query once more in B's frame, without the cache, and `r` becomes that answer
/// (mapped back to A first) unless its upper bound (upperBound()) is the larger by more than the
/// touching band. Rounding sits differently there. A 1.78 m segment 5e-9 rad from parallel to a
/// box's face, its lower end on the face: in the segment's frame v came out perpendicular to its
/// axis to 4e-17 (its support a tie between the ends, decided by rounding), GJK stalled on the
/// diagonal of the face with a lower bound of -2.3e-8 m and answered 4.48e-9 m, the distance of
/// the segment's middle; in the box's frame the ends differ by 9e-9 m along v, and the answer was
/// 4.4e-16 m (fuzz/regressions/core/gjk-segment-by-box-face-5e-9-rad-tie-frame). A disc 2.1 m
/// across 7.84e-3 m from a needle ellipsoid 5.7e6 m long: in the disc's frame GJK's triangles
/// spanned the needle, their weights lost 1e-16 of 2.9e6 m vertices times the sliver's condition,
/// and v ended 3.06e-3 m long while its witness points were 1.6e-2 m apart; in the needle's
/// frame 7.8424e-3 m, 1.5e-6 m above the truth
/// (fuzz/regressions/core/gjk-disc-by-5.7e6m-needle-witness-mismatch). A flat ellipse touching a
/// padded flat ellipse 5.3e6 m long: in A's frame GJK ended uncertain (lower bound -1.1 m) with
/// v 2.3e-6 rad off, along which B reaches 6.1 m further; in B's frame certified, 8e-11 m above the
/// first answer: that normal is kept
/// (fuzz/regressions/core/gjk-ellipse-touching-padded-5.3e6m-ellipse-normal).
[[gnu::noinline, gnu::cold]] void retryInFrameOfB(const PairFrame& f, const QueryOptions& o,
                                                  bool want_depth, ContactResult& r) {
  ContactResult s = want_depth
                        ? distanceIn<true>(*f.b, *f.pose_b, *f.a, *f.pose_a, nullptr, o, false)
                        : distanceIn<false>(*f.b, *f.pose_b, *f.a, *f.pose_a, nullptr, o, false);
  s.gjk_iterations += r.gjk_iterations;
  s.epa_iterations += r.epa_iterations;
  r.gjk_iterations = s.gjk_iterations;
  r.epa_iterations = s.epa_iterations;
  // The retried answer unless the first one's upper bound is lower by more than the touching
  // band: within it the retried one, certified unless rounding fails in both frames, also has the
  // better normal (the flat ellipses above).
  if (s.status == Status::FailedToConverge ||
      upperBound(r) < upperBound(s) - o.touch_tolerance * f.size)
    return;
  std::swap(s.point_a, s.point_b);
  s.normal = -s.normal;
  r = s;
}

template <bool kWantDepth>
CM_ALWAYS_INLINE ContactResult distanceIn(const ConvexShape& a, const Transform3& pose_a,
                                          const ConvexShape& b, const Transform3& pose_b,
                                          PairCache* cache, const QueryOptions& options,
                                          bool may_swap) {
  const PairFrame f = makeFrame(a, pose_a, b, pose_b, may_swap);
  if (!f.finite) return ContactResult{};  // FailedToConverge, distance +inf, normal UnitX
  const auto run = [&] {
    return withPair(a, b, f, cache,
                    [&](const auto& md) { return query(md, f, cache, options, kWantDepth); });
  };
  if constexpr (!kWantDepth) return run();
  const bool warm = cache != nullptr && cache->size > 0;
  ContactResult r = run();
  if (!warm || r.status != Status::FailedToConverge) return r;
  // A warm seed that holds the origin only to rounding can start EPA on a polytope the origin is
  // outside of: a capsule crossing a flat 4750 m box (vertices 2400 m out) cycled through the
  // same three support points for 256 iterations (FailedToConverge, depth 0.38 m) where the cold
  // query's EPA converged in 4 (0.217 m): fuzz/regressions/core/epa-warm-capsule-by-flat-4750m-box.
  // Such a query runs again cold (and caches the cold simplex). Here, not inside query(): there
  // the fallback cost 47 / 86 instructions per hull12 distance / warm query (code generation).
  cache->size = 0;
  return run();
}

/// `cache` bound to (a, b) (PairCache): a cache of other shapes, or of these in the other order,
/// starts cold.
CM_ALWAYS_INLINE PairCache* bindCache(PairCache* cache, const ConvexShape& a,
                                      const ConvexShape& b) {
  if (cache != nullptr &&
      __builtin_expect(cache->core_a != a.coreId() || cache->core_b != b.coreId(), 0)) {
    cache->size = 0;  // its points are not read again
    cache->hint_a = -1;
    cache->hint_b = -1;
    cache->core_a = a.coreId();
    cache->core_b = b.coreId();
  }
  return cache;
}

}  // namespace

bool intersect(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
               const Transform3& pose_b, PairCache* cache, const QueryOptions& options) {
  cache = bindCache(cache, a, b);
  const PairFrame f = makeFrame(a, pose_a, b, pose_b);
  if (!f.finite) return true;  // undecidable: conservative
  // Touching counts as intersecting: the same band as signedDistance()'s Touching.
  const double margin = (f.rA + f.rB + options.touch_tolerance * f.size) * f.scale;
  return withPair(a, b, f, cache, [&](const auto& md) {
    Simplex<3> s;
    const Simplex<3>* seed = seedFromCache(md, cache, s);
    if (seed == nullptr) s.size = 0;
    unsigned kept = 0;
    const bool hit = gjkIntersect(md, margin, gjkSettings(f, options), &s, nullptr, &kept);
    storeCache(md, s, kept, cache);
    return hit;
  });
}

ContactResult distance(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                       const Transform3& pose_b, PairCache* cache, const QueryOptions& options) {
  return distanceIn<false>(a, pose_a, b, pose_b, bindCache(cache, a, b), options, true);
}

ContactResult signedDistance(const ConvexShape& a, const Transform3& pose_a, const ConvexShape& b,
                             const Transform3& pose_b, PairCache* cache,
                             const QueryOptions& options) {
  return distanceIn<true>(a, pose_a, b, pose_b, bindCache(cache, a, b), options, true);
}

}  // namespace core
}  // namespace collision_monitor
