/// \file
/// One geometry-core fuzz case: bytes -> two shapes, two poses -> every query -> checks.
///
/// Shared by the libFuzzer target (fuzz/fuzz_core.cpp, clang, ASan+UBSan) and by the plain gtest
/// that replays fuzz/regressions/ and the seed corpus (test/robustness/test_fuzz_regressions.cpp,
/// g++), so that a crash corpus entry fails the normal suite too.
///
/// Decoding (any byte string is a valid case; missing bytes read as 0):
///   - a "magnitude" picks 0, a denormal, 1e-9, 1e-6, 1e-3, 0.1, 1, 10, 1e3, 1e6 (times 1..5),
///     a negative value, NaN, +-Inf, -0.0 or 8 raw bytes (any double);
///   - shapes: every ConvexShape factory (sphere, box, capsule, cylinder, cone, ellipsoid, point,
///     segment, convexHull of 0..64 points in general / coplanar / collinear / coincident /
///     near-duplicate / raw / mixed-scale layouts), optionally padded;
///   - poses: identity, a random or axis-aligned or 1e-9 rad quaternion, or raw doubles; B placed
///     absolutely or along a direction at a factor 0..2 of the contact distance (near contact).
///
/// Checks (any failure is a bug; the message says which):
///   1. factories throw std::invalid_argument exactly for invalid input (non-finite or negative
///      sizes, non-finite points, no points) and nothing else ever;
///   2. inside the domain (finite, |x| <= 1e7): every query returns finite numbers, a unit
///      normal, iteration counts within the bounds (twice the per-run bounds: a query may run in
///      both frames), and does not report FailedToConverge;
///   3. intersect / distance / signedDistance, the warm-started repeat, the swapped pair and the
///      libccd backend agree with each other outside a tolerance band;
///   4. polytope-like pairs (point, segment, box, hull, with radii) agree with the exact oracle
///      (qhull hull of the Minkowski difference, test/core/oracle.h) within tol;
///   5. every pair: the normal certifies the answer through independent support functions
///      (written here, not taken from the core): gap(n) = distance; no sampled direction gives
///      a larger gap (separated) or a smaller overlap (penetrating); witness points lie on the
///      supporting planes, and on the shapes (outsideOf(), every kind but hulls; curved cores
///      of aspect ratio up to kMaxWitnessAspect).
/// Outside the domain (huge raw doubles), only "no crash, no hang, no exception" is required.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "collision_monitor/core/backend.h"
#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/core/query.h"
#include "oracle.h"  // test/core/oracle.h (include path set by the build)

namespace cm_fuzz {

namespace cmc = collision_monitor::core;
using cmc::Vec3;

/// Largest magnitude for which results are checked (the decoder's tables reach 5e6).
constexpr double kDomain = 1e7;
/// Largest aspect ratio of a curved core (cylinder, cone, ellipsoid) whose results are checked.
constexpr double kMaxCurvedAspect = 1e6;
/// Largest aspect ratio of a curved core whose witness points are held to the shape (beyond
/// it, to its supporting plane only): on a flat-topped cone of aspect 3.9e5 (3.6 m by 1.4e6 m,
/// padded 1.4e6 m) the normal is 2.6e-6 rad off and a segment's witness 1.3 m off its end,
/// 4.5e-7 of the size (fuzz/regressions/core/check-witness-on-flat-cone-ill-conditioned).
constexpr double kMaxWitnessAspect = 1e3;
/// Relative tolerance of FailedToConverge estimates (curved cores only), see runCase().
constexpr double kLooseTolerance = 1e-3;

/// Reads the fuzz input; past the end every read is 0.
class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : p_(data), n_(size) {}
  std::uint8_t u8() { return i_ < n_ ? p_[i_++] : 0; }
  double raw() {
    std::uint64_t bits = 0;
    for (int k = 0; k < 8; ++k)
      bits |= static_cast<std::uint64_t>(u8()) << (8 * k);
    double d;
    std::memcpy(&d, &bits, sizeof d);
    return d;
  }
  /// In [-1, 1].
  double unit() { return static_cast<std::int8_t>(u8()) / 127.0; }
  /// Three unit() reads in the order x, y, z. Reads never sit side by side in one argument list:
  /// C++ leaves the order of argument evaluation unspecified, and g++ (right to left) and clang
  /// (left to right) decoded the same input into different cases, so the g++ replay
  /// (test_fuzz_regressions) did not run the cases the clang fuzzer had found.
  Vec3 unitVec() {
    const double x = unit();
    const double y = unit();
    const double z = unit();
    return Vec3(x, y, z);
  }
  /// Two unit() reads (x, y) and z = 0.
  Vec3 unitVecXY() {
    const double x = unit();
    const double y = unit();
    return Vec3(x, y, 0.0);
  }
  /// Quaternion (w, x, y, z) from four reads of `read` in that order (not normalised).
  template <class Read>
  Eigen::Quaterniond quaternion(Read read) {
    const double w = read();
    const double x = read();
    const double y = read();
    const double z = read();
    return Eigen::Quaterniond(w, x, y, z);
  }

 private:
  const std::uint8_t* p_;
  std::size_t n_;
  std::size_t i_ = 0;
};

