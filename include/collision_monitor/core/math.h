/// \file
/// Small linear-algebra vocabulary of the geometry core: dimension-generic vectors and rigid
/// transforms on Eigen fixed-size types. Units are whatever the caller uses (metres in ROS).
#pragma once

#include <cmath>
#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>

/// Forces inlining of small functions on the GJK hot path, where GCC's heuristics otherwise keep
/// Eigen's 3x3 products and the simplex helpers as calls (measured: ~30 % of a box/box distance
/// query in call overhead).
/// Not in AddressSanitizer builds: there GCC spent 16 minutes on query.cpp with the simplex
/// helpers forced into every core-type pair's GJK and EPA (2 cores, -O2 -g, ASan + UBSan), 4
/// minutes without; the answers are the same, only the code is laid out otherwise.
#if defined(__GNUC__) && !defined(__SANITIZE_ADDRESS__)
#define CM_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define CM_ALWAYS_INLINE inline
#endif

namespace collision_monitor {
namespace core {

template <int D>
using Vec = Eigen::Matrix<double, D, 1>;
template <int D>
using Mat = Eigen::Matrix<double, D, D>;
using Vec2 = Vec<2>;
using Vec3 = Vec<3>;
using Mat3 = Mat<3>;

/// Rigid transform x -> R x + t in D dimensions. R must be orthonormal with det +1: the queries
/// take that as given and do not check it (a scaled or singular R gives a defined but meaningless
/// answer); callers check poses where they enter from outside, as the ROS layer does
/// (isValidRotation()). Non-finite poses give FailedToConverge with distance +inf, and
/// intersect() true (undecidable: conservative).
template <int D>
struct Transform {
  Mat<D> R = Mat<D>::Identity();
  Vec<D> t = Vec<D>::Zero();

  static Transform Identity() { return Transform(); }
  Vec<D> operator*(const Vec<D>& x) const { return R * x + t; }
  Transform operator*(const Transform& o) const { return Transform{R * o.R, R * o.t + t}; }
  Transform inverse() const {
    Transform inv;
    inv.R = R.transpose();
    inv.t = -(inv.R * t);
    return inv;
  }
};
using Transform3 = Transform<3>;

/// R^T x, written out (Eigen's product is not always inlined in the GJK loop).
template <int D>
CM_ALWAYS_INLINE Vec<D> mulTransposed(const Mat<D>& R, const Vec<D>& x) {
  Vec<D> y;
  for (int i = 0; i < D; ++i) {
    double s = R(0, i) * x[0];
    for (int k = 1; k < D; ++k)
      s += R(k, i) * x[k];
    y[i] = s;
  }
  return y;
}

/// R x + t, written out (see mulTransposed()).
template <int D>
CM_ALWAYS_INLINE Vec<D> mulAdd(const Mat<D>& R, const Vec<D>& x, const Vec<D>& t) {
  Vec<D> y;
  for (int i = 0; i < D; ++i) {
    double s = R(i, 0) * x[0];
    for (int k = 1; k < D; ++k)
      s += R(i, k) * x[k];
    y[i] = s + t[i];
  }
  return y;
}

/// Transform from a unit quaternion and a translation.
inline Transform3 makeTransform(const Eigen::Quaterniond& q, const Vec3& t) {
  Transform3 T;
  T.R = q.normalized().toRotationMatrix();
  T.t = t;
  return T;
}

/// True when every entry is finite.
template <class Derived>
bool allFinite(const Eigen::MatrixBase<Derived>& m) {
  return m.allFinite();
}

/// True when R is a rotation (orthonormal, det +1) within `tol`.
template <int D>
bool isValidRotation(const Mat<D>& R, double tol = 1e-6) {
  return R.allFinite() && (R.transpose() * R - Mat<D>::Identity()).cwiseAbs().maxCoeff() <= tol &&
         std::abs(R.determinant() - 1.0) <= tol;
}

/// Axis-aligned bounding box. An empty box has min > max.
struct Aabb {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());

