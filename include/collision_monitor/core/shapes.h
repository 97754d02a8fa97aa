/// \file
/// Support mappings: the one abstraction of the geometry core. Anything with
///   Vec<D> support(const Vec<D>& d) const
/// returning a point of the shape (in the shape's own frame) that maximises dot(d, x) is a
/// convex shape for GJK. A direction of zero length gets a defined answer (some point of the
/// shape), never NaN.
///
/// Each shape also has interiorPoint(): a point of the shape near its middle (the start of a cold
/// GJK run: cA - cB is a point of A - B, as MPR's centre; Minkowski portal refinement, Snethen
/// 2008).
///
/// The shapes here are *cores*: a sphere is a PointShape with a radius, a capsule a SegmentShape
/// with a radius. The radius (and any padding) is kept out of the GJK iterations and added after
/// convergence (see query.h), as in Box2D and coal.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "collision_monitor/core/math.h"

namespace collision_monitor {
namespace core {

namespace detail {

/// Keeps the larger value, on a tie the smaller index (first maximum), lane by lane.
template <class V>
CM_ALWAYS_INLINE void foldLanes(V& b, V& i, const V& ob, const V& oi) {
  const auto take = (ob > b) | ((ob == b) & (oi < i));
  b = take ? ob : b;
  i = take ? oi : i;
}

/// The block loop of scanBlocks: per lane of one vector, the first maximum (`best`) and its
/// vertex index as a double (`idx`; exact below 2^53). From kTwoChainsFrom vertices, four-lane
/// vectors keep two independent maxima (even and odd blocks of four vertices), folded at the end:
/// with one, every block's compare waits for the previous block's (hull100: 25 blocks in one
/// chain per scan). Measured, ns per query, one / two chains: hull100 distance 680 / 611,
/// intersect 260 / 238, warm 161 / 151; hull32 the same either way; hull12 distance 254 / 270.
template <int D, class V>
CM_ALWAYS_INLINE void scanLanes(const double* c, int np, const double* d, V& best_out, V& idx_out) {
  constexpr int kW = sizeof(V) / sizeof(double);  // lanes per vector
  constexpr int kN = 4 / kW;                      // vectors per block of four vertices
  constexpr int kU = kN == 1 ? 2 : 1;             // blocks per step
  constexpr int kA = kN * kU;                     // independent maxima, kW lanes each
  constexpr int kTwoChainsFrom = 48;              // vertices (padded)
  // Whole-vector initialisation (lane-by-lane stores draw GCC's -Wmaybe-uninitialized).
  const V zero = {};
  V lane = zero;  // 0, 1, ..., kW - 1
  if constexpr (kW == 2) {
    lane = V{0.0, 1.0};
  } else {
    lane = V{0.0, 1.0, 2.0, 3.0};
  }
  V dd[D], best[kA], idx[kA], at[kA];
  for (int k = 0; k < D; ++k)
    dd[k] = zero + d[k];
  for (int j = 0; j < kA; ++j) {
    best[j] = zero - std::numeric_limits<double>::infinity();
    at[j] = idx[j] = lane + static_cast<double>(j * kW);
  }
  // Vector j of a step holds vertices i + j kW ...; at[j] holds their indices.
  const auto step = [&](int i, int vectors, int advance) {
    for (int j = 0; j < vectors; ++j) {
      V x, y;
      __builtin_memcpy(&x, c + i + j * kW, sizeof(V));
      x *= dd[0];
      for (int k = 1; k < D; ++k) {
        __builtin_memcpy(&y, c + k * np + i + j * kW, sizeof(V));
        x += y * dd[k];
      }
      const auto gt = x > best[j];
      best[j] = gt ? x : best[j];
      idx[j] = gt ? at[j] : idx[j];
      at[j] += static_cast<double>(advance);
    }
  };
  int i = 0;
  if (kU == 1 || np < kTwoChainsFrom) {
    for (; i < np; i += 4)
      step(i, kN, 4);
  } else {
    for (; i + 4 * kU <= np; i += 4 * kU)
      step(i, kA, 4 * kU);
    if (i < np) step(i, kN, 4);  // the last block of four: at[j] = i + j kW + lane
    // The larger value, on a tie the smaller index: the first maximum over all blocks.
    for (int j = kN; j < kA; ++j)
      foldLanes(best[j % kN], idx[j % kN], best[j], idx[j]);
  }
  for (int j = 1; j < kN; ++j)
    foldLanes(best[0], idx[0], best[j], idx[j]);
  best_out = best[0];
  idx_out = idx[0];
}

/// Index of the first maximum of dot(d, x_i) over a structure-of-arrays vertex block: coordinate
/// k of vertex i at c[k * np + i], np a multiple of 4; pad slots repeat vertex 0. `lanes` vectors
/// of two doubles (GCC/Clang vector extensions: SSE2 on x86-64, NEON on aarch64) or, compiled
/// for AVX2 (scanIndexAvx2 below), one vector of four. Each lane keeps its first maximum; a pad
/// slot can only tie with vertex 0 and loses the tie (larger index). The dot product is summed in
/// coordinate order without FMA, so every variant returns the same index.
/// `kFold`: the lanes are reduced in the vector registers, without branches (GJK: measured 25 %
/// off a hull12 distance query, where the scalar reduction's branches mispredicted about once per
/// call); else by scalar compares and branches, which libccd's MPR runs faster (its support
/// directions repeat, so the branches predict: 239 vs 266 ns per hull12 intersect query).
template <int D, class V, bool kFold = true>
CM_ALWAYS_INLINE int scanBlocks(const double* c, int np, const double* d) {
  constexpr int kW = sizeof(V) / sizeof(double);
  V best, idx;
  scanLanes<D, V>(c, np, d, best, idx);
  // The larger value wins, a tie goes to the smaller index (first maximum).
  if constexpr (!kFold) {
    double bv = best[0];
    double bi = idx[0];
    for (int l = 1; l < kW; ++l) {
      const bool take = best[l] > bv || (best[l] == bv && idx[l] < bi);
      bv = take ? best[l] : bv;
      bi = take ? idx[l] : bi;
    }
    return static_cast<int>(bi);
  } else if constexpr (kW == 4) {
    foldLanes(best, idx, __builtin_shufflevector(best, best, 2, 3, 0, 1),
              __builtin_shufflevector(idx, idx, 2, 3, 0, 1));
    foldLanes(best, idx, __builtin_shufflevector(best, best, 1, 0, 3, 2),
              __builtin_shufflevector(idx, idx, 1, 0, 3, 2));
  } else {
    foldLanes(best, idx, __builtin_shufflevector(best, best, 1, 0),
              __builtin_shufflevector(idx, idx, 1, 0));
  }
  return static_cast<int>(idx[0]);
}

/// Both scans of one Minkowski support point of A - B: the first maximum of dot(d, x) over block
/// `ca` and of dot(db, x) over block `cb` (scanBlocks each; db = -d when B is in A's frame, else
/// -d rotated into B's frame).
template <int D, class V>
CM_ALWAYS_INLINE std::array<int, 2> scanPairBlocks(const double* ca, int npa, const double* cb,
                                                   int npb, const double* d, const double* db) {
  V ba, ia, bb, ib;
  scanLanes<D, V>(ca, npa, d, ba, ia);
  scanLanes<D, V>(cb, npb, db, bb, ib);
  // Both lane reductions at once: A's lanes in the low half, B's in the high half.
  if constexpr (sizeof(V) == 4 * sizeof(double)) {
    V b = __builtin_shufflevector(ba, bb, 0, 1, 4, 5),
      i = __builtin_shufflevector(ia, ib, 0, 1, 4, 5);
    foldLanes(b, i, __builtin_shufflevector(ba, bb, 2, 3, 6, 7),
              __builtin_shufflevector(ia, ib, 2, 3, 6, 7));
    foldLanes(b, i, __builtin_shufflevector(b, b, 1, 0, 3, 2),
              __builtin_shufflevector(i, i, 1, 0, 3, 2));
    return {static_cast<int>(i[0]), static_cast<int>(i[2])};
  } else {
    V b = __builtin_shufflevector(ba, bb, 0, 2), i = __builtin_shufflevector(ia, ib, 0, 2);
    foldLanes(b, i, __builtin_shufflevector(ba, bb, 1, 3), __builtin_shufflevector(ia, ib, 1, 3));
    return {static_cast<int>(i[0]), static_cast<int>(i[1])};
  }
}

/// Maps a structure-of-arrays vertex block (layout of scanBlocks) by x -> R x + t into `out`
/// (same layout). `R` row-major. Summed in the order of mulAdd() (math.h), without FMA, so each
/// vertex comes out bit for bit as mulAdd() would give it.
template <int D, class V>
CM_ALWAYS_INLINE void transformBlocks(const double* c, int np, const double* R, const double* t,
                                      double* out) {
  constexpr int kW = sizeof(V) / sizeof(double);
  const V zero = {};
  V rr[D * D], tt[D];  // broadcast once (stores to `out` could alias R and t)
  for (int k = 0; k < D * D; ++k)
    rr[k] = zero + R[k];
  for (int r = 0; r < D; ++r)
    tt[r] = zero + t[r];
  for (int i = 0; i < np; i += kW) {
    for (int r = 0; r < D; ++r) {
      V x, s;
      __builtin_memcpy(&x, c + i, sizeof(V));
      s = x * rr[r * D];
      for (int k = 1; k < D; ++k) {
        __builtin_memcpy(&x, c + k * np + i, sizeof(V));
        s += x * rr[r * D + k];
      }
      s += tt[r];
      __builtin_memcpy(out + r * np + i, &s, sizeof(V));
    }
  }
}

using V2d = double __attribute__((vector_size(16), aligned(8)));

#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#define CM_HAVE_AVX2_SCAN 1
using V4d = double __attribute__((vector_size(32), aligned(8)));
/// scanBlocks on four-lane AVX2 vectors; call only where cpuHasAvx2().
template <int D, bool kFold>
__attribute__((target("avx2"), noinline)) int scanIndexAvx2(const double* c, int np,
                                                            const double* d) {
  return scanBlocks<D, V4d, kFold>(c, np, d);
}
template <int D>
__attribute__((target("avx2"), noinline)) std::array<int, 2> scanPairAvx2(const double* ca, int npa,
                                                                          const double* cb, int npb,
                                                                          const double* d,
                                                                          const double* db) {
  return scanPairBlocks<D, V4d>(ca, npa, cb, npb, d, db);
}
template <int D>
__attribute__((target("avx2"), noinline)) void transformAvx2(const double* c, int np,
                                                             const double* R, const double* t,
                                                             double* out) {
  transformBlocks<D, V4d>(c, np, R, t, out);
}
/// True when this CPU runs AVX2 (checked once).
inline bool cpuHasAvx2() {
  static const bool has = __builtin_cpu_supports("avx2");
  return has;
}
#else
inline bool cpuHasAvx2() {
  return false;
}
#endif

}  // namespace detail

/// A single point (sphere and padding cores).
template <int D>
struct PointShape {
  Vec<D> p = Vec<D>::Zero();
  Vec<D> support(const Vec<D>& /*d*/) const { return p; }
  Vec<D> interiorPoint() const { return p; }
};

/// Segment from a to b (capsule cores).
template <int D>
struct SegmentShape {
  Vec<D> a = Vec<D>::Zero();
  Vec<D> b = Vec<D>::Zero();
  Vec<D> support(const Vec<D>& d) const { return d.dot(b - a) > 0.0 ? b : a; }
  Vec<D> interiorPoint() const { return 0.5 * (a + b); }
};

/// Axis-aligned box centred at the origin with half extents `half` (each >= 0; 0 is a flat box).
template <int D>
struct BoxShape {
  Vec<D> half = Vec<D>::Zero();
  Vec<D> support(const Vec<D>& d) const {
    Vec<D> s;
    for (int i = 0; i < D; ++i)
      s[i] = d[i] < 0.0 ? -half[i] : half[i];
    return s;
  }
  Vec<D> interiorPoint() const { return Vec<D>::Zero(); }
};

/// Ellipsoid centred at the origin with semi-axes `semi` along the frame axes (each >= 0).
/// support(d) = S^2 d / |S d| with S = diag(semi); for |S d| = 0 the centre.
template <int D>
struct EllipsoidShape {
  Vec<D> semi = Vec<D>::Ones();
  /// Where |S d| leaves [1e-150, 1e150] the squares below lose digits or overflow (a 7.3e-161 m
  /// ellipsoid's support was 7e-164 m off, 800 times the distance to a point beyond its tip:
  /// fuzz/regressions/core/gjk-ellipsoid-1e-161m-support-underflow): there S u / |u| with
  /// u = S d scaled by its largest component instead, and u made from d scaled by its largest
  /// component where S d itself overflows (along d of 1e200 the support was the centre).
  /// Beyond about 1e154 m, S (S d) overflows where |S d| does not: then S (S d / |S d|) (a 5e180 m
  /// ellipsoid along a direction 1e-46 long gave an infinite support point, and GJK a unit box at
  /// its centre as separated at +inf: fuzz/regressions/ros/body-ellipsoid-5e180m-support-overflow).
  Vec<D> support(const Vec<D>& d) const {
    const Vec<D> sd = semi.cwiseProduct(d);
    const double n = sd.norm();
    if (n >= 1e-150 && n <= 1e150) {
      const Vec<D> p = semi.cwiseProduct(sd) / n;
      return p.allFinite() ? p : Vec<D>(semi.cwiseProduct(sd / n));
    }
    double m = sd.cwiseAbs().maxCoeff();
    Vec<D> u;
    if (m < std::numeric_limits<double>::infinity()) {
      if (!(m > 0.0)) return Vec<D>::Zero();
      u = sd / m;
    } else {  // S d overflowed, or d is not finite
      const double dm = d.cwiseAbs().maxCoeff();
      if (!(dm < std::numeric_limits<double>::infinity())) return Vec<D>::Zero();
      const Vec<D> sdm = semi.cwiseProduct(d / dm);  // each component at most its semi-axis
      m = sdm.cwiseAbs().maxCoeff();
      if (!(m > 0.0)) return Vec<D>::Zero();
      u = sdm / m;
    }
    return semi.cwiseProduct(u) / u.norm();
  }
  Vec<D> interiorPoint() const { return Vec<D>::Zero(); }
};

/// Cylinder along z, centred at the origin: z in [-half_height, half_height], radius `radius`.
struct CylinderShape {
  double half_height = 0.0;
  double radius = 0.0;
  Vec3 support(const Vec3& d) const {
    const double r_xy = std::hypot(d.x(), d.y());
    Vec3 s(0.0, 0.0, d.z() < 0.0 ? -half_height : half_height);
    if (r_xy > 0.0) {  // unit direction first: radius * d.x can be sub-normal (see ConeShape)
      s.x() = radius * (d.x() / r_xy);
      s.y() = radius * (d.y() / r_xy);
    }
    return s;
  }
  Vec3 interiorPoint() const { return Vec3::Zero(); }
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
    // The unit direction first: radius * d.x is sub-normal for a 1.3e-163 m rim and a 8.6e-159
    // direction, and lost all but three digits (the rim point 1e-3 of the radius outside the
    // cylinder: fuzz/regressions/core/gjk-point-by-1e-163m-cylinder-rim-underflow).
    if (r_xy > 0.0) {
      rim.x() = radius * (d.x() / r_xy);
      rim.y() = radius * (d.y() / r_xy);
    }
    return d.dot(apex) >= d.dot(rim) ? apex : rim;
  }
  /// The centre of the axis, inside the cone (on it when the radius is 0).
  Vec3 interiorPoint() const { return Vec3::Zero(); }
};

/// Convex polytope given by its vertices (all of them hull vertices when built by
/// buildConvexHull()), with the hull's vertex adjacency for hill-climbing support queries.
///
/// With an empty adjacency (or few vertices) the support query is a linear scan over a
/// structure-of-arrays copy of the vertices (x[], y[], z[] padded to a multiple of 4, scanned two
/// or four vertices per vector instruction, see scanIndex()). With adjacency, support(d, hint)
/// hill-climbs from vertex `hint` to a vertex maximising dot(d, x); on a convex polytope a local
/// maximum over the edge graph is the global one. `hint` is updated to the answer, so a caller
/// that keeps it (the warm-start cache) starts next to the answer. The climb starts at the better
/// (larger dot(d, x)) of `hint` and startVertex(d): the extreme vertex, computed once at
/// construction, of the centre direction of d's cell in a cube map of 6 x 16 x 16 directions (3D;
/// 8 directions in 2D). A `hint` outside [0, size()) (e.g. -1: no hint) is ignored.
template <int D>
class Polytope {
 public:
  /// Below this many vertices the linear scan beats hill-climbing (measured: see docs/benchmarks).
  static constexpr int kLinearScanMax = 48;

