/// \file
/// One case of the world model's fuzzer (fuzz_world.cpp; replayed by the gtest
/// test_world_fuzz_regressions): the bytes decode into settings, up to six bodies of one or two
/// spheres or capsules (in a quarter of the cases with twists, boxes among them, and in half of
/// those convex hulls of 4 to 8 points too; in every case of boxes, cylinders, cones and
/// ellipsoids instead of about half the boxes; in a case that turns bodies, every part turns with
/// its body, each body about an axis of its own), and a sequence of operations on a WorldModel
/// (poses with stamps in and out of order, with or without twists, static poses, poses stamped
/// ahead of the clock (aging from when they came), checks at times that move on by 0 to 0.7 s,
/// the clock going back by up to 0.4 s (in frames mode too), bodies replaced, removed and added
/// again, unresolved poses, forgotten poses, new thresholds, disabled pairs, and the three
/// queries). Every check() is held to the contract:
/// - always: the events replay as a status machine (END of the status a pair has, BEGIN from
///   CLEAR; catch-up may give several transitions of a pair, in stamp order), and the statuses
///   they leave are those listed (every pair in WARNING, COLLISION or UNKNOWN, sorted, no
///   duplicate); a pair with a stale body is UNKNOWN; stale_bodies are the bodies without a fresh
///   pose; in_collision is whether a pair is in COLLISION; a listed verdict is a fixed point of
///   the status machine at its distance; a transition's distance gives it from the status before;
///   min_distance is at most each listed distance; a pair's verdict events never go back in
///   stamp.
/// - against a reference model that knows only the documented rules and the parts' exact
///   distances (segment to segment in closed form; with a box or a hull, separating axes and
///   closest features, coreDistance(); with a cylinder, cone or ellipsoid, where there is no
///   closed form, the core's signed distance, certified from the shapes' own supports and
///   membership, certifiedDistance()): every status, every event (type, order, distance,
///   stamp), min_distance, distance() and checkHypothetical(), with align_poses off (each body
///   at its latest pose) or in frames mode (align_poses on, every body posed at each frame's
///   stamp: each pair stepped over every frame, as catch-up promises); with twists (align_poses
///   off, or in frames, with or without rates), every time_to_collision given (listed pairs,
///   events, distance(), checkHypothetical()) against the first time the exact distance under
///   the twists comes within 1e-7 m of contact_distance and the first time it passes it by more
///   (checkTtc()); in half of those cases (bit 7 of the second settings byte) with
///   estimate_twists, a body posed without a twist under the one its last two poses give.
/// A failure is returned as text with the operations so far.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "collision_monitor/world/world_model.h"
#include "oracle.h"

