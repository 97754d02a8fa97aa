/// \file
/// GJK (Gilbert, Johnson, Keerthi 1988) in any dimension D, on support mappings (shapes.h).
///
/// All computations are done in the frame of shape A: the relative transform T_AB = T_A^-1 T_B is
/// computed once per query and B's support points are mapped into A's frame
/// (MinkowskiDifference). The pair's support function is a fully typed template instantiation, so
/// the loop has no virtual call, no switch on shape type and no heap allocation.
///
/// Simplex sub-algorithm: signed volumes (Montanari, Petrinic, Barbieri 2017, "Improving the GJK
/// algorithm for faster and more reliable distance queries between convex objects", ACM TOG 36(3))
/// for D = 2 and D = 3; for other D a projection onto the affine hull with recursion into the
/// facets whose barycentric weight is <= 0 (the closest point lies on such a facet). Both accept
/// any simplex (not only the ones GJK builds, so warm-start seeds are safe) and degenerate ones
/// (flat, collinear, duplicate vertices) and never produce NaN. Inside the 3D loop the same
/// signed-volume arithmetic runs only on the features that hold the newest support point
/// (detail::closestInLoop); a cold run starts at an interior point cA - cB when the shapes have
/// one (gjkStart).
///
/// Termination (van den Bergen 1999, "A fast and robust GJK implementation for collision detection
/// of convex objects", J. Graphics Tools 4(2)): |v|^2 - v.w <= eps_rel |v|^2 (with an absolute
/// floor, see GjkSettings), a duplicate support point, no progress, or the iteration bound.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <type_traits>
#include <utility>

#include <Eigen/QR>

#include "collision_monitor/core/math.h"

namespace collision_monitor {
namespace core {

// ---------------------------------------------------------------------------------------------
// Support points and simplices
// ---------------------------------------------------------------------------------------------

/// A point of the Minkowski difference A - B with the two points it came from.
template <int D>
struct SupportPoint {
  Vec<D> w;  ///< a - b, A's frame
  Vec<D> a;  ///< point of A, A's frame
  Vec<D> b;  ///< point of B, A's frame
};

/// A GJK simplex: up to D + 1 support points and the barycentric weights of the point of their
/// convex hull closest to the origin (weights > 0, summing to 1, for the first `size` vertices).
template <int D>
struct Simplex {
  std::array<SupportPoint<D>, D + 1> v;
  std::array<double, D + 1> bary{};
  int size = 0;

  /// The closest point sum(bary_i w_i), A's frame.
  CM_ALWAYS_INLINE Vec<D> closest() const {
    Vec<D> p = Vec<D>::Zero();
    for (int i = 0; i < size; ++i)
      p += bary[i] * v[i].w;
    return p;
  }
  /// Witness points sum(bary_i a_i) on A and sum(bary_i b_i) on B, A's frame, as the first
  /// vertex plus the weighted differences to it: the weights, ratios of lengths, areas or volumes
  /// of A - B, sum to 1 only to a rounding that the ratio of A - B's size to its edges amplifies,
  /// and so the points move by that rounding times the vertices' differences, not times their
  /// distance from the origin. A point 950 m from its frame's origin, 0.04 m from a 3 mm polygon:
  /// the plain sum put the witness 3.8e-11 m off the point (test_gjk_2d_sweep), 180 ulps at 950 m.
  CM_ALWAYS_INLINE void witnesses(Vec<D>& a, Vec<D>& b) const {
    if (size <= 0) {
      a.setZero();
      b.setZero();
      return;
    }
    a = v[0].a;
    b = v[0].b;
    for (int i = 1; i < size; ++i) {
      a += bary[i] * (v[i].a - v[0].a);
      b += bary[i] * (v[i].b - v[0].b);
    }
  }
};

// ---------------------------------------------------------------------------------------------
// Support-mapping adapters (Jolt's ConvexSupport.h idea: small stacked templates)
// ---------------------------------------------------------------------------------------------

/// Shape `S` placed by the rigid transform `pose` (shape frame -> outer frame).
template <int D, class S>
struct Transformed {
  static constexpr int kDim = D;
  const S* shape;
  Transform<D> pose;
  Transformed(const S& s, const Transform<D>& p) : shape(&s), pose(p) {}
  Vec<D> support(const Vec<D>& d) const { return pose * shape->support(pose.R.transpose() * d); }
};

/// Minkowski sum S1 + S2 (both in the same frame).
template <int D, class S1, class S2>
struct MinkowskiSum {
  static constexpr int kDim = D;
  const S1* s1;
  const S2* s2;
  MinkowskiSum(const S1& a, const S2& b) : s1(&a), s2(&b) {}
  Vec<D> support(const Vec<D>& d) const { return s1->support(d) + s2->support(d); }
};

/// Shape `S` inflated by `radius` (>= 0): S + ball(radius); support adds radius d / |d|. For
/// composing shapes by hand (the tests do); the queries keep radii out of the GJK loop and add
/// them after convergence (see query.h).
template <int D, class S>
struct Padded {
  static constexpr int kDim = D;
  const S* shape;
  double radius;
  Padded(const S& s, double r) : shape(&s), radius(r) {}
  Vec<D> support(const Vec<D>& d) const {
    Vec<D> p = shape->support(d);
    const double n = d.norm();
    if (n > 0.0 && radius > 0.0) p += (radius / n) * d;
    return p;
  }
};

namespace detail {
/// True when S has interiorPoint() (every core in shapes.h; not the adapters above).
template <class S, class = void>
struct HasInteriorPoint : std::false_type {};
template <class S>
struct HasInteriorPoint<S, std::void_t<decltype(std::declval<const S&>().interiorPoint())>>
    : std::true_type {};
}  // namespace detail

/// The Minkowski difference A - B in A's frame, with B placed by T_AB (B's frame -> A's frame).
/// support(d) = sA(d) - (R_AB sB(R_AB^T (-d)) + t_AB). SA and SB are support mappings in their
/// own frames (shapes.h); a PolytopeSupport keeps its hill-climbing hint across calls.
template <int D, class SA, class SB>
class MinkowskiDifference {
 public:
  static constexpr int kDim = D;

  MinkowskiDifference(const SA& a, const SB& b, const Transform<D>& T_AB)
      : a_(a), b_(b), R_(T_AB.R), t_(T_AB.t) {}

  /// Support point of A - B maximising dot(d, w), A's frame.
  CM_ALWAYS_INLINE SupportPoint<D> support(const Vec<D>& d) const {
    SupportPoint<D> p;
    p.a = a_.support(d);
    p.b = mulAdd<D>(R_, b_.support(mulTransposed<D>(R_, -d)), t_);
    p.w = p.a - p.b;
    return p;
  }
  /// A point of A - B from a point of A (A's frame) and one of B (B's frame): how a cached
  /// simplex is re-evaluated for the current poses.
  SupportPoint<D> fromLocal(const Vec<D>& a_local, const Vec<D>& b_local) const {
    SupportPoint<D> p;
    p.a = a_local;
    p.b = R_ * b_local + t_;
    p.w = p.a - p.b;
    return p;
  }
  /// True when both shapes have interiorPoint(): a cold GJK run then starts at interiorPoint().
  static constexpr bool kHasInterior =
      detail::HasInteriorPoint<SA>::value && detail::HasInteriorPoint<SB>::value;
  /// cA - cB for interior points cA of A and cB of B: a point of A - B near its middle (A's
  /// frame). Only for kHasInterior.
  SupportPoint<D> interiorPoint() const {
    return fromLocal(a_.interiorPoint(), b_.interiorPoint());
  }
  /// A point of A as fromLocal() takes it back (A's frame: itself).
  const Vec<D>& toLocalA(const Vec<D>& a) const { return a; }
  /// A point given in A's frame, mapped into B's frame.
  Vec<D> toLocalB(const Vec<D>& b) const { return R_.transpose() * (b - t_); }
  /// First search direction: from the centre of A - B (at -t_AB) towards the origin.
  Vec<D> initialDirection() const {
    return t_.squaredNorm() > 0.0 ? Vec<D>(t_) : Vec<D>(Vec<D>::Unit(0));
  }
  const Mat<D>& rotation() const { return R_; }
  const Vec<D>& translation() const { return t_; }