  Polytope() = default;
  /// `adjacency_offsets` has size vertices.size() + 1; neighbours of vertex i are
  /// adjacency[adjacency_offsets[i] .. adjacency_offsets[i+1]). Empty offsets: no adjacency.
  Polytope(std::vector<Vec<D>> vertices, std::vector<int> adjacency_offsets = {},
           std::vector<int> adjacency = {})
      : vertices_(std::move(vertices)),
        offsets_(std::move(adjacency_offsets)),
        adjacency_(std::move(adjacency)) {
    buildScanArrays();
    buildStartTable();
    if (!vertices_.empty()) {
      for (const Vec<D>& v : vertices_)
        centroid_ += v;
      centroid_ /= static_cast<double>(vertices_.size());
    }
  }

  const std::vector<Vec<D>>& vertices() const { return vertices_; }
  int size() const { return static_cast<int>(vertices_.size()); }
  /// The mean of the vertices (a point of the polytope; the origin when empty).
  const Vec<D>& interiorPoint() const { return centroid_; }
  bool hasAdjacency() const { return offsets_.size() == vertices_.size() + 1; }
  const std::vector<int>& adjacencyOffsets() const { return offsets_; }
  const std::vector<int>& adjacency() const { return adjacency_; }

  /// True when supportIndex() is a linear scan (few vertices or no adjacency).
  bool usesLinearScan() const { return size() <= kLinearScanMax || !hasAdjacency(); }

