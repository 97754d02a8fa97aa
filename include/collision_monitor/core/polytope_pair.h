/// \file
/// A - B for two small polytopes, both scanned linearly (see applies()): B's vertices are mapped
/// into A's frame once per query, as Box2D's b2ShapeDistance does with its point proxies. A support
/// point of A - B is then both scans in one call and no rotation: the general MinkowskiDifference
/// rotates every direction into B's frame and every support point of B back (two 3x3 products per
/// support, on the loop's critical path).
#pragma once

#include <array>

#include "collision_monitor/core/gjk.h"
#include "collision_monitor/core/shapes.h"

namespace collision_monitor {
namespace core {

/// `kAvx2`: false, the scans and the transform dispatch at run time (Polytope::scansAvx2()) to
/// the AVX2 functions or to two-lane vectors; true, they are four-lane vectors inlined into the
/// caller, for callers compiled for AVX2 (query.cpp compiles its whole polytope-pair query so,
/// see BasicPolytopePairDifference<true> there). Elsewhere the four-lane code still computes the
/// same, only slower.
/// `kMapB`: true, B's vertices are mapped into A's frame at construction and a support point is
/// both scans with no rotation; false, B is scanned in its own frame, the direction rotated into
/// it and B's support point mapped back per call, with MinkowskiDifference's arithmetic (its
/// support points bit for bit where it scans B too). Mapping costs about two scans of B, which a
/// large B with few support calls does not win back: see kMapMax.
template <bool kAvx2, bool kMapB = true>
class BasicPolytopePairDifference : public MinkowskiDifference<3, Polytope<3>, Polytope<3>> {
  using Base = MinkowskiDifference<3, Polytope<3>, Polytope<3>>;

 public:
  /// Most vertices of either polytope for this path on AVX2, where query.cpp runs it with both
  /// scans inlined, four vertices per instruction: up to here the scans beat hill-climbing
  /// (Polytope::supportIndex) on both shapes. Measured, ns per query, climbing / this path:
  /// 100 vertices distance 866 / 663, intersect 321 / 280; 128 vertices distance 911 / 816,
  /// intersect 342 / 339, warm 204 / 226; 150 vertices distance 961 / 971, intersect 356 / 402.
  /// Without AVX2 the limit is Polytope::kLinearScanMax, where climbing starts anyway.
  static constexpr int kMaxVerticesAvx2 = 120;
  /// Most vertices of B worth mapping (kMapB = true; query.cpp picks the instantiation).
  /// Measured on AVX2 (one-chain scans), ns per query, mapped / B in its own frame: 12 vertices
  /// distance 253 / 266, intersect 134 / 148; 32: 365 / 378, 161 / 174; 100: distance 667 / 671,
  /// intersect 276 / 260, warm 177 / 153. Without AVX2 B has at most Polytope::kLinearScanMax
  /// vertices here.
  static constexpr int kMapMax = 64;
  /// Largest padded vertex count of B.
  static constexpr int kMaxPadded = (kMaxVerticesAvx2 + 3) / 4 * 4;

  /// True when the pair qualifies: each polytope within the limit above (or without adjacency:
  /// it scans anyway) and B fits the buffer.
  static bool applies(const Polytope<3>& a, const Polytope<3>& b) {
    const int max = a.scansAvx2() ? kMaxVerticesAvx2 : Polytope<3>::kLinearScanMax;
    const auto scans = [max](const Polytope<3>& p) { return p.size() <= max || !p.hasAdjacency(); };
    return a.size() > 0 && b.size() > 0 && b.paddedSize() <= kMaxPadded && scans(a) && scans(b);
  }

  /// Only where applies(a, b).
  BasicPolytopePairDifference(const Polytope<3>& a, const Polytope<3>& b, const Transform3& T_AB)
      : Base(a, b, T_AB), a_(a), b_local_(b), npb_(b.paddedSize()), avx2_(a.scansAvx2()) {
    if constexpr (kMapB) mapB(T_AB);
  }

  /// Support point of A - B maximising dot(d, w), A's frame (hides Base::support).
  CM_ALWAYS_INLINE SupportPoint<3> support(const Vec3& d) const {
    const double dd[3] = {d.x(), d.y(), d.z()};
    // B's direction: -d, in B's frame unless B is mapped.
    const Vec3 nd = kMapB ? Vec3(-d) : mulTransposed<3>(rotation(), -d);
    const double db[3] = {nd.x(), nd.y(), nd.z()};
    const double* cb = kMapB ? b_.data() : b_local_.scanData();
    std::array<int, 2> i;
#ifdef CM_HAVE_AVX2_SCAN
    if constexpr (kAvx2) {
      i = detail::scanPairBlocks<3, detail::V4d>(a_.scanData(), a_.paddedSize(), cb, npb_, dd, db);
    } else if (avx2_) {
      i = detail::scanPairAvx2<3>(a_.scanData(), a_.paddedSize(), cb, npb_, dd, db);
    } else
#endif
    {
      i = detail::scanPairBlocks<3, detail::V2d>(a_.scanData(), a_.paddedSize(), cb, npb_, dd, db);
    }
    SupportPoint<3> p;
    p.a = a_.vertices()[i[0]];
    if constexpr (kMapB) {
      p.b = Vec3(b_[i[1]], b_[npb_ + i[1]], b_[2 * npb_ + i[1]]);
    } else {
      p.b = mulAdd<3>(rotation(), b_local_.vertices()[i[1]], translation());
    }
    p.w = p.a - p.b;
    return p;
  }

 private:
  /// b_ from B's vertices (b_local_).
  void mapB(const Transform3& T_AB) {
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R = T_AB.R;
    const double* c = b_local_.scanData();
#ifdef CM_HAVE_AVX2_SCAN
    if constexpr (kAvx2) {
      detail::transformBlocks<3, detail::V4d>(c, npb_, R.data(), T_AB.t.data(), b_.data());
      return;
    }
    if (avx2_) {
      detail::transformAvx2<3>(c, npb_, R.data(), T_AB.t.data(), b_.data());
      return;
    }
#endif
    detail::transformBlocks<3, detail::V2d>(c, npb_, R.data(), T_AB.t.data(), b_.data());
  }

  const Polytope<3>& a_;
  const Polytope<3>& b_local_;
  int npb_;
  bool avx2_;
  /// B's vertices in A's frame, structure of arrays (Polytope::scanData() layout); kMapB only.
  alignas(32) std::array<double, kMapB ? 3 * kMaxPadded : 0> b_;
};

using PolytopePairDifference = BasicPolytopePairDifference<false>;

}  // namespace core
}  // namespace collision_monitor
