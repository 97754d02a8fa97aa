/// \file
/// EPA, the Expanding Polytope Algorithm (van den Bergen 2001, "Proximity queries and penetration
/// depth computation on 3D game objects", GDC; see also Jolt's EPAPenetrationDepth.h and Bullet's
/// gjkepa2): penetration depth and normal of two overlapping convex shapes, starting from the
/// terminal simplex of gjkDistance() (which encloses the origin, or touches it within tolerance).
///
/// 3D: a terminal simplex of fewer than 4 vertices is blown up to a tetrahedron by support
/// searches; when the Minkowski difference A - B turns out to be flat (a point, a segment or a
/// planar set: lower-dimensional cores) the answer is depth 0 with the flat set's description
/// (EpaStatus::Flat), a defined answer instead of a degenerate polytope. The polytope is expanded
/// towards its face closest to the origin; new faces come from the horizon (silhouette) of the new
/// support point. Termination on a relative/absolute tolerance (exact on polytopes: the support
/// point then lies on the face), the iteration bound, and degenerate faces.
/// 2D: the same on a convex polygon (footprints).
///
/// All storage is in fixed-size arrays on the stack: no heap allocation, no virtual calls.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "collision_monitor/core/gjk.h"
#include "collision_monitor/core/math.h"

namespace collision_monitor {
namespace core {

/// Tolerances and bounds of one EPA run.
struct EpaSettings {
  /// Stop when the support point along the closest face's normal gains at most
  /// rel_tolerance * depth + abs_tolerance over that face; out of iterations (or degenerate),
  /// converged still when the smallest support depth seen is within that of the face
  /// (EpaUpperBound::settles).
  double rel_tolerance = 1e-12;
  /// Length unit; callers pass rel_tolerance * shape size. Also the flatness threshold.
  double abs_tolerance = 0.0;
  int max_iterations = 256;  ///< clamped to kEpaMaxIterations
};

/// Upper bound on EPA iterations (fixed storage, about 80 kB of stack in 3D). Polytopes converge
/// in a few dozen; curved pairs can take longer: of 20,000 deep cylinder/cone overlaps, 30 needed
/// 128 to 230 iterations to know the depth to 1e-10 of itself (QueryOptions::epa_rel_tolerance).
constexpr int kEpaMaxIterations = 256;

enum class EpaStatus {
  Converged,      ///< depth and normal within tolerance
  Flat,           ///< A - B is flat (affine dimension < D): depth 0, see flat_dimension
  MaxIterations,  ///< iteration bound hit: best estimate, see detail::EpaUpperBound
  Degenerate      ///< numerical trouble (degenerate face, broken horizon): best estimate
};

/// Result of EPA. Frames: A's frame.
template <int D>
struct EpaResult {
  EpaStatus status = EpaStatus::Degenerate;
  /// Penetration depth of the cores (length, >= 0 up to rounding): the shortest translation of B
  /// along `normal` that separates them.
  double depth = 0.0;
  /// Unit, from A towards B (outward normal of A - B at its boundary point closest to the
  /// origin). For Flat with flat_dimension == D - 1: the flat set's normal (sign arbitrary). For
  /// flat_dimension 0 (A - B a single point): UnitX; for a segment in 3D: unit direction of the
  /// segment in `flat_direction`, normal any unit perpendicular.
  Vec<D> normal = Vec<D>::Unit(0);
  Vec<D> point_a = Vec<D>::Zero();  ///< witness on A, A's frame (point_a - point_b = depth normal)
  Vec<D> point_b = Vec<D>::Zero();  ///< witness on B, A's frame
  /// MaxIterations / Degenerate: `depth` is an upper bound on the depth (see EpaUpperBound).
  bool depth_is_upper_bound = false;
  int flat_dimension = -1;                 ///< for Flat: affine dimension of A - B (0 .. D-1)
  Vec<D> flat_direction = Vec<D>::Zero();  ///< for Flat, dimension 1 in 3D: the line's direction
  int iterations = 0;
};

namespace detail {

/// True when `ids[0 .. n)` holds `id`.
template <std::size_t N>
bool contains(const std::array<int, N>& ids, int n, int id) {
  return std::find(ids.begin(), ids.begin() + n, id) != ids.begin() + n;
}

/// True when p lies on the line through a and b to within 64 eps times the largest coordinate (the
/// rounding of the points themselves), or a and b coincide.
[[gnu::noinline, gnu::cold]] inline bool onLine(const Vec3& a, const Vec3& b, const Vec3& p) {
  const double m =
      std::max({a.cwiseAbs().maxCoeff(), b.cwiseAbs().maxCoeff(), p.cwiseAbs().maxCoeff()});
  const double noise = 64.0 * std::numeric_limits<double>::epsilon() * m;
  const Vec3 u = b - a;
  return u.cross(p - a).squaredNorm() <= noise * noise * u.squaredNorm();
}

/// Barycentric weights of p's projection on the plane of the triangle w0, w1, w2 (a third each
/// for a triangle without area).
inline std::array<double, 3> faceWeights(const Vec3& w0, const Vec3& w1, const Vec3& w2,
                                         const Vec3& p) {
  const Vec3 n = (w1 - w0).cross(w2 - w0);
  const double nn = n.squaredNorm();
  if (!(nn > 0.0)) return {1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0};
  const double l0 = n.dot((w1 - p).cross(w2 - p)) / nn;
  const double l1 = n.dot((w2 - p).cross(w0 - p)) / nn;
  return {l0, l1, 1.0 - l0 - l1};
}

/// Witness points of the point p = d n on a face of the expanded polytope: barycentric weights
/// `l` of the face's support points (faceWeights()), applied to the shape whose points on the
/// face lie closer together (as its first point plus weighted differences), the other witness
/// that one plus or minus p, so that a - b = p. On a needle face the weights lose eps times the
/// coordinates over its width: a jittered 5281 m cube holding a point put the witness on the
/// cube 4.9e-4 m off its face, weighting the cube's points (fuzz/regressions/core/epa-witness-
/// off-face-jittered-2640m-cube-holding-point); the point's own witness is now the point, and
/// the cube's is it plus p.
inline void epaWitness3(const SupportPoint<3>& p0, const SupportPoint<3>& p1,
                        const SupportPoint<3>& p2, const std::array<double, 3>& l, const Vec3& p,
                        Vec3& a, Vec3& b) {
  const Vec3 da1 = p1.a - p0.a, da2 = p2.a - p0.a;
  const Vec3 db1 = p1.b - p0.b, db2 = p2.b - p0.b;
  if (std::max(db1.squaredNorm(), db2.squaredNorm()) <=
      std::max(da1.squaredNorm(), da2.squaredNorm())) {
    b = p0.b + l[1] * db1 + l[2] * db2;
    a = b + p;
  } else {
    a = p0.a + l[1] * da1 + l[2] * da2;
    b = a - p;
  }
}

/// The smallest overlap EPA has seen along a support direction: h_{A-B}(n) >= depth for every
/// unit n, so it bounds the depth from above, and that n, the depth h_{A-B}(n) and witness
/// points on the two supporting planes are exactly consistent. When EPA stops unconverged (the
/// iteration bound: a cone in a cylinder ends within 1.1e-3 of the size after 128 iterations;
/// or a degenerate polytope: a 1.4e6 m needle of a hull with a 3e-6 m base) this is what it
/// reports, rather than the lower bound of its nearest face whose normal does not realise it: a
/// depth too large by at most the remaining gap, never too small (the safe side), refined first
/// (refineUpperBound()).
template <int D>
struct EpaUpperBound {
  double depth = std::numeric_limits<double>::infinity();
  Vec<D> normal = Vec<D>::Unit(0);
  Vec<D> point_a = Vec<D>::Zero();
  Vec<D> point_b = Vec<D>::Zero();
  bool certified = false;  ///< settles() held: the answer, within EPA's tolerance