  bool empty() const { return (min.array() > max.array()).any(); }
  void extend(const Vec3& p) {
    min = min.cwiseMin(p);
    max = max.cwiseMax(p);
  }
  void extend(const Aabb& o) {
    min = min.cwiseMin(o.min);
    max = max.cwiseMax(o.max);
  }
  Aabb inflated(double r) const { return Aabb{min.array() - r, max.array() + r}; }
  bool overlaps(const Aabb& o) const {
    return (min.array() <= o.max.array()).all() && (o.min.array() <= max.array()).all();
  }
  /// Euclidean distance between the boxes (0 when they overlap). A lower bound on the distance
  /// between anything inside them. Gaps beyond 1.3e154 m, whose squares overflow, are scaled
  /// first: the plain norm was +inf there, above any finite reach, so a broad phase dropped the
  /// pair. (Only then: this is the broad phase's per-pair test.)
  double distance(const Aabb& o) const {
    const Vec3 gap = (o.min - max).cwiseMax(min - o.max).cwiseMax(Vec3::Zero());
    const double d = gap.norm();
    if (d < std::numeric_limits<double>::infinity()) return d;
    const double largest = gap.maxCoeff();  // an infinite gap stays +inf
    return std::isfinite(largest) ? largest * (gap / largest).norm() : largest;
  }
};

/// a x b with each component a difference of products rounded once (Kahan's fma algorithm) rather
/// than twice: the normal of a needle triangle, |a x b| << |a| |b|, keeps its direction (the plain
/// product's rounding is eps |a| |b| per component). EPA's lift along a 1.95 m x 1e-9 m triangle's
/// plain normal, tilted 1.9e-9 rad, found 1.8e-9 m of "thickness" in a box 4.9e-324 m thick
/// (fuzz/regressions/core/epa-needle-triangle-lift-on-flat-box). For rare paths only: out of line
/// and cold, as inlined into EPA's loop its fma() calls cost every query (hull12 signed distance
/// 688 -> 903 ns per query).
__attribute__((noinline, cold)) inline Vec3 crossAccurate(const Vec3& a, const Vec3& b) {
  const auto diff = [](double p, double q, double r, double t) {  // p q - r t
    const double rt = r * t;
    return std::fma(p, q, -rt) - std::fma(r, t, -rt);
  };
  return Vec3(diff(a.y(), b.z(), a.z(), b.y()), diff(a.z(), b.x(), a.x(), b.z()),
              diff(a.x(), b.y(), a.y(), b.x()));
}

/// 6 x the signed volume of the tetrahedron (a, b, c, d), (b - a) . ((c - a) x (d - a)), taken
/// from the vertex whose three edges are shortest: the four choices are even permutations (the
/// same value in exact arithmetic) and the product of the edge lengths bounds the rounding. From
/// a far vertex a needle (three vertices 1e-6 m apart at one end, 1.1e3 m away) loses the sign.
inline double orientation(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  const Vec3* v[4] = {&a, &b, &c, &d};
  static constexpr int kEven[4][4] = {{0, 1, 2, 3}, {1, 0, 3, 2}, {2, 3, 0, 1}, {3, 2, 1, 0}};
  int base = 0;
  double shortest = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 4; ++i) {
    const Vec3& o = *v[kEven[i][0]];
    const double prod = (*v[kEven[i][1]] - o).squaredNorm() * (*v[kEven[i][2]] - o).squaredNorm() *
                        (*v[kEven[i][3]] - o).squaredNorm();
    if (prod < shortest) {
      shortest = prod;
      base = i;
    }
  }
  const int* q = kEven[base];
  const Vec3& o = *v[q[0]];
  return (*v[q[1]] - o).dot((*v[q[2]] - o).cross(*v[q[3]] - o));
}

}  // namespace core
}  // namespace collision_monitor