/// A size or coordinate magnitude: the interesting scales and the invalid values.
inline double magnitude(Bytes& in) {
  const std::uint8_t sel = in.u8();
  const double m = 1.0 + in.u8() / 64.0;  // 1 .. 5
  switch (sel % 16) {
    case 0:
      return 0.0;
    case 1:
      return std::numeric_limits<double>::denorm_min() * (1.0 + (sel >> 4));
    case 2:
      return 1e-9 * m;
    case 3:
      return 1e-6 * m;
    case 4:
      return 1e-3 * m;
    case 5:
      return 0.1 * m;
    case 6:
    case 15:
      return m;
    case 7:
      return 10.0 * m;
    case 8:
      return 1e3 * m;
    case 9:
      return 1e6 * m;
    case 10:
      return -m;
    case 11:
      return std::numeric_limits<double>::quiet_NaN();
    case 12:
      return (sel & 0x10) ? -std::numeric_limits<double>::infinity()
                          : std::numeric_limits<double>::infinity();
    case 13:
      return -0.0;
    default:
      return in.raw();
  }
}

/// A coordinate: a magnitude with a sign.
inline double coordinate(Bytes& in) {
  const bool negative = in.u8() & 1;
  const double v = magnitude(in);
  return negative ? -v : v;
}

/// Three coordinate() reads in the order x, y, z (see Bytes::unitVec()).
inline Vec3 coordinates(Bytes& in) {
  const double x = coordinate(in);
  const double y = coordinate(in);
  const double z = coordinate(in);
  return Vec3(x, y, z);
}

struct ShapeSpec {
  enum Kind { Sphere, Box, Capsule, Cylinder, Cone, Ellipsoid, Point, Segment, Hull, kCount };
  Kind kind = Sphere;
  Vec3 dims = Vec3::Zero();  ///< sphere [r], box sides, capsule/cylinder/cone [len, r], semi axes
  std::vector<Vec3> pts;     ///< point [p], segment [a, b], hull points
  bool padded = false;
  double padding = 0.0;
};

inline const char* kindName(ShapeSpec::Kind k) {
  static const char* const names[] = {"sphere",    "box",   "capsule", "cylinder", "cone",
                                      "ellipsoid", "point", "segment", "hull"};
  return k < ShapeSpec::kCount ? names[k] : "?";
}