namespace cm_fuzz_world {

namespace cw = collision_monitor::world;
using collision_monitor::core::ConvexShape;
using cw::EventType;
using cw::PairStatus;
using cw::Stamp;
using cw::Vec3;

struct Outcome {
  std::string failure;      ///< empty: every check passed
  bool exact = false;       ///< the reference model was used (align_poses off, or frames)
  bool frames = false;      ///< frames mode (align_poses, every body posed at each frame's stamp)
  bool rates = false;       ///< frames mode with rates (only some bodies posed at a frame)
  bool turns = false;       ///< bodies turn as well (each about an axis of its own)
  bool clock_back = false;  ///< frames mode, and the clock went back
  bool capsules = false;    ///< bodies of capsules rather than spheres
  bool boxes = false;       ///< some parts boxes (a twists case)
  bool hulls = false;       ///< some parts convex hulls (a case of boxes)
  bool twists = false;      ///< poses with twists: times to collision held to the reference
  bool estimated = false;   ///< a twists case with estimate_twists
  int checks = 0;
  int events = 0;
  int collisions = 0;       ///< COLLISION_BEGIN events
  int ttc_checked = 0;      ///< times to collision held to the reference
  int ttc_finite = 0;       ///< of them, finite and not 0 (the bodies approach)
  int ttc_estimated = 0;    ///< of them, finite with a body under an estimated twist
  int ttc_rotating = 0;     ///< of them, with a body turning
  int ttc_lower_bound = 0;  ///< of those, a lower bound short of the contact (128 steps ran out)
  int ttc_skipped = 0;      ///< left unjudged: the reference's search ran out of evaluations
  bool curved = false;      ///< some parts cylinders, cones or ellipsoids (a case of boxes)
  int certified = 0;        ///< distances of curved parts certified (certifiedDistance())
  /// The least of those lower bounds as a fraction of the time the bodies come within 1e-7 m of
  /// contact_distance (1 without one; a later contact than the horizon counts as the horizon).
  double ttc_least_fraction = 1.0;
  double seconds = 0.0;
};

class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  bool done() const { return pos_ >= size_; }
  template <typename T, std::size_t N>
  T pick(const T (&table)[N]) {
    return table[byte() % N];
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Exact distances (closed form, or coreDistance() with a box) against GJK's on spheres, capsules
/// and boxes of up to 5 m apart, and the band around a threshold within which either status is
/// accepted.
constexpr double kTol = 1e-8;
/// world_model.cpp: a pair unseen for so many checks is forgotten, once its last event is more
/// than pose_timeout old.
constexpr std::uint64_t kForgetAfterCycles = 64;

/// A body's pose as the reference knows it: a position, and an angle about the body's own axis
/// (RefBody::axis; 0 unless the case turns bodies).
struct RefPose {
  Vec3 position = Vec3::Zero();
  double angle = 0.0;
};

/// A part of a body as the reference knows it: a sphere, or in a case of capsules a capsule (a
/// segment swept by the radius; a sphere when the segment is a point), or in a case of boxes a
/// box, a hull, a cylinder, a cone or an ellipsoid, rounded by the radius (0 or more).
struct RefPart {
  RefPart(const Vec3& c, const Vec3& h, double r) : centre(c), half(h), radius(r) {}
  Vec3 centre;  ///< in the body frame
  Vec3 half;    ///< half the segment, in the body frame: from the centre to one end
  double radius;
  /// A box: its half sides, and its axes in the body frame (the farthest a corner is from the
  /// centre is the half sides' norm).
  bool box = false;
  Vec3 box_half = Vec3::Zero();
  /// The box's (or hull's) axes in the body frame.
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
  /// A convex hull (rounded by the radius, 0 or more): qhull's hull of the points it is given
  /// as (oracle::makeHull(), which keeps them as `points`), about the centre before `turn`: its
  /// faces, edges and facet planes, moved to each pose as they are.
  std::shared_ptr<const oracle::Hull> hull;
  /// A curved part (rounded by the radius, 0 or more), about the centre, its axes `turn`: a
  /// cylinder or a cone (the cone centred like shape_msgs: base at -z, apex at +z), `size` its
  /// (radius, radius, half height), or an ellipsoid, `size` its semi-axes.
  enum class Curved { None, Cylinder, Cone, Ellipsoid };
  Curved curved = Curved::None;
  Vec3 size = Vec3::Zero();
  /// Its core as the core library has it (coreShape()), placed at the centre, turned by `turn`:
  /// for the distances of curved parts, which the reference takes from the core and certifies
  /// (certifiedDistance()).
  std::shared_ptr<const ConvexShape> shape;

  /// The farthest a point of its core is from its centre.
  double reach() const {
    if (curved == Curved::Ellipsoid) return size.maxCoeff();
    if (curved != Curved::None) return std::hypot(size.x(), size.z());
    double r = box ? box_half.norm() : half.norm();
    if (hull)
      for (const Vec3& v : hull->points)
        r = std::max(r, v.norm());
    return r;
  }
};

inline const char* name(RefPart::Curved c) {
  static const char* const names[] = {"", "cylinder", "cone", "ellipsoid"};
  return names[static_cast<int>(c)];
}

/// Part x's core as a ConvexShape in the part's frame (about its centre, before `turn`).
inline std::shared_ptr<const ConvexShape> coreShape(const RefPart& x) {
  using C = RefPart::Curved;
  const double r = x.size.x(), h = 2.0 * x.size.z();
  if (x.curved == C::Cylinder) return std::make_shared<ConvexShape>(ConvexShape::cylinder(h, r));
  if (x.curved == C::Cone) return std::make_shared<ConvexShape>(ConvexShape::cone(h, r));
  if (x.curved == C::Ellipsoid)
    return std::make_shared<ConvexShape>(ConvexShape::ellipsoid(x.size));
  if (x.hull) return std::make_shared<ConvexShape>(ConvexShape::convexHull(x.hull->points));
  if (x.box) return std::make_shared<ConvexShape>(ConvexShape::box(2.0 * x.box_half));
  if (x.half.isZero(0.0)) return std::make_shared<ConvexShape>(ConvexShape::point(Vec3::Zero()));
  return std::make_shared<ConvexShape>(ConvexShape::segment(-x.half, x.half));
}

/// A part's core placed in the fixed frame: its axes and centre.
struct PlacedPart {
  const RefPart* x;
  Eigen::Matrix3d axes;
  Vec3 centre;

  /// Its support point along u (fixed frame): the point of the core farthest along u, from the
  /// shape's definition (written apart from the core's support mappings, which it checks).
  Vec3 support(const Vec3& u) const {
    using C = RefPart::Curved;
    const Vec3 l = axes.transpose() * u;  // u in the part's frame
    const Vec3& a = x->size;
    const double xy = std::hypot(l.x(), l.y());
    const auto rim = [&](double z) {  // the point of the rim at height z farthest along l
      return xy > 0.0 ? Vec3(a.x() * l.x() / xy, a.x() * l.y() / xy, z) : Vec3(0.0, 0.0, z);
    };
    Vec3 p;
    if (x->curved == C::Cylinder) {
      p = rim(l.z() >= 0.0 ? a.z() : -a.z());
    } else if (x->curved == C::Cone) {
      const Vec3 apex(0.0, 0.0, a.z()), base = rim(-a.z());
      p = l.dot(apex) >= l.dot(base) ? apex : base;
    } else if (x->curved == C::Ellipsoid) {
      const Vec3 s = a.cwiseProduct(l);  // D l, D = diag(semi-axes): the point is D^2 l / |D l|
      p = s.norm() > 0.0 ? Vec3(a.cwiseProduct(s) / s.norm()) : Vec3::Zero();
    } else if (x->hull) {
      p = x->hull->points.front();
      for (const Vec3& v : x->hull->points)
        if (l.dot(v) > l.dot(p)) p = v;
    } else if (x->box) {
      p = Vec3(l.x() >= 0.0 ? 1.0 : -1.0, l.y() >= 0.0 ? 1.0 : -1.0, l.z() >= 0.0 ? 1.0 : -1.0)
              .cwiseProduct(x->box_half);
    } else {
      p = l.dot(x->half) >= 0.0 ? x->half : Vec3(-x->half);
    }
    return centre + axes * p;
  }
  std::string describe() const {
    std::ostringstream out;
    out.precision(17);
    out << (x->curved != RefPart::Curved::None ? name(x->curved)
            : x->hull                          ? "hull"
            : x->box                           ? "box"
                                               : "segment")
        << " ("
        << (x->curved != RefPart::Curved::None ? x->size
            : x->box                           ? x->box_half
                                               : x->half)
               .transpose()
        << ") at (" << centre.transpose() << ") axes (" << axes.row(0) << "; " << axes.row(1)
        << "; " << axes.row(2) << ")";
    return out.str();
  }
  /// How far the point q (fixed frame) is outside the core: 0 inside, else its distance (an
  /// ellipsoid's: a lower bound of it; oracle::outsideEllipsoid()).
  double outside(const Vec3& q) const {
    using C = RefPart::Curved;
    const Vec3 l = axes.transpose() * (q - centre);
    const Vec3& a = x->size;
    if (x->curved == C::Cylinder) return oracle::outsideCylinder(l, a.x(), a.z());
    if (x->curved == C::Cone) return oracle::outsideCone(l, a.x(), a.z());
    if (x->curved == C::Ellipsoid) return oracle::outsideEllipsoid(l, a);
    if (x->hull) return std::max(0.0, oracle::signedDistance(*x->hull, l));
    if (x->box) return (l.cwiseAbs() - x->box_half).cwiseMax(0.0).norm();
    return (l - oracle::closestPointSegment(l, -x->half, x->half)).norm();
  }
};

/// A certificate that failed: certifiedDistance() throws it, Run::go() reports it.
struct Uncertified : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The cores' directions the certificate of an overlap tries against its depth: the axes, the
/// cube's diagonals and the edges' midpoints (26), and each part's axes.
inline const std::vector<Vec3>& probeDirections() {
  static const std::vector<Vec3> dirs = [] {
    std::vector<Vec3> d;
    for (int i = -1; i <= 1; ++i)
      for (int j = -1; j <= 1; ++j)
        for (int k = -1; k <= 1; ++k)
          if (i || j || k) d.push_back(Vec3(i, j, k).normalized());
    return d;
  }();
  return dirs;
}

/// The signed distance of two part cores (at least one curved: no closed form), by the core
/// library (core::signedDistance()), certified from the shapes' own definitions
/// (PlacedPart::support(), outside()): apart, its witness points lie on the cores (to 1e-7 of
/// the size) and the supports along its normal leave no more than kCertTol between the witness
/// points' distance and the separating planes' (a lower bound of the distance): the distance is
/// exact to kCertTol. Overlapping, the witnesses lie on the cores too, the cores overlap along
/// its normal by its depth, and along no probe direction (probeDirections(), the parts' axes) by
/// less (the depth is the least overlap over every direction): an upper bound, and a
/// falsification test. Throws Uncertified. The tolerance grows by 1e-11 of the distance and the
/// cores' distances from the origin.
inline constexpr double kCertTol = 1e-9;
inline double certifiedDistance(const PlacedPart& p, const PlacedPart& q, int* certified) {
  namespace cc = collision_monitor::core;
  const cc::ContactResult c = cc::signedDistance(*p.x->shape, cc::Transform3{p.axes, p.centre},
                                                 *q.x->shape, cc::Transform3{q.axes, q.centre});
  // The overlap of the cores along u: > 0 overlapping that far, < 0 a separating gap.
  const auto overlap = [&](const Vec3& u) { return u.dot(p.support(u)) - u.dot(q.support(-u)); };
  // Far out (a time-to-collision search places bodies hundreds of metres away) GJK converges
  // to its relative tolerance and rounding grows with the coordinates.
  const double tol = kCertTol + 1e-11 * (std::abs(c.distance) + p.centre.norm() + q.centre.norm());
  // Witness points, as the core's fuzzer holds them (fuzz/core_case.h): to 1e-7 of the size
  // (EPA's upper bound on a point at an ellipsoid's centre put the point's witness 6.7e-9 m off
  // it, its normal 2.7e-9 rad off the axis).
  const double size = p.x->reach() + q.x->reach() + (q.centre - p.centre).norm();
  const double tol_w = tol + 1e-7 * size;
  std::ostringstream why;
  why.precision(17);
  const Vec3& n = c.normal;
  if (!std::isfinite(c.distance) || !(std::abs(n.norm() - 1.0) <= 1e-12)) {
    why << "signed distance " << c.distance << ", normal (" << n.transpose() << ")";
  } else if (p.outside(c.point_a) > tol_w ||
             // Unconverged EPA's upper bound has B's witness on B's supporting plane only.
             (c.status != cc::Status::FailedToConverge && q.outside(c.point_b) > tol_w)) {
    why << "witness points " << p.outside(c.point_a) << " and " << q.outside(c.point_b)
        << " m off the cores";
  } else if (c.distance > 0.0) {
    const double upper = (c.point_b - c.point_a).norm(), lower = -overlap(n);
    if (!(upper - c.distance <= tol && c.distance - upper <= tol && c.distance - lower <= tol)) {
      why << "distance " << c.distance << " between the separating planes' " << lower
          << " and the witness points' " << upper;
    }
  } else {
    const double depth = -c.distance;
    if (!(std::abs(overlap(n) - depth) <= tol)) {
      why << "depth " << depth << " where the cores overlap " << overlap(n) << " along the normal";
    } else {
      std::vector<Vec3> dirs = probeDirections();
      for (const PlacedPart* x : {&p, &q})
        for (int k = 0; k < 3; ++k)
          dirs.push_back(x->axes.col(k));
      for (const Vec3& u : dirs) {
        for (const Vec3& v : {u, Vec3(-u)}) {
          if (overlap(v) < depth - tol) {
            why << "depth " << depth << " where the cores overlap only " << overlap(v) << " along ("
                << v.transpose() << ")";
            break;
          }
        }
        if (why.tellp() > 0) break;
      }
    }
  }
  if (why.tellp() > 0) {
    why << " (status " << cc::toString(c.status) << ", distance " << c.distance
        << ", witness points (" << c.point_a.transpose() << ") and (" << c.point_b.transpose()
        << "), normal (" << n.transpose() << "); cores " << p.describe() << " and " << q.describe()
        << ")";
    throw Uncertified("the core's distance of two parts not certified: " + why.str());
  }
  ++*certified;
  return c.distance;
}

/// A part's core in the fixed frame as coreDistance() takes it: a box (its centre, axes and half
/// sides), a convex hull (qhull's, placed), or a segment from a to b (a point when they are
/// equal).
struct PlacedCore {
  bool box = false;
  Vec3 centre = Vec3::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  ///< a box's, as columns
  Vec3 half = Vec3::Zero();
  Vec3 a = Vec3::Zero(), b = Vec3::Zero();
  std::optional<oracle::Hull> hull;

  /// Its vertices: a box's 8 corners (corner c on the positive side of axis k when bit k of c is
  /// set), a hull's points (those inside it too: they are points of it), a segment's two ends, a
  /// point.
  std::vector<Vec3> vertices() const {
    if (hull) return hull->points;
    if (!box) return a == b ? std::vector<Vec3>{a} : std::vector<Vec3>{a, b};
    std::vector<Vec3> v;
    for (int c = 0; c < 8; ++c) {
      const Vec3 sign(c & 1 ? 1.0 : -1.0, c & 2 ? 1.0 : -1.0, c & 4 ? 1.0 : -1.0);
      v.push_back(centre + axes * sign.cwiseProduct(half));
    }
    return v;
  }
  /// Its edges as pairs of vertices() indices: a box's 12, a hull's triangles' edges (the
  /// diagonals of its faces among them: segments of it), a segment's one.
  std::vector<std::pair<int, int>> edges() const {
    if (hull) return hull->edges;
    if (!box)
      return a == b ? std::vector<std::pair<int, int>>{} : std::vector<std::pair<int, int>>{{0, 1}};
    std::vector<std::pair<int, int>> e;
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 8; ++c)
        if (!(c & (1 << k))) e.emplace_back(c, c | (1 << k));
    return e;
  }
  /// The directions of its edges: a box's axes, a hull's edges', a segment's direction.
  std::vector<Vec3> directions() const {
    if (hull) {
      std::vector<Vec3> d;
      for (const auto& [i, j] : hull->edges)
        d.push_back(hull->points[j] - hull->points[i]);
      return d;
    }
    if (!box) return a == b ? std::vector<Vec3>{} : std::vector<Vec3>{b - a};
    return {axes.col(0), axes.col(1), axes.col(2)};
  }
  /// The normals of its faces: a box's axes, a hull's facet normals; none for a segment.
  std::vector<Vec3> faceNormals() const {
    if (hull) return hull->normals;
    if (!box) return {};
    return {axes.col(0), axes.col(1), axes.col(2)};
  }
  /// The distance of x to it, solid (0 inside a box or hull).
  double distanceTo(const Vec3& x) const {
    if (hull) return std::max(0.0, oracle::signedDistance(*hull, x));
    if (!box) return (x - oracle::closestPointSegment(x, a, b)).norm();
    const Vec3 local = axes.transpose() * (x - centre);
    return (local.cwiseAbs() - half).cwiseMax(0.0).norm();
  }
};

/// The exact signed distance of two part cores, at least one a box or a hull. Written apart
/// from the core's GJK and EPA; test_world_fuzz_regressions checks it against qhull's hull of
/// the Minkowski difference (oracle::solveMinkowski(); the closest points of a segment, of two
/// segments in long double, of a point and a hull's triangles are test/core/oracle.h's).
/// Overlapping: the least overlap over the candidate separating axes, which include every facet
/// normal of the cores' Minkowski difference (the faces' normals, and the cross products of the
/// two cores' edge directions). Apart: the least of each vertex's distance to the other core
/// and of each edge pair's (a closest pair of points of two convex polytopes is always a vertex
/// and a point of the other, or a point of each of two edges), an edge pair passed over where
/// the balls about the two edges are already farther apart than the best so far.
inline double coreDistance(const PlacedCore& p, const PlacedCore& q) {
  const std::vector<Vec3> vp = p.vertices(), vq = q.vertices();
  double depth = kInf;  // the least overlap so far; <= 0: a separating axis
  const auto axis = [&](const Vec3& n) {
    double p_hi = -kInf, p_lo = kInf, q_hi = -kInf, q_lo = kInf;
    for (const Vec3& v : vp) {
      p_hi = std::max(p_hi, n.dot(v));
      p_lo = std::min(p_lo, n.dot(v));
    }
    for (const Vec3& v : vq) {
      q_hi = std::max(q_hi, n.dot(v));
      q_lo = std::min(q_lo, n.dot(v));
    }
    depth = std::min({depth, p_hi - q_lo, q_hi - p_lo});
  };
  for (const PlacedCore* x : {&p, &q})
    for (const Vec3& n : x->faceNormals())
      axis(n);
  for (const Vec3& dp : p.directions()) {
    for (const Vec3& dq : q.directions()) {
      const Vec3 c = dp.cross(dq);
      const double len = c.norm();
      if (len > 1e-13 * dp.norm() * dq.norm()) axis(c / len);  // parallel edges: no facet
    }
  }
  if (depth > 0.0) return -depth;
  double best = kInf;
  for (const Vec3& v : vp)
    best = std::min(best, q.distanceTo(v));
  for (const Vec3& v : vq)
    best = std::min(best, p.distanceTo(v));
  for (const auto& [i, j] : p.edges()) {
    const Vec3 mid_p = 0.5 * (vp[i] + vp[j]);
    const double half_p = 0.5 * (vp[j] - vp[i]).norm();
    for (const auto& [k, l] : q.edges()) {
      const double apart =
          (0.5 * (vq[k] + vq[l]) - mid_p).norm() - half_p - 0.5 * (vq[l] - vq[k]).norm();
      if (apart >= best) continue;
      Vec3 on_p, on_q;
      best =
          std::min(best, oracle::closestSegmentSegment(vp[i], vp[j], vq[k], vq[l], &on_p, &on_q));
    }
  }
  return best;
}

/// The points of a hull part: a box's corners (half sides `half`), or with `tetrahedron` the four
/// with an even number of positive sides, corner c pulled in to 40 % of the way from the centre
/// where bit c of `pulled` is set (some are then inside the hull of the others).
inline std::vector<Vec3> hullPoints(const Vec3& half, bool tetrahedron, std::uint8_t pulled) {
  std::vector<Vec3> points;
  for (int c = 0; c < 8; ++c) {
    if (tetrahedron && ((c & 1) + ((c >> 1) & 1) + ((c >> 2) & 1)) % 2) continue;
    const Vec3 sign(c & 1 ? 1.0 : -1.0, c & 2 ? 1.0 : -1.0, c & 4 ? 1.0 : -1.0);
    points.push_back((pulled >> c & 1 ? 0.4 : 1.0) * sign.cwiseProduct(half));
  }
  return points;
}

/// The distance between segments [p0, p1] and [q0, q1]: the core tests' exact oracle (long double,
/// written apart from the core's GJK, which it checks).
inline double segmentDistance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  Vec3 on_p, on_q;
  return oracle::closestSegmentSegment(p0, p1, q0, q1, &on_p, &on_q);
}