  /// Index of the first vertex maximising dot(d, x) by a linear scan over all vertices: four
  /// vertices per AVX2 instruction where the CPU has it, else two (SSE2), same answer either way
  /// (detail::scanBlocks). GCC lowers four-lane vectors to branchy scalar code on the SSE2
  /// baseline, hence the run-time choice. `kFold`: how the lanes are reduced (same index; which
  /// is faster depends on the caller, see detail::scanBlocks).
  template <bool kFold = true>
  CM_ALWAYS_INLINE int scanIndex(const Vec<D>& d) const {
    double dd[D];
    for (int k = 0; k < D; ++k)
      dd[k] = d[k];
#ifdef CM_HAVE_AVX2_SCAN
    if (avx2_) return detail::scanIndexAvx2<D, kFold>(soa_.data(), padded_, dd);
#endif
    return detail::scanBlocks<D, detail::V2d, kFold>(soa_.data(), padded_, dd);
  }

  /// The structure-of-arrays copy of the vertices that scanIndex() scans: coordinate k of vertex
  /// i at scanData()[k * paddedSize() + i]; slots from size() to paddedSize() repeat vertex 0.
  const double* scanData() const {
    return soa_.data();
  }
  /// size() rounded up to a multiple of 4.
  int paddedSize() const {
    return padded_;
  }
  /// True when scanIndex() runs on AVX2.
  bool scansAvx2() const {
    return avx2_;
  }