  /// Offers the support point p along the unit n.
  void offer(const Vec<D>& n, const SupportPoint<D>& p) {
    const double h = n.dot(p.w);
    if (!(h < depth)) return;
    depth = h;
    normal = n;
    point_a = p.a;
    point_b = p.a - h * n;
  }
  /// For EPA out of iterations (or stopped degenerate): true (and then the answer, not an estimate)
  /// when this bound is within `need` of EPA's lower bound `lower` (its nearest face), the depth
  /// being known to `need` although that face's own support point still gains more. On curved
  /// shapes the bound settles first (a cone in a cylinder, bench pool cylinder_cone pair 460 step
  /// 0, at 1e-12: its bound was 1.2e-11 m from the depth after 128 iterations, its nearest face
  /// converged after 195). Only at the end: in the loop, touching polytopes settle at once on a
  /// bound whose support point is a vertex away from the contact (test_oracle_sweep box-hull 4308:
  /// point_b 1.06 m off B), where the face converges in a few more iterations.
  bool settles(double lower, double need) {
    certified = depth - lower <= need;
    return certified;
  }
  void applyTo(EpaResult<D>& r) const {
    const bool unconverged =
        r.status == EpaStatus::MaxIterations || r.status == EpaStatus::Degenerate;
    if (!(unconverged || certified) || !std::isfinite(depth)) return;
    r.depth_is_upper_bound = unconverged;
    r.depth = depth;
    r.normal = normal;
    r.point_a = point_a;
    r.point_b = point_b;
  }
};

/// EPA's checkpoint (EpaProgress): true when the gap between its bounds on the depth, `gap_half`
/// at half as many iterations and `gap` now, will not be within `need` after `factor` times as
/// many iterations, extrapolated at the rate it closed since, with a margin of 1e4. Where the
/// depth is reached along a circle of directions the gap closes as 1 / iterations^2 (the
/// polytope's polygon round the circle): a point at a cone's centre had 1.7e-3, 4.3e-4 and
/// 1.1e-4 of the size after 32, 64 and 128 iterations; the 256 iterations cost 1.3 ms (each new
/// point on the base's plane rebuilds the base's fan of faces) and ended 1e6 times above the
/// tolerance. With a margin of 100 and a checkpoint at 64 iterations, 38 of 2,400 deep overlaps
/// inside ellipsoids and identical shapes (the sixteenth session's audit, deep.cpp) lost a
/// certificate they got by 256 iterations; with these, none.
inline bool epaStalls(double gap_half, double gap, int factor, double need) {
  if (gap <= need) return false;
  const double rate = gap_half > gap ? gap_half / gap : 1.0;  // per doubling
  double predicted = gap;
  for (int f = factor; f > 1; f /= 2)
    predicted /= rate;
  return predicted > 1e4 * need;
}

/// Evaluations refineUpperBound() may spend (support calls; about 20 to 60 ns each on primitives).
constexpr int kEpaRefineBudget = 240;

/// Lowers EPA's upper bound on the depth, min over unit n of h_{A-B}(n), by a local search on the
/// sphere (3D) or circle (2D) of directions around its normal, for EPA stopped unconverged. Where
/// the depth is reached along a whole circle of directions (a point on the axis of a cone, of a
/// cylinder taller than it is wide or of a prolate ellipsoid, coaxial cylinders; in 2D a point
/// at a disc's centre), EPA's polytope has to refine all of the circle before its nearest face's
/// normal gets close to any of it: a point at a cone's centre stopped after 256 iterations with
/// its bound 4.0e-5 of the size above the depth, a segment 1e-4 m off a cylinder's axis 7.5e-5
/// (with its normal 90 degrees away from the deepest one), a point 1e-4 m off a unit disc's
/// centre 7.5e-9. Nelder-Mead in the tangent space of the normal (h is only piecewise smooth: a
/// cylinder's rims and a cone's apex give kinks), restarted twice from its best point, stopping
/// when the simplex is below 1e-12 rad across or the budget is spent. Every direction evaluated
/// bounds the depth from above, so the bound only gets closer to the depth, whatever the search
/// does. Witness points: the point depth * normal in the hull of the support points on the
/// supporting plane 1e-11 rad around the normal (a generator of the cone, a side line of the
/// cylinder: the support point itself is an end of it, off the other shape), or the point of
/// that hull nearest to it.
template <class MD>
[[gnu::noinline, gnu::cold]] void refineUpperBound(const MD& md, EpaUpperBound<MD::kDim>& upper,
                                                   double need) {
  constexpr int D = MD::kDim;
  constexpr int M = D - 1;  // dimension of the search: the tangent space
  static_assert(D == 2 || D == 3, "refineUpperBound is for EPA's dimensions");
  using U = Vec<M>;
  if (!std::isfinite(upper.depth)) return;
  constexpr int kRecent = 8;
  std::array<SupportPoint<D>, kRecent> recent;
  int nrecent = 0;
  int evals = 0;
  Vec<D> n0;
  std::array<Vec<D>, M> e;  // orthonormal basis of the tangent space at n0
  const auto tangentAtBest = [&] {
    n0 = upper.normal;
    if constexpr (D == 3) {
      e[0] = n0.unitOrthogonal();
      e[1] = n0.cross(e[0]);
    } else {
      e[0] = Vec2(-n0.y(), n0.x());
    }
  };
  const auto eval = [&](const U& u) {
    Vec<D> n = n0;
    for (int i = 0; i < M; ++i)
      n += u[i] * e[i];
    n.normalize();
    const SupportPoint<D> p = md.support(n);
    ++evals;
    recent[nrecent % kRecent] = p;
    ++nrecent;
    upper.offer(n, p);
    return n.dot(p.w);
  };
  double step = 0.05;  // rad
  for (int round = 0; round < 3 && evals < kEpaRefineBudget; ++round) {
    tangentAtBest();
    std::array<U, M + 1> x;
    std::array<double, M + 1> f;
    x[0] = U::Zero();
    f[0] = upper.depth;
    for (int i = 1; i <= M; ++i) {
      x[i] = step * U::Unit(i - 1);
      f[i] = eval(x[i]);
    }
    while (evals < kEpaRefineBudget) {
      // Order: x[0] best, x[M] worst.
      for (int i = 1; i <= M; ++i)
        for (int j = i; j > 0 && f[j] < f[j - 1]; --j) {
          std::swap(f[j], f[j - 1]);
          std::swap(x[j], x[j - 1]);
        }
      double diam = 0.0;
      for (int i = 1; i <= M; ++i)
        diam = std::max(diam, (x[i] - x[0]).norm());
      if (diam < 1e-12) break;
      U c = U::Zero();
      for (int i = 0; i < M; ++i)
        c += x[i] / M;
      const U xr = c + (c - x[M]);
      const double fr = eval(xr);
      if (fr < f[0]) {
        const U xe = c + 2.0 * (c - x[M]);
        const double fe = eval(xe);
        x[M] = fe < fr ? xe : xr;
        f[M] = std::min(fe, fr);
      } else if (fr < f[M - 1]) {
        x[M] = xr;
        f[M] = fr;
      } else {
        const U xc = fr < f[M] ? U(c + 0.5 * (xr - c)) : U(c + 0.5 * (x[M] - c));
        const double fc = eval(xc);
        if (fc < std::min(fr, f[M])) {
          x[M] = xc;
          f[M] = fc;
        } else {
          for (int i = 1; i <= M; ++i) {
            x[i] = x[0] + 0.5 * (x[i] - x[0]);
            f[i] = eval(x[i]);
          }
        }
      }
    }
    step = std::max(1e-3 * step, 1e-6);
  }
  // Witness points: depth * normal in the hull of the support points on the plane around the
  // normal (probes 1e-11 rad off it: the ends of a cylinder's side line, a disc's rim points).
  tangentAtBest();
  for (int k = 0; k < kRecent; ++k) {
    const double ang = k * (2.0 * 3.14159265358979323846 / kRecent);
    U u;
    u[0] = std::cos(ang);
    if constexpr (M == 2) u[1] = std::sin(ang);
    eval(1e-11 * u);
  }
  const Vec<D> t = upper.depth * upper.normal;
  std::array<SupportPoint<D>, kRecent> q;
  int nq = 0;
  for (int k = 0; k < kRecent; ++k) {
    if (upper.normal.dot(recent[k].w) < upper.depth - need) continue;
    q[nq] = recent[k];
    q[nq].w -= t;
    ++nq;
  }
  if (nq == 0) return;
  Simplex<D> s;
  s.v[0] = q[0];
  s.size = 1;
  Vec<D> v = s.v[0].w;
  for (int it = 0; it < 2 * kRecent && s.size <= D; ++it) {
    int best = -1;
    double lowest = v.squaredNorm() - 1e-12 * need * need;
    for (int k = 0; k < nq; ++k) {
      const double vq = v.dot(q[k].w);
      if (vq < lowest) {
        lowest = vq;
        best = k;
      }
    }
    if (best < 0) break;
    s.v[s.size++] = q[best];
    v = solveSimplex<D>(s);
  }
  Vec<D> a;
  Vec<D> b;
  s.witnesses(a, b);
  upper.point_a = a;
  upper.point_b = a - t;
}

/// EPA's checkpoint (iteration 128) and its end, the same in 2D and 3D.
struct EpaProgress {
  static constexpr int kCheckpoint = 128;
  double lower_half = 0.0;  ///< the nearest face's distance at kCheckpoint / 2 iterations