inline ShapeSpec decodeShape(Bytes& in) {
  ShapeSpec s;
  const std::uint8_t k = in.u8();
  s.kind = static_cast<ShapeSpec::Kind>((k & 0x7f) % ShapeSpec::kCount);
  s.padded = (k & 0x80) != 0;
  switch (s.kind) {
    case ShapeSpec::Sphere:
      s.dims[0] = magnitude(in);
      break;
    case ShapeSpec::Box:
    case ShapeSpec::Ellipsoid:
      for (int i = 0; i < 3; ++i)
        s.dims[i] = magnitude(in);
      break;
    case ShapeSpec::Capsule:
    case ShapeSpec::Cylinder:
    case ShapeSpec::Cone:
      s.dims[0] = magnitude(in);
      s.dims[1] = magnitude(in);
      break;
    case ShapeSpec::Point:
      s.pts.push_back(coordinates(in));
      break;
    case ShapeSpec::Segment:
      for (int i = 0; i < 2; ++i)
        s.pts.push_back(coordinates(in));
      break;
    case ShapeSpec::Hull: {
      const std::uint8_t h = in.u8();
      const int n = h % 65;
      const int layout = in.u8() % 8;
      const double scale = magnitude(in);
      const Vec3 centre = coordinates(in);
      const Vec3 dir = in.unitVec() + Vec3(1e-3, 0, 0);
      for (int i = 0; i < n; ++i) {
        Vec3 p;
        switch (layout) {
          case 0:  // general position
          default:
            p = scale * in.unitVec();
            break;
          case 1:  // coplanar
            p = scale * in.unitVecXY();
            break;
          case 2:  // collinear
            p = scale * in.unit() * dir;
            break;
          case 3:  // coincident
            p = Vec3::Zero();
            break;
          case 4:  // near duplicates of a few points
            p = scale * Vec3((i % 4) == 1, (i % 4) == 2, (i % 4) == 3) +
                scale * 1e-12 * in.unitVec();
            break;
          case 5:  // every coordinate decoded (NaN, Inf, denormals, huge)
            p = coordinates(in);
            break;
          case 6:  // cube corners, slightly jittered
            p = scale *
                (Vec3((i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1) + 1e-9 * in.unitVec());
            break;
          case 7:  // mixed scales: one far point, the rest tiny
            p = (i == 0 ? 1e6 : 1e-6) * scale * in.unitVec();
            break;
        }
        s.pts.push_back(p + centre);
      }
      break;
    }
    case ShapeSpec::kCount:
      break;
  }
  if (s.padded) s.padding = magnitude(in);
  return s;
}

inline bool validSize(double v) {
  return std::isfinite(v) && !(v < 0.0);
}

/// Whether the factory must accept the spec (written from ConvexShape's documented contract).
inline bool expectValid(const ShapeSpec& s) {
  bool ok = true;
  switch (s.kind) {
    case ShapeSpec::Sphere:
      ok = validSize(s.dims[0]);
      break;
    case ShapeSpec::Box:
    case ShapeSpec::Ellipsoid:
      ok = validSize(s.dims[0]) && validSize(s.dims[1]) && validSize(s.dims[2]);
      break;
    case ShapeSpec::Capsule:
    case ShapeSpec::Cylinder:
    case ShapeSpec::Cone:
      ok = validSize(s.dims[0]) && validSize(s.dims[1]);
      break;
    default:
      ok = !s.pts.empty();
      for (const Vec3& p : s.pts)
        ok = ok && p.allFinite();
      break;
  }
  if (s.padded) ok = ok && validSize(s.padding);
  return ok;
}

/// Cores with a curved surface (EPA approximates them by polytopes).
inline bool curved(const ShapeSpec& s) {
  return s.kind == ShapeSpec::Cylinder || s.kind == ShapeSpec::Cone ||
         s.kind == ShapeSpec::Ellipsoid;
}

/// False for a curved core (cylinder, cone, ellipsoid) whose aspect ratio is beyond `aspect`;
/// dimensions below 1e-9 of the largest count as flat (exact), not as a ratio.
inline bool aspectWithin(const ShapeSpec& s, double aspect) {
  if (!curved(s)) return true;
  const int n = s.kind == ShapeSpec::Ellipsoid ? 3 : 2;
  const double big = s.dims.head(n).cwiseAbs().maxCoeff();
  for (int k = 0; k < n; ++k) {
    const double d = std::abs(s.dims[k]);
    if (d > 1e-9 * big && big > aspect * d) return false;
  }
  return true;
}

inline bool inDomain(const ShapeSpec& s) {
  bool ok = s.dims.cwiseAbs().maxCoeff() <= kDomain;
  for (const Vec3& p : s.pts)
    ok = ok && p.cwiseAbs().maxCoeff() <= kDomain;
  if (s.padded) ok = ok && std::abs(s.padding) <= kDomain;
  // Curved cores with an aspect ratio beyond 1e6 (a 1.4 m x 3.3e6 m cone: GJK put its centre
  // 1.4e-4 m outside, 0.68 m off, 2e-7 of the size) are past what double-precision GJK resolves
  // to 1e-9.
  return ok && aspectWithin(s, kMaxCurvedAspect);
}

inline cmc::ConvexShape build(const ShapeSpec& s) {
  std::optional<cmc::ConvexShape> shape;
  switch (s.kind) {
    case ShapeSpec::Sphere:
      shape = cmc::ConvexShape::sphere(s.dims[0]);
      break;
    case ShapeSpec::Box:
      shape = cmc::ConvexShape::box(s.dims);
      break;
    case ShapeSpec::Capsule:
      shape = cmc::ConvexShape::capsule(s.dims[0], s.dims[1]);
      break;
    case ShapeSpec::Cylinder:
      shape = cmc::ConvexShape::cylinder(s.dims[0], s.dims[1]);
      break;
    case ShapeSpec::Cone:
      shape = cmc::ConvexShape::cone(s.dims[0], s.dims[1]);
      break;
    case ShapeSpec::Ellipsoid:
      shape = cmc::ConvexShape::ellipsoid(s.dims);
      break;
    case ShapeSpec::Point:
      shape = cmc::ConvexShape::point(s.pts[0]);
      break;
    case ShapeSpec::Segment:
      shape = cmc::ConvexShape::segment(s.pts[0], s.pts[1]);
      break;
    default:
      shape = cmc::ConvexShape::convexHull(s.pts);
      break;
  }
  if (s.padded) shape = shape->padded(s.padding);
  return *shape;
}

/// Independent support value h(n) = max over the full shape of n . x (shape frame), for any n.
inline double supportValue(const ShapeSpec& s, const Vec3& n) {
  const double len = n.norm();
  const double nxy = std::hypot(n.x(), n.y());
  double h = 0.0;
  switch (s.kind) {
    case ShapeSpec::Sphere:
      h = s.dims[0] * len;
      break;
    case ShapeSpec::Box:
      h = 0.5 *
          (std::abs(n.x()) * s.dims[0] + std::abs(n.y()) * s.dims[1] + std::abs(n.z()) * s.dims[2]);
      break;
    case ShapeSpec::Capsule:
      h = 0.5 * s.dims[0] * std::abs(n.z()) + s.dims[1] * len;
      break;
    case ShapeSpec::Cylinder:
      h = 0.5 * s.dims[0] * std::abs(n.z()) + s.dims[1] * nxy;
      break;
    case ShapeSpec::Cone:
      h = std::max(0.5 * s.dims[0] * n.z(), -0.5 * s.dims[0] * n.z() + s.dims[1] * nxy);
      break;
    case ShapeSpec::Ellipsoid:
      h = s.dims.cwiseProduct(n).stableNorm();  // |S n|^2 underflows below 1e-154 m
      break;
    default: {
      h = -std::numeric_limits<double>::infinity();
      for (const Vec3& p : s.pts)
        h = std::max(h, n.dot(p));
      break;
    }
  }
  if (s.padded) h += s.padding * len;
  return h;
}

/// How far x (shape frame) lies outside the full shape: 0 inside, else its distance, or for an
/// ellipsoid a lower bound of it ((|S^-1 x| - 1) times the least semi-axis: S^-1 shrinks lengths
/// by at most that). Independent of the core, as supportValue(). Hulls, and ellipsoids flatter
/// than kMaxCurvedAspect: nullopt (their witnesses are held to the supporting planes only; hulls'
/// distances to the exact oracle).
inline std::optional<double> outsideOf(const ShapeSpec& s, const Vec3& x) {
  double core = 0.0;  // the distance to the core
  switch (s.kind) {
    case ShapeSpec::Sphere:
      core = std::max(0.0, x.norm() - s.dims[0]);
      break;
    case ShapeSpec::Box:
      core = (x.cwiseAbs() - 0.5 * s.dims).cwiseMax(0.0).norm();
      break;
    case ShapeSpec::Capsule: {
      const Vec3 end(0.0, 0.0, 0.5 * s.dims[0]);
      core =
          std::max(0.0, (x - oracle::closestPointSegment(x, Vec3(-end), end)).norm() - s.dims[1]);
      break;
    }
    case ShapeSpec::Cylinder:
      core = oracle::outsideCylinder(x, s.dims[1], 0.5 * s.dims[0]);
      break;
    case ShapeSpec::Cone:
      core = oracle::outsideCone(x, s.dims[1], 0.5 * s.dims[0]);
      break;
    case ShapeSpec::Ellipsoid:
      // Flatter than kMaxCurvedAspect (a semi-axis 0): not checked.
      if (!(s.dims.minCoeff() * kMaxCurvedAspect >= s.dims.maxCoeff())) return std::nullopt;
      core = oracle::outsideEllipsoid(x, s.dims);
      break;
    case ShapeSpec::Point:
      core = (x - s.pts[0]).norm();
      break;
    case ShapeSpec::Segment:
      core = (x - oracle::closestPointSegment(x, s.pts[0], s.pts[1])).norm();
      break;
    default:
      return std::nullopt;
  }
  return std::max(0.0, core - (s.padded ? s.padding : 0.0));
}

/// A placed shape spec.
struct Placed {
  ShapeSpec spec;
  cmc::Transform3 pose;
  /// Support value of the placed shape along world direction n.
  double h(const Vec3& n) const {
    return supportValue(spec, pose.R.transpose() * n) + n.dot(pose.t);
  }
  /// outsideOf() for a world point x.
  std::optional<double> outside(const Vec3& x) const {
    return outsideOf(spec, pose.R.transpose() * (x - pose.t));
  }
  /// Polytope-like: core vertices (shape frame) and the radius, when the core is a point set.
  bool polyCore(std::vector<Vec3>* core, double* radius) const {
    *radius = spec.padded ? spec.padding : 0.0;
    core->clear();
    switch (spec.kind) {
      case ShapeSpec::Sphere:
        core->push_back(Vec3::Zero());
        *radius += spec.dims[0];
        return true;
      case ShapeSpec::Capsule:
        core->emplace_back(0, 0, -0.5 * spec.dims[0]);
        core->emplace_back(0, 0, 0.5 * spec.dims[0]);
        *radius += spec.dims[1];
        return true;
      case ShapeSpec::Box:
        for (int i = 0; i < 8; ++i) {
          core->push_back(0.5 * Vec3((i & 1) ? spec.dims[0] : -spec.dims[0],
                                     (i & 2) ? spec.dims[1] : -spec.dims[1],
                                     (i & 4) ? spec.dims[2] : -spec.dims[2]));
        }
        return true;
      case ShapeSpec::Point:
      case ShapeSpec::Segment:
      case ShapeSpec::Hull:
        *core = spec.pts;
        return true;
      default:
        return false;
    }
  }
};

inline cmc::Transform3 decodePose(Bytes& in) {
  const std::uint8_t mode = in.u8() % 6;
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  switch (mode) {
    case 0:
      break;
    case 1:
    case 2:
      q = in.quaternion([&in] { return in.unit(); });
      break;
    case 3: {  // multiples of 90 degrees about an axis
      const int axis = in.u8() % 3;
      const double angle = (in.u8() % 4) * M_PI / 2;
      q = Eigen::AngleAxisd(angle, Vec3::Unit(axis));
      break;
    }
    case 4: {  // tiny rotation
      const Vec3 axis = in.unitVec() + Vec3(0, 0, 1e-3);
      q = Eigen::AngleAxisd(1e-9 * (1 + in.u8()), axis.normalized());
      break;
    }
    case 5:
      q = in.quaternion([&in] { return in.raw(); });
      break;
  }
  cmc::Transform3 T = cmc::Transform3::Identity();
  // The core's precondition: a rotation (the ROS layer refuses zero / non-unit quaternions).
  if (q.coeffs().allFinite() && q.norm() > 1e-3 && q.norm() < 1e3) {
    T = cmc::makeTransform(q, Vec3::Zero());
    if (!cmc::isValidRotation(T.R, 1e-12)) T.R.setIdentity();
  }
  return T;
}

/// What one case exercised (for the replay test's "was the sample meaningful" check).
struct Outcome {
  std::string failure;      ///< empty: every check passed
  std::string description;  ///< the decoded case (shapes and poses)
  bool factories_ok = false;
  bool checked = false;      ///< in the domain, results checked
  bool oracle = false;       ///< exact oracle used
  bool overlap = false;      ///< reference signed distance < 0
  bool unconverged = false;  ///< a query reported FailedToConverge (curved cores only)
  double seconds = 0.0;
};

inline std::string describe(const Placed& p) {
  std::ostringstream o;
  o.precision(17);
  o << kindName(p.spec.kind) << " dims [" << p.spec.dims.transpose() << "]";
  if (!p.spec.pts.empty()) {
    o << " pts{";
    for (std::size_t i = 0; i < p.spec.pts.size() && i < 8; ++i)
      o << (i ? "; " : "") << p.spec.pts[i].transpose();
    if (p.spec.pts.size() > 8) o << "; ... (" << p.spec.pts.size() << ")";
    o << "}";
  }
  if (p.spec.padded) o << " padding " << p.spec.padding;
  o << " t [" << p.pose.t.transpose() << "] R [" << p.pose.R.row(0) << "; " << p.pose.R.row(1)
    << "; " << p.pose.R.row(2) << "]";
  return o.str();
}

inline std::string describe(const cmc::ContactResult& r) {
  std::ostringstream o;
  o.precision(17);
  o << cmc::toString(r.status) << " d " << r.distance << " n [" << r.normal.transpose() << "] pa ["
    << r.point_a.transpose() << "] pb [" << r.point_b.transpose() << "] it " << r.gjk_iterations
    << "/" << r.epa_iterations;
  return o.str();
}

/// Exact signed distance for polytope-like pairs (qhull hull of the Minkowski difference of the
/// cores, minus the radii), or nullopt when the difference is flat (qhull cannot hull it).
/// Most point-triangle and segment-segment pairs oracleDistance() checks by brute force: two
/// 20-point sets, or 80 points and one.
constexpr double kBruteForceBudget = 1e5;

inline std::optional<double> oracleDistance(const Placed& a, const Placed& b) {
  std::vector<Vec3> ca, cb;
  double ra = 0.0, rb = 0.0;
  if (!a.polyCore(&ca, &ra) || !b.polyCore(&cb, &rb)) return std::nullopt;
  for (Vec3& v : ca)
    v = a.pose * v;
  for (Vec3& v : cb)
    v = b.pose * v;
  if (ca.size() <= 2 && cb.size() <= 2) {
    Vec3 c1, c2;
    const double d = oracle::closestSegmentSegment(ca[0], ca.back(), cb[0], cb.back(), &c1, &c2);
    return d - ra - rb;
  }
  std::vector<Vec3> diff;
  diff.reserve(ca.size() * cb.size());
  for (const Vec3& x : ca)
    for (const Vec3& y : cb)
      diff.push_back(x - y);
  // qhull at about unit size (a power of two, exact): its products of coordinates underflow
  // below about 1e-154 m, and a 2.6e-163 m hull 1.05e-168 m above a point came out "touching"
  // (fuzz/regressions/core/oracle-qhull-underflow-2.6e-163m-hull).
  double m = 0.0;
  for (const Vec3& x : diff)
    m = std::max(m, x.cwiseAbs().maxCoeff());
  const double unit = oracle::unitScale(m);
  for (Vec3& x : diff)
    x *= unit;
  double d = 0.0;
  try {
    d = oracle::originSignedDistance(diff) / unit;
  } catch (const std::runtime_error&) {
    return std::nullopt;  // qhull failed
  }
  // Apart and few points: the distance again from every point-triangle and segment-segment pair
  // of the two point sets (the closest features of two separated hulls are among them; the others
  // are farther), without qhull. qhull's hull of a thin difference can lose a vertex to its
  // merging precision: two plates 5.9 m and 2.5e6 m across, 1.3e6 m apart, were 0.61 m too far
  // (fuzz/regressions/core/oracle-qhull-thin-plates-1.3e6m-apart; ours agreed with a long-double
  // brute force to 7e-10 m). Where that costs at most kBruteForceBudget feature pairs: a flat
  // 23-point polygon 3.2 m from a point (both 4875 m out, so their difference is flat only to
  // rounding) came out 0.32 m too far from qhull (fuzz/regressions/core/
  // oracle-qhull-flat-polygon-by-point; ours agreed with an exact rational 2D evaluation to
  // 4e-16 m); until then only pairs of at most 8 points each were checked this way.
  const auto choose3 = [](double n) { return n * (n - 1) * (n - 2) / 6; };
  const double na = static_cast<double>(ca.size()), nb = static_cast<double>(cb.size());
  const double pairs = na * choose3(nb) + nb * choose3(na) + na * (na - 1) / 2 * nb * (nb - 1) / 2;
  if (d > 0.0 && pairs <= kBruteForceBudget) {
    // At qhull's unit size too (exact: a power of two): a 30-point hull 2.6e-163 m across was
    // "touching" a box 1e-168 m from it in metres (squares underflow).
    for (Vec3& x : ca)
      x *= unit;
    for (Vec3& x : cb)
      x *= unit;
    double best = std::numeric_limits<double>::infinity();
    const auto pointToTriangles = [&best](const std::vector<Vec3>& ps,
                                          const std::vector<Vec3>& ts) {
      const std::size_t n = ts.size();
      for (const Vec3& p : ps)
        for (std::size_t i = 0; i < n; ++i)
          for (std::size_t j = i + 1; j < n; ++j)
            for (std::size_t k = j + 1; k < n; ++k)
              best =
                  std::min(best, (p - oracle::closestPointTriangle(p, ts[i], ts[j], ts[k])).norm());
    };
    pointToTriangles(ca, cb);
    pointToTriangles(cb, ca);
    for (std::size_t i = 0; i < ca.size(); ++i)
      for (std::size_t j = i + 1; j < ca.size(); ++j)
        for (std::size_t k = 0; k < cb.size(); ++k)
          for (std::size_t l = k + 1; l < cb.size(); ++l) {
            Vec3 c1, c2;
            best =
                std::min(best, oracle::closestSegmentSegment(ca[i], ca[j], cb[k], cb[l], &c1, &c2));
          }
    if (best < std::numeric_limits<double>::infinity()) d = best / unit;
  }
  return d - ra - rb;
}

inline bool finite(const cmc::ContactResult& r) {
  return std::isfinite(r.distance) && r.point_a.allFinite() && r.point_b.allFinite() &&
         r.normal.allFinite();
}

/// A decoded case: the two placed shape specs (B already placed).
struct Case {
  Placed a, b;
  bool relative = false;
  double factor = 0.0;
};

inline Case decodeCase(const std::uint8_t* data, std::size_t len) {
  Bytes in(data, len);
  Case c;
  const std::uint8_t flags = in.u8();
  c.a.spec = decodeShape(in);
  c.b.spec = decodeShape(in);
  c.a.pose = decodePose(in);
  c.b.pose = decodePose(in);
  c.a.pose.t = coordinates(in);
  c.relative = flags & 1;
  const Vec3 u_raw = in.unitVec();
  c.factor = (flags & 2) ? 1.0 : in.u8() / 128.0;  // 0 .. 2 of the contact distance
  const Vec3 b_abs = coordinates(in);
  if (c.relative) {
    const double un = u_raw.norm();
    const Vec3 u = un > 1e-6 ? Vec3(u_raw / un) : Vec3::UnitX();
    // B at factor * (reach of A along u + reach of B along -u) from A's origin.
    Placed b0 = c.b;
    b0.pose.t.setZero();
    const double reach = (c.a.h(u) - u.dot(c.a.pose.t)) + b0.h(-u);
    c.b.pose.t = c.a.pose.t + c.factor * reach * u;
  } else {
    c.b.pose.t = b_abs;
  }
  return c;
}

inline std::string describeCase(const std::uint8_t* data, std::size_t len) {
  const Case c = decodeCase(data, len);
  return "A: " + describe(c.a) + "\n  B: " + describe(c.b) + "\n  relative " +
         std::to_string(c.relative) + " factor " + std::to_string(c.factor);
}

/// Runs one case. Never throws; crashes and hangs are the sanitizers' and libFuzzer's to report.
inline Outcome runCase(const std::uint8_t* data, std::size_t len) {
  const auto t0 = std::chrono::steady_clock::now();
  Outcome out;
  const Case c = decodeCase(data, len);
  const Placed& a = c.a;
  const Placed& b = c.b;
  out.description = describeCase(data, len);
  auto fail = [&](const std::string& why) {
    out.failure = why + "\n  " + out.description;
    return out;
  };

  // 1. Factories.
  std::optional<cmc::ConvexShape> shape[2];
  const ShapeSpec* specs[2] = {&a.spec, &b.spec};
  for (int i = 0; i < 2; ++i) {
    const bool valid = expectValid(*specs[i]);
    try {
      shape[i] = build(*specs[i]);
    } catch (const std::invalid_argument& e) {
      if (valid) return fail(std::string("factory refused valid input: ") + e.what());
      continue;
    } catch (const std::exception& e) {
      return fail(std::string("factory threw a non-invalid_argument exception: ") + e.what());
    } catch (...) {
      return fail("factory threw a non-std exception");
    }
    if (!valid) return fail(std::string("factory accepted invalid ") + kindName(specs[i]->kind));
  }
  out.factories_ok = true;
  if (!shape[0] || !shape[1]) return out;

  const bool domain = inDomain(a.spec) && inDomain(b.spec) && a.pose.t.allFinite() &&
                      b.pose.t.allFinite() && a.pose.t.cwiseAbs().maxCoeff() <= kDomain &&
                      b.pose.t.cwiseAbs().maxCoeff() <= kDomain;

  const cmc::ConvexShape& A = *shape[0];
  const cmc::ConvexShape& B = *shape[1];
  cmc::ContactResult sd, dist, sd_warm, swapped, ccd;
  bool hit = false, hit_ccd = false;
  try {
    cmc::PairCache cache;
    hit = cmc::intersect(A, a.pose, B, b.pose);
    dist = cmc::distance(A, a.pose, B, b.pose);
    sd = cmc::signedDistance(A, a.pose, B, b.pose, &cache);
    sd_warm = cmc::signedDistance(A, a.pose, B, b.pose, &cache);
    swapped = cmc::signedDistance(B, b.pose, A, a.pose);
    // libccd only with finite poses: it dereferences a null pointer on a NaN translation
    // (pinned by test_core_hostile, LibccdNanTranslation); our GJK must survive those.
    if (a.pose.t.allFinite() && b.pose.t.allFinite()) {
      const auto libccd = cmc::makeNarrowPhase(cmc::BackendType::Libccd);
      hit_ccd = libccd->intersect(A, a.pose, B, b.pose, nullptr);
      ccd = libccd->signedDistance(A, a.pose, B, b.pose, nullptr);
    }
  } catch (const std::exception& e) {
    return fail(std::string("query threw: ") + e.what());
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!(a.pose.t.allFinite() && b.pose.t.allFinite())) {
    // query.cpp's contract for non-finite poses: a defined failure, intersect() conservative.
    if (sd.status != cmc::Status::FailedToConverge || dist.status != cmc::Status::FailedToConverge)
      return fail("non-finite pose not reported as FailedToConverge: " + describe(sd));
    if (!sd.normal.allFinite()) return fail("non-finite pose gave a NaN normal: " + describe(sd));
    if (!hit) return fail("non-finite pose: intersect() not conservative (false)");
  }
  if (!domain) return out;
  out.checked = true;

  // 2. Finite results, bounded iterations, convergence.
  const cmc::ContactResult* all[] = {&dist, &sd, &sd_warm, &swapped, &ccd};
  const char* names[] = {"distance", "signedDistance", "warm signedDistance", "swapped",
                         "libccd signedDistance"};
  for (int i = 0; i < 5; ++i) {
    const cmc::ContactResult& r = *all[i];
    if (!finite(r)) return fail(std::string(names[i]) + " not finite: " + describe(r));
    if (std::abs(r.normal.norm() - 1.0) > 1e-9)
      return fail(std::string(names[i]) + " normal not unit: " + describe(r));
    if (r.status == cmc::Status::FailedToConverge) {
      // Allowed only where EPA meets a curved core (its polytope approximation of a cylinder,
      // cone or ellipsoid may need more than the iteration bound to reach its tolerance);
      // the estimate is then checked with the looser tolerance below. Never for polytope cores.
      if (!curved(a.spec) && !curved(b.spec))
        return fail(std::string(names[i]) +
                    " failed to converge on polytope cores: " + describe(r));
      out.unconverged = true;
    }
    // Per frame: a query retried in B's frame (query.h) counts both frames' runs.
    const cmc::QueryOptions bounds;
    if (r.gjk_iterations > 2 * bounds.max_iterations ||
        r.epa_iterations > 2 * bounds.max_epa_iterations || r.gjk_iterations < 0)
      return fail(std::string(names[i]) + " iteration count out of bound: " + describe(r));
  }

  // Tolerance: relative to the pair's size (the cores' own scale, about their origins:
  // ConvexShape::offset()) plus the rounding of coordinates `far` out: the checks' own support
  // functions (gap() below, the oracle) work with the given coordinates and poses, up to
  // |t| + bounding radius. A point given 2890625 m out and posed back to 3.7e-9 m from a padded
  // 4.6e-9 m box: ours exact, gap() 2.8e-13 m high by its own rounding of products with 2.9e6 m
  // (fuzz/regressions/core/check-far-given-point-posed-home-rounding).
  // stableNorm(): norm() squares, and below about 1e-154 m the squares underflow (a 1.8e-163 m
  // offset had a size of 0, a tolerance of 1e-300 and an exact normal "failing" by 3e-179 m:
  // fuzz/regressions/core/oracle-size-underflow-1.8e-163m-offset).
  const Vec3 core_a = a.pose * A.offset(), core_b = b.pose * B.offset();
  const double size = A.localRadius() + B.localRadius() + (core_b - core_a).stableNorm();
  const double far = std::max(a.pose.t.stableNorm() + A.boundingRadius(),
                              b.pose.t.stableNorm() + B.boundingRadius());
  // An unconverged estimate (curved cores only) is checked to kLooseTolerance of the size.
  const double rel = out.unconverged ? kLooseTolerance : 1e-9;
  const double tol = rel * size + 1e-13 * far + 1e-300;

  // 4. Exact oracle.
  double ref = sd.distance;
  if (const auto exact = oracleDistance(a, b)) {
    out.oracle = true;
    ref = *exact;
    if (std::abs(sd.distance - ref) > tol) {
      std::ostringstream o;
      o.precision(17);
      o << "signedDistance " << sd.distance << " vs exact oracle " << ref << " (err "
        << std::abs(sd.distance - ref) << ", tol " << tol << "): " << describe(sd);
      return fail(o.str());
    }
  }
  out.overlap = ref < 0.0;

  // 3. Agreement between the queries.
  auto near = [&](double x, double y) { return std::abs(x - y) <= tol; };
  if (ref > tol && hit) return fail("intersect() true but apart: " + describe(sd));
  if (ref < -tol && !hit) return fail("intersect() false but overlapping: " + describe(sd));
  if (ref > tol && !near(dist.distance, sd.distance))
    return fail("distance() " + describe(dist) + " vs signedDistance " + describe(sd));
  if (ref < -tol && dist.distance != 0.0)
    return fail("distance() of overlapping shapes not 0: " + describe(dist));
  if (!near(sd_warm.distance, sd.distance))
    return fail("warm start changed the answer: " + describe(sd_warm) + " vs " + describe(sd));
  if (!near(swapped.distance, sd.distance))
    return fail("swapped pair: " + describe(swapped) + " vs " + describe(sd));
  // libccd: its EPA is a polytope approximation of curved shapes (ccd_backend.h: 1e-11 of the
  // size on boxes, a few 1e-6 on padded ones), and its GJK works with absolute epsilons in the
  // pair's unit-size frame: on thin, long or tiny shapes its boolean verdicts are wrong (up to
  // 1.9e-5 of the size on a needle by a disc and a 2e6 m triangle through a 4 m cylinder; a
  // 4e-245 m overlap missed), every ~1,000 inputs of this domain. The backend checks both of
  // libccd's verdicts (ccd_backend.cpp): its intersect() confirms "apart" with our GJK and contact
  // with its signedDistance, which is checked against the supports and our GJK. Their answers
  // must agree with the reference outside a 1e-4 band.
  // libccd runs about the shapes' frame origins (not offset()), so its scale includes the offsets.
  const double ccd_size =
      A.boundingRadius() + B.boundingRadius() + (b.pose.t - a.pose.t).stableNorm();
  const double ccd_tol = 1e-4 * ccd_size + tol;
  if (ref > ccd_tol && hit_ccd) return fail("libccd intersect() true but apart: " + describe(sd));
  if (ref < -ccd_tol && !hit_ccd)
    return fail("libccd intersect() false but overlapping: " + describe(sd));
  // Its depth is not checked: on degenerate cores (a zero-width box) libccd reports touching
  // (depth 0) where the depth is hundreds of metres (test_core_hostile, LibccdFlatBoxDepth).
  if (ref > ccd_tol && !(ccd.distance > 0.0))
    return fail("libccd signedDistance says contact, apart: " + describe(ccd) + " vs " +
                describe(sd));
  if (ref < -ccd_tol && ccd.distance > ccd_tol)
    return fail("libccd signedDistance says apart, overlap: " + describe(ccd) + " vs " +
                describe(sd));

  // 5. Certificate through independent support functions. gap(m) = -(hA(m) + hB(-m)) is a lower
  // bound on the distance for every unit m (and -gap(m) an upper bound on the depth), with
  // equality at the true normal.
  auto gap = [&](const Vec3& m) { return -(a.h(m) + b.h(-m)); };
  // GJK's termination bounds the distance error, not the direction: the normal and the witness
  // points are accurate to ~1e-9 of the size where a face is nearly parallel to the answer
  // (measured: a point 0.3 m above a 1e-9-jittered 3.6 m triangle has its witness 1.1e-9 m off,
  // gap(n) 1.5e-8 m below the distance). They are checked to 1e-7 of the size.
  // Near contact the direction is ill-conditioned: rounding of the coordinates (1e-16 of the
  // size and of the far offset) over the cores' distance tilts it (the sweep's formula); measured:
  // two boxes touching 1e6 m from the origin, normal 6e-6 rad off (fuzz/regressions/core).
  // size / gap first: multiplied first, the sizes of a 3.9e-163 m pair underflowed to 0 and left
  // 1e-7 of the size to a touching normal 2.5e-7 rad off
  // (fuzz/regressions/core/check-tiny-touching-normal-tolerance-underflow).
  const double core_gap = std::abs(sd.distance + A.radius() + B.radius());
  const double tol_n = std::max(
      {tol, 1e-7 * size, (1e-14 * size + 1e-14 * far) * (size / std::max(core_gap, 1e-300))});
  const Vec3 n = sd.normal;
  if (std::abs(gap(n) - sd.distance) > tol_n) {
    std::ostringstream o;
    o.precision(17);
    o << "normal does not realise the distance: gap(n) " << gap(n) << " vs " << sd.distance
      << " (tol " << tol_n << "): " << describe(sd);
    return fail(o.str());
  }
  // Witness points on the supporting planes, point_b - point_a = distance * normal.
  if (std::abs(n.dot(sd.point_a) - a.h(n)) > tol_n ||
      std::abs(-n.dot(sd.point_b) - b.h(-n)) > tol_n)
    return fail("witness points off the supporting planes: " + describe(sd));
  // On the shapes too: a supporting plane holds the whole of a contact's face, the shape only
  // part of it. EPA's nearest face was once a coplanar neighbour of the one holding d n (a
  // cylinder through a box's face, parallel to it), its weights extrapolated the witness off the
  // box by 6 mm (test ExactCurved.CylinderThroughABoxFaceHasWitnessesOnBoth).
  // Unconverged (FailedToConverge, curved cores), EPA reports its best upper bound: A's support
  // point along the normal, and B's witness on B's supporting plane that far along it (epa.h,
  // EpaUpperBound), where B need not be (1.66 m off a cylinder holding a cone 3.9 m deep,
  // fuzz/regressions/core/epa-cone-in-cylinder-normal-off): A's only. Curved cores flatter than
  // kMaxWitnessAspect: neither (the normal's direction is ill-conditioned there).
  const bool conditioned =
      aspectWithin(a.spec, kMaxWitnessAspect) && aspectWithin(b.spec, kMaxWitnessAspect);
  for (const auto& [placed, w] : {std::pair{&a, sd.point_a}, std::pair{&b, sd.point_b}}) {
    if (!conditioned || (placed == &b && sd.status == cmc::Status::FailedToConverge)) continue;
    const std::optional<double> off = placed->outside(w);
    if (off && *off > tol_n) {
      std::ostringstream o;
      o.precision(17);
      o << "witness point " << (placed == &a ? "a" : "b") << " " << *off << " m off its shape (tol "
        << tol_n << "): " << describe(sd);
      return fail(o.str());
    }
  }
  // Except by as much as the normal realises the distance better than the witness points'
  // direction does: GJK turns the normal of a stalled run toward its best lower bound only where
  // that bound gains more than the mismatch the turn causes (gjk.h, GjkResult::normal_along_cert).
  // A disc 1.2e-3 m from a hull's corner in its plane, one edge of the corner along the rim's
  // tangent: the distance right to 1.4e-15 m, the witness points' direction 3e-6 rad off (the rim
  // and that edge leave it first-order free), the normal turned to a bound 3.4e-9 m better and
  // 3.2e-9 m off the witness points (fuzz/regressions/core/gjk-disc-by-corner-edge-tangent-turn).
  const Vec3 apart = sd.point_b - sd.point_a;
  const double mismatch = (apart - sd.distance * n).norm();
  if (mismatch > tol_n) {
    const double an = apart.norm();
    const bool turned =
        sd.distance > 0.0 && an > 0.0 && gap(n) - gap(apart / an) >= mismatch - tol_n;
    if (!turned) return fail("point_b - point_a != distance * normal: " + describe(sd));
  }
  // Optimality of the normal: perturbed and sampled directions do no better.
  std::vector<Vec3> probes;
  const Vec3 e1 = n.unitOrthogonal(), e2 = n.cross(e1);
  for (double eps : {1e-1, 1e-2, 1e-3, 1e-4}) {
    for (int k = 0; k < 8; ++k) {
      const double phi = k * M_PI / 4;
      probes.push_back((n + eps * (std::cos(phi) * e1 + std::sin(phi) * e2)).normalized());
    }
  }
  for (int k = 0; k < 3; ++k) {
    probes.push_back(Vec3::Unit(k));
    probes.push_back(-Vec3::Unit(k));
  }
  for (int k = 0; k < 32; ++k) {
    const Vec3 m(std::sin(1.0 + 2.3 * k), std::cos(0.7 * k * k), std::sin(0.3 + 1.7 * k * k));
    probes.push_back(m.normalized());
  }
  for (const Vec3& m : probes) {
    if (gap(m) > sd.distance + tol) {
      std::ostringstream o;
      o.precision(17);
      o << "direction [" << m.transpose() << "] gives gap " << gap(m) << " > reported "
        << sd.distance << " (tol " << tol << "): " << describe(sd);
      return fail(o.str());
    }
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace cm_fuzz