/// A body as the reference knows it.
struct RefBody {
  bool exists = false;
  std::vector<RefPart> parts;
  std::string group;
  Vec3 axis = Vec3::UnitZ();  ///< it turns about this axis through its origin, only
  bool has_pose = false;
  bool unresolved = false;
  Stamp stamp;  ///< zero: static
  /// The time its pose ages from: its stamp, or when it came if earlier (a stamp ahead of the
  /// clock), or the time of a check that saw the clock go back before it.
  Stamp fresh_from;
  RefPose pose;
  /// The twist of its latest pose (a twists case): linear velocity in the fixed frame, and a
  /// turn about its own axis (RefBody::axis, through its origin) at `rate` rad/s.
  bool has_twist = false;
  bool estimated = false;  ///< the twist is estimate_twists' (poseTwist())
  Vec3 linear = Vec3::Zero();
  double rate = 0.0;
  /// Frames mode: its poses since the last check that found it stale (or since it came), and
  /// the first of them within pose_timeout of the first check that found it fresh since.
  std::vector<std::pair<Stamp, RefPose>> frames;
  Stamp known_from;
  bool fresh_prev = false;      ///< fresh at the last check
  Stamp checked;                ///< its stamp at the last check
  bool checked_moving = false;  ///< moving() at the last check
};

using Key = std::pair<std::string, std::string>;  ///< first < second

struct RefPair {
  PairStatus status = PairStatus::Clear;
  Stamp last_event;             ///< of its verdict events
  Stamp max_to;                 ///< frames mode: the latest time the reference evaluated it at
  std::uint64_t last_busy = 0;  ///< the last check it was not CLEAR
  /// CLEAR for more than kForgetAfterCycles checks, its last event more than pose_timeout old
  /// at one of them: the world may have forgotten it with that stamp (until its next event).
  bool forgettable = false;
};

inline const char* name(PairStatus s) {
  switch (s) {
    case PairStatus::Clear:
      return "CLEAR";
    case PairStatus::Warning:
      return "WARNING";
    case PairStatus::Collision:
      return "COLLISION";
    default:
      return "UNKNOWN";
  }
}

inline const char* name(EventType t) {
  switch (t) {
    case EventType::CollisionBegin:
      return "COLLISION_BEGIN";
    case EventType::CollisionEnd:
      return "COLLISION_END";
    case EventType::WarningBegin:
      return "WARNING_BEGIN";
    case EventType::WarningEnd:
      return "WARNING_END";
    case EventType::UnknownBegin:
      return "UNKNOWN_BEGIN";
    default:
      return "UNKNOWN_END";
  }
}

inline PairStatus statusOf(EventType t) {
  switch (t) {
    case EventType::CollisionBegin:
    case EventType::CollisionEnd:
      return PairStatus::Collision;
    case EventType::WarningBegin:
    case EventType::WarningEnd:
      return PairStatus::Warning;
    default:
      return PairStatus::Unknown;
  }
}

inline bool isBegin(EventType t) {
  return t == EventType::CollisionBegin || t == EventType::WarningBegin ||
         t == EventType::UnknownBegin;
}

inline EventType endOf(PairStatus s) {
  return s == PairStatus::Collision ? EventType::CollisionEnd
         : s == PairStatus::Warning ? EventType::WarningEnd
                                    : EventType::UnknownEnd;
}
inline EventType beginOf(PairStatus s) {
  return s == PairStatus::Collision ? EventType::CollisionBegin
         : s == PairStatus::Warning ? EventType::WarningBegin
                                    : EventType::UnknownBegin;
}

/// The events of a transition (node.md): END(from) unless CLEAR, BEGIN(to) unless CLEAR.
inline std::vector<EventType> transition(PairStatus from, PairStatus to) {
  std::vector<EventType> out;
  if (from == to) return out;
  if (from != PairStatus::Clear) out.push_back(endOf(from));
  if (to != PairStatus::Clear) out.push_back(beginOf(to));
  return out;
}

class Run {
 public:
  Run(const std::uint8_t* data, std::size_t size) : in_(data, size) {}

  Outcome go() {
    const auto t0 = std::chrono::steady_clock::now();
    try {
      setUp();
      for (int op = 0; op < 200 && !in_.done() && out_.failure.empty(); ++op)
        step();
      if (out_.failure.empty()) check();  // the state the last operations left
    } catch (const Uncertified& e) {
      fail(e.what());
    }
    out_.certified = certified_;
    out_.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return out_;
  }

 private:
  // --- set-up -------------------------------------------------------------------------------
  void setUp() {
    static const double warning[] = {0.05, 0.1, 0.0, 0.3};
    static const double contact[] = {0.0, 0.0, 0.02, 0.1};
    static const double hysteresis[] = {0.005, 0.02, 0.0, 0.1};
    static const double timeout[] = {0.5, 0.2, 1.0, 0.05};
    const std::uint8_t flags = in_.byte();
    s_.warning_distance = in_.pick(warning);
    s_.contact_distance = in_.pick(contact);
    s_.hysteresis = in_.pick(hysteresis);
    s_.pose_timeout = in_.pick(timeout);
    s_.align_poses = (flags & 1) != 0;
    s_.exact_min_distance = (flags & 2) == 0;
    s_.backend = (flags & 4) ? collision_monitor::core::BackendType::Libccd
                             : collision_monitor::core::BackendType::Gjk;
    // libccd's penetration depth is not exact: its verdicts are held to the invariants only.
    const bool gjk = s_.backend == collision_monitor::core::BackendType::Gjk;
    exact_ = !s_.align_poses && gjk;
    frames_ = s_.align_poses && gjk && (flags & 8) != 0;
    rates_ = frames_ && (flags & 16) != 0;
    turns_ = (flags & 128) != 0;
    // Bit 5 without bit 6 (a regression input from before has both): frames with checks at
    // times before the last check's.
    clock_back_ = frames_ && (flags & 0x60) == 0x20;
    // Bit 6 without bit 5: capsules rather than spheres.
    capsules_ = (flags & 0x60) == 0x40;
    // Bits 5 and 6 with align_poses off, or in frames without rates (the regression input with
    // both bits is of frames with rates): poses with twists, and a second settings byte
    // (capsules, the horizon for turning bodies, boxes, and in frames rates after all).
    twists_ = (flags & 0x60) == 0x60 && (!s_.align_poses || (frames_ && !rates_));
    if (twists_) {
      static const double horizon[] = {10.0, 1.0, 0.25, 3.0};
      const std::uint8_t more = in_.byte();
      capsules_ = (more & 1) != 0;
      s_.ttc_horizon = horizon[(more >> 1) % 4];
      boxes_ = (more >> 3) % 4 == 3;
      hulls_ = boxes_ && (more & 0x40) != 0;
      rates_ = frames_ && (more & 0x20) != 0;
      s_.estimate_twists = (more & 0x80) != 0;
    }
    out_.exact = exact_ || frames_;
    out_.frames = frames_;
    out_.rates = rates_;
    out_.turns = turns_;
    out_.capsules = capsules_;
    out_.boxes = boxes_;
    out_.hulls = hulls_;
    out_.twists = twists_;
    out_.estimated = twists_ && s_.estimate_twists;
    world_.emplace(s_);
    log_ << "settings: w " << s_.warning_distance << " c " << s_.contact_distance << " h "
         << s_.hysteresis << " timeout " << s_.pose_timeout << " align " << s_.align_poses
         << " exact_min " << s_.exact_min_distance << " frames " << frames_ << " rates " << rates_
         << " turns " << turns_ << " clock back " << clock_back_ << " capsules " << capsules_
         << " boxes " << boxes_ << " hulls " << hulls_ << " twists " << twists_ << " horizon "
         << s_.ttc_horizon << " estimate twists " << s_.estimate_twists << " backend "
         << (s_.backend == collision_monitor::core::BackendType::Gjk ? "gjk" : "libccd") << "\n";
    const int n = 2 + in_.byte() % 5;
    bodies_.resize(n);
    // Each body turns about an axis of its own (kept when it is replaced, or removed and added
    // again), so a pair's two bodies turn about different axes.
    static const Vec3 axes[] = {Vec3::UnitZ(),
                                Vec3::UnitX(),
                                Vec3(1.0, 1.0, 1.0).normalized(),
                                Vec3::UnitY(),
                                Vec3(0.3, -0.8, 0.5).normalized(),
                                Vec3(0.0, 0.6, 0.8)};
    for (int i = 0; i < n; ++i) {
      bodies_[i].axis = axes[i];
      add(i);
    }
  }

  static std::string id(int i) { return "b" + std::to_string(i); }