 private:
  const SA& a_;
  const SB& b_;
  Mat<D> R_;
  Vec<D> t_;
};

// ---------------------------------------------------------------------------------------------
// Simplex sub-algorithms
// ---------------------------------------------------------------------------------------------

namespace detail {

/// Closest point of the convex hull of some vertices of a simplex: which vertices (indices into
/// the input), their weights, the point and its squared norm.
template <int D>
struct Closest {
  std::array<int, D + 1> idx{};
  std::array<double, D + 1> lambda{};
  int n = 0;
  Vec<D> v = Vec<D>::Zero();
  double dist2 = std::numeric_limits<double>::infinity();
};

template <int D>
using Points = std::array<Vec<D>, D + 1>;

inline bool sameSign(double a, double b) {
  return (a > 0.0 && b > 0.0) || (a < 0.0 && b < 0.0);
}

/// The triangle's normal (s1 - s0) x (s2 - s0), computed from the two edges at its largest angle
/// (the edges other than the longest): the same vector in exact arithmetic, and the one product
/// whose factors are not nearly parallel on a sliver. From s0 a triangle with two vertices 1 m
/// apart and the third 8e5 m away (a 1.1e6 m capsule by a cylinder) gave a normal 2e-10 rad off
/// and a projection of the origin 6.6e-4 m too near, below the distance
/// (fuzz/regressions/core/gjk-sliver-triangle-normal-base). `kAccurate`: crossAccurate().
/// `opposite_longest` (optional, out): the vertex (0, 1, 2) opposite the longest edge;
/// `longest_sq` (optional, out): that edge's squared length.
template <bool kAccurate = false>
CM_ALWAYS_INLINE Vec3 triangleNormal(const Vec3& s0, const Vec3& s1, const Vec3& s2,
                                     int* opposite_longest = nullptr,
                                     double* longest_sq = nullptr) {
  const Vec3 e01 = s1 - s0, e02 = s2 - s0, e12 = s2 - s1;
  const double l01 = e01.squaredNorm(), l02 = e02.squaredNorm(), l12 = e12.squaredNorm();
  // e01 x e02 = e01 x e12 = e02 x e12
  const bool from0 = l12 >= l01 && l12 >= l02;
  if (opposite_longest != nullptr) *opposite_longest = from0 ? 0 : l02 >= l01 ? 1 : 2;
  if (longest_sq != nullptr) *longest_sq = from0 ? l12 : std::max(l01, l02);
  const Vec3& a = from0 || l02 >= l01 ? e01 : e02;
  const Vec3& b = from0 ? e02 : e12;
  if constexpr (kAccurate) {
    return crossAccurate(a, b);
  } else {
    return a.cross(b);
  }
}

/// True when a triangle's plane is too poorly placed for the origin's projection q onto it to
/// stand for its closest point (then sum(lambda_m s_m) does): the plane is only as well placed as
/// the triangle is wide (its height over the longest edge, |n| / |e|). The vertices' rounding
/// turns a sliver's plane about that edge, and q with it by |q| times that angle, while the sum's
/// error stays a rounding of the vertices. So: a triangle narrower than |q| and than 1e-6 of its
/// length. A cone 0.12 m from a 2e6 m needle: a triangle along the needle, q 2.2e-3 m off the sum
/// and 1.5e-3 m inside the distance (fuzz/regressions/core/gjk-cone-by-2e6m-needle-sliver).
/// `nn` = |n|^2, `qq` = |q|^2, `longest_sq` = |e|^2.
CM_ALWAYS_INLINE bool sliverPlane(double nn, double qq, double longest_sq) {
  return __builtin_expect(nn < qq * longest_sq && nn < 1e-12 * longest_sq * longest_sq, 0);
}

/// Barycentric weights of a triangle's point from its signed areas C_m (sub-triangle opposite
/// vertex m, from the edge opposite m) over the whole area mu: C_m / mu, except the vertex opposite
/// the longest edge (`opposite_longest`, from triangleNormal()), whose area multiplies the two
/// longest lengths and loses the most digits on a sliver; it gets 1 minus the others, so the
/// weights sum to 1. On a 2e6 m needle triangle (a cone by a 2e6 m flat ellipse) two of the C_m /
/// mu were off by 1.3e-7 and summed to 1 - 2.6e-7: the witness point on the needle, sum(lambda_m
/// b_m) with |b_m| = 1e6 m, was 0.14 m off while the distance was right
/// (fuzz/regressions/core/gjk-cone-by-2e6m-flat-ellipse-witness-sum). The weight of the vertex
/// opposite the short edge is accurate, and the split of the rest between two nearly coincident
/// vertices moves the point by little.
CM_ALWAYS_INLINE void triangleWeights(int opposite_longest, double mu, double C0, double C1,
                                      double C2, double* lambda) {
  double a = C0 / mu, b = C1 / mu, c = C2 / mu;
  a = opposite_longest == 0 ? 1.0 - b - c : a;
  b = opposite_longest == 1 ? 1.0 - a - c : b;
  c = opposite_longest == 2 ? 1.0 - a - b : c;
  lambda[0] = a;
  lambda[1] = b;
  lambda[2] = c;
}

/// True when a tetrahedron's volume mu or a weight C_m (GJK's signed volumes, from vertex 0 and
/// the origin) is within a rounding bound of 0, where its sign may be wrong: 64 eps M^3, M the
/// largest |s_m| (the formulas multiply three lengths of at most 2M each).
inline bool volumesUncertain(const Vec3& s0, const Vec3& s1, const Vec3& s2, const Vec3& s3,
                             double mu, double C0, double C1, double C2, double C3) {
  const double m2 = std::max(std::max(s0.squaredNorm(), s1.squaredNorm()),
                             std::max(s2.squaredNorm(), s3.squaredNorm()));
  const double bound = 64.0 * std::numeric_limits<double>::epsilon() * m2 * std::sqrt(m2);
  const double least = std::min(std::min(std::abs(mu), std::abs(C0)),
                                std::min(std::min(std::abs(C1), std::abs(C2)), std::abs(C3)));
  return least <= bound;
}

/// mu and the weights C_m again, each from the vertex of its tetrahedron whose edges are
/// shortest (orientation()). A needle tetrahedron (two vertices at each end of a 1094 m box
/// 1e-6 m wide, the origin inside) had weights of the wrong sign from vertex 0 and the origin:
/// "no progress", a separation for overlapping shapes
/// (fuzz/regressions/core/gjk-needle-tetrahedron-weights). Out of line: rare.
__attribute__((noinline, cold)) inline void robustVolumes(const Vec3& s0, const Vec3& s1,
                                                          const Vec3& s2, const Vec3& s3,
                                                          double& mu, double& C0, double& C1,
                                                          double& C2, double& C3) {
  const Vec3 o = Vec3::Zero();
  mu = orientation(s0, s1, s2, s3);
  C0 = orientation(o, s1, s2, s3);
  C1 = orientation(s0, o, s2, s3);
  C2 = orientation(s0, s1, o, s3);
  C3 = orientation(s0, s1, s2, o);
}

template <int D>
Closest<D> vertex(const Points<D>& w, int i) {
  Closest<D> c;
  c.n = 1;
  c.idx[0] = i;
  c.lambda[0] = 1.0;
  c.v = w[i];
  c.dist2 = c.v.squaredNorm();
  return c;
}

template <int D>
void finish(Closest<D>& c, const Points<D>& w) {
  c.v.setZero();
  c.dist2 = 0.0;
  if (c.n == D + 1) return;  // the origin itself: see offerTetrahedron()
  for (int k = 0; k < c.n; ++k)
    c.v += c.lambda[k] * w[c.idx[k]];
  c.dist2 = c.v.squaredNorm();
}

/// Segment (Montanari et al. S1D, written for an arbitrary segment: the endpoint whose weight is
/// <= 0 is dropped, so it does not rely on which vertex GJK added last).
template <int D>
Closest<D> s1d(const Points<D>& w, int i0, int i1) {
  const Vec<D> t = w[i1] - w[i0];
  const double tt = t.squaredNorm();
  const double l0 = w[i1].dot(t);   // tt * weight of i0
  const double l1 = -w[i0].dot(t);  // tt * weight of i1
  if (tt > 0.0 && l0 > 0.0 && l1 > 0.0) {
    Closest<D> c;
    c.n = 2;
    c.idx = {};
    c.idx[0] = i0;
    c.idx[1] = i1;
    c.lambda[0] = l0 / tt;
    c.lambda[1] = l1 / tt;
    finish(c, w);
    return c;
  }
  if (l1 > 0.0) return vertex(w, i1);  // origin projects beyond i1
  if (l0 > 0.0) return vertex(w, i0);  // ... before i0
  // Coincident endpoints: either one (the nearer, for a defined answer).
  return w[i0].squaredNorm() <= w[i1].squaredNorm() ? vertex(w, i0) : vertex(w, i1);
}

template <int D>
void keepCloser(Closest<D>& best, const Closest<D>& c) {
  if (c.dist2 < best.dist2) best = c;
}

/// Triangle in 3D (Montanari et al. S2D): project the origin onto the triangle's plane, take 2D
/// barycentric coordinates in the coordinate plane where the triangle's projection is largest;
/// recurse into the edges whose weight does not share the sign of the area.
inline Closest<3> s2d3(const Points<3>& w, int i0, int i1, int i2) {
  const Vec3& s0 = w[i0];
  const Vec3& s1 = w[i1];
  const Vec3& s2 = w[i2];
  int longest = 0;
  double longest_sq = 0.0;
  const Vec3 n = triangleNormal(s0, s1, s2, &longest, &longest_sq);
  const double nn = n.squaredNorm();
  std::array<bool, 3> check{true, true, true};
  if (nn > 0.0) {
    const Vec3 p = n * (s0.dot(n) / nn);  // projection of the origin onto the plane
    int I = 0;
    n.cwiseAbs().maxCoeff(&I);
    const int j = (I + 1) % 3;
    const int k = (I + 2) % 3;
    auto area2 = [j, k](const Vec3& a, const Vec3& b, const Vec3& c) {
      return (b[j] - a[j]) * (c[k] - a[k]) - (b[k] - a[k]) * (c[j] - a[j]);
    };
    const double mu = n[I];  // = area2(s0, s1, s2)
    const std::array<double, 3> C{area2(s1, s2, p), area2(s0, p, s2), area2(s0, s1, p)};
    if (sameSign(mu, C[0]) && sameSign(mu, C[1]) && sameSign(mu, C[2])) {
      Closest<3> c;
      c.n = 3;
      c.idx = {i0, i1, i2, 0};
      triangleWeights(longest, mu, C[0], C[1], C[2], c.lambda.data());
      c.v = p;  // not sum(lambda_m w_m) unless a sliver's: see offerTriangle()
      c.dist2 = p.squaredNorm();
      if (sliverPlane(nn, c.dist2, longest_sq)) {
        c.v = c.lambda[0] * s0 + c.lambda[1] * s1 + c.lambda[2] * s2;
        c.dist2 = c.v.squaredNorm();
      }
      return c;
    }
    for (int m = 0; m < 3; ++m)
      check[m] = !sameSign(mu, C[m]);
  }
  Closest<3> best;
  if (check[0]) keepCloser(best, s1d(w, i1, i2));
  if (check[1]) keepCloser(best, s1d(w, i0, i2));
  if (check[2]) keepCloser(best, s1d(w, i0, i1));
  return best;
}

/// Tetrahedron in 3D (Montanari et al. S3D): barycentric coordinates of the origin from signed
/// volumes; recurse into the faces opposite the vertices whose weight does not share the sign
/// of the volume.
inline Closest<3> s3d(const Points<3>& w, int i0, int i1, int i2, int i3) {
  const Vec3& s0 = w[i0];
  const Vec3& s1 = w[i1];
  const Vec3& s2 = w[i2];
  const Vec3& s3 = w[i3];
  const Vec3 e1 = s1 - s0;
  const Vec3 e2 = s2 - s0;
  const Vec3 e3 = s3 - s0;
  double mu = e1.dot(e2.cross(e3));
  // Volumes with vertex m replaced by the origin (they sum to mu).
  std::array<double, 4> C{s1.dot(s2.cross(s3)), -s0.dot(e2.cross(e3)), -e1.dot(s0.cross(e3)),
                          -e1.dot(e2.cross(s0))};
  if (volumesUncertain(s0, s1, s2, s3, mu, C[0], C[1], C[2], C[3]))
    robustVolumes(s0, s1, s2, s3, mu, C[0], C[1], C[2], C[3]);
  if (mu != 0.0 && sameSign(mu, C[0]) && sameSign(mu, C[1]) && sameSign(mu, C[2]) &&
      sameSign(mu, C[3])) {
    Closest<3> c;
    c.n = 4;
    c.idx = {i0, i1, i2, i3};
    for (int m = 0; m < 4; ++m)
      c.lambda[m] = C[m] / mu;
    finish(c, w);
    return c;
  }
  const bool all = mu == 0.0;
  Closest<3> best;
  if (all || !sameSign(mu, C[0])) keepCloser(best, s2d3(w, i1, i2, i3));
  if (all || !sameSign(mu, C[1])) keepCloser(best, s2d3(w, i0, i2, i3));
  if (all || !sameSign(mu, C[2])) keepCloser(best, s2d3(w, i0, i1, i3));
  if (all || !sameSign(mu, C[3])) keepCloser(best, s2d3(w, i0, i1, i2));
  return best;
}

/// Triangle in 2D (signed areas; the origin lies in the triangle's plane).
inline Closest<2> s2d2(const Points<2>& w, int i0, int i1, int i2) {
  auto cross2 = [](const Vec2& a, const Vec2& b) { return a.x() * b.y() - a.y() * b.x(); };
  const Vec2& s0 = w[i0];
  const Vec2& s1 = w[i1];
  const Vec2& s2 = w[i2];
  const double mu = cross2(s1 - s0, s2 - s0);
  const std::array<double, 3> C{cross2(s1, s2), cross2(s2, s0), cross2(s0, s1)};
  if (mu != 0.0 && sameSign(mu, C[0]) && sameSign(mu, C[1]) && sameSign(mu, C[2])) {
    Closest<2> c;
    c.n = 3;
    c.idx = {i0, i1, i2};
    for (int m = 0; m < 3; ++m)
      c.lambda[m] = C[m] / mu;
    finish(c, w);
    return c;
  }
  const bool all = mu == 0.0;
  Closest<2> best;
  if (all || !sameSign(mu, C[0])) keepCloser(best, s1d(w, i1, i2));
  if (all || !sameSign(mu, C[1])) keepCloser(best, s1d(w, i0, i2));
  if (all || !sameSign(mu, C[2])) keepCloser(best, s1d(w, i0, i1));
  return best;
}

/// Any dimension: least-squares projection of the origin onto the affine hull of the vertices
/// `idx[0..m)` (rank-revealing QR, so a degenerate simplex is detected rather than inverted).
/// If the projection has all weights > 0 it is the answer; otherwise the closest point lies on a
/// facet opposite a vertex with weight <= 0 (all facets when the hull is degenerate): recurse
/// and keep the closest.
template <int D>
Closest<D> generic(const Points<D>& w, const std::array<int, D + 1>& idx, int m) {
  if (m == 1) return vertex(w, idx[0]);
  if (m == 2) return s1d(w, idx[0], idx[1]);
  using EMat = Eigen::Matrix<double, D, Eigen::Dynamic, 0, D, D>;
  EMat E(D, m - 1);
  for (int k = 1; k < m; ++k)
    E.col(k - 1) = w[idx[k]] - w[idx[0]];
  Eigen::ColPivHouseholderQR<EMat> qr(E);
  bool full = false;
  std::array<double, D + 1> lambda{};
  if (qr.rank() == m - 1) {
    const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, D, 1> mu = qr.solve(Vec<D>(-w[idx[0]]));
    lambda[0] = 1.0 - mu.sum();
    full = lambda[0] > 0.0;
    for (int k = 1; k < m; ++k) {
      lambda[k] = mu[k - 1];
      full = full && lambda[k] > 0.0;
    }
    if (full && std::isfinite(mu.sum())) {
      Closest<D> c;
      c.n = m;
      c.idx = idx;
      c.lambda = lambda;
      finish(c, w);
      return c;
    }
    full = true;  // weights are meaningful: recurse only where they are <= 0
  }
  Closest<D> best;
  for (int drop = 0; drop < m; ++drop) {
    if (full && lambda[drop] > 0.0) continue;
    std::array<int, D + 1> sub{};
    int n = 0;
    for (int k = 0; k < m; ++k)
      if (k != drop) sub[n++] = idx[k];
    keepCloser(best, generic<D>(w, sub, m - 1));
  }
  return best;
}

}  // namespace detail

namespace detail {

/// Closest point to the origin of the convex hull of the simplex's vertices, without changing the
/// simplex: which vertices carry it, their weights, the point and its squared norm.
template <int D>
Closest<D> closestOf(const Simplex<D>& s, bool force_generic = false) {
  Points<D> w;
  for (int i = 0; i < s.size; ++i)
    w[i] = s.v[i].w;
  if (s.size <= 0) {
    Closest<D> c;
    c.dist2 = 0.0;
    return c;
  }
  if (s.size == 1) return vertex<D>(w, 0);
  if (s.size == 2) return s1d<D>(w, 0, 1);
  if constexpr (D == 3) {
    if (!force_generic) return s.size == 3 ? s2d3(w, 0, 1, 2) : s3d(w, 0, 1, 2, 3);
  } else if constexpr (D == 2) {
    if (!force_generic) return s2d2(w, 0, 1, 2);
  }
  std::array<int, D + 1> all{};
  for (int i = 0; i <= D; ++i)
    all[i] = i;
  return generic<D>(w, all, s.size);
}

/// Reduce `s` in place to the vertices of `c` (from closestOf(s)) with their weights. The kept
/// indices are increasing (every sub-algorithm lists vertices in increasing order), so
/// c.idx[k] >= k and nothing is overwritten before it is read.
template <int D>
void compact(Simplex<D>& s, const Closest<D>& c) {
  if (s.size <= 0) return;
  const int n = std::min(c.n, D + 1);
  for (int k = 0; k < n; ++k) {
    if (c.idx[k] != k) s.v[k] = s.v[c.idx[k]];
    s.bary[k] = c.lambda[k];
  }
  s.size = n;
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------
// The 3D sub-algorithm of the GJK loop
// ---------------------------------------------------------------------------------------------

namespace detail {

/// Best candidate of the loop's 3D sub-algorithm: the vertices that carry it (bit i: vertex i of
/// the simplex), their weights by vertex index, the point and its squared norm.
struct Loop3 {
  unsigned mask = 0;
  double lambda[4] = {0.0, 0.0, 0.0, 0.0};
  Vec3 v = Vec3::Zero();
  double dist2 = std::numeric_limits<double>::infinity();
};

CM_ALWAYS_INLINE void offerVertex(const SupportPoint<3>* p, int i, Loop3& best) {
  const double d2 = p[i].w.squaredNorm();
  if (d2 < best.dist2) {
    best.mask = 1u << i;
    best.lambda[0] = best.lambda[1] = best.lambda[2] = best.lambda[3] = 0.0;
    best.lambda[i] = 1.0;
    best.v = p[i].w;
    best.dist2 = d2;
  }
}

/// Segment i0-i1: the arithmetic of s1d().
CM_ALWAYS_INLINE void offerSegment(const SupportPoint<3>* p, int i0, int i1, Loop3& best) {
  const Vec3& w0 = p[i0].w;
  const Vec3& w1 = p[i1].w;
  const Vec3 t = w1 - w0;
  const double tt = t.squaredNorm();
  const double l0 = w1.dot(t);   // tt * weight of i0
  const double l1 = -w0.dot(t);  // tt * weight of i1
  if (tt > 0.0 && l0 > 0.0 && l1 > 0.0) {
    const double a = l0 / tt;
    const double b = l1 / tt;
    const Vec3 v = a * w0 + b * w1;
    const double d2 = v.squaredNorm();
    if (d2 < best.dist2) {
      best.mask = (1u << i0) | (1u << i1);
      best.lambda[0] = best.lambda[1] = best.lambda[2] = best.lambda[3] = 0.0;
      best.lambda[i0] = a;
      best.lambda[i1] = b;
      best.v = v;
      best.dist2 = d2;
    }
    return;
  }
  if (l1 > 0.0) return offerVertex(p, i1, best);
  if (l0 > 0.0) return offerVertex(p, i0, best);
  offerVertex(p, w0.squaredNorm() <= w1.squaredNorm() ? i0 : i1, best);
}

/// Twice the signed areas, in the coordinate plane where the triangle's normal n is largest, of the
/// triangle (mu = n[I]) and of the triangles with q, a point of its plane, in place of vertex m
/// (C_m): q's barycentric coordinates are C_m / mu.
struct PlaneAreas {
  double mu, C0, C1, C2;
  bool inside() const { return sameSign(mu, C0) && sameSign(mu, C1) && sameSign(mu, C2); }
};
CM_ALWAYS_INLINE PlaneAreas planeAreas(const Vec3& s0, const Vec3& s1, const Vec3& s2,
                                       const Vec3& n, const Vec3& q) {
  const double ax = std::abs(n.x()), ay = std::abs(n.y()), az = std::abs(n.z());
  const int I = ax >= ay ? (ax >= az ? 0 : 2) : (ay >= az ? 1 : 2);  // first maximum
  const int j = I == 2 ? 0 : I + 1;
  const int k = I == 0 ? 2 : I - 1;
  const auto area2 = [j, k](const Vec3& a, const Vec3& b, const Vec3& c) {
    return (b[j] - a[j]) * (c[k] - a[k]) - (b[k] - a[k]) * (c[j] - a[j]);
  };
  return {n[I], area2(s1, s2, q), area2(s0, q, s2), area2(s0, s1, q)};
}

/// Triangle i0-i1-i2 whose newest vertex is i2: the arithmetic of s2d3(), without the edge
/// i0-i1 (it does not hold the newest vertex). When the origin projects inside, the closest point
/// is that projection q, not sum(lambda_i w_i): the sum rounds at the vertices' size, q's direction
/// is the normal's. A plate 1094 m long touching an ellipsoid gave triangles with vertices 547 m
/// out and |v| 1e-7 m: the sum's 5e-14 m of rounding across the plate turned v 7e-8 rad, the
/// support point went to the plate's wrong end, and GJK stopped on a duplicate 7.3e-7 m from the
/// contact (fuzz/regressions/core/gjk-needle-triangle-projection-warm). Except on a sliver whose
/// plane is less certain than the sum (sliverPlane()).
inline void offerTriangle(const SupportPoint<3>* p, int i0, int i1, int i2, Loop3& best) {
  const Vec3& s0 = p[i0].w;
  const Vec3& s1 = p[i1].w;
  const Vec3& s2 = p[i2].w;
  int longest = 0;
  double longest_sq = 0.0;
  const Vec3 n = triangleNormal(s0, s1, s2, &longest, &longest_sq);
  const double nn = n.squaredNorm();
  bool edge12 = true, edge02 = true;
  if (nn > 0.0) {
    const Vec3 q = n * (s0.dot(n) / nn);  // projection of the origin onto the plane
    const PlaneAreas ar = planeAreas(s0, s1, s2, n, q);
    const bool in0 = sameSign(ar.mu, ar.C0), in1 = sameSign(ar.mu, ar.C1);
    if (in0 && in1 && sameSign(ar.mu, ar.C2)) {
      double w[3];
      triangleWeights(longest, ar.mu, ar.C0, ar.C1, ar.C2, w);
      const double a = w[0], b = w[1], c = w[2];
      Vec3 v = q;
      double d2 = v.squaredNorm();
      if (sliverPlane(nn, d2, longest_sq)) {
        v = a * s0 + b * s1 + c * s2;
        d2 = v.squaredNorm();
      }
      if (d2 < best.dist2) {
        best.mask = (1u << i0) | (1u << i1) | (1u << i2);
        best.lambda[0] = best.lambda[1] = best.lambda[2] = best.lambda[3] = 0.0;
        best.lambda[i0] = a;
        best.lambda[i1] = b;
        best.lambda[i2] = c;
        best.v = v;
        best.dist2 = d2;
      }
      return;
    }
    edge12 = !in0;
    edge02 = !in1;
  }
  if (edge12) offerSegment(p, i1, i2, best);
  if (edge02) offerSegment(p, i0, i2, best);
}

/// Tetrahedron whose newest vertex is 3: the arithmetic of s3d(), without the face 0-1-2.
inline void offerTetrahedron(const SupportPoint<3>* p, Loop3& best) {
  const Vec3& s0 = p[0].w;
  const Vec3& s1 = p[1].w;
  const Vec3& s2 = p[2].w;
  const Vec3& s3 = p[3].w;
  const Vec3 e1 = s1 - s0;
  const Vec3 e2 = s2 - s0;
  const Vec3 e3 = s3 - s0;
  const Vec3 e23 = e2.cross(e3);
  double mu = e1.dot(e23);
  double C0 = s1.dot(s2.cross(s3));
  double C1 = -s0.dot(e23);
  double C2 = -e1.dot(s0.cross(e3));
  double C3 = -e1.dot(e2.cross(s0));
  bool in0 = sameSign(mu, C0), in1 = sameSign(mu, C1), in2 = sameSign(mu, C2);
  bool in3 = sameSign(mu, C3);
  // A sign that rounding may have flipped: again, from better vertices. Inside too: a segment
  // 0.04 m from a 2.5e6 m cylinder gave a needle tetrahedron "holding" the origin, and distance()
  // said Penetrating (fuzz/regressions/core/gjk-segment-by-2.5e6m-cylinder-false-inside).
  if (volumesUncertain(s0, s1, s2, s3, mu, C0, C1, C2, C3)) {
    robustVolumes(s0, s1, s2, s3, mu, C0, C1, C2, C3);
    in0 = sameSign(mu, C0), in1 = sameSign(mu, C1), in2 = sameSign(mu, C2);
    in3 = sameSign(mu, C3);
  }
  if (mu != 0.0 && in0 && in1 && in2 && in3) {
    best.mask = 15u;
    best.lambda[0] = C0 / mu;
    best.lambda[1] = C1 / mu;
    best.lambda[2] = C2 / mu;
    best.lambda[3] = C3 / mu;
    // All four weights positive: the tetrahedron holds the origin, its closest point. Not
    // sum(lambda_i w_i): on a needle the weights lose digits and that sum is metres off (a box in
    // a 4.9e6 m segment: C0 off by 4e-6 of itself, v 4.6 m from the origin, "no progress" and
    // a 0.03 m separation for an overlap of 1.3 m: fuzz/regressions/core/
    // gjk-box-in-4900km-segment-needle-tetrahedron).
    best.v = Vec3::Zero();
    best.dist2 = 0.0;
    return;
  }
  const bool all = mu == 0.0;
  if (all || !in0) offerTriangle(p, 1, 2, 3, best);
  if (all || !in1) offerTriangle(p, 0, 2, 3, best);
  if (all || !in2) offerTriangle(p, 0, 1, 3, best);
}

/// Closest point to the origin of the simplex in the GJK loop, whose last vertex is the newest
/// support point. Only the features holding the newest vertex are examined: the previous closest
/// point lies on the others, and the new point passed it (v.w < |v|^2), so the new closest point
/// has a positive weight on it (van den Bergen 2003, "Collision Detection in Interactive 3D
/// Environments", 4.3). Same signed-volume arithmetic as closestOf(); no candidate at all (only
/// through rounding) leaves dist2 = +inf, which the loop treats as no progress.
CM_ALWAYS_INLINE void closestInLoop(const Simplex<3>& s, Loop3& best) {
  switch (s.size) {
    case 2:
      offerSegment(s.v.data(), 0, 1, best);
      break;
    case 3:
      offerTriangle(s.v.data(), 0, 1, 2, best);
      break;
    case 4:
      offerTetrahedron(s.v.data(), best);
      break;
    default:
      offerVertex(s.v.data(), 0, best);
  }
}

/// closestOf() for a warm-start seed (any simplex, no newest vertex) with the loop's lean
/// arithmetic, where that is short: a vertex, a segment, a triangle (its face and edges), a
/// tetrahedron holding the origin (the common case after a small motion of overlapping shapes).
/// False (`best` unusable) otherwise: the caller falls back to closestOf().
CM_ALWAYS_INLINE bool closestOfSeed(const Simplex<3>& s, Loop3& best) {
  const SupportPoint<3>* p = s.v.data();
  switch (s.size) {
    case 1:
      offerVertex(p, 0, best);
      break;
    case 2:
      offerSegment(p, 0, 1, best);
      break;
    case 3:
      offerTriangle(p, 0, 1, 2, best);  // the face, else the edges through vertex 2
      // The edge offerTriangle() leaves out, unless the origin projects into the face: that
      // projection is then the triangle's closest point.
      if (best.mask != 7u) offerSegment(p, 0, 1, best);
      break;
    default:
      offerTetrahedron(p, best);
      return best.mask == 15u;  // else the faces through vertex 3 only: not enough for a seed
  }
  return best.dist2 < std::numeric_limits<double>::infinity();
}

/// Reduce `s` in place to the vertices of `c` (from closestInLoop(s)) with their weights.
CM_ALWAYS_INLINE void compact(Simplex<3>& s, const Loop3& c) {
  int n = 0;
  for (int i = 0; i < s.size; ++i) {
    if ((c.mask >> i) & 1u) {
      if (i != n) s.v[n] = s.v[i];
      s.bary[n] = c.lambda[i];
      ++n;
    }
  }
  s.size = n;
}

/// The loop's sub-algorithm: the lean one above in 3D, closestOf() in other dimensions. Returns
/// false (and leaves `s` as it is) when the new closest point is not closer than `vv`; else
/// reduces `s`, sets v and vv.
template <int D>
CM_ALWAYS_INLINE bool progress(Simplex<D>& s, Vec<D>& v, double& vv) {
  if constexpr (D == 3) {
    Loop3 c;
    closestInLoop(s, c);
    if (!(c.dist2 < vv)) return false;
    compact(s, c);
    v = c.v;
    vv = c.dist2;
  } else {
    const Closest<D> c = closestOf(s);
    if (!(c.dist2 < vv)) return false;
    compact(s, c);
    v = c.v;
    vv = c.dist2;
  }
  return true;
}

}  // namespace detail

/// Closest point to the origin of the convex hull of the simplex's vertices. Reduces `s` in place
/// to the vertices that carry it (weights in s.bary) and returns the point (A's frame). Uses signed
/// volumes for D = 2, 3 and the generic projection otherwise; `force_generic` selects the generic
/// one in any D (for tests). Any input is accepted, degenerate ones included; never NaN for finite
/// input. `kept` (optional, out): the vertices kept (bit i: input vertex i).
template <int D>
Vec<D> solveSimplex(Simplex<D>& s, bool force_generic = false, unsigned* kept = nullptr) {
  if (kept != nullptr) *kept = 0;
  if (s.size <= 0) return Vec<D>::Zero();
  const detail::Closest<D> c = detail::closestOf(s, force_generic);
  detail::compact(s, c);
  if (kept != nullptr) {
    for (int k = 0; k < c.n; ++k)
      *kept |= 1u << c.idx[k];
  }
  return c.v;
}

// ---------------------------------------------------------------------------------------------
// GJK
// ---------------------------------------------------------------------------------------------

/// Tolerances and bounds of one GJK run.
struct GjkSettings {
  /// Relative gap: stop when |v|^2 - v.w <= rel_tolerance |v|^2 (van den Bergen), i.e. when the
  /// upper bound |v| and the lower bound v.w / |v| on the distance agree to this fraction.
  double rel_tolerance = 1e-12;
  /// Absolute floor, length unit (callers pass rel_tolerance * shape size): the gap test also
  /// passes when |v| - v.w / |v| <= abs_tolerance (reachable in floating point when the distance
  /// is tiny compared with the shapes), and |v| <= abs_tolerance counts as the origin reached.
  double abs_tolerance = 0.0;
  int max_iterations = 128;
};

enum class GjkStatus {
  Separated,     ///< converged; distance = |v| > abs_tolerance
  Intersecting,  ///< origin enclosed by the simplex or within abs_tolerance of it
  MaxIterations  ///< iteration bound hit; fields hold the best estimate (distance is an upper
                 ///< bound)
};

/// Result of gjkDistance(). Frames: A's frame throughout.
template <int D>
struct GjkResult {
  GjkStatus status = GjkStatus::MaxIterations;
  double distance = 0.0;      ///< distance between the cores, |v| (length unit)
  Vec<D> v = Vec<D>::Zero();  ///< point of A - B closest to the origin = point_a - point_b
  /// The best-certified direction a stalled and restarted run saw (detail::restartFrom): of the
  /// v's tried, the one whose support point gave the highest lower bound on the distance,
  /// v.w / |v| (`cert_lower`; -inf: none kept).
  Vec<D> cert_v = Vec<D>::Zero();
  double cert_lower = -std::numeric_limits<double>::infinity();
  /// Report the normal along cert_v instead of v (-normal): set when cert_v's lower bound beats
  /// v's own by more than the witness points' mismatch that turning the normal away from v
  /// causes, |v| |unit(cert_v) - unit(v)|.
  bool normal_along_cert = false;
  /// The direction of -normal: cert_v or v.
  const Vec<D>& normalDirection() const { return normal_along_cert ? cert_v : v; }
  /// Separated only: no lower bound the run saw (v.w / |v| at its exit, or the best of its
  /// restarts) comes within the tolerance of |v|. A stall in rounding ended it (no progress, a
  /// duplicate support point), and `distance` is an upper bound only.
  bool uncertified = false;
  Vec<D> point_a = Vec<D>::Zero();  ///< witness point on A, A's frame
  Vec<D> point_b = Vec<D>::Zero();  ///< witness point on B, A's frame
  Simplex<D> simplex;               ///< terminal simplex (input of EPA; the warm-start cache)
  int iterations = 0;               ///< support evaluations in the main loop
  /// Nonzero when `simplex` is the seed's simplex reduced to the vertices of these bits (bit i:
  /// seed vertex i), in their order, no support point added: a caller that keeps the seed in
  /// another form (a warm-start cache's local points) can reduce that instead of mapping the
  /// simplex back.
  unsigned seed_kept = 0;
};

namespace detail {

template <class MD, class = void>
struct StartsInside : std::false_type {};
template <class MD>
struct StartsInside<MD, std::void_t<decltype(MD::kHasInterior)>>
    : std::bool_constant<MD::kHasInterior> {};

/// Start simplex: the (re-evaluated) seed when given; else the interior point cA - cB when the
/// shapes have one (no support call: the first support then goes from the middle of A - B
/// towards the origin, as MPR's first portal ray); else one support point. An interior point
/// within `tol2` (squared length) of the origin would end the run at once with witness points
/// inside the shapes, wrong for a contact (a 3e-212 m segment touching a point gave its midpoint
/// as witness: fuzz/regressions/core/gjk-subnormal-segment-touching-point-witness): the run then
/// starts from a support point instead.
template <class MD>
CM_ALWAYS_INLINE Vec<MD::kDim> gjkStart(const MD& md, const Simplex<MD::kDim>* seed,
                                        Simplex<MD::kDim>& s, double tol2, unsigned& seed_kept) {
  constexpr int D = MD::kDim;
  seed_kept = 0;
  if (seed != nullptr && seed->size > 0 && seed->size <= D + 1) {
    s = *seed;
    if constexpr (D == 3) {
      if (Loop3 c; closestOfSeed(s, c)) {
        compact(s, c);
        seed_kept = c.mask;
        return c.v;
      }
    }
    return solveSimplex<D>(s, false, &seed_kept);
  }
  s.size = 1;
  s.bary[0] = 1.0;
  if constexpr (StartsInside<MD>::value) {
    s.v[0] = md.interiorPoint();
    if (s.v[0].w.squaredNorm() > tol2) return s.v[0].w;
  }
  s.v[0] = md.support(md.initialDirection());
  return s.v[0].w;
}

/// max |w_i|^2 over the first `n` vertices of `s` (M^2 of the rounding bounds below).
template <int D>
double largestVertexSquared(const Simplex<D>& s, int n) {
  double m2 = 0.0;
  for (int i = 0; i < n; ++i)
    m2 = std::max(m2, s.v[i].w.squaredNorm());
  return m2;
}

/// planeAreas(...).inside(), out of line (the retries below are rare).
__attribute__((noinline, cold)) inline bool projectsInside(const Vec3& s0, const Vec3& s1,
                                                           const Vec3& s2, const Vec3& n,
                                                           const Vec3& q) {
  return planeAreas(s0, s1, s2, n, q).inside();
}

/// The origin's projection onto the plane of the triangle s.v[0..2], from triangleNormal<true>()
/// (each component rounded once, from the edges at the largest angle); false when the triangle is
/// degenerate, or when the projection is nearer than `lower` (a lower bound on the distance: the
/// run's last v.w / |v|) by more than the rounding of the vertices (64 eps M): then it is not a
/// point of the triangle. The accurate plane of the retries below. On a needle triangle (2.3 m
/// long, 5e-10 m wide) the rounded edges turn the normal by about eps M / width (1e-7 rad) about a
/// vertex; the projection came out 7.3e-11 m from the origin, inside by the rounded weights, far
/// outside in exact arithmetic (the triangle is 3.9e-9 m away; the lower bound was 3.7e-9 m), and
/// a segment 3.8e-9 m from a flat ellipse was "touching"
/// (fuzz/regressions/core/gjk-needle-ellipse-plane-projection-outside).
/// Also false when that projection is outside the triangle by the signed areas taken with this
/// normal: the loop's (offerTriangle()) come from its plain normal, whose rounding on a sliver
/// moves its projection off the plane, and so across the triangle's width in the coordinate plane.
/// A 1e-9 m segment 4.03e-9 m from a flat ellipse 1.08e-9 x 1.77 m: a triangle 3.7 m long and
/// 1.1e-9 m wide, the origin's projection outside by the weights (-0.98, 3.75, -1.77) (exact and
/// these) and inside by the loop's (0.26, 0.63, 0.12); its plane passes 2.68e-9 m from the origin,
/// GJK took that, and the warm query called them touching
/// (fuzz/regressions/core/gjk-needle-ellipse-sliver-weights-outside).
inline bool planeProjection(const Simplex<3>& s, Vec3& q, double lower) {
  const Vec3 n = triangleNormal<true>(s.v[0].w, s.v[1].w, s.v[2].w);
  const double nn = n.squaredNorm();
  if (!(nn > 0.0)) return false;
  q = n * (s.v[0].w.dot(n) / nn);
  if (!projectsInside(s.v[0].w, s.v[1].w, s.v[2].w, n, q)) return false;
  if (lower > 0.0) {
    const double slack =
        64.0 * std::numeric_limits<double>::epsilon() * std::sqrt(largestVertexSquared(s, 3));
    if (q.norm() < lower - slack) return false;
  }
  return true;
}

/// After a no-progress or duplicate-support exit that the last support point does not certify (its
/// lower bound v.w/|v| is below the upper bound |v| by more than the tolerance) on a 3D triangle:
/// v = sum(lambda_i w_i) may have lost its direction by cancellation when |v| << |w_i| (two nearly
/// coplanar flat polygons 1e-8 m apart: v 1.3e-7 rad off the triangle's normal, a wrong support
/// point, and a "separated" verdict for shapes that overlap:
/// fuzz/regressions/core/flat-hulls-nearly-coplanar-1e-9-band; a capsule 0.26 m from a
/// 0.11 m x 1 um x 4.9e6 m box, where the support along v was a vertex of the simplex 9 m short
/// of certifying it and the normal 9 m short of realising the distance:
/// fuzz/regressions/core/gjk-capsule-by-flat-4900km-box-normal-off).
/// Sets v to the projection of the origin onto the triangle's plane (its direction is the normal
/// to rounding; in exact arithmetic it is the same point, so the weights stand) and returns true,
/// once per run (`retried`).
/// On a segment (once per run too): v made orthogonal to the segment, v - (v.u / u.u) u. A
/// needle 1e-9 m wide and 1.2 m long (a cone) shows its width to a support direction only when
/// that direction's component along it is below 8e-10 of its length; v = sum(lambda_i w_i) had
/// 1.2e-7 there (rounding of 0.6 m vertices against |v| = 5e-10 m), the support point along it was
/// the segment's own end again, and a point inside the cone was "5e-10 m outside"
/// (fuzz/regressions/core/gjk-point-in-1e-9-needle-cone-line-retry). `retried`: the cases used
/// (kRetriedPlane, kRetriedLine).
constexpr int kRetriedPlane = 1;
constexpr int kRetriedLine = 2;
template <int D>
bool retryProjected(const Simplex<D>& s, Vec<D>& v, double& vv, int& retried, double lower) {
  if (s.size == 2 && !(retried & kRetriedLine)) {
    const Vec<D> u = s.v[1].w - s.v[0].w;
    const double uu = u.squaredNorm();
    if (!(uu > 0.0)) return false;
    retried |= kRetriedLine;
    v -= (v.dot(u) / uu) * u;
    vv = v.squaredNorm();
    return true;
  }
  if constexpr (D == 3) {
    if (s.size != 3 || (retried & kRetriedPlane)) return false;
    Vec3 q;
    if (!planeProjection(s, q, lower)) return false;
    retried |= kRetriedPlane;
    v = q;
    vv = v.squaredNorm();
    return true;
  } else {
    (void)lower;
    return false;
  }
}

/// After "no progress" on the triangle just formed (s.size == 3) whose sub-algorithm found the
/// origin's projection inside it: that projection again, from a normal rounded once per component
/// (planeProjection()), as the closest point when it is closer than v (sum(lambda_i w_i) until
/// the late night of 2026-11-23; offerTriangle() now takes the plain product's projection). The
/// weights of a sliver lose digits and that sum with them: a 1 m hull and a 6.4e5 m segment through
/// it gave a triangle whose plane passes 3.1e-7 m from the origin (113-bit arithmetic) and a
/// sum 1.0e-5 m away, no progress from 1.28e-6 m, and "touching" for shapes overlapping by 0.43 m
/// (fuzz/regressions/core/gjk-sliver-triangle-no-progress). Reduces `s`, sets v and vv, returns
/// true; else leaves them.
template <int D>
bool progressOnPlane(Simplex<D>& s, Vec<D>& v, double& vv, double lower) {
  if constexpr (D == 3) {
    if (s.size != 3) return false;
    Loop3 c;
    offerTriangle(s.v.data(), 0, 1, 2, c);
    if (c.mask != 7u) return false;
    Vec3 q;
    if (!planeProjection(s, q, lower)) return false;
    const double qq = q.squaredNorm();
    if (!(qq < vv)) return false;
    compact(s, c);
    v = q;
    vv = qq;
    return true;
  } else {
    (void)s, (void)v, (void)vv, (void)lower;
    return false;
  }
}

/// After "no progress" (and no progress on the plane either): the closest point of the simplex with
/// the new vertex is as close as v to rounding (|v|^2 within 8 ulps) but elsewhere. Exact
/// arithmetic would have moved v by less than a rounding of |v|^2 but turned it enough to break a
/// tie of the support function: a 1 mm disc 1.03 mm from the end of a 3218 m edge perpendicular to
/// v, whose far end the support along -v returned; v moved toward it by 3.2e-12 m along the edge,
/// which turns the next support to the near end. GJK stopped 1.3e-5 m above the distance in one
/// order and 7e-7 m in the other (fuzz/regressions/core/gjk-flat-cone-by-3218m-hull-tie), and
/// gjkIntersect() called a 64-gon padded 2e-6 m past the distance apart.
/// Takes that point as v, keeps vv at the smaller of the two (|v|^2 never grows, so ties and
/// progress cannot cycle), sets `retried` |= kRetriedTie (the loop clears it on real progress: no
/// two ties in a row) and returns true; else leaves everything.
constexpr int kRetriedTie = 4;
template <int D>
bool progressOnTie(Simplex<D>& s, Vec<D>& v, double& vv, int& retried) {
  if (retried & kRetriedTie) return false;
  // |v|^2 of a closest point rounds by about eps |v| M, M the largest vertex: a 0.23 m square's
  // edge 0.014 m from a cone's rim (M / |v| = 16) gave the triangle with the far corner 48 ulps
  // above v, in exact arithmetic 5 ulps below (fuzz/regressions/core/gjk-square-by-cone-rim-tie).
  const double m2 = largestVertexSquared(s, s.size);
  const double limit =
      vv + 8.0 * std::numeric_limits<double>::epsilon() * std::max(vv, std::sqrt(vv * m2));
  const auto take = [&](const auto& c) {
    if (!(c.dist2 <= limit) || c.v == v) return false;
    compact(s, c);
    v = c.v;
    retried |= kRetriedTie;
    return true;
  };
  if constexpr (D == 3) {
    Loop3 c;
    closestInLoop(s, c);
    return take(c);
  } else {
    return take(closestOf(s));
  }
}

/// After "no progress" that neither the plane nor the tie step settles: the support along -v may
/// be one end of a tie set (a face or edge of A - B perpendicular to v) whose other end would make
/// progress. Asks again along -v tilted by 1e-9 rad toward v across the new point w, and keeps the
/// answer where it is another end of such a set, at least half way across from w to v (a tilt
/// only moves a point of a curved surface by 1e-9 of its radius of curvature, which this excludes:
/// it would add tiny triangles whose planes are less certain than the distance; an ellipsoid
/// 8e-3 m from a sphere got 1.9e-12 m below the distance with a 1e-6 rad tilt and no such test)
/// and the simplex with it is closer. Else w goes back into its slot (the caller's lower bound
/// and restart use it) and the result is false. A disc 1.2e-3 m from the corner of a hull whose
/// top face is in the disc's plane: with v in that plane the support was the hull's bottom end,
/// whose triangle is closer only by the square of the gap (6e-18 m, below rounding), and GJK
/// stopped 2.9e-11 m long cold and 5.2e-11 m warm, restarts included
/// (fuzz/regressions/core/gjk-disc-by-coplanar-corner-tie). Each success strictly lowers |v|^2.
template <class MD>
__attribute__((noinline, cold)) bool progressTilted(const MD& md, Simplex<MD::kDim>& s,
                                                    Vec<MD::kDim>& v, double& vv) {
  constexpr int D = MD::kDim;
  SupportPoint<D>& slot = s.v[s.size - 1];
  const SupportPoint<D> w = slot;
  const Vec<D> vhat = v / std::sqrt(vv);
  Vec<D> u = v - w.w;
  u -= u.dot(vhat) * vhat;
  const double un = u.norm();
  if (!(un > 0.0) || !std::isfinite(un)) return false;
  const Vec<D> uhat = u / un;
  slot = md.support(Vec<D>(1e-9 * uhat - vhat));
  if ((slot.w - w.w).dot(uhat) >= 0.5 * un && progress(s, v, vv)) return true;
  slot = w;
  return false;
}

/// After a duplicate support point that does not certify v (and no projection retry left): the
/// same tie as progressTilted()'s, met as a vertex of the simplex. A segment of A - B 0.3 m long
/// and 1.7e-10 m from the origin had v's component along it rounded to 0 (-2.3e-19 m in exact
/// arithmetic), so A (a segment along it) was all a tie and its support the end already in the
/// simplex, 2.1e-10 m past v; GJK stopped there and called a hull of collinear points and a
/// hull 1.8e-9 m across, which share a point, 1.7e-10 m apart
/// (fuzz/regressions/core/gjk-collinear-hull-by-1e-9m-hull-tie-duplicate). Puts w after the
/// simplex and tries the tilt; on failure the simplex is as before.
template <class MD>
__attribute__((noinline, cold)) bool progressTiltedFromDuplicate(const MD& md, Simplex<MD::kDim>& s,
                                                                 Vec<MD::kDim>& v, double& vv) {
  ++s.size;
  if (progressTilted(md, s, v, vv)) return true;
  --s.size;
  return false;
}

/// The best lower bound on the distance seen in a GJK run, v.w / |v| (kept as the pair vw, vn,
/// compared by cross-multiplication: no division in the loop), and its v
/// (GjkResult::cert_v). A disc 2.8e-7 m from an ellipse 1e-9 x 4.98 m (aspect 5e9) stalled GJK
/// (three runs, 58 iterations) with the distance right to 1.2e-12 m but v 7e-7 rad off, along
/// which the ellipse reaches 3.5e-6 m further: the normal did not realise the distance; the
/// best lower bound of the restarted runs is 1.5e-12 m below it
/// (fuzz/regressions/core/gjk-disc-by-5e9-aspect-ellipse-normal). Tracked only in restarted
/// runs (gjkRun<true>): at every iteration of every run it cost 54 instructions, 4 % of a hull12
/// distance query.
template <int D>
struct Certificate {
  double vw = -std::numeric_limits<double>::infinity();
  double vn = 1.0;
  Vec<D> v = Vec<D>::Zero();
  CM_ALWAYS_INLINE void offer(const Vec<D>& v_, double vw_, double vn_) {
    if (vw_ * vn > vw * vn_) {
      vw = vw_;
      vn = vn_;
      v = v_;
    }
  }
};

template <int D>
CM_ALWAYS_INLINE bool isDuplicate(const Simplex<D>& s, const Vec<D>& w, double tol2) {
  for (int i = 0; i < s.size; ++i)
    if ((s.v[i].w - w).squaredNorm() <= tol2) return true;
  return false;
}

/// gjkDistance(); `kTrack`: keep the best lower bound seen (Certificate) for the normal of an
/// uncertified exit (restarted runs).
template <bool kTrack, class MD>
GjkResult<MD::kDim> gjkRun(const MD& md, const GjkSettings& st, const Simplex<MD::kDim>* seed,
                           int restarts);

/// The lower bound on the distance certified for a finished Separated run's v: v.w / |v| with w
/// its last support point (left in the slot after the simplex); +inf for other runs.
template <int D>
double exitLower(const GjkResult<D>& g) {
  if (g.status != GjkStatus::Separated || g.simplex.size > D || !(g.distance > 0.0))
    return std::numeric_limits<double>::infinity();
  return g.v.dot(g.simplex.v[g.simplex.size].w) / g.distance;
}

/// After an uncertified "no progress" exit (`r` finished, `w` the support point that passed v
/// without the simplex getting closer): GJK again from w alone, with the iterations left, and the
/// better of the two runs. Where two nearly parallel flat faces meet a curved rim GJK converges
/// slowly, and the triangle with w can be closer by less than rounding although w passes v by a
/// clear gap: two cylinders whose caps are 1.16e-7 rad from parallel ended 2.36e-7 m above their
/// distance in one order (the gap was 4.4e-7 m, the triangle's gain 1.5e-15 m) and right in the
/// other (fuzz/regressions/core/gjk-nearly-parallel-cylinder-caps-restart). Out of line: the
/// loop pays a branch.
template <class MD>
__attribute__((noinline, cold)) GjkResult<MD::kDim> restartFrom(const MD& md, const GjkSettings& st,
                                                                const SupportPoint<MD::kDim>& w,
                                                                const GjkResult<MD::kDim>& r,
                                                                int restarts) {
  Simplex<MD::kDim> seed;
  seed.v[0] = w;
  seed.bary[0] = 1.0;
  seed.size = 1;
  GjkSettings left = st;
  left.max_iterations = st.max_iterations - r.iterations;
  GjkResult<MD::kDim> again = gjkRun<true>(md, left, &seed, restarts);
  again.iterations += r.iterations;
  again.seed_kept = 0;  // its seed was w, not the caller's
  // The better distance; the best certificate of both (r's exit v, and what the tracked runs
  // kept); the normal along it where it beats v's own by more than the witness points' mismatch.
  GjkResult<MD::kDim> best = again.distance < r.distance ? again : r;
  best.iterations = again.iterations;
  best.cert_lower = -std::numeric_limits<double>::infinity();
  const auto offer = [&best](const Vec<MD::kDim>& v, double lower) {
    if (lower < std::numeric_limits<double>::infinity() && lower > best.cert_lower) {
      best.cert_v = v;
      best.cert_lower = lower;
    }
  };
  offer(r.v, exitLower(r));
  offer(r.cert_v, r.cert_lower);
  offer(again.v, exitLower(again));
  offer(again.cert_v, again.cert_lower);
  const double own = exitLower(best);
  const double turn = (best.cert_v.normalized() - best.v.normalized()).norm();
  best.normal_along_cert =
      own < std::numeric_limits<double>::infinity() && best.cert_lower - own > best.distance * turn;
  best.uncertified =
      best.status == GjkStatus::Separated && !(best.distance - std::max(own, best.cert_lower) <=
                                               st.rel_tolerance * best.distance + st.abs_tolerance);
  return best;
}

}  // namespace detail

/// The highest lower bound on the distance that a Separated result's support points certify: v.w /
/// |v| at its exit, or the best of its restarts (cert_lower); +inf for other statuses.
template <int D>
double certifiedLower(const GjkResult<D>& g) {
  return std::max(detail::exitLower(g), g.cert_lower);
}

/// Distance between two convex shapes given as their Minkowski difference `md` (anything with
/// kDim, support(d) -> SupportPoint, initialDirection(); normally a MinkowskiDifference).
/// `seed`: optional warm-start simplex (points of A - B for the current poses, e.g. from
/// MinkowskiDifference::fromLocal on cached local points). `restarts`: how many times an
/// uncertified no-progress exit may start over from its last support point
/// (detail::restartFrom).
template <class MD>
GjkResult<MD::kDim> gjkDistance(const MD& md, const GjkSettings& st,
                                const Simplex<MD::kDim>* seed = nullptr, int restarts = 2) {
  return detail::gjkRun<false>(md, st, seed, restarts);
}

namespace detail {

template <bool kTrack, class MD>
GjkResult<MD::kDim> gjkRun(const MD& md, const GjkSettings& st, const Simplex<MD::kDim>* seed,
                           int restarts) {
  constexpr int D = MD::kDim;
  GjkResult<D> r;
  Simplex<D>& s = r.simplex;
  const double tol = st.abs_tolerance;
  const double tol2 = tol * tol;
  Vec<D> v = detail::gjkStart(md, seed, s, tol2, r.seed_kept);
  double vv = v.squaredNorm();
  int it = 0;
  int retried = 0;
  bool stuck = false;   // an uncertified no-progress exit that may restart (detail::restartFrom)
  Certificate<D> best;  // kTrack only
  bool uncertified = true;  // the exit's v is not certified by its support point
  for (;;) {
    if (s.size == D + 1 || vv <= tol2) {
      r.status = GjkStatus::Intersecting;
      break;
    }
    if (it >= st.max_iterations) {
      r.status = GjkStatus::MaxIterations;
      break;
    }
    ++it;
    // The new support point goes straight into the free slot; the simplex is only reduced
    // (compacted) once it is known to make progress, so "undo" is dropping that slot.
    SupportPoint<D>& w = s.v[s.size];
    w = md.support(-v);
    const double vw = v.dot(w.w);
    const double vn = std::sqrt(vv);
    if constexpr (kTrack) best.offer(v, vw, vn);
    // van den Bergen: upper bound |v| and lower bound v.w/|v| agree (plus an absolute floor).
    const bool certified = vv - vw <= st.rel_tolerance * vv + tol * vn;
    if (certified || detail::isDuplicate(s, w.w, tol2)) {
      if (!certified && (detail::retryProjected(s, v, vv, retried, vw / vn) ||
                         detail::progressTiltedFromDuplicate(md, s, v, vv)))
        continue;
      r.status = GjkStatus::Separated;
      uncertified = !certified;
      break;
    }
    ++s.size;
    r.seed_kept = 0;
    if (!detail::progress(s, v, vv)) {  // no progress (rounding): keep the better simplex, stop
      if (detail::progressOnPlane(s, v, vv, vw / vn) || detail::progressOnTie(s, v, vv, retried) ||
          detail::progressTilted(md, s, v, vv))
        continue;
      --s.size;
      if (detail::retryProjected(s, v, vv, retried, vw / vn))
        continue;  // not certified (see above)
      r.status = GjkStatus::Separated;
      stuck = restarts > 0 && it < st.max_iterations;
      break;
    }
    retried &= ~detail::kRetriedTie;  // progress: a later tie may be taken again
  }
  r.iterations = it;
  // A run that ended on a tie step (no progress since) holds that step's v with the smaller |v|^2
  // kept (progressOnTie): report |v| itself, so that v / distance is a unit normal. A 1.9e-9 m
  // disc 3.5e-10 m from a 10.8 m flat cone's rim got a normal of length 1 + 1.2e-8 (fuzz/
  // regressions/core/gjk-tie-step-normal-length).
  if (retried & kRetriedTie) vv = v.squaredNorm();
  r.v = v;
  r.uncertified = uncertified && r.status == GjkStatus::Separated;
  if (kTrack && r.uncertified) {
    r.cert_v = best.v;
    r.cert_lower = best.vw / best.vn;
  }
  r.distance = std::sqrt(vv);
  s.witnesses(r.point_a, r.point_b);
  if (r.status == GjkStatus::Intersecting) {
    r.distance = s.size == D + 1 ? 0.0 : r.distance;
  }
  if (stuck) r = detail::restartFrom(md, st, s.v[s.size], r, restarts - 1);
  return r;
}

}  // namespace detail

/// Boolean GJK with early exit: true when the cores are within `margin` (length, >= 0; the sum of
/// the radii plus any touching band) of each other. Returns false as soon as a support point
/// fails to pass the margin (v.w > margin |v|: a separating plane), true as soon as |v| <= margin
/// or the simplex encloses the origin. When the iteration bound is hit undecided the answer is
/// true (conservative for a collision monitor). `simplex` (optional, in/out): warm-start seed
/// on input (size 0 = cold), terminal simplex on output. `iterations` (optional, out).
/// `seed_kept` (optional, out): as GjkResult::seed_kept.
template <class MD>
bool gjkIntersect(const MD& md, double margin, const GjkSettings& st,
                  Simplex<MD::kDim>* simplex = nullptr, int* iterations = nullptr,
                  unsigned* seed_kept = nullptr) {
  constexpr int D = MD::kDim;
  Simplex<D> s;
  const double tol = st.abs_tolerance;
  const double reach = margin + tol;
  unsigned kept = 0;
  Vec<D> v = detail::gjkStart(md, simplex, s, tol * tol, kept);
  double vv = v.squaredNorm();
  int it = 0;
  int retried = 0;
  bool result = true;
  for (;;) {
    if (s.size == D + 1 || vv <= reach * reach) {
      result = true;
      break;
    }
    if (it >= st.max_iterations) {
      result = true;
      break;
    }
    ++it;
    SupportPoint<D>& w = s.v[s.size];
    w = md.support(-v);
    const double vw = v.dot(w.w);
    const double vn = std::sqrt(vv);
    if (vw > reach * vn) {  // separating plane with the margin: lower bound > margin
      result = false;
      break;
    }
    const bool certified = vv - vw <= st.rel_tolerance * vv + tol * vn;
    if (certified || detail::isDuplicate(s, w.w, tol * tol)) {
      if (!certified && (detail::retryProjected(s, v, vv, retried, vw / vn) ||
                         detail::progressTiltedFromDuplicate(md, s, v, vv)))
        continue;
      result = vn <= reach;  // converged: the distance is |v|
      break;
    }
    ++s.size;
    kept = 0;
    if (!detail::progress(s, v, vv)) {
      if (detail::progressOnPlane(s, v, vv, vw / vn) || detail::progressOnTie(s, v, vv, retried) ||
          detail::progressTilted(md, s, v, vv))
        continue;
      --s.size;
      if (detail::retryProjected(s, v, vv, retried, vw / vn))
        continue;  // not certified (see above)
      result = vn <= reach;
      break;
    }
    retried &= ~detail::kRetriedTie;
  }
  if (simplex != nullptr) *simplex = s;
  if (iterations != nullptr) *iterations = it;
  if (seed_kept != nullptr) *seed_kept = kept;
  return result;
}

}  // namespace core
}  // namespace collision_monitor