  /// Start vertex of a cold hill-climb: the precomputed extreme vertex of the centre direction of
  /// d's cell (directionCell(): 384 cube-map cells in 3D, 8 directions in 2D). 0 for a zero or
  /// non-finite d.
  int startVertex(const Vec<D>& d) const {
    if (start_.empty()) return 0;
    return start_[directionCell(d)];
  }

  /// Index of a vertex maximising dot(d, x). `hint` (in/out): a candidate start vertex of the
  /// climb (the better of it and startVertex(d) is used; outside [0, size()): ignored). `kFold`:
  /// see scanIndex().
  template <bool kFold = true>
  int supportIndex(const Vec<D>& d, int& hint) const {
    const int n = size();
    if (usesLinearScan()) {
      hint = scanIndex<kFold>(d);
      return hint;
    }
    // Start at the better of the hint and the direction table's vertex: a kept hint is near the
    // answer for small changes of d, the table for large ones (GJK's first iterations).
    int cur = startVertex(d);
    double cur_dot = vertices_[cur].dot(d);
    if (hint >= 0 && hint < n && hint != cur) {
      const double h = vertices_[hint].dot(d);
      if (h >= cur_dot) {
        cur = hint;
        cur_dot = h;
      }
    }
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
  template <bool kFold = true>
  Vec<D> support(const Vec<D>& d, int& hint) const {
    return vertices_[supportIndex<kFold>(d, hint)];
  }
  /// Support without a kept hint (a climb starts at startVertex(d)).
  Vec<D> support(const Vec<D>& d) const {
    int hint = -1;
    return support(d, hint);
  }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();

  /// Start table resolution in 3D: a cube map of 6 faces x kCubeGrid x kCubeGrid cells (6 kB
  /// per climbing polytope). Measured on the benchmark's 500-vertex hulls (instructions per
  /// distance query): grid 2 (24 cells, like the earlier 26-direction table) 10,612; 4: 9,607;
  /// 6: 9,189; 8: 8,921 (8,986 on the late-night code of 2026-11-23); 12: 8,748; 16: 8,607; 24:
  /// 8,454. A climb from a grid-8 start takes 1.5 steps (9.7 neighbour dot products) on average,
  /// from a grid-2 start 2.8 (18.1). Random directions, cold hint, one climb: 500 vertices 63 -> 50
  /// ns from grid 8 to 16, 100 vertices 40 -> 37 ns. 24 would take 13.8 kB for 1.8 % fewer
  /// instructions.
  static constexpr int kCubeGrid = 16;

  /// Cell of direction d for the start table. 3D: the cube-map cell of d (major axis and sign,
  /// then the other two components over the major one, each in kCubeGrid bins of [-1, 1]).
  /// Other D: one of the 3^D directions with components in {-1, 0, 1} (component k counts when
  /// |d_k| > (sqrt(2) - 1) max |d_j|). 0 for a zero or non-finite d.
  static int directionCell(const Vec<D>& d) {
    if constexpr (D == 3) {
      const double ax = std::abs(d.x()), ay = std::abs(d.y()), az = std::abs(d.z());
      const int m = ax >= ay ? (ax >= az ? 0 : 2) : (ay >= az ? 1 : 2);
      const double am = m == 0 ? ax : (m == 1 ? ay : az);
      if (!(am > 0.0) || !(am < kInf)) return 0;
      const double h = 0.5 * kCubeGrid / am;  // maps [-am, am] onto [0, kCubeGrid]
      const auto bin = [h](double x) {
        const int b = static_cast<int>(x * h + 0.5 * kCubeGrid);
        return b < 0 ? 0 : (b >= kCubeGrid ? kCubeGrid - 1 : b);
      };
      const int face = 2 * m + (d[m] < 0.0 ? 1 : 0);
      const int j = m == 2 ? 0 : m + 1;  // (m + 1) % 3 without a division
      const int k = m == 0 ? 2 : m - 1;  // (m + 2) % 3
      return (face * kCubeGrid + bin(d[j])) * kCubeGrid + bin(d[k]);
    } else {
      const double m = d.cwiseAbs().maxCoeff();
      if (!(m > 0.0) || !(m < kInf)) return 0;
      const double th = 0.41421356237309503 * m;
      int cell = 0;
      for (int k = 0; k < D; ++k)
        cell = 3 * cell + (d[k] > th ? 2 : (d[k] < -th ? 0 : 1));
      return cell;
    }
  }

  void buildScanArrays() {
    const int n = size();
    padded_ = (n + 3) / 4 * 4;
    soa_.assign(static_cast<std::size_t>(D) * padded_, 0.0);
    for (int i = 0; i < padded_; ++i) {
      const Vec<D>& p = vertices_[i < n ? i : 0];
      for (int k = 0; k < D; ++k)
        soa_[static_cast<std::size_t>(k) * padded_ + i] = p[k];
    }
  }

  /// The extreme vertex of each cell's centre direction (directionCell()).
  void buildStartTable() {
    if (vertices_.empty() || usesLinearScan()) return;
    if constexpr (D == 3) {
      start_.assign(6 * kCubeGrid * kCubeGrid, 0);
      for (int face = 0; face < 6; ++face) {
        const int m = face / 2;
        for (int u = 0; u < kCubeGrid; ++u) {
          for (int v = 0; v < kCubeGrid; ++v) {
            Vec3 dir;
            dir[m] = face % 2 == 0 ? 1.0 : -1.0;
            dir[(m + 1) % 3] = (2.0 * u + 1.0) / kCubeGrid - 1.0;
            dir[(m + 2) % 3] = (2.0 * v + 1.0) / kCubeGrid - 1.0;
            start_[(face * kCubeGrid + u) * kCubeGrid + v] = scanIndex(dir);
          }
        }
      }
    } else {
      int cells = 1;
      for (int k = 0; k < D; ++k)
        cells *= 3;
      start_.assign(cells, 0);
      for (int cell = 0; cell < cells; ++cell) {
        Vec<D> dir;
        int c = cell;
        for (int k = D - 1; k >= 0; --k) {
          dir[k] = static_cast<double>(c % 3 - 1);
          c /= 3;
        }
        start_[cell] = scanIndex(dir);
      }
    }
  }

  std::vector<Vec<D>> vertices_;
  std::vector<int> offsets_;
  std::vector<int> adjacency_;
  std::vector<double> soa_;  ///< coordinates k of vertex i at [k * padded_ + i]
  int padded_ = 0;           ///< vertex count rounded up to a multiple of 4
  std::vector<int> start_;   ///< extreme vertex per direction cell (climbing polytopes only)
  Vec<D> centroid_ = Vec<D>::Zero();  ///< mean of the vertices
  bool avx2_ = detail::cpuHasAvx2();  ///< scanIndex() on AVX2
};

/// A polytope with its own hill-climbing hint: the per-query support object GJK uses, so the
/// shared Polytope stays immutable (and thread-safe) while each pair keeps its own hint.
template <int D>
struct PolytopeSupport {
  const Polytope<D>* poly = nullptr;
  mutable int hint = -1;  ///< -1: cold (the climb starts at Polytope::startVertex)
  Vec<D> support(const Vec<D>& d) const { return poly->support(d, hint); }
  const Vec<D>& interiorPoint() const { return poly->interiorPoint(); }
};

}  // namespace core
}  // namespace collision_monitor