  /// Before iteration `it` with EPA's lower bound `lower`: true when EPA should stop there
  /// (epaStalls(), the upper bound refined first).
  template <class MD>
  bool stalls(const MD& md, EpaUpperBound<MD::kDim>& upper, int it, int max_it, double lower,
              double need) {
    if (it == kCheckpoint / 2) lower_half = lower;
    if (it != kCheckpoint) return false;
    refineUpperBound(md, upper, need);
    return epaStalls(upper.depth - lower_half, upper.depth - lower, max_it / it, need);
  }
  /// At the end, EPA unconverged with lower bound `lower`: converged after all when the upper
  /// bound, refined, is within `need` of it (EpaUpperBound::settles()). Refined again after the
  /// checkpoint's search: starting over from its best point, with its first step, lowered the
  /// deep-tie audit's value errors from 13 to 11 and witness errors from 93 to 81 of 3,600.
  template <class MD>
  static void settle(const MD& md, EpaUpperBound<MD::kDim>& upper, double lower, double need,
                     EpaStatus& status) {
    if (status == EpaStatus::Converged) return;
    if (!upper.settles(lower, need)) {
      refineUpperBound(md, upper, need);
      upper.settles(lower, need);
    }
    if (upper.certified) status = EpaStatus::Converged;
  }
};

}  // namespace detail

/// 3D EPA on the terminal simplex of gjkDistance() (status Intersecting): `md` as for GJK.
template <class MD>
EpaResult<3> epa3(const MD& md, const Simplex<3>& simplex, const EpaSettings& st) {
  static_assert(MD::kDim == 3, "epa3 needs a 3D Minkowski difference");
  constexpr int kMaxVerts = kEpaMaxIterations + 4;
  constexpr int kMaxFaces = 2 * kMaxVerts;
  struct Face {
    std::array<int, 3> v;         // vertex indices, counter-clockwise seen from outside
    std::array<int, 3> adj;       // face across edge i = (v[i], v[i+1])
    std::array<int, 3> adj_edge;  // index of that edge in the neighbour
    Vec3 n;                       // unit outward normal
    double d;                     // n . v0: signed distance of the plane from the origin
    bool alive;
  };
  struct Edge {
    int face;
    int edge;
  };

  EpaResult<3> r;
  detail::EpaUpperBound<3> upper;
  const double tol = st.abs_tolerance;
  // A face is replaced when the new point is above it or less than vis_eps below it. Not kept
  // when the point is a little above: that leaves a reflex edge, which a sliver face next to it
  // turns into vertices far outside (a jittered cube, 34 vertices 1e-9 m off its faces: a vertex
  // 2.5e-9 m outside a face, then faces 3 m too near and no convergence in 256 iterations;
  // fuzz/regressions/core/epa-jittered-cube-reflex-edge).
  const double vis_eps = 1e-2 * tol;
  // A horizon edge whose line passes through the new point (to rounding at the coordinates' size)
  // would give a face without area, its normal all rounding. The faces on both sides of such an
  // edge contain the point's line, and rounding can put the point above one and below the other:
  // in a 6,800 m needle prism (a box by a 3925 m hull) it was 1.9e-10 m above one and 2.5e-10 m
  // below the other; the face on the edge came out inverted (the origin 0.15 m outside it) and
  // EPA stopped unconverged (fuzz/regressions/core/epa-box-by-3925m-needle-hull-coplanar-horizon).
  // The face the point is below is then replaced too (`forced`), and the walk starts again. Only
  // faces the point is less than `suspect` below are checked (the test costs a cross product).
  const double suspect = 1e3 * tol;
  std::array<int, 4> forced;
  const int max_it = std::min(std::max(st.max_iterations, 0), kEpaMaxIterations);

  std::array<SupportPoint<3>, kMaxVerts> verts;
  int nv = std::min(simplex.size, 4);
  for (int i = 0; i < nv; ++i)
    verts[i] = simplex.v[i];

  auto flat = [&](int dim) {
    r.status = EpaStatus::Flat;
    r.flat_dimension = dim;
    r.depth = 0.0;
    Simplex<3> s = simplex;
    solveSimplex<3>(s);
    s.witnesses(r.point_a, r.point_b);
    return r;
  };

  // ---- Blow the terminal simplex up to a tetrahedron, or find A - B flat. ----
  if (nv <= 0) {
    verts[0] = md.support(md.initialDirection());
    nv = 1;
  }
  for (int guard = 0;; ++guard) {
    if (guard > 8) {
      r.status = EpaStatus::Degenerate;
      upper.applyTo(r);
      return r;
    }
    const Vec3 w0 = verts[0].w;
    if (nv == 1) {
      // A second point: the support point farthest from w0 over the six axis directions.
      const std::array<Vec3, 6> dirs{Vec3::UnitX(),  -Vec3::UnitX(), Vec3::UnitY(),
                                     -Vec3::UnitY(), Vec3::UnitZ(),  -Vec3::UnitZ()};
      double best = -1.0;
      for (const Vec3& d : dirs) {
        const SupportPoint<3> p = md.support(d);
        upper.offer(d, p);
        const double h = (p.w - w0).norm();
        if (h > best) {
          best = h;
          verts[1] = p;
        }
      }
      if (best <= tol) return flat(0);
      nv = 2;
    } else if (nv == 2) {
      const Vec3 u = verts[1].w - w0;
      const double len = u.norm();
      if (len <= tol) {
        nv = 1;
        continue;
      }
      const Vec3 un = u / len;
      const Vec3 e1 = un.unitOrthogonal();
      const Vec3 e2 = un.cross(e1);
      // Six directions 60 degrees apart around the segment (van den Bergen): if A - B extends
      // off the line, at least two of them find it.
      double best = -1.0;
      for (int k = 0; k < 6; ++k) {
        const double ang = k * (3.14159265358979323846 / 3.0);
        const Vec3 d = std::cos(ang) * e1 + std::sin(ang) * e2;
        const SupportPoint<3> p = md.support(d);
        upper.offer(d, p);
        const Vec3 off = (p.w - w0) - (p.w - w0).dot(un) * un;
        const double h = off.norm();
        if (h > best) {
          best = h;
          verts[2] = p;
        }
      }
      if (best <= tol) {
        r.flat_direction = un;
        r.normal = e1;
        return flat(1);
      }
      nv = 3;
    } else if (nv == 3) {
      const Vec3 n = crossAccurate(verts[1].w - w0, verts[2].w - w0);
      const double longest = std::max(
          {(verts[1].w - w0).norm(), (verts[2].w - w0).norm(), (verts[2].w - verts[1].w).norm()});
      const double nn = n.norm();
      if (!(nn > tol * longest) || !(nn > 0.0)) {
        // Collinear: keep the two points farthest apart.
        int i = 0;
        int j = 1;
        double dmax = (verts[1].w - verts[0].w).squaredNorm();
        if ((verts[2].w - verts[0].w).squaredNorm() > dmax) {
          j = 2;
          dmax = (verts[2].w - verts[0].w).squaredNorm();
        }
        if ((verts[2].w - verts[1].w).squaredNorm() > dmax) {
          i = 1;
          j = 2;
        }
        const SupportPoint<3> pi = verts[i];
        const SupportPoint<3> pj = verts[j];
        verts[0] = pi;
        verts[1] = pj;
        nv = 2;
        continue;
      }
      const Vec3 un = n / nn;
      const SupportPoint<3> pp = md.support(un);
      const SupportPoint<3> pm = md.support(-un);
      upper.offer(un, pp);
      upper.offer(-un, pm);
      const double hp = un.dot(pp.w - w0);
      const double hm = -un.dot(pm.w - w0);
      if (std::max(hp, hm) <= tol) {
        r.normal = un;
        return flat(2);
      }
      verts[3] = hp >= hm ? pp : pm;
      nv = 4;
    } else {
      // orientation(): from the best vertex. From vertex 0 a needle (a segment through a 5e-9 m
      // flat box: three vertices at the far end of a 1.77 m tetrahedron) got the wrong sign, an
      // inward face and a "degenerate" EPA: fuzz/regressions/core/epa-needle-tetrahedron-volume-
      // sign. (crossAccurate() there cost 190 ns per EPA run on box pairs.)
      const double vol = orientation(verts[0].w, verts[1].w, verts[2].w, verts[3].w);
      if (vol == 0.0 || !std::isfinite(vol)) {
        nv = 3;  // a flat tetrahedron: redo the lift from its first face
        continue;
      }
      if (vol < 0.0) std::swap(verts[1], verts[2]);
      break;
    }
  }

  // ---- Initial tetrahedron (positive volume): outward faces. ----
  std::array<Face, kMaxFaces> faces;
  int nf = 0;
  std::array<int, kMaxFaces> free_list;
  int nfree = 0;
  auto allocFace = [&]() -> int {
    if (nfree > 0) return free_list[--nfree];
    return nf < kMaxFaces ? nf++ : -1;
  };
  auto makeFace = [&](int f, int a, int b, int c) -> bool {
    Face& F = faces[f];
    F.v = {a, b, c};
    F.alive = true;
    const Vec3 eb = verts[b].w - verts[a].w;
    const Vec3 ec = verts[c].w - verts[a].w;
    Vec3 n = eb.cross(ec);
    // A needle face (sine of its angle at a below 1e-4): the plain product gives the normal's
    // direction to eps / sine only. A box in a 4.9e6 m segment (A - B a needle prism) broke its
    // horizon after 8 iterations that way: fuzz/regressions/core/gjk-box-in-4900km-segment-
    // needle-tetrahedron.
    if (n.squaredNorm() < 1e-8 * eb.squaredNorm() * ec.squaredNorm()) n = crossAccurate(eb, ec);
    const double len = n.norm();
    if (!(len > 0.0) || !std::isfinite(len)) return false;
    F.n = n / len;
    F.d = (F.n.dot(verts[a].w) + F.n.dot(verts[b].w) + F.n.dot(verts[c].w)) / 3.0;
    return true;
  };
  {
    const std::array<std::array<int, 3>, 4> tet{{{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}};
    for (const auto& t : tet) {
      if (!makeFace(allocFace(), t[0], t[1], t[2])) {
        r.status = EpaStatus::Degenerate;
        upper.applyTo(r);
        return r;
      }
    }
    for (int f = 0; f < 4; ++f)
      for (int i = 0; i < 3; ++i)
        for (int g = 0; g < 4; ++g)
          for (int j = 0; j < 3; ++j)
            if (faces[g].v[j] == faces[f].v[(i + 1) % 3] &&
                faces[g].v[(j + 1) % 3] == faces[f].v[i]) {
              faces[f].adj[i] = g;
              faces[f].adj_edge[i] = j;
            }
  }

  // ---- Expansion. ----
  std::array<Edge, kMaxFaces> horizon;
  std::array<Edge, 2 * kMaxFaces + 3> stack;
  std::array<int, kMaxFaces> new_faces;
  Face best;
  bool have_best = false;
  detail::EpaProgress progress;
  r.status = EpaStatus::MaxIterations;
  for (int it = 0;; ++it) {
    int bi = -1;
    double bd = std::numeric_limits<double>::infinity();
    for (int f = 0; f < nf; ++f) {
      if (faces[f].alive && faces[f].d < bd) {
        bd = faces[f].d;
        bi = f;
      }
    }
    if (bi < 0) {
      r.status = EpaStatus::Degenerate;
      break;
    }
    best = faces[bi];
    have_best = true;
    if (it >= max_it || nv >= kMaxVerts) {
      r.status = EpaStatus::MaxIterations;
      break;
    }
    if (progress.stalls(md, upper, it, max_it, best.d, st.rel_tolerance * std::abs(best.d) + tol)) {
      r.status = EpaStatus::MaxIterations;
      break;
    }
    r.iterations = it + 1;
    const SupportPoint<3> p = md.support(best.n);
    upper.offer(best.n, p);
    const double gain = best.n.dot(p.w) - best.d;
    if (gain <= st.rel_tolerance * std::abs(best.d) + tol) {
      r.status = EpaStatus::Converged;
      break;
    }
    const int wi = nv;
    verts[nv++] = p;

    // Silhouette of the new point (van den Bergen's depth-first walk; an explicit stack in the
    // order of the recursive version, so the horizon comes out as one ordered loop).
    int nh = 0;
    bool near = false;  // the point is less than `suspect` below a face of the horizon
    int nforced = 0;
    const int nfree0 = nfree;
    const auto walk = [&] {
      int ns = 0;
      nh = 0;
      faces[bi].alive = false;
      free_list[nfree++] = bi;
      for (int i = 2; i >= 0; --i)
        stack[ns++] = Edge{best.adj[i], best.adj_edge[i]};
      while (ns > 0) {
        const Edge e = stack[--ns];
        Face& g = faces[e.face];
        if (!g.alive) continue;
        const double h = g.n.dot(p.w) - g.d;
        if (h <= -vis_eps && (nforced == 0 || !detail::contains(forced, nforced, e.face))) {
          near |= h > -suspect;
          horizon[nh++] = e;
          continue;
        }
        g.alive = false;
        free_list[nfree++] = e.face;
        const int j1 = (e.edge + 1) % 3;
        const int j2 = (e.edge + 2) % 3;
        stack[ns++] = Edge{g.adj[j2], g.adj_edge[j2]};
        stack[ns++] = Edge{g.adj[j1], g.adj_edge[j1]};
      }
    };
    walk();
    while (near && nforced < static_cast<int>(forced.size())) {
      // A horizon edge on the point's line: replace its face too and walk again (see `suspect`).
      near = false;
      int lined = -1;
      for (int k = 0; k < nh && lined < 0; ++k) {
        const Face& g = faces[horizon[k].face];
        const int j = horizon[k].edge;
        if (g.n.dot(p.w) - g.d > -suspect &&
            detail::onLine(verts[g.v[j]].w, verts[g.v[(j + 1) % 3]].w, p.w))
          lined = horizon[k].face;
      }
      if (lined < 0) break;
      forced[nforced++] = lined;
      while (nfree > nfree0)
        faces[free_list[--nfree]].alive = true;
      walk();
    }
    bool ok = nh >= 3;
    for (int k = 0; ok && k < nh; ++k) {
      const Face& g = faces[horizon[k].face];
      const int j = horizon[k].edge;
      const int f = allocFace();
      ok = f >= 0 && makeFace(f, g.v[(j + 1) % 3], g.v[j], wi);
      if (!ok) break;
      faces[f].adj[0] = horizon[k].face;
      faces[f].adj_edge[0] = j;
      faces[horizon[k].face].adj[j] = f;
      faces[horizon[k].face].adj_edge[j] = 0;
      new_faces[k] = f;
    }
    for (int k = 0; ok && k < nh; ++k) {
      const int f = new_faces[k];
      const int g = new_faces[(k + 1) % nh];
      // Face k = (q_k, p_k, w), face k+1 = (q_k+1, p_k+1, w): edge 1 of k meets edge 2 of k+1
      // when q_k+1 == p_k (the walk's order).
      ok = faces[g].v[0] == faces[f].v[1];
      faces[f].adj[1] = g;
      faces[f].adj_edge[1] = 2;
      faces[g].adj[2] = f;
      faces[g].adj_edge[2] = 1;
    }
    if (!ok) {
      r.status = EpaStatus::Degenerate;
      break;
    }
  }
  if (have_best) {
    r.depth = best.d;
    r.normal = best.n;
    const Vec3 p = best.d * best.n;
    // The witnesses come from the face that holds p = d n. Faces tied with the nearest one
    // (coplanar faces of A - B, as a box's face and a cylinder's side parallel to it make) may
    // hold it where the nearest does not: p's weights there are negative and give witness points
    // off the shapes (a 0.01 m cylinder through a box's face: 6 mm off the box; found by
    // fuzz_world's certificate of curved parts; test ExactCurved.CylinderThroughABoxFaceHas-
    // WitnessesOnBoth, fuzz/regressions/core/epa-witness-off-cylinder-segment-in-mid-plane). So,
    // converged, walk across the edge of the most negative weight to a face as near (within the
    // convergence tolerance), a few steps at most.
    const Face* at = &best;
    std::array<double, 3> l =
        detail::faceWeights(verts[best.v[0]].w, verts[best.v[1]].w, verts[best.v[2]].w, p);
    const double slack = st.rel_tolerance * std::abs(best.d) + tol;
    for (int step = 0; step < 8 && r.status == EpaStatus::Converged; ++step) {
      const int k = static_cast<int>(std::min_element(l.begin(), l.end()) - l.begin());
      if (!(l[k] < -1e-12)) break;
      const int g = at->adj[(k + 1) % 3];  // across the edge (v[k + 1], v[k + 2])
      if (g < 0 || !faces[g].alive || !(faces[g].d <= best.d + slack)) break;
      at = &faces[g];
      l = detail::faceWeights(verts[at->v[0]].w, verts[at->v[1]].w, verts[at->v[2]].w, p);
    }
    detail::epaWitness3(verts[at->v[0]], verts[at->v[1]], verts[at->v[2]], l, p, r.point_a,
                        r.point_b);
    progress.settle(md, upper, best.d, st.rel_tolerance * std::abs(best.d) + tol, r.status);
  }
  upper.applyTo(r);
  return r;
}

/// 2D EPA on the terminal simplex of gjkDistance(): expansion of a convex polygon (kept convex:
/// the chain of edges visible from a new support point is replaced by two edges).
template <class MD>
EpaResult<2> epa2(const MD& md, const Simplex<2>& simplex, const EpaSettings& st) {
  static_assert(MD::kDim == 2, "epa2 needs a 2D Minkowski difference");
  constexpr int kMaxVerts = kEpaMaxIterations + 3;
  auto cross2 = [](const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); };
  EpaResult<2> r;
  detail::EpaUpperBound<2> upper;
  const double tol = st.abs_tolerance;
  const double vis_eps = 1e-2 * tol;
  const int max_it = std::min(std::max(st.max_iterations, 0), kEpaMaxIterations);

  std::array<SupportPoint<2>, kMaxVerts> P;
  int n = std::min(simplex.size, 3);
  for (int i = 0; i < n; ++i)
    P[i] = simplex.v[i];
  auto flat = [&](int dim) {
    r.status = EpaStatus::Flat;
    r.flat_dimension = dim;
    r.depth = 0.0;
    Simplex<2> s = simplex;
    solveSimplex<2>(s);
    s.witnesses(r.point_a, r.point_b);
    return r;
  };
  if (n <= 0) {
    P[0] = md.support(md.initialDirection());
    n = 1;
  }
  for (int guard = 0;; ++guard) {
    if (guard > 8) {
      r.status = EpaStatus::Degenerate;
      upper.applyTo(r);
      return r;
    }
    const Vec2 w0 = P[0].w;
    if (n == 1) {
      const std::array<Vec2, 4> dirs{Vec2::UnitX(), -Vec2::UnitX(), Vec2::UnitY(), -Vec2::UnitY()};
      double best = -1.0;
      for (const Vec2& d : dirs) {
        const SupportPoint<2> p = md.support(d);
        upper.offer(d, p);
        const double h = (p.w - w0).norm();
        if (h > best) {
          best = h;
          P[1] = p;
        }
      }
      if (best <= tol) return flat(0);
      n = 2;
    } else if (n == 2) {
      const Vec2 u = P[1].w - w0;
      const double len = u.norm();
      if (len <= tol) {
        n = 1;
        continue;
      }
      const Vec2 perp(-u.y() / len, u.x() / len);
      const SupportPoint<2> pp = md.support(perp);
      const SupportPoint<2> pm = md.support(-perp);
      upper.offer(perp, pp);
      upper.offer(-perp, pm);
      const double hp = perp.dot(pp.w - w0);
      const double hm = -perp.dot(pm.w - w0);
      if (std::max(hp, hm) <= tol) {
        r.normal = perp;
        return flat(1);
      }
      P[2] = hp >= hm ? pp : pm;
      n = 3;
    } else {
      const double area = cross2(P[1].w - w0, P[2].w - w0);
      const double longest =
          std::max({(P[1].w - w0).norm(), (P[2].w - w0).norm(), (P[2].w - P[1].w).norm()});
      if (!(std::abs(area) > tol * longest) || area == 0.0) {
        int i = 0;
        int j = 1;
        double dmax = (P[1].w - P[0].w).squaredNorm();
        if ((P[2].w - P[0].w).squaredNorm() > dmax) {
          j = 2;
          dmax = (P[2].w - P[0].w).squaredNorm();
        }
        if ((P[2].w - P[1].w).squaredNorm() > dmax) {
          i = 1;
          j = 2;
        }
        const SupportPoint<2> pi = P[i];
        const SupportPoint<2> pj = P[j];
        P[0] = pi;
        P[1] = pj;
        n = 2;
        continue;
      }
      if (area < 0.0) std::swap(P[1], P[2]);  // counter-clockwise
      break;
    }
  }

  std::array<Vec2, kMaxVerts> en;
  std::array<double, kMaxVerts> ed;
  std::array<SupportPoint<2>, kMaxVerts> Q;
  int bi = 0;
  detail::EpaProgress progress;
  r.status = EpaStatus::MaxIterations;
  for (int it = 0;; ++it) {
    // Outward edge normals (counter-clockwise polygon: outward is the edge turned clockwise).
    bool ok = true;
    bi = -1;
    double bd = std::numeric_limits<double>::infinity();
    for (int i = 0; i < n; ++i) {
      const Vec2 e = P[(i + 1) % n].w - P[i].w;
      const double len = e.norm();
      if (!(len > 0.0)) {
        ok = false;
        en[i] = Vec2::Zero();
        ed[i] = std::numeric_limits<double>::infinity();
        continue;
      }
      en[i] = Vec2(e.y() / len, -e.x() / len);
      ed[i] = 0.5 * (en[i].dot(P[i].w) + en[i].dot(P[(i + 1) % n].w));
      if (ed[i] < bd) {
        bd = ed[i];
        bi = i;
      }
    }
    if (bi < 0) {
      r.status = EpaStatus::Degenerate;
      break;
    }
    if (!ok) {
      r.status = EpaStatus::Degenerate;
      break;
    }
    if (it >= max_it || n >= kMaxVerts) break;
    if (progress.stalls(md, upper, it, max_it, ed[bi], st.rel_tolerance * std::abs(ed[bi]) + tol))
      break;
    r.iterations = it + 1;
    const SupportPoint<2> p = md.support(en[bi]);
    upper.offer(en[bi], p);
    const double gain = en[bi].dot(p.w) - ed[bi];
    if (gain <= st.rel_tolerance * std::abs(ed[bi]) + tol) {
      r.status = EpaStatus::Converged;
      break;
    }
    // The chain of edges visible from p: start .. end (cyclic), containing bi.
    int start = bi;
    int end = bi;
    int count = 1;
    while (count < n) {
      const int prev = (start + n - 1) % n;
      if (en[prev].dot(p.w) - ed[prev] <= -vis_eps) break;
      start = prev;
      ++count;
    }
    while (count < n) {
      const int next = (end + 1) % n;
      if (en[next].dot(p.w) - ed[next] <= -vis_eps) break;
      end = next;
      ++count;
    }
    if (count >= n) {
      r.status = EpaStatus::Degenerate;
      break;
    }
    // Keep vertices end+1, ..., start (cyclic), then p.
    int m = 0;
    for (int k = (end + 1) % n;; k = (k + 1) % n) {
      Q[m++] = P[k];
      if (k == start) break;
    }
    Q[m++] = p;
    for (int k = 0; k < m; ++k)
      P[k] = Q[k];
    n = m;
  }
  if (bi >= 0) {
    const SupportPoint<2>& a = P[bi];
    const SupportPoint<2>& b = P[(bi + 1) % n];
    const Vec2 e = b.w - a.w;
    const double ee = e.squaredNorm();
    const Vec2 q = ed[bi] * en[bi];
    const double t = ee > 0.0 ? (q - a.w).dot(e) / ee : 0.0;
    r.depth = ed[bi];
    r.normal = en[bi];
    r.point_a = (1.0 - t) * a.a + t * b.a;
    r.point_b = (1.0 - t) * a.b + t * b.b;
    progress.settle(md, upper, ed[bi], st.rel_tolerance * std::abs(ed[bi]) + tol, r.status);
  }
  upper.applyTo(r);
  return r;
}

/// EPA for D = 2 or 3 (dispatch on the Minkowski difference's dimension).
template <class MD>
EpaResult<MD::kDim> epaPenetration(const MD& md, const Simplex<MD::kDim>& simplex,
                                   const EpaSettings& st) {
  static_assert(MD::kDim == 2 || MD::kDim == 3, "EPA is implemented for D = 2 and D = 3");
  if constexpr (MD::kDim == 3) {
    return epa3(md, simplex, st);
  } else {
    return epa2(md, simplex, st);
  }
}

}  // namespace core
}  // namespace collision_monitor