  /// Adds (or replaces) body i with spheres (or capsules) decoded from the input.
  void add(int i) {
    static const double radius[] = {0.05, 0.1, 0.2, 0.3};
    static const double offset[] = {0.0, 0.15, -0.25, 0.4};
    RefBody b = bodies_[i];
    b.parts.clear();
    const std::uint8_t k = in_.byte();
    // When bodies turn, the first sphere may be off the body's origin too, up to 1.6 m out on a
    // lever: a turn between two poses then sweeps it through places neither pose's box is near
    // (1 m beyond them for a turn of 2.5 rad: the broad phase's bulge).
    static const double lever[] = {0.0, 0.4, -0.9, 1.6};
    const Vec3 first = turns_ ? Vec3(lever[in_.byte() % 4], 0.0, 0.1) : Vec3::Zero();
    // Radii off the thresholds' grid (a tie with a threshold is accepted either way anyway).
    b.parts.push_back({first, Vec3::Zero(), radius[k % 4] + 1e-4 * std::sqrt(2.0 + i)});
    if (k & 4) {
      b.parts.push_back({Vec3(offset[(k >> 3) % 4], offset[(k >> 5) % 4], 0.07), Vec3::Zero(),
                         radius[(k >> 1) % 4] * 0.5 + 1e-4 * std::sqrt(3.0 + i)});
    }
    // Capsules: each part's segment up to 1.6 m long, along an axis of the body's or across
    // them; a segment reaches out of the part's centre as a lever does.
    static const double length[] = {0.0, 0.3, 0.8, 1.6};
    static const Vec3 along[] = {Vec3::UnitX(), Vec3::UnitZ(), Vec3(1.0, 1.0, 0.0).normalized(),
                                 Vec3(0.0, -0.6, 0.8)};
    // Boxes: in a case of boxes, a part whose next byte is odd is a box, its half sides from 1 cm
    // (a plate) to 0.45 m, turned in the body by one of four rotations, and rounded by half the
    // part's radius or not at all. In a case of hulls too, such a part whose turn's byte has bit
    // 2 is the convex hull of that box's corners instead, each corner pulled in to 40 % of the
    // way from the centre where a bit of the next byte says (some then inside the others' hull),
    // or with bit 3 of only four of them (a tetrahedron), again some pulled in.
    static const double side[] = {0.01, 0.08, 0.2, 0.45};
    static const Eigen::Quaterniond turn[] = {
        Eigen::Quaterniond::Identity(), Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Vec3::UnitZ())),
        Eigen::Quaterniond(Eigen::AngleAxisd(2.1, Vec3(1.0, -1.0, 0.5).normalized())),
        Eigen::Quaterniond(Eigen::AngleAxisd(-0.4, Vec3(0.2, 1.0, 0.0).normalized()))};
    for (RefPart& part : b.parts) {
      if (capsules_) {
        const std::uint8_t c = in_.byte();
        part.half = 0.5 * length[c % 4] * along[(c >> 2) % 4];
      }
      if (boxes_) {
        const std::uint8_t x = in_.byte();
        if (x & 1) {
          part.half = Vec3::Zero();
          part.box_half = Vec3(side[(x >> 1) % 4], side[(x >> 3) % 4], side[(x >> 5) % 4]);
          part.radius = x & 0x80 ? 0.5 * part.radius : 0.0;
          const std::uint8_t t = in_.byte();
          part.turn = turn[t % 4].toRotationMatrix();
          part.box = true;
          if (t & 16) {
            using C = RefPart::Curved;
            static const C kinds[] = {C::Cylinder, C::Cone, C::Ellipsoid, C::Cylinder};
            part.curved = kinds[(t >> 5) % 4];
            part.size = part.curved == C::Ellipsoid
                            ? part.box_half
                            : Vec3(part.box_half.x(), part.box_half.x(), part.box_half.z());
            part.box = false;
            part.box_half = Vec3::Zero();
            out_.curved = true;
          } else if (hulls_ && (t & 4)) {
            part.hull = std::make_shared<const oracle::Hull>(
                oracle::makeHull(hullPoints(part.box_half, (t & 8) != 0, in_.byte())));
            part.box = false;
            part.box_half = Vec3::Zero();
          }
        }
      }
      part.shape = coreShape(part);
    }
    b.group = (k & 0x80) && (k & 0x40) ? "g" : "";
    cw::BodySpec spec;
    spec.id = id(i);
    spec.frame = "map";
    spec.group = b.group;
    spec.pose_source = cw::PoseSource::Topic;
    for (const RefPart& x : b.parts) {
      cw::Part part{capsules_ ? ConvexShape::capsule(2.0 * x.half.norm(), x.radius)
                              : ConvexShape::sphere(x.radius),
                    cw::Transform3::Identity()};
      part.pose.t = x.centre;
      if (x.box || x.hull || x.curved != RefPart::Curved::None) {
        part.shape = *x.shape;
        if (x.radius > 0.0) part.shape = part.shape.padded(x.radius);
        part.pose.R = x.turn;
      } else if (x.half != Vec3::Zero()) {
        part.pose.R = Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), x.half).toRotationMatrix();
      }
      spec.parts.push_back(part);
    }
    log_ << "add " << spec.id << " (" << (capsules_ ? "capsules" : "spheres")
         << (boxes_ ? ", boxes" : "");
    for (const RefPart& x : b.parts) {
      log_ << " r " << x.radius << " at (" << x.centre.transpose() << ") half ("
           << x.half.transpose() << ")";
      if (x.box) log_ << " box (" << x.box_half.transpose() << ") turned " << x.turn.row(0);
      if (x.curved != RefPart::Curved::None)
        log_ << " " << name(x.curved) << " (" << x.size.transpose() << ") turned " << x.turn.row(0);
      if (x.hull) {
        log_ << " hull of";
        for (const Vec3& v : x.hull->points)
          log_ << " (" << v.transpose() << ")";
        log_ << " turned " << x.turn.row(0);
      }
    }
    log_ << ", group '" << b.group << "')\n";
    const std::string why = world_->addBody(spec);
    if (!why.empty()) return fail("addBody refused: " + why);
    if (!b.exists) {  // new (or again after a removal): no pose yet
      b.has_pose = false;
      b.unresolved = false;
      b.stamp = Stamp();
      b.has_twist = false;
      b.frames.clear();
      b.fresh_prev = false;
    }
    b.exists = true;
    bodies_[i] = b;
  }

  // --- operations ---------------------------------------------------------------------------
  void step() {
    const std::uint8_t op = in_.byte();
    const int i = static_cast<int>(in_.byte() % bodies_.size());
    switch (op % 12) {
      case 0:
      case 1:
      case 2:
      case 3:
        return frames_ ? frame() : setPose(i);
      case 4:
      case 5:
      case 6:
        return advanceAndCheck();
      case 7:
        if (bodies_[i].exists) return remove(i);
        return add(i);
      case 8:
        if (!bodies_[i].exists) return;
        // Replaced: statuses and pose kept. With frames, between two checks: a new geometry, like
        // new thresholds, applies from the next check, at the pairs' time then (frames since the
        // last check would be caught up with it, or a pair it puts beyond the broad phase's reach
        // would end at the check: either is a reading of "at the next check").
        if (frames_) check();
        add(i);
        if (frames_) check();
        return;
      case 9:
        if (frames_) return;
        return markUnresolved(i);
      case 10:
        return query(i);
      default:
        return rare(i);
    }
  }

  /// Within 0.64 m of the origin, or a step of up to 64 mm from `from` (a body moving on).
  Vec3 position(const Vec3& from = Vec3::Zero()) {
    const std::uint8_t mode = in_.byte();
    const double unit = mode & 1 ? 0.005 : 0.0005;
    const auto c = [&] { return (static_cast<int>(in_.byte()) - 128) * unit; };
    const double x = c(), y = c(), z = c() * 0.25;
    return mode & 1 ? Vec3(x, y, z) : Vec3(from + Vec3(x, y, z));
  }

  void setPose(int i) {
    // ms relative to the clock; 1000: a static pose.
    static const int offset_ms[] = {0, 0, 0, -10, -100, 5, 1000, -600, -1, 20};
    RefBody& b = bodies_[i];
    // Any angle (in 0.05 rad steps) when bodies turn.
    const RefPose p{position(b.pose.position), turns_ ? (in_.byte() - 128) * 0.05 : 0.0};
    const int off = in_.pick(offset_ms);
    const Stamp stamp = off == 1000 ? Stamp() : Stamp::fromNanoseconds(now_ns_ + off * 1000000LL);
    const std::optional<cw::Twist> twist = twists_ ? twistFor(b) : std::nullopt;
    log_ << "setPose " << id(i) << " " << describe(p) << " at " << stamp.nanoseconds()
         << describe(twist) << "\n";
    // As the node does: with the ROS time it came (a pose stamped ahead ages from then).
    const Stamp came = Stamp::fromNanoseconds(now_ns_);
    const bool ok = world_->setPose(id(i), transform(b, p), stamp, twist, came);
    const bool expected =
        b.exists && !(b.has_pose && !stamp.isStatic() && !b.stamp.isStatic() && stamp < b.stamp);
    if (ok != expected) {
      return fail(std::string("setPose returned ") + (ok ? "true" : "false") +
                  " (out of order only between timed stamps: a stamp older than the one held)");
    }
    if (!ok) return;
    poseTwist(&b, p, stamp, twist);
    b.has_pose = true;
    b.unresolved = false;
    b.stamp = stamp;
    b.fresh_from = std::min(stamp, came);
    b.pose = p;
  }

  /// Body b's twist from its latest pose's (none: at rest).
  static void setTwist(RefBody* b, const std::optional<cw::Twist>& twist) {
    b->has_twist = twist.has_value();
    b->estimated = false;
    b->linear = twist ? twist->linear : Vec3::Zero();
    b->rate = twist ? twist->angular.dot(b->axis) : 0.0;
  }

  /// Body b's twist once posed at `p`, `stamp` (before b takes them): the one given, or with
  /// estimate_twists (node.md) the motion from its held pose to this one when both are timed and
  /// 0 < their gap <= pose_timeout (the same stamp again: the twist it has), else at rest. The
  /// turn is about the body's own axis: the angle between the two, the shorter way round.
  void poseTwist(RefBody* b, const RefPose& p, Stamp stamp,
                 const std::optional<cw::Twist>& twist) const {
    if (twist || !s_.estimate_twists || !b->has_pose || stamp.isStatic() || b->stamp.isStatic())
      return setTwist(b, twist);
    if (stamp == b->stamp) return;
    const double dt = stamp - b->stamp;
    if (!(dt > 0.0 && dt <= s_.pose_timeout)) return setTwist(b, std::nullopt);
    b->linear = (p.position - b->pose.position) / dt;
    b->rate = std::remainder(p.angle - b->pose.angle, 2.0 * M_PI) / dt;
    b->has_twist = !b->linear.isZero(0.0) || b->rate != 0.0;
    b->estimated = b->has_twist;
  }

  /// A twists case: none, or a linear velocity of up to 3 m/s (0 too) and, when bodies turn, a
  /// turn about the body's own axis of up to 7 rad/s.
  std::optional<cw::Twist> twistFor(const RefBody& b) {
    static const double speed[] = {0.0, 0.05, 0.5, 3.0};
    static const Vec3 dir[] = {Vec3::UnitX(),
                               -Vec3::UnitX(),
                               Vec3::UnitY(),
                               -Vec3::UnitY(),
                               Vec3(1.0, 1.0, 0.0).normalized(),
                               Vec3(-1.0, 0.5, 0.2).normalized(),
                               -Vec3::UnitZ(),
                               Vec3(0.3, -0.9, 0.1).normalized()};
    static const double rate[] = {0.0, 0.4, -2.5, 7.0};
    const std::uint8_t k = in_.byte();
    if ((k & 1) == 0) return std::nullopt;
    cw::Twist t;
    t.linear = speed[(k >> 1) % 4] * dir[(k >> 3) % 8];
    if (turns_) t.angular = rate[(k >> 6) % 4] * b.axis;
    return t;
  }

  /// The world's pose for a reference pose of body b.
  static cw::Transform3 transform(const RefBody& b, const RefPose& p) {
    cw::Transform3 pose = cw::Transform3::Identity();
    pose.t = p.position;
    if (p.angle != 0.0) pose.R = Eigen::AngleAxisd(p.angle, b.axis).toRotationMatrix();
    return pose;
  }
  static std::string describe(const RefPose& p) {
    std::ostringstream out;
    out << "(" << p.position.transpose() << ")";
    if (p.angle != 0.0) out << " turned " << p.angle;
    return out.str();
  }
  static std::string describe(const std::optional<cw::Twist>& t) {
    if (!t) return "";
    std::ostringstream out;
    out << " twist (" << t->linear.transpose() << ") (" << t->angular.transpose() << ")";
    return out.str();
  }

  /// Frames mode: every body posed at one new stamp, 1 to 20 ms on (at most a tenth of
  /// pose_timeout), from the last frame, or from the clock once every pose is stale there. A check
  /// comes first when the frame would be more than half of pose_timeout after the oldest stamp the
  /// last check had of a fresh body (the frames since it, else), and with rates a body is posed
  /// anyway once its pose is a quarter of pose_timeout old: catch-up has the poses of the last
  /// pose_timeout (node.md), and needs them back to the pairs' last time.
  void frame() {
    static const int step_ms[] = {1, 10, 20};
    const std::int64_t timeout_ns = static_cast<std::int64_t>(s_.pose_timeout * 1e9);
    const std::int64_t step_ns = std::min<std::int64_t>(
        in_.pick(step_ms) * 1000000LL, std::max<std::int64_t>(timeout_ns / 10, 1000000));
    const std::int64_t stamp = (now_ns_ - frame_ns_ > timeout_ns ? now_ns_ : frame_ns_) + step_ns;
    const std::optional<std::int64_t> since = oldest_checked_ ? oldest_checked_ : span_from_;
    if (since && (stamp - *since) * 1e-9 > 0.5 * s_.pose_timeout) {
      now_ns_ = std::max(now_ns_, frame_ns_);
      check();
    }
    if (!span_from_) span_from_ = stamp;
    frame_ns_ = stamp;
    // With rates, the bodies the mask names (all when it names none): sources of different
    // rates, each pair at the older stamp.
    const std::uint8_t mask = rates_ ? in_.byte() : 0;
    log_ << "frame at " << stamp << "\n";
    for (int i = 0; i < static_cast<int>(bodies_.size()); ++i) {
      RefBody& b = bodies_[i];
      const bool lags =
          b.has_pose && (stamp - b.stamp.nanoseconds()) * 1e-9 > 0.25 * s_.pose_timeout;
      if (!b.exists || (mask != 0 && !(mask >> i & 1) && !lags)) continue;
      // A turn of up to 2.56 rad from the last pose (the shortest arc, which the world
      // interpolates along, is then this turn).
      RefPose p{position(b.pose.position),
                b.pose.angle + (turns_ ? (in_.byte() - 128) * 0.02 : 0.0)};
      if (b.has_pose && p.position == b.pose.position) {
        p.position.x() += 1e-6;  // every pose moves (moving() above)
      }
      const std::optional<cw::Twist> twist = twists_ ? twistFor(b) : std::nullopt;
      log_ << "  " << id(i) << " " << describe(p) << describe(twist) << "\n";
      if (!world_->setPose(id(i), transform(b, p), Stamp::fromNanoseconds(stamp), twist)) {
        return fail("setPose of a frame refused");
      }
      poseTwist(&b, p, Stamp::fromNanoseconds(stamp), twist);
      b.has_pose = true;
      b.stamp = Stamp::fromNanoseconds(stamp);
      b.fresh_from = b.stamp;
      b.pose = p;
      b.frames.emplace_back(b.stamp, p);
    }
  }

  void remove(int i) {
    log_ << "remove " << id(i) << "\n";
    if (!world_->removeBody(id(i))) return fail("removeBody of an existing body returned false");
    for (auto it = pairs_.begin(); it != pairs_.end();) {
      if (it->first.first == id(i) || it->first.second == id(i)) {
        if (it->second.status != PairStatus::Clear) {
          removed_.push_back({it->first, it->second.status});
        }
        it = pairs_.erase(it);
      } else {
        ++it;
      }
    }
    bodies_[i].exists = false;
  }

  void markUnresolved(int i) {
    log_ << "markUnresolved " << id(i) << "\n";
    world_->markUnresolved(id(i), "fuzz");
    if (bodies_[i].exists) bodies_[i].unresolved = true;
  }

  void rare(int i) {
    const std::uint8_t k = in_.byte();
    switch (frames_ ? 1 + k % (clock_back_ ? 4 : 3) : k % 5) {
      case 0: {
        log_ << "clearPoses\n";
        world_->clearPoses();
        for (RefBody& b : bodies_) {
          if (b.has_pose && !b.unresolved && b.stamp.isStatic()) continue;
          b.has_pose = false;
          b.unresolved = false;
          b.stamp = Stamp();
          b.has_twist = false;
        }
        for (auto& kv : pairs_)
          kv.second.last_event = Stamp();
        return;
      }
      case 1: {
        static const double warning[] = {0.05, 0.1, 0.0, 0.3};
        static const double hysteresis[] = {0.005, 0.02, 0.0, 0.1};
        const double w = in_.pick(warning), h = in_.pick(hysteresis);
        if (frames_) check();  // see the replacement in step()
        s_.warning_distance = w;
        s_.hysteresis = h;
        log_ << "setSettings w " << s_.warning_distance << " h " << s_.hysteresis << "\n";
        world_->setSettings(s_);
        if (frames_) check();
        return;
      }
      case 4: {
        // The clock goes back a little (a bag played again, a second /clock; further back the
        // node forgets every pose: clearPoses()). Poses and checks follow from the new time. In
        // frames mode a check follows at once (the next would take the clock to the frames'
        // time again): the frames since the last check, and those after, are ahead of it.
        static const int back_ms[] = {1, 10, 100, 400};
        now_ns_ = std::max<std::int64_t>(now_ns_ - in_.pick(back_ms) * 1000000LL, 700000000LL);
        log_ << "clock back to " << now_ns_ << "\n";
        if (frames_) {
          out_.clock_back = true;
          check();
        }
        return;
      }
      default: {
        const int j = static_cast<int>(in_.byte() % bodies_.size());
        if (i == j) return;
        log_ << "disablePair " << id(i) << " " << id(j) << "\n";
        world_->disablePair(id(i), id(j));
        disabled_.insert(key(i, j));
        return;
      }
    }
  }

  void advanceAndCheck() {
    static const int advance_ms[] = {0, 1, 1, 10, 10, 20, 50, 200, 700};
    now_ns_ = std::max(now_ns_, frames_ ? frame_ns_ : 0) + in_.pick(advance_ms) * 1000000LL;
    check();
  }

  // --- the reference --------------------------------------------------------------------------
  static Key key(int i, int j) { return i < j ? Key{id(i), id(j)} : Key{id(j), id(i)}; }
  static int index(const std::string& id) { return std::stoi(id.substr(1)); }

  bool fresh(const RefBody& b, Stamp now) const {
    if (!b.exists || !b.has_pose || b.unresolved) return false;
    return b.stamp.isStatic() || now - b.fresh_from <= s_.pose_timeout;
  }
  bool allowed(int i, int j) const {
    if (i == j || !bodies_[i].exists || !bodies_[j].exists) return false;
    if (!bodies_[i].group.empty() && bodies_[i].group == bodies_[j].group) return false;
    return disabled_.count(key(i, j)) == 0;
  }
  /// Where a point `c` (body frame) of body b is at pose p: turned about b's axis.
  static Vec3 pointAt(const RefBody& b, const RefPose& p, const Vec3& c) {
    return p.position + Eigen::AngleAxisd(p.angle, b.axis) * c;
  }
  /// The core of part x of body b at pose p, in the fixed frame.
  static PlacedCore placedCore(const RefBody& b, const RefPose& p, const RefPart& x) {
    PlacedCore core;
    core.box = x.box;
    if (x.hull || x.box) {
      const Eigen::Matrix3d axes = Eigen::AngleAxisd(p.angle, b.axis).toRotationMatrix() * x.turn;
      if (x.hull) {
        core.hull = x.hull->transformed(axes, pointAt(b, p, x.centre));
        return core;
      }
      core.centre = pointAt(b, p, x.centre);
      core.axes = axes;
      core.half = x.box_half;
    } else {
      core.a = pointAt(b, p, x.centre - x.half);
      core.b = pointAt(b, p, x.centre + x.half);
    }
    return core;
  }
  /// Part x of body b at pose p, placed.
  static PlacedPart placedPart(const RefBody& b, const RefPose& p, const RefPart& x) {
    return {&x, Eigen::AngleAxisd(p.angle, b.axis).toRotationMatrix() * x.turn,
            pointAt(b, p, x.centre)};
  }
  /// Exact signed distance of bodies A and B at poses pa and pb: closed form between segments
  /// (spheres and capsules), separating axes and closest features with a box or a hull
  /// (coreDistance()), the core's distance certified with a curved part (certifiedDistance()).
  double bodyDistance(const RefBody& A, const RefPose& pa, const RefBody& B,
                      const RefPose& pb) const {
    double best = kInf;
    for (const RefPart& x : A.parts) {
      for (const RefPart& y : B.parts) {
        if (x.curved != RefPart::Curved::None || y.curved != RefPart::Curved::None) {
          const double apart =
              certifiedDistance(placedPart(A, pa, x), placedPart(B, pb, y), &certified_);
          best = std::min(best, apart - x.radius - y.radius);
          continue;
        }
        if (x.box || y.box || x.hull || y.hull) {
          const double apart = coreDistance(placedCore(A, pa, x), placedCore(B, pb, y));
          best = std::min(best, apart - x.radius - y.radius);
          continue;
        }
        const double apart =
            segmentDistance(pointAt(A, pa, x.centre - x.half), pointAt(A, pa, x.centre + x.half),
                            pointAt(B, pb, y.centre - y.half), pointAt(B, pb, y.centre + y.half));
        best = std::min(best, apart - x.radius - y.radius);
      }
    }
    return best;
  }
  double distanceAt(int i, const RefPose& pi, int j, const RefPose& pj) const {
    return bodyDistance(bodies_[i], pi, bodies_[j], pj);
  }
  /// At their latest poses.
  double distance(int i, int j) const { return distanceAt(i, bodies_[i].pose, j, bodies_[j].pose); }
  /// Times to collision: the reference's search keeps to this precision (s); a world time
  /// within kBand (m) of contact_distance counts as contact.
  static constexpr double kTimeTol = 1e-9;
  static constexpr double kBand = 1e-7;
  /// The searches' work, in distances of a pair of spheres or capsules (about 0.3 us each
  /// without sanitizers): a search gives up after kSearchBudget of it, and a case's searches
  /// after kCaseBudget in all, so that no input runs for long (libFuzzer's -timeout, 10 s in CI,
  /// under ASan and UBSan, which make the long double distances about 40 times slower).
  static constexpr double kSearchBudget = 200000;
  static constexpr double kCaseBudget = 300000;
  /// The work of one distance of bodies A and B in those units: per part pair, 1 of two spheres
  /// or capsules (closed form, 0.3 us), 4 of a box and a capsule or sphere, 25 of two boxes
  /// (coreDistance(): 1.3 and 6.9 us); with a hull (up to 8 points, 18 edges, 12 faces), 360
  /// of two hulls and 120 of a hull and a box (coreDistance() took 26.2 and 8.5 us where two
  /// boxes took 1.83 us), 20 of a hull and a capsule or sphere (3.9 us where a box and a segment
  /// took 0.79 us).
  /// With a curved part, 30 (the core's distance and its certificate: about 3 us apart,
  /// EPA's overlaps longer).
  static double distanceWork(const RefBody& A, const RefBody& B) {
    double work = 0.0;
    for (const RefPart& x : A.parts) {
      for (const RefPart& y : B.parts) {
        if (x.curved != RefPart::Curved::None || y.curved != RefPart::Curved::None) {
          work += 30.0;
          continue;
        }
        if (x.hull || y.hull) {
          work += x.hull && y.hull ? 360.0 : x.box || y.box ? 120.0 : 20.0;
          continue;
        }
        work += x.box && y.box ? 25.0 : x.box || y.box ? 4.0 : 1.0;
      }
    }
    return work;
  }

  /// The first time in [0, T] at which D <= level, D being L-Lipschitz in time: within kTimeTol
  /// after a crossing, never before one; +inf when there is none; nullopt when the search takes
  /// more than `budget` distances. A span whose ends leave D no room to reach the level between
  /// them is passed over; the others are halved, the earlier half searched first.
  static std::optional<double> firstBelow(const std::function<double(double)>& D, double L,
                                          double T, double level, int budget) {
    const double d0 = D(0.0);
    if (d0 <= level) return 0.0;
    if (!(L > 0.0)) return kInf;  // D does not change
    struct Span {
      double lo, hi, dlo, dhi;
    };
    std::vector<Span> todo{{0.0, T, d0, D(T)}};
    while (!todo.empty()) {
      const Span s = todo.back();
      todo.pop_back();
      // The least D can be between the ends: where the slopes L down from both meet.
      if (0.5 * (s.dlo + s.dhi) - 0.5 * L * (s.hi - s.lo) > level) continue;
      if (s.hi - s.lo <= kTimeTol) {
        if (s.dhi <= level) return s.hi;
        continue;  // a dip within kTimeTol: at most L * kTimeTol / 2 deep
      }
      if (--budget < 0) return std::nullopt;
      const double mid = 0.5 * (s.lo + s.hi), dm = D(mid);
      todo.push_back({mid, s.hi, dm, s.dhi});
      todo.push_back({s.lo, mid, s.dlo, dm});
    }
    return kInf;
  }

  /// The farthest a point of a part's core (any kind: RefPart::reach()) reaches from its body's
  /// origin.
  static double coreReach(const RefBody& b) {
    double r = 0.0;
    for (const RefPart& x : b.parts)
      r = std::max(r, x.centre.norm() + x.reach());
    return r;
  }

  /// A time to collision the world gave (`got`) for bodies A and B at poses pa and pb, held to
  /// the reference (node.md): under their twists (a body without one at rest; a linear velocity
  /// and a turn about its own axis through its origin), the first time their distance is within
  /// kBand of contact_distance (lo) and the first time it is below that by more (hi), searched
  /// over the exact distance (bodyDistance()), Lipschitz in time at the bodies' relative speed
  /// bound (the linear velocities' difference plus each turn rate times the body's core reach).
  /// `got` must be between the two. With a turn, the search ends at ttc_horizon (+inf when hi is
  /// later), and `got` may also be a lower bound (the world's 128 steps can run out before the
  /// contact): never after hi, +inf only when hi is, and never after the horizon.
  void checkTtc(const std::string& what, const RefBody& A, const RefPose& pa, const RefBody& B,
                const RefPose& pb, double got) {
    if (!twists_ || !(exact_ || frames_)) return;  // only where the reference is used
    const Vec3 va = A.has_twist ? A.linear : Vec3::Zero();
    const Vec3 vb = B.has_twist ? B.linear : Vec3::Zero();
    const double ra = A.has_twist ? A.rate : 0.0, rb = B.has_twist ? B.rate : 0.0;
    const bool rotating = ra != 0.0 || rb != 0.0;
    const double reach_a = coreReach(A), reach_b = coreReach(B);
    const double L =
        ((vb - va).norm() + std::abs(ra) * reach_a + std::abs(rb) * reach_b) * (1.0 + 1e-9);
    int distances = 0;
    // Translating, only the relative motion counts: B moves by it, A stays (each at its own
    // velocity, a late time would place them where doubles are coarse).
    const Vec3 ua = rotating ? va : Vec3::Zero(), ub = rotating ? vb : Vec3(vb - va);
    const auto D = [&](double t) {
      ++distances;
      return bodyDistance(A, {pa.position + t * ua, pa.angle + t * ra}, B,
                          {pb.position + t * ub, pb.angle + t * rb});
    };
    // Translating together (node.md): velocities within 1e-9 of the faster one's speed of each
    // other are equal ones rounded (estimated from poses): never, once apart.
    if (!rotating && (vb - va).norm() <= 1e-9 * std::max(va.norm(), vb.norm()) &&
        D(0.0) > s_.contact_distance + kBand) {
      if (!(std::isinf(got) && got > 0.0)) {
        std::ostringstream why;
        why.precision(12);
        why << what << ": time_to_collision " << got << " s of bodies moving together ("
            << va.transpose() << ") and (" << vb.transpose() << ") m/s; the reference: +inf";
        fail(why.str());
      }
      ++out_.ttc_checked;
      return;
    }
    // Translating: after T the relative motion has taken them more than contact_distance + 1 m
    // apart, however near they started (their distance, cores' reach and radii).
    double radii = 0.0;
    for (const RefPart& x : A.parts)
      for (const RefPart& y : B.parts)
        radii = std::max(radii, x.radius + y.radius);
    const double c = s_.contact_distance;
    const double T =
        rotating ? s_.ttc_horizon
                 : ((pb.position - pa.position).norm() + reach_a + reach_b + radii + c + 1.0) /
                       std::max((vb - va).norm(), 1e-300);
    // As many distances as the search's budget and what the case's has left allow.
    const double work = distanceWork(A, B);
    const auto search = [&](double level) -> std::optional<double> {
      const double left = std::min(kSearchBudget, kCaseBudget - ttc_work_);
      distances = 0;
      const std::optional<double> at =
          left >= work ? firstBelow(D, L, T, level, static_cast<int>(left / work)) : std::nullopt;
      ttc_work_ += distances * work;
      return at;
    };
    const std::optional<double> lo = search(c + kBand);
    const std::optional<double> hi = lo ? search(c - kBand) : std::nullopt;
    if (!lo || !hi) {
      ++out_.ttc_skipped;
      return;
    }
    ++out_.ttc_checked;
    if (got > 0.0 && std::isfinite(got)) ++out_.ttc_finite;
    if (got > 0.0 && std::isfinite(got) && (A.estimated || B.estimated)) ++out_.ttc_estimated;
    if (rotating) ++out_.ttc_rotating;
    const double tol = 2.0 * kTimeTol + 1e-12 * (std::isfinite(got) ? got : 0.0);
    const bool early = got < *lo - tol;
    if (rotating && early) {
      ++out_.ttc_lower_bound;
      out_.ttc_least_fraction =
          std::min(out_.ttc_least_fraction, got / std::min(*lo, s_.ttc_horizon));
    }
    const bool beyond = rotating && std::isfinite(got) && got > s_.ttc_horizon + tol;
    if ((early && !rotating) || !(got <= *hi + tol) || beyond) {
      std::ostringstream why;
      why.precision(12);
      why << what << ": time_to_collision " << got << " s (the bodies "
          << (std::isfinite(got) ? D(got) : kInf) << " m apart then); the reference: within "
          << kBand << " m of contact_distance " << c << " after " << *lo << " s, past it after "
          << *hi << " s";
      if (rotating) why << " (searched up to the horizon, " << s_.ttc_horizon << " s)";
      fail(why.str());
    }
  }
  /// Of bodies i and j placed as for an evaluation at `t`: in frames along their frames, else
  /// at their latest poses.
  void checkTtc(const std::string& what, int i, int j, Stamp t, double got) {
    const auto at = [&](int k) { return frames_ ? poseAt(bodies_[k], t) : bodies_[k].pose; };
    checkTtc(what, bodies_[i], at(i), bodies_[j], at(j), got);
  }

  /// The status machine as node.md states it, written out apart from pair_logic.h's: a status
  /// is entered at its threshold (COLLISION at d <= contact, WARNING at d < warning) and left
  /// only once past it by the hysteresis.
  PairStatus next(PairStatus prev, double d) const {
    const double c = s_.contact_distance, w = s_.warning_distance, h = s_.hysteresis;
    const bool held = prev == PairStatus::Collision || prev == PairStatus::Warning;
    if (d <= c || (prev == PairStatus::Collision && d <= c + h)) return PairStatus::Collision;
    if (d < w || (held && d < w + h)) return PairStatus::Warning;
    return PairStatus::Clear;
  }
  /// The statuses the thresholds may give within kTol of `d` (one, or two at a threshold).
  std::set<PairStatus> statusesNear(PairStatus prev, double d) const {
    return {next(prev, d - kTol), next(prev, d), next(prev, d + kTol)};
  }
  /// pairStamp() without align_poses: the older timed stamp; the timed one; `now` when both
  /// are static.
  static Stamp pairStamp(const RefBody& a, const RefBody& b, Stamp now) {
    if (a.stamp.isStatic()) return b.stamp.isStatic() ? now : b.stamp;
    if (b.stamp.isStatic()) return a.stamp;
    return std::min(a.stamp, b.stamp);
  }

  // --- one check ----------------------------------------------------------------------------
  void check() {
    const Stamp now = Stamp::fromNanoseconds(now_ns_);
    log_ << "check at " << now_ns_ << "\n";
    const cw::CycleResult r = world_->check(now);
    // A check whose time is before the last one's (the clock went back): a pose that came after
    // it ages from it (node.md).
    if (last_check_ns_ && now_ns_ < *last_check_ns_) {
      for (RefBody& b : bodies_)
        if (!b.stamp.isStatic() && now < b.fresh_from) b.fresh_from = now;
    }
    last_check_ns_ = now_ns_;
    span_from_.reset();
    oldest_checked_.reset();
    for (const RefBody& b : bodies_) {
      if (fresh(b, now) && !b.stamp.isStatic() &&
          (!oldest_checked_ || b.stamp.nanoseconds() < *oldest_checked_)) {
        oldest_checked_ = b.stamp.nanoseconds();
      }
    }
    revived_.clear();
    for (RefBody& b : bodies_) {
      if (!fresh(b, now)) {
        b.frames.clear();  // its next pose starts again
        continue;
      }
      // Fresh again without a new frame (the clock went back): its pose is where it starts.
      if (frames_ && b.frames.empty()) {
        b.frames.emplace_back(b.stamp, b.pose);
        revived_.insert(static_cast<int>(&b - bodies_.data()));
      }
      if (!b.fresh_prev) b.known_from = firstFreshFrame(b, now);
    }
    ++cycle_;
    ++out_.checks;
    out_.events += static_cast<int>(r.events.size());
    std::ostringstream got;
    for (const cw::Event& e : r.events) {
      got << "  event " << name(e.type) << " " << e.pair.body_a << "-" << e.pair.body_b << " d "
          << e.pair.distance << " at " << e.stamp.nanoseconds() << "\n";
      if (e.type == EventType::CollisionBegin) ++out_.collisions;
    }
    for (const cw::PairResult& p : r.pairs)
      got << "  pair " << p.body_a << "-" << p.body_b << " " << name(p.status) << " d "
          << p.distance << "\n";
    got << "  min_distance " << r.min_distance << "; " << r.num_broad_phase_pairs
        << " broad-phase pairs, " << r.num_pairs_caught_up << " caught up, " << r.num_catch_up_skips
        << " passed over\n";
    log_ << got.str();
    std::stable_sort(removed_.begin(), removed_.end(),
                     [](const auto& x, const auto& y) { return x.first < y.first; });
    structure(r, now);
    if (out_.failure.empty() && (exact_ || frames_)) reference(r, now);
    removed_.clear();
    for (RefBody& b : bodies_) {
      b.fresh_prev = fresh(b, now);
      b.checked = b.stamp;
      b.checked_moving = moving(b);
    }
  }

  /// The invariants of every mode.
  void structure(const cw::CycleResult& r, Stamp now) {
    // Pairs: sorted, unique, ordered ids, each of existing bodies that may collide.
    std::map<Key, const cw::PairResult*> listed;
    for (std::size_t k = 0; k < r.pairs.size(); ++k) {
      const cw::PairResult& p = r.pairs[k];
      if (!(p.body_a < p.body_b)) return fail("a listed pair's ids are not in order");
      if (k > 0 && !(std::tie(r.pairs[k - 1].body_a, r.pairs[k - 1].body_b) <
                     std::tie(p.body_a, p.body_b))) {
        return fail("the listed pairs are not sorted, or one is listed twice");
      }
      if (p.status == PairStatus::Clear) return fail("a CLEAR pair is listed");
      if (!allowed(index(p.body_a), index(p.body_b))) {
        return fail("listed: a pair that may not collide, or of a removed body: " + p.body_a + "-" +
                    p.body_b);
      }
      if (p.status != PairStatus::Unknown) {
        if (!std::isfinite(p.distance)) return fail("a listed verdict without a distance");
        if (next(p.status, p.distance) != p.status) {
          return fail("listed " + std::string(name(p.status)) + " at " +
                      std::to_string(p.distance) + " m, which that status does not hold at");
        }
        if (r.min_distance > p.distance) return fail("min_distance above a listed pair's distance");
      }
      listed[{p.body_a, p.body_b}] = &p;
    }
    bool collision = false;
    for (const cw::PairResult& p : r.pairs)
      collision |= p.status == PairStatus::Collision;
    if (collision != r.in_collision) return fail("in_collision is not whether a pair collides");
    if (std::isnan(r.min_distance)) return fail("min_distance is NaN");

    // Stale bodies, and their pairs UNKNOWN.
    std::vector<std::string> stale;
    for (int i = 0; i < static_cast<int>(bodies_.size()); ++i) {
      if (bodies_[i].exists && !fresh(bodies_[i], now)) stale.push_back(id(i));
    }
    if (stale != r.stale_bodies)
      return fail("stale_bodies are not the bodies without a fresh pose");
    for (int i = 0; i < static_cast<int>(bodies_.size()); ++i) {
      for (int j = i + 1; j < static_cast<int>(bodies_.size()); ++j) {
        if (!allowed(i, j) || (fresh(bodies_[i], now) && fresh(bodies_[j], now))) continue;
        const auto it = listed.find(key(i, j));
        if (it == listed.end() || it->second->status != PairStatus::Unknown) {
          return fail("the pair " + id(i) + "-" + id(j) + " of a stale body is not listed UNKNOWN");
        }
      }
    }

    // Events: removal ENDs first, then by pair; per pair END before BEGIN, replayed on the
    // statuses of the last check.
    std::map<Key, std::vector<const cw::Event*>> by_pair;
    std::size_t k = 0;
    for (; k < removed_.size() && k < r.events.size(); ++k) {
      const cw::Event& e = r.events[k];
      const auto& [pk, status] = removed_[k];
      if (Key{e.pair.body_a, e.pair.body_b} != pk || e.type != endOf(status) || e.stamp != now) {
        return fail("removal: expected " + std::string(name(endOf(status))) + " of " + pk.first +
                    "-" + pk.second + " at the check's time first");
      }
    }
    if (k < removed_.size()) return fail("a removed body's pair got no END");
    Key last{"", ""};
    for (; k < r.events.size(); ++k) {
      const cw::Event& e = r.events[k];
      const Key pk{e.pair.body_a, e.pair.body_b};
      if (!(pk.first < pk.second)) return fail("an event's ids are not in order");
      if (pk < last) return fail("events are not sorted by pair");
      last = pk;
      by_pair[pk].push_back(&e);
    }
    std::set<Key> all;
    for (const auto& kv : pairs_)
      all.insert(kv.first);
    for (const auto& kv : by_pair)
      all.insert(kv.first);
    for (const auto& kv : listed)
      all.insert(kv.first);
    before_ = pairs_;
    for (const Key& pk : all) {
      RefPair& rp = pairs_[pk];
      PairStatus status = rp.status;
      const auto ev = by_pair.find(pk);
      const std::vector<const cw::Event*> none;
      const auto& events = ev == by_pair.end() ? none : ev->second;
      const bool may = allowed(index(pk.first), index(pk.second));
      // Replayed as transitions: END(X) and BEGIN(Y) of one stamp are X -> Y; catch-up
      // (align_poses) may give several of a pair, in stamp order.
      for (std::size_t x = 0; x < events.size(); ++x) {
        const cw::Event& e = *events[x];
        const std::string what = std::string(name(e.type)) + " of " + pk.first + "-" + pk.second +
                                 " (the pair " + name(status) + ")";
        if (isBegin(e.type) ? status != PairStatus::Clear : status != statusOf(e.type)) {
          return fail("unmatched " + what);
        }
        const PairStatus from = status;
        PairStatus to = isBegin(e.type) ? statusOf(e.type) : PairStatus::Clear;
        if (!isBegin(e.type) && x + 1 < events.size() && isBegin(events[x + 1]->type) &&
            events[x + 1]->stamp == e.stamp) {
          to = statusOf(events[++x]->type);
        }
        status = to;
        if (to == PairStatus::Unknown) continue;  // at the check's time, no verdict
        // A verdict: its distance gives it from the status before (not for an END of a pair no
        // longer allowed, which has none), and its stamp does not go back (while the pair is
        // remembered: its next event after the world may have forgotten it starts again).
        if (may && !statusesNear(from, e.pair.distance).count(to)) {
          return fail("the transition " + std::string(name(from)) + " -> " + name(to) + " of " +
                      pk.first + "-" + pk.second + " at " + std::to_string(e.pair.distance) + " m");
        }
        if (!rp.forgettable && e.stamp < rp.last_event) {
          return fail("a verdict event of " + pk.first + "-" + pk.second +
                      " went back in stamp, from " + std::to_string(rp.last_event.nanoseconds()) +
                      " to " + std::to_string(e.stamp.nanoseconds()));
        }
        rp.last_event = rp.forgettable ? e.stamp : std::max(rp.last_event, e.stamp);
        rp.forgettable = false;
      }
      const auto li = listed.find(pk);
      const PairStatus shown = li == listed.end() ? PairStatus::Clear : li->second->status;
      if (shown != status) {
        return fail("the events leave " + pk.first + "-" + pk.second + " " + name(status) +
                    " but it is listed " + name(shown));
      }
      if (rp.status != PairStatus::Clear || status != PairStatus::Clear) rp.last_busy = cycle_;
      rp.status = status;
      if (status == PairStatus::Clear && cycle_ - rp.last_busy > kForgetAfterCycles &&
          now - rp.last_event > s_.pose_timeout) {
        rp.forgettable = true;
      }
    }
  }

  /// One evaluation of a pair in the reference: its time and the bodies' distance then.
  struct Eval {
    Stamp stamp;  ///< the poses' time
    double d;
    Stamp at;  ///< its events' stamp (the live check's: never before the pair's last event's)
  };

  /// Steps a pair from `before` over `evals` and matches the world's events of it (`got`, in
  /// order): at each evaluation the world's transition must be one the thresholds give within
  /// kTol (so a tie goes either way), with the evaluation's distance, and with its stamp when
  /// `stamped` (else one evaluation takes every event). Returns the status it leaves.
  std::optional<PairStatus> match(int i, int j, PairStatus before, const std::vector<Eval>& evals,
                                  const std::vector<const cw::Event*>& got, bool stamped) {
    const std::string pair = key(i, j).first + "-" + key(i, j).second;
    std::size_t g = 0;
    PairStatus st = before;
    for (const Eval& ev : evals) {
      std::vector<const cw::Event*> here;
      while (g < got.size() && (!stamped || got[g]->stamp == ev.at))
        here.push_back(got[g++]);
      PairStatus to = st;
      if (!here.empty())
        to = isBegin(here.back()->type) ? statusOf(here.back()->type) : PairStatus::Clear;
      const std::vector<EventType> want = transition(st, to);
      bool same = want.size() == here.size();
      for (std::size_t k = 0; same && k < want.size(); ++k)
        same = here[k]->type == want[k] && std::abs(here[k]->pair.distance - ev.d) <= kTol;
      if (!same || !statusesNear(st, ev.d).count(to)) {
        fail(pair + " at " + std::to_string(ev.at.nanoseconds()) + ": " + name(st) + " -> " +
             name(to) + " (" + std::to_string(here.size()) + " events) where the bodies are " +
             std::to_string(ev.d) + " m apart: the reference gives " + name(next(st, ev.d)));
        return std::nullopt;
      }
      for (const cw::Event* e : here) {
        if (std::isfinite(e->pair.distance)) {
          checkTtc(pair + "'s " + name(e->type), i, j, ev.stamp, e->pair.time_to_collision);
        }
      }
      if (!out_.failure.empty()) return std::nullopt;
      st = to;
    }
    if (g < got.size()) {
      fail(pair + ": an event at " + std::to_string(got[g]->stamp.nanoseconds()) +
           " where the reference has no evaluation");
      return std::nullopt;
    }
    return st;
  }

  /// Frames mode: body b's pose at `t`, along its frames (interpolated between two: position
  /// and angle linear, each turn below pi being the shortest arc; before the first, the first;
  /// after the last, the last).
  static RefPose poseAt(const RefBody& b, Stamp t) {
    if (b.frames.empty() || !(b.frames.front().first < t)) {
      return b.frames.empty() ? b.pose : b.frames.front().second;
    }
    for (std::size_t k = 1; k < b.frames.size(); ++k) {
      const auto& [t1, p1] = b.frames[k];
      if (t1 < t) continue;
      const auto& [t0, p0] = b.frames[k - 1];
      const double s = (t - t0) / (t1 - t0);
      return {p0.position + (p1.position - p0.position) * s, p0.angle + (p1.angle - p0.angle) * s};
    }
    return b.frames.back().second;
  }
  /// Where a body found fresh at `now` after a spell (or for the first time) is known from: its
  /// first frame since then within pose_timeout of `now` (its latest, else).
  Stamp firstFreshFrame(const RefBody& b, Stamp now) const {
    for (const auto& f : b.frames)
      if (now - f.first <= s_.pose_timeout) return f.first;
    return b.stamp;
  }
  /// A body posed once since it came or came back is still as far as is known.
  static bool moving(const RefBody& b) { return b.frames.size() >= 2; }
  /// The pair's time (align_poses): the older stamp, or the newer when the older body is still.
  static Stamp alignedStamp(Stamp sa, bool moving_a, Stamp sb, bool moving_b) {
    if (sa == sb) return sa;
    const bool older_moving = sa < sb ? moving_a : moving_b;
    return older_moving ? std::min(sa, sb) : std::max(sa, sb);
  }
  Eval evalAt(int i, int j, Stamp t) const {
    return {t, distanceAt(i, poseAt(bodies_[i], t), j, poseAt(bodies_[j], t)), t};
  }
  /// The pair's evaluations at a check: from `from` (at it too when `from_too`), every stamp of
  /// either body before `to`, then the live check at `to`.
  std::vector<Eval> evaluations(int i, int j, Stamp from, bool from_too, Stamp to) const {
    std::set<Stamp> stamps;
    if (from < to) {
      if (from_too) stamps.insert(from);
      for (const int x : {i, j}) {
        for (const auto& f : bodies_[x].frames)
          if (from < f.first && f.first < to) stamps.insert(f.first);
      }
    }
    std::vector<Eval> out;
    for (const Stamp t : stamps)
      out.push_back(evalAt(i, j, t));
    out.push_back(evalAt(i, j, to));
    return out;
  }

  /// Every status, event and min_distance against the reference: align_poses off (each body at
  /// its latest pose, one evaluation a check), or frames (every body posed at each frame's
  /// stamp: each pair stepped over every frame since its last evaluation, or from its bodies'
  /// first frames since they came or came back, as catch-up promises).
  void reference(const cw::CycleResult& r, Stamp now) {
    std::map<Key, std::vector<const cw::Event*>> by_pair;
    for (std::size_t k = removed_.size(); k < r.events.size(); ++k)
      by_pair[{r.events[k].pair.body_a, r.events[k].pair.body_b}].push_back(&r.events[k]);
    double min_expected = kInf;
    const int n = static_cast<int>(bodies_.size());
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) {
        const Key pk = key(i, j);
        const auto was = before_.find(pk);
        const PairStatus before = was == before_.end() ? PairStatus::Clear : was->second.status;
        const Stamp last_event = was == before_.end() ? Stamp() : was->second.last_event;
        const PairStatus after = pairs_.count(pk) ? pairs_[pk].status : PairStatus::Clear;
        const auto ev = by_pair.find(pk);
        const std::vector<const cw::Event*> none;
        const auto& events = ev == by_pair.end() ? none : ev->second;
        const std::string pair = pk.first + "-" + pk.second;
        if (!bodies_[i].exists || !bodies_[j].exists) continue;
        if (!allowed(i, j) || !fresh(bodies_[i], now) || !fresh(bodies_[j], now)) {
          if (!allowed(i, j) && after != PairStatus::Clear) {
            return fail(pair + " may not collide but is " + name(after));
          }
          continue;  // stale: structure() holds it UNKNOWN
        }
        std::vector<Eval> evals;
        bool ambiguous = false;
        if (frames_) {
          const RefBody& A = bodies_[i];
          const RefBody& B = bodies_[j];
          const Stamp to = alignedStamp(A.stamp, moving(A), B.stamp, moving(B));
          const Stamp known = std::max(A.known_from, B.known_from);
          if (to < known) {  // no verdict yet: held UNKNOWN (structure() checked its events)
            // A new pair beyond the broad phase's reach stays CLEAR, without events (node.md).
            if (before == PairStatus::Clear && after == PairStatus::Clear && events.empty()) {
              continue;
            }
            if (after != PairStatus::Unknown) {
              return fail(pair + " has no verdict before " + std::to_string(known.nanoseconds()) +
                          " but is " + name(after));
            }
            continue;
          }
          // From the pair's time at the last check (both fresh then), its last verdict event
          // and its first poses since they came or came back; the world also goes from the
          // latest time it checked the pair at, which the reference knows only while the pair
          // was within the broad phase's reach: where that changes the evaluations, the pair
          // is taken as the world has it this once.
          const Stamp prev =
              A.fresh_prev && B.fresh_prev
                  ? alignedStamp(A.checked, A.checked_moving, B.checked, B.checked_moving)
                  : Stamp();
          const Stamp lo = std::max(last_event, prev);
          const Stamp hi = std::max(lo, was == before_.end() ? Stamp() : was->second.max_to);
          evals = evaluations(i, j, std::max(lo, known), lo < known, to);
          const std::vector<Eval> other = evaluations(i, j, std::max(hi, known), hi < known, to);
          // A pair the world may have forgotten (RefPair::forgettable), its last event's stamp
          // with it, goes from the pair's last time alone.
          const bool forgotten = was != before_.end() && was->second.forgettable;
          // A body fresh again without a new pose (the clock went back) may bring a stamp before
          // the other body's kept poses: the world keeps every pose of the last pose_timeout
          // only while its checks find stamps apart (WorldModel::keepsPoses()), else the last
          // two, and places a body before its first kept pose at that pose. The reference does
          // not model which poses are kept: such a pair, too, is taken as the world has it.
          ambiguous = other.size() != evals.size() || (forgotten && prev < last_event) ||
                      revived_.count(i) > 0 || revived_.count(j) > 0;
          evals.back().at = std::max(to, last_event);
          pairs_[pk].max_to = std::max(pairs_[pk].max_to, to);
        } else {
          evals.push_back({pairStamp(bodies_[i], bodies_[j], now), distance(i, j), Stamp()});
        }
        const double d = evals.back().d;
        min_expected = std::min(min_expected, d);
        std::optional<PairStatus> left;
        if (ambiguous) {
          left = after;
        } else if (frames_ && before == PairStatus::Unknown && events.size() == 1 &&
                   events[0]->type == EventType::UnknownEnd && evals.size() > 1 &&
                   events[0]->stamp == evals.back().at &&
                   std::abs(events[0]->pair.distance - evals.back().d) <= kTol &&
                   std::all_of(evals.begin(), evals.end(), [&](const Eval& e) {
                     return statusesNear(PairStatus::Clear, e.d).count(PairStatus::Clear) > 0;
                   })) {
          // node.md: a pair beyond the broad phase's reach all along is not caught up; its
          // UNKNOWN_END carries its time at the check.
          left = PairStatus::Clear;
          checkTtc(pair + "'s UNKNOWN_END", i, j, evals.back().stamp,
                   events[0]->pair.time_to_collision);
        } else {
          left = match(i, j, before, evals, events, frames_);
        }
        if (!left) return;
        if (*left != after) return fail(pair + ": the reference leaves it " + name(*left));
        if (after != PairStatus::Clear) {
          const auto it =
              std::find_if(r.pairs.begin(), r.pairs.end(), [&](const cw::PairResult& p) {
                return p.body_a == pk.first && p.body_b == pk.second;
              });
          if (std::abs(it->distance - d) > kTol) {
            return fail(pair + " listed at " + std::to_string(it->distance) + " m, the bodies " +
                        std::to_string(d) + " m apart");
          }
          if (it->status != PairStatus::Unknown) {
            checkTtc(pair + " listed", i, j, evals.back().stamp, it->time_to_collision);
          }
        }
        if (frames_) continue;
        // Its poses' time, or the pair's last event's when that is later.
        const Stamp stamp = evals.front().stamp;
        for (const cw::Event* e : events) {
          if (e->stamp < stamp || e->stamp > std::max(stamp, last_event)) {
            return fail(pair + ": an event is not stamped with its poses' time (" +
                        std::to_string(stamp.nanoseconds()) + ")");
          }
        }
      }
    }
    // min_distance: over every pair of fresh bodies that may collide; without
    // exact_min_distance, only a pair within the clear cutoff is sure to count.
    const double base = std::max(s_.warning_distance, s_.contact_distance);
    if (s_.exact_min_distance || min_expected <= base - kTol) {
      if (!(std::abs(r.min_distance - min_expected) <= kTol) &&
          !(std::isinf(min_expected) && std::isinf(r.min_distance))) {
        return fail("min_distance " + std::to_string(r.min_distance) + ", the bodies' " +
                    std::to_string(min_expected));
      }
    } else if (r.min_distance < min_expected - kTol ||
               (std::isfinite(r.min_distance) &&
                r.min_distance > base + std::max(0.0, s_.hysteresis) + kTol)) {
      return fail("min_distance " + std::to_string(r.min_distance) + " without the far search");
    }
  }

  // --- queries --------------------------------------------------------------------------------
  static constexpr double kProbeRadius = 0.1;  ///< checkHypothetical()'s probe sphere
  /// The probe as the reference knows it: a sphere at its body's origin.
  static const RefBody& probeBody() {
    static const RefBody probe = [] {
      RefBody b;
      b.parts.push_back({Vec3::Zero(), Vec3::Zero(), kProbeRadius});
      b.parts.back().shape = coreShape(b.parts.back());
      return b;
    }();
    return probe;
  }

  void query(int i) {
    const std::uint8_t k = in_.byte();
    const Stamp now = Stamp::fromNanoseconds(now_ns_);
    if (k % 2 == 0) {
      const int j = static_cast<int>(in_.byte() % bodies_.size());
      log_ << "distance " << id(i) << " " << id(j) << "\n";
      std::string why;
      const auto d = world_->distance(id(i), id(j), now, &why);
      if (d && why.empty() == false) return fail("distance answered with a reason");
      if (!d && why.empty()) return fail("distance refused without a reason");
      const bool answerable = i != j && bodies_[i].exists && bodies_[j].exists &&
                              fresh(bodies_[i], now) && fresh(bodies_[j], now);
      if (!answerable && d) return fail("distance answered for a stale, unknown or same body");
      if (!exact_ && !frames_) return;
      double want = answerable ? distance(i, j) : kInf;
      Stamp at;  // the pair's time, in frames
      if (frames_ && answerable) {
        // At the pair's time; none before a body's first pose since it came or came back (as
        // the next check will know it).
        const RefBody& A = bodies_[i];
        const RefBody& B = bodies_[j];
        const auto knownAt = [&](const RefBody& b) {
          return b.fresh_prev ? b.known_from : firstFreshFrame(b, now);
        };
        const Stamp to = alignedStamp(A.stamp, moving(A), B.stamp, moving(B));
        if (to < std::max(knownAt(A), knownAt(B))) {
          if (d) return fail("distance answered before a body's first pose since it came");
          return;
        }
        want = evalAt(i, j, to).d;
        at = to;
      }
      if (answerable != d.has_value()) return fail("distance refused: " + why);
      if (!d) return;
      if (std::abs(d->distance - want) > kTol || d->body_a != id(i)) {
        return fail("distance " + std::to_string(d->distance) + ", the bodies " +
                    std::to_string(want));
      }
      const auto it = pairs_.find(key(i, j));
      const PairStatus tracked = it == pairs_.end() ? PairStatus::Clear : it->second.status;
      if (!statusesNear(tracked, want).count(d->status)) return fail("distance's status");
      checkTtc("distance " + id(i) + " " + id(j), i, j, at, d->time_to_collision);
      return;
    }
    // A probe sphere at a position: every fresh body within the margin (or colliding), each
    // stale one UNKNOWN.
    const Vec3 p = position();
    const double margin = (k >> 1) % 4 * 0.1;
    cw::BodySpec probe;
    probe.id = "probe";
    probe.frame = "map";
    probe.parts.push_back({ConvexShape::sphere(kProbeRadius), cw::Transform3::Identity()});
    cw::Transform3 pose = cw::Transform3::Identity();
    pose.t = p;
    log_ << "checkHypothetical at (" << p.transpose() << ") margin " << margin << "\n";
    std::string why;
    const auto got = world_->checkHypothetical(probe, pose, margin, now, false, nullptr, &why);
    if (!got) return fail("checkHypothetical refused: " + why);
    std::map<std::string, std::pair<PairStatus, double>> want;
    for (int b = 0; b < static_cast<int>(bodies_.size()); ++b) {
      if (!bodies_[b].exists) continue;
      if (!fresh(bodies_[b], now)) {
        want[id(b)] = {PairStatus::Unknown, kInf};
        continue;
      }
      const double d = bodyDistance(probeBody(), RefPose{p, 0.0}, bodies_[b], bodies_[b].pose);
      if (d <= margin + kTol || d <= s_.contact_distance + kTol) {
        want[id(b)] = {next(PairStatus::Clear, d), d};
      }
    }
    double prev = -kInf;
    for (const cw::PairResult& x : *got) {
      const std::string other = x.body_a == "probe" ? x.body_b : x.body_a;
      const auto w = want.find(other);
      if (w == want.end()) {
        return fail("checkHypothetical lists " + other + " at " + std::to_string(x.distance));
      }
      if (x.status != PairStatus::Unknown) {
        if (!exact_ && !frames_) {
          want.erase(w);
          continue;
        }
        if (std::abs(x.distance - w->second.second) > kTol) {
          return fail("checkHypothetical distance to " + other + " " + std::to_string(x.distance) +
                      ", the bodies " + std::to_string(w->second.second));
        }
        if (!statusesNear(PairStatus::Clear, x.distance).count(x.status)) {
          return fail("checkHypothetical status");
        }
        if (x.distance < prev) return fail("checkHypothetical not sorted by distance");
        prev = x.distance;
        // The probe has no twist: the time from the other body's alone.
        const RefBody& B = bodies_[index(other)];
        checkTtc("checkHypothetical " + other, probeBody(), RefPose{p, 0.0}, B, B.pose,
                 x.time_to_collision);
      } else if (w->second.first != PairStatus::Unknown) {
        return fail("checkHypothetical: " + other + " UNKNOWN");
      }
      want.erase(w);
    }
    for (const auto& [other, v] : want) {
      // A fresh body within kTol of the margin may be left out.
      if (v.first == PairStatus::Unknown || v.second < margin - kTol) {
        return fail("checkHypothetical leaves out " + other + " (" + name(v.first) + " at " +
                    std::to_string(v.second) + ")");
      }
    }
  }

  void fail(const std::string& why) {
    if (out_.failure.empty()) out_.failure = why + "\noperations:\n" + log_.str();
  }

  Reader in_;
  Outcome out_;
  cw::Settings s_;
  bool exact_ = false;
  bool frames_ = false;        ///< align_poses, every body posed at each frame's stamp
  bool rates_ = false;         ///< frames: only some bodies posed at a frame
  bool turns_ = false;         ///< bodies turn (each about its own axis), not only move
  bool clock_back_ = false;    ///< frames: the clock may go back, a check at once
  bool capsules_ = false;      ///< bodies of capsules (segments swept by a radius), not spheres
  bool boxes_ = false;         ///< some parts boxes (rounded or not), the others as they would be
  bool hulls_ = false;         ///< boxes: some of them convex hulls instead (rounded or not)
  double ttc_work_ = 0.0;      ///< the time-to-collision searches' work so far (kCaseBudget)
  mutable int certified_ = 0;  ///< Outcome::certified (the reference's distances are const)
  bool twists_ = false;        ///< align_poses off: poses with twists (times to collision)
  std::int64_t frame_ns_ = 0;
  std::optional<std::int64_t> span_from_;       ///< the first frame's stamp since the last check
  std::optional<std::int64_t> oldest_checked_;  ///< the oldest stamp of a fresh body then
  std::optional<cw::WorldModel> world_;
  std::vector<RefBody> bodies_;
  std::map<Key, RefPair> pairs_;
  std::map<Key, RefPair> before_;  ///< pairs_ before the check's events
  std::set<Key> disabled_;
  std::set<int> revived_;  ///< frames: bodies fresh again at this check without a new pose
  std::vector<std::pair<Key, PairStatus>> removed_;  ///< END events due at the next check
  std::int64_t now_ns_ = 1000000000LL;
  std::optional<std::int64_t> last_check_ns_;
  std::uint64_t cycle_ = 0;
  std::ostringstream log_;
};

inline Outcome runCase(const std::uint8_t* data, std::size_t size) {
  return Run(data, size).go();
}

}  // namespace cm_fuzz_world
