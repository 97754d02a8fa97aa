/// \file
/// The world model: bodies in dense slots, hash-grid broad phase, compound narrow phase
/// with per-part-pair warm starts, per-pair status with hysteresis and events.
///
/// Per cycle (check()):
///  1. freshness of every body at `now`; bodies that moved (pose or geometry), became fresh or
///     went stale since the last cycle update the hash grid (HashGrid, broad_phase.h);
///  2. broad phase: pairs of two unmoved bodies are kept from the last cycle, each moved body is
///     queried in the grid (boxes are in the fixed frame, exact, updated when a pose or the
///     geometry changes), refined by the exact box distance;
///  3. narrow phase for each surviving pair, unless neither body moved since the pair's last
///     result (then that result is reused); per part pair a cheap lower bound first; before it,
///     catch-up at the pair's stamps since its last check (Impl::catchUp(), align_poses);
///     3b. min_distance beyond the broad phase's reach (exact_min_distance);
///  4. every pair with a stale body is UNKNOWN;
///  5. tracked pairs the broad phase no longer reports are CLEAR.
#include "collision_monitor/world/world_model.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iterator>
#include <sstream>
#include <tuple>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "collision_monitor/world/broad_phase.h"
#include "collision_monitor/world/pair_logic.h"

namespace collision_monitor {
namespace world {

const char* toString(BodyOrigin origin) {
  switch (origin) {
    case BodyOrigin::Urdf:
      return "urdf";
    case BodyOrigin::Parameter:
      return "parameter";
    case BodyOrigin::Topic:
      return "topic";
  }
  return "unknown";
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
/// Tracked pairs not reported by the broad phase for this many cycles are forgotten (their
/// warm-start caches go with them), once their last event is more than pose_timeout old: the
/// events of a fresh pose come no earlier, so the pair's next events stay in stamp order without
/// it. A pair hovering at the broad-phase margin keeps its cache.
constexpr std::uint64_t kForgetAfterCycles = 64;
/// Why a query fails after abandonChecks(): its part queries were cut short.
constexpr const char* kAbandoned = "checks abandoned: the monitor is shutting down";

std::uint64_t pairKey(int lo, int hi) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(lo)) << 32) |
         static_cast<std::uint32_t>(hi);
}
int keyLo(std::uint64_t key) {
  return static_cast<int>(key >> 32);
}
int keyHi(std::uint64_t key) {
  return static_cast<int>(key & 0xffffffffu);
}
std::uint64_t orderedKey(int i, int j) {
  return i < j ? pairKey(i, j) : pairKey(j, i);
}

/// A lower bound on the distance between two balls (centres, radii): the centres' distance less
/// the radii, or -inf (no bound) when norm(), which squares, overflows (centres 1e308 m apart: a
/// pair skipped as beyond reach was reported CLEAR where its query fails).
double ballGap(const Vec3& ca, double ra, const Vec3& cb, double rb) {
  const double gap = (cb - ca).norm() - ra - rb;
  return gap < kInf ? gap : -kInf;
}

bool validTransform(const Transform3& T) {
  return core::isValidRotation<3>(T.R) && core::allFinite(T.t);
}

}  // namespace

core::Aabb shapeAabb(const core::ConvexShape& shape, const Transform3& pose) {
  const core::Mat3& R = pose.R;
  const double r = shape.radius();
  Vec3 lo;
  Vec3 hi;
  const auto& c = shape.core();
  if (const auto* p = std::get_if<core::PointShape<3>>(&c)) {
    lo = hi = R * p->p;
  } else if (const auto* sg = std::get_if<core::SegmentShape<3>>(&c)) {
    const Vec3 a = R * sg->a;
    const Vec3 b = R * sg->b;
    lo = a.cwiseMin(b);
    hi = a.cwiseMax(b);
  } else if (const auto* bx = std::get_if<core::BoxShape<3>>(&c)) {
    hi = R.cwiseAbs() * bx->half;
    lo = -hi;
  } else if (const auto* el = std::get_if<core::EllipsoidShape<3>>(&c)) {
    hi = (R * el->semi.asDiagonal()).rowwise().norm();
    lo = -hi;
  } else if (const auto* cy = std::get_if<core::CylinderShape>(&c)) {
    for (int i = 0; i < 3; ++i) {
      const double z = R(i, 2);
      hi[i] = std::abs(z) * cy->half_height + cy->radius * std::sqrt(std::max(0.0, 1.0 - z * z));
    }
    lo = -hi;
  } else if (const auto* poly = std::get_if<std::shared_ptr<const core::Polytope<3>>>(&c);
             poly && *poly && (*poly)->size() > 0 && (*poly)->size() <= 64) {
    const std::vector<Vec3>& v = (*poly)->vertices();
    lo = hi = R * v[0];
    for (std::size_t k = 1; k < v.size(); ++k) {
      const Vec3 w = R * v[k];
      lo = lo.cwiseMin(w);
      hi = hi.cwiseMax(w);
    }
  } else {
    return shape.aabb(pose);
  }
  const Vec3 t = pose.t + R * shape.offset();  // the core's origin (ConvexShape::offset())
  return core::Aabb{lo.array() + (t.array() - r), hi.array() + (t.array() + r)};
}

namespace {

/// Narrow-phase output for a compound pair, in the fixed frame.
struct Narrow {
  double distance = kInf;  ///< signed, m; +inf when every part pair was beyond the cutoff
  Vec3 point_a = Vec3::Zero();
  Vec3 point_b = Vec3::Zero();
  Vec3 normal = Vec3::UnitX();
  bool exact = false;  ///< distance is the true minimum (not only "beyond the cutoff")
  /// At most the true minimum: `distance` when exact, else the nearest any part pair may be
  /// (+inf when a box or ball gap overflowed, or the query failed: no bound).
  double lower_bound = kInf;
  int gjk_runs = 0;
};

/// A body's parts placed in the fixed frame at one pose of the body.
struct Placement {
  Transform3 pose = Transform3::Identity();  ///< body frame -> fixed frame
  core::Aabb box;                            ///< union of part boxes, fixed frame
  std::vector<core::Aabb> part_boxes;        ///< fixed frame
  std::vector<Transform3> part_poses;        ///< part frame -> fixed frame
  std::vector<Vec3> part_centres;  ///< the cores' origins (ConvexShape::offset()), fixed frame
  std::vector<double> part_radii;  ///< bounding radius about the part's centre, m

  void place(const BodySpec& spec, const Transform3& at) {
    pose = at;
    const std::size_t n = spec.parts.size();
    part_boxes.resize(n);
    part_poses.resize(n);
    part_centres.resize(n);
    part_radii.resize(n);
    box = core::Aabb();
    for (std::size_t i = 0; i < n; ++i) {
      part_poses[i] = pose * spec.parts[i].pose;
      part_boxes[i] = shapeAabb(spec.parts[i].shape, part_poses[i]);
      part_centres[i] = part_poses[i] * spec.parts[i].shape.offset();
      part_radii[i] = spec.parts[i].shape.localRadius();
      box.extend(part_boxes[i]);
    }
  }
};

/// A timed pose a body had.
struct StampedPose {
  Stamp stamp;
  Transform3 pose;
  core::Aabb box;  ///< the body's at `pose` (Placement::box)
};

/// A body's recent timed poses, oldest first: a vector whose dropped front is erased in one go
/// once it is half of it (a deque took 21 ns more per setPose; a vector of two live poses in 32
/// slots 140 us more a cycle of 1,000 bodies).
class PoseHistory {
 public:
  bool empty() const { return first_ == poses_.size(); }
  std::size_t size() const { return poses_.size() - first_; }
  const StampedPose* begin() const { return poses_.data() + first_; }
  const StampedPose* end() const { return poses_.data() + poses_.size(); }
  const StampedPose& front() const { return poses_[first_]; }
  const StampedPose& operator[](std::size_t k) const { return poses_[first_ + k]; }
  StampedPose& operator[](std::size_t k) { return poses_[first_ + k]; }
  StampedPose& back() { return poses_.back(); }
  /// The last pose at or before `t`, else the first.
  const StampedPose* at(Stamp t) const {
    const StampedPose* next = std::upper_bound(
        begin(), end(), t, [](Stamp x, const StampedPose& p) { return x < p.stamp; });
    return next == begin() ? next : next - 1;
  }
  void push(Stamp stamp, const Transform3& pose, const core::Aabb& box) {
    poses_.push_back(StampedPose{stamp, pose, box});
  }
  void dropFront() {
    ++first_;
    if (first_ >= poses_.size() - first_) {  // as many dropped as kept: O(1) a pose
      poses_.erase(poses_.begin(), poses_.begin() + static_cast<std::ptrdiff_t>(first_));
      first_ = 0;
    }
  }
  void clear() {
    poses_.clear();
    first_ = 0;
  }

 private:
  std::vector<StampedPose> poses_;
  std::size_t first_ = 0;
};

/// The pose between two of a body's poses at share `s` (0: `a`, 1: `b`): translation linear,
/// rotation along the shortest arc (slerp).
Transform3 interpolate(const Transform3& a, const Transform3& b, double s) {
  Transform3 out;
  out.t = a.t + s * (b.t - a.t);
  if (a.R == b.R) {  // a translation: no arc to follow
    out.R = a.R;
    return out;
  }
  const Eigen::Quaterniond qa(a.R), qb(b.R);
  out.R = qa.slerp(s, qb).normalized().toRotationMatrix();
  return out;
}

/// How far a point at distance `r` from a body's origin can leave the box of its positions at
/// two poses while the body is interpolated between them (rotation by `angle` rad along the
/// shortest arc, translation linear): the arc's sagitta r (1 - cos(angle / 2)), bounded by r.
double arcBulge(double r, double angle) {
  return r * (1.0 - std::cos(std::min(angle, M_PI) / 2.0));
}

/// The angle (rad, in [0, pi]) of the rotation from `a` to `b`.
double rotationAngle(const core::Mat3& a, const core::Mat3& b) {
  const double c = ((a.transpose() * b).trace() - 1.0) / 2.0;
  return std::acos(std::clamp(c, -1.0, 1.0));
}

/// At least as far as a point within `r` of a body's origin moves from pose `a` to pose `b`:
/// |b.t - a.t| + |(b.R - a.R) x| <= |b.t - a.t| + |b.R - a.R|_F r. For a turn by `angle` the
/// Frobenius norm is 2 sqrt(2) sin(angle / 2), sqrt(2) times the chord a metre out; from the
/// entries, it does not round a small turn to 0 (acos of the trace does below 1e-8 rad), and
/// holds for a matrix that is not quite a rotation too.
double pointShift(const Transform3& a, const Transform3& b, double r) {
  return (b.t - a.t).norm() + (b.R - a.R).norm() * r;
}

/// Settings::estimate_twists: the twist that takes pose `a` to pose `b` in `dt` seconds (linear:
/// the origin's displacement over dt; angular: the rotation b.R a.R^T over dt, in the fixed frame,
/// as MovedParts applies it). None when dt is not in (0, timeout], or the two are the same.
std::optional<Twist> twistBetween(const Transform3& a, const Transform3& b, double dt,
                                  double timeout) {
  if (!(dt > 0.0 && dt <= timeout)) return std::nullopt;
  Twist out;
  out.linear = (b.t - a.t) / dt;
  // Not turned: none (b.R a.R^T rounds to a turn of ~1e-17 rad, which would count as turning).
  if (!(a.R == b.R)) {
    const Eigen::AngleAxisd turn(Eigen::Quaterniond(b.R * a.R.transpose()).normalized());
    out.angular = turn.axis() * (turn.angle() / dt);
  }
  if (!core::allFinite(out.linear) || !core::allFinite(out.angular)) return std::nullopt;
  if (out.linear.isZero(0.0) && out.angular.isZero(0.0)) return std::nullopt;
  return out;
}

/// A body in its slot, with its placement in the fixed frame.
struct BodyState {
  // Hot fields first (read for every slot each cycle), the rest after.
  bool used = false;
  bool has_pose = false;
  bool unresolved = false;
  bool fresh = false;       ///< fresh at the last check()
  bool fresh_prev = false;  ///< fresh at the check() before (and existed)
  bool was_active = false;  ///< in the broad phase of the last check()
  bool has_twist = false;
  bool swept = false;  ///< its broad-phase box spans poses before the held one (check())
  /// Since the last check(), where it was before stopped being known: its static pose moved, its
  /// pose turned static or timed, it was given a new pose source, or poses were forgotten.
  bool renewed = false;
  /// moving() and `stamp` at the check() before the last one and at the last one that found it
  /// fresh ([0] is what Impl::lastPairStamp() reads during a check: the previous one's).
  bool checked_moving[2] = {false, false};
  /// Timed poses of new stamps since the last check() (at most 255): a second one tells of a
  /// source that outran the checks (Impl::outran), as sources of different rates whose stamps
  /// meet at every check do.
  std::uint8_t new_stamps = 0;
  int group = 0;  ///< dense id of spec.group, 0 = none
  Stamp stamp;    ///< isStatic(): a static pose
  /// The time freshness is judged from: `stamp`, or when it came, if earlier (setPose).
  Stamp fresh_from;
  /// Bumped whenever the pose or the geometry changes: a pair result computed at the same
  /// versions of both bodies is still exact.
  std::uint64_t version = 0;
  std::uint64_t swept_version = 0;  ///< version in the broad phase of the last check()
  /// The stamp from which the held pose has been held (the first of its poses in `history` that
  /// is the held pose); zero when that is all of `history` (or the pose is static): the body is
  /// still, as far as its history tells.
  Stamp held_since;
  Stamp swept_from;        ///< while `swept`: the stamp of the first pose it spans
  Stamp checked_stamp[2];  ///< see checked_moving
  /// Catch-up (WorldModel::Impl::catchUp()) never goes back before this: set by the first check
  /// that finds it fresh after a spell without a fresh pose, or `renewed`, to the stamp of its
  /// first fresh pose since (firstFreshPose()); `now` for a static pose. Where it was before is
  /// not known: its history's first pose stands in for it there (poseAt()).
  Stamp known_from;
  Placement at;  ///< at the held (latest) pose
  Twist twist;
  BodySpec spec;
  std::string unresolved_why;  ///< markUnresolved()'s reason while `unresolved`
  /// The timed poses of the last pose_timeout, oldest first, the held one last (and one older
  /// than pose_timeout so that its start is covered; at most kMaxHistory): where the body was at
  /// an older stamp (poseAt()). A pair's older stamp is fresh, so within pose_timeout of now.
  /// Cleared while the body is stale (check()): after a spell without a pose it starts again.
  PoseHistory history;

  /// Places the body at its held pose, and its kept poses' boxes, for a new `spec`.
  void place() {
    at.place(spec, at.pose);
    Placement scratch;
    for (std::size_t k = 0; k < history.size(); ++k) {
      scratch.place(spec, history[k].pose);
      history[k].box = scratch.box;
    }
  }
  bool isFresh(Stamp now, double timeout) const {
    if (!has_pose || unresolved) return false;
    if (stamp.isStatic()) return true;
    return now - fresh_from <= timeout;
  }
  /// Its pose changed within its history.
  bool moving() const { return !held_since.isStatic(); }
  /// Whether the history places the body elsewhere at `t` than at its held pose: it moved after
  /// `t`.
  bool elsewhereAt(Stamp t) const { return t < held_since; }
  /// The body's pose at `t` from its history: between two of its poses, interpolated; before the
  /// first one kept, that one (the nearest known); the held pose unless elsewhereAt(t).
  Transform3 poseAt(Stamp t) const {
    if (!elsewhereAt(t)) return at.pose;
    const StampedPose& before = *history.at(t);
    if (t <= before.stamp) return before.pose;  // at one of its poses, or before the first
    // t < held_since <= stamp: a pose follows the one before `t`.
    const StampedPose& after = *(&before + 1);
    return interpolate(before.pose, after.pose, (t - before.stamp) / (after.stamp - before.stamp));
  }
  /// Keeps the held pose (`at.pose`, timed `stamp`) in the history, whose poses older than
  /// `keep` s before it go but the newest of them, and all but the last `most`.
  void remember(bool moved, double keep, std::size_t most) {
    if (stamp.isStatic()) {
      forget();
      return;
    }
    if (!history.empty() && history.back().stamp == stamp) {
      history.back().pose = at.pose;  // the same time again: this pose replaces it
      history.back().box = at.box;
      if (moved) held_since = history.size() > 1 ? stamp : Stamp();
    } else {
      history.push(stamp, at.pose, at.box);
      if (moved && history.size() > 1) held_since = stamp;
    }
    while (history.size() > most || (history.size() > 1 && stamp - history[1].stamp > keep))
      history.dropFront();
    if (held_since <= history.front().stamp) held_since = Stamp();
  }
  void forget() {
    history.clear();
    held_since = Stamp();
  }
  /// The stamp of its first kept pose not older than `timeout` at `now` (the held one's if none
  /// is): what the body did since a check that found it stale (which forgot its poses), or since
  /// its first pose.
  Stamp firstFreshPose(Stamp now, double timeout) const {
    for (const StampedPose& p : history)
      if (now - p.stamp <= timeout) return p.stamp;
    return stamp;
  }
  /// The farthest a point of the body is from its origin, m.
  double reachFromOrigin() const {
    double r = 0.0;
    for (std::size_t i = 0; i < at.part_centres.size(); ++i)
      r = std::max(r, (at.part_centres[i] - at.pose.t).norm() + at.part_radii[i]);
    return r;
  }
  /// The stamp of the pose sweptBox() starts from for `t`: the last one at or before it (else
  /// the first). The box changes only when this does (or the body moves).
  Stamp sweepStart(Stamp t) const { return history.at(t)->stamp; }
  /// The box of every place poseAt() gives the body from stamp `from` (sweepStart()) on: the
  /// boxes of its poses from there, each two neighbours' with the bulge of the turn between.
  core::Aabb sweptBox(Stamp from) const {
    core::Aabb out = at.box;
    const double r = reachFromOrigin();
    for (const StampedPose* next = history.at(from) + 1; next != history.end(); ++next) {
      const StampedPose& prev = *(next - 1);  // the last one is the held pose
      core::Aabb both = prev.box;
      both.extend(next->box);
      out.extend(both.inflated(arcBulge(r, rotationAngle(prev.pose.R, next->pose.R))));
    }
    return out;
  }

  /// 0.5 s (pose_timeout's default) of poses at 1 kHz, 78 kB.
  static constexpr std::size_t kMaxHistory = 512;
};

/// A body's geometry at one placement: its held one, or one at an older stamp (placedAt()).
struct Placed {
  const BodyState& body;
  const Placement& at;
};

/// A body's part poses and centres (fixed frame) after `t` seconds under a constant twist (angular
/// about the body's origin: a screw motion), for timeToCollisionOf().
struct MovedParts {
  std::vector<Transform3> poses;
  std::vector<Vec3> centres;

  void place(const Placed& S, const Twist& motion, double t) {
    const double angle = motion.angular.norm() * t;
    Transform3 pose = S.at.pose;
    pose.t += t * motion.linear;
    if (angle > 0.0) pose.R = Eigen::AngleAxisd(angle, motion.angular.normalized()) * S.at.pose.R;
    const BodySpec& spec = S.body.spec;
    const std::size_t n = spec.parts.size();
    poses.resize(n);
    centres.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      poses[i] = pose * spec.parts[i].pose;
      centres[i] = poses[i] * spec.parts[i].shape.offset();
    }
  }
};

/// id -> slot for the hot path (setPose by id string): open addressing with linear probing on
/// the id's hash, one flat array (std::unordered_map costs a bucket and a node per lookup).
/// Mirrors Impl::slot_of; tombstones on erase, rebuilt when half full.
class SlotIndex {
 public:
  static std::uint64_t hashOf(const std::string& id) { return std::hash<std::string>()(id); }
  template <class IdOf>
  int find(const std::string& id, const IdOf& id_of) const {
    if (cells_.empty()) return -1;
    const std::uint64_t h = hashOf(id);
    for (std::size_t i = h & mask_;; i = (i + 1) & mask_) {
      const Cell& c = cells_[i];
      if (c.slot == kEmpty) return -1;
      if (c.slot >= 0 && c.hash == h && id_of(c.slot) == id) return c.slot;
    }
  }
  void insert(const std::string& id, int slot) {
    if (2 * (live_ + tombs_ + 1) > cells_.size())
      rehash(std::max<std::size_t>(16, 4 * (live_ + 1)));
    place(hashOf(id), slot);
    ++live_;
  }
  void erase(const std::string& id, int slot) {
    if (cells_.empty()) return;
    const std::uint64_t h = hashOf(id);
    for (std::size_t i = h & mask_;; i = (i + 1) & mask_) {
      Cell& c = cells_[i];
      if (c.slot == kEmpty) return;
      if (c.slot == slot) {
        c.slot = kTomb;
        --live_;
        ++tombs_;
        return;
      }
    }
  }

 private:
  static constexpr int kEmpty = -1;
  static constexpr int kTomb = -2;
  struct Cell {
    std::uint64_t hash = 0;
    int slot = kEmpty;
  };
  void place(std::uint64_t h, int slot) {
    std::size_t i = h & mask_;
    while (cells_[i].slot >= 0)
      i = (i + 1) & mask_;
    if (cells_[i].slot == kTomb) --tombs_;
    cells_[i] = Cell{h, slot};
  }
  void rehash(std::size_t want) {
    std::size_t cap = 16;
    while (cap < want)
      cap *= 2;
    std::vector<Cell> old;
    old.swap(cells_);
    cells_.assign(cap, Cell());
    mask_ = cap - 1;
    tombs_ = 0;
    for (const Cell& c : old) {
      if (c.slot >= 0) place(c.hash, c.slot);
    }
  }
  std::vector<Cell> cells_;
  std::size_t mask_ = 0;
  std::size_t live_ = 0;
  std::size_t tombs_ = 0;
};

/// A pair's warm-start caches (224 bytes each), at most kMaxCaches: one per part pair (index
/// i * parts_b + j) for a pair of up to kMaxCaches part pairs, else one per part pair queried,
/// all dropped when kMaxCaches are held (the part pairs queried since keep theirs). A cache for
/// every part pair, made before the first query, took 208 MB for two bodies of 1,000 parts
/// (1,000,000 part pairs, of which the bounds let few through), allocated in 0.65 s.
class PartCaches {
 public:
  /// The cache of part pair `k` of `n` (parts_a * parts_b), cold when new. Another `n` than the
  /// last call's (a body's parts changed) drops every cache.
  core::PairCache* get(std::size_t k, std::size_t n) {
    if (n != n_) {
      clear();
      n_ = n;
      if (n <= kMaxCaches) caches_.resize(n);
    }
    if (n <= kMaxCaches) return &caches_[k];
    auto [it, added] = slot_.try_emplace(k, static_cast<std::uint32_t>(caches_.size()));
    if (added) {
      if (caches_.size() == kMaxCaches) {
        slot_.clear();
        caches_.clear();
        it = slot_.try_emplace(k, 0u).first;
      }
      caches_.emplace_back();
    }
    return &caches_[it->second];
  }
  void clear() {
    n_ = 0;
    slot_ = {};
    caches_ = {};
  }
  std::size_t size() const { return caches_.size(); }

 private:
  static constexpr std::size_t kMaxCaches = 4096;
  std::size_t n_ = 0;
  std::unordered_map<std::size_t, std::uint32_t> slot_;  ///< part pair -> caches_ (n > kMaxCaches)
  std::vector<core::PairCache> caches_;
};

/// What is remembered of a pair between cycles. Slots in key order: a = lower slot.
struct PairEntry {
  PairStatus status = PairStatus::Clear;
  bool has_result = false;
  std::uint64_t version_a = 0;
  std::uint64_t version_b = 0;
  Stamp aligned_at;  ///< the pair's time the result is of, when a body moved after it (pairTime())
  double cutoff_used = 0.0;
  Narrow result;
  PartCaches caches;
  std::uint64_t last_seen = 0;  ///< cycle
  Stamp last_event;             ///< the stamp of its last event (Impl::eventStamp())
  /// The latest pair stamp (Impl::pairStamp()) it was checked at: catch-up (Impl::catchUp())
  /// starts after it.
  Stamp checked_to;
};

}  // namespace

struct WorldModel::Impl {
  Settings settings;
  std::unique_ptr<core::NarrowPhase> narrow;
  std::vector<BodyState> bodies;  ///< by slot
  std::vector<core::Aabb> boxes;  ///< by slot: the broad phase's (the held pose's, or swept)
  std::vector<int> free_slots;
  std::unordered_map<std::string, int> slot_of;  ///< id -> slot
  SlotIndex fast_slot_of;                        ///< the same, for setPose
  std::unordered_map<std::string, int> group_ids;
  std::unordered_map<std::string, std::unordered_set<std::string>> disabled;  ///< both ways
  std::unordered_set<std::string> default_off;                                ///< disableByDefault
  std::unordered_map<std::string, std::unordered_set<std::string>> enabled;   ///< both ways
  /// The pairs of bodies present that isDisabled() calls disabled.
  std::unordered_set<std::uint64_t> disabled_slots;    ///< orderedKey
  std::unordered_map<std::uint64_t, PairEntry> pairs;  ///< orderedKey
  HashGrid grid;                                       ///< the fresh bodies' boxes
  std::uint64_t cycle = 0;
  std::optional<Stamp> last_check_now;  ///< the time the last check() was given
  bool sweep_all = false;  ///< the next check() takes every body as moved (new reach, backend)
  /// A check() within pose_timeout found fresh timed poses of different stamps, or a body posed
  /// more than once since the check before (`outran`): setPose() keeps poses
  /// (BodyState::history) only then.
  bool mixed_stamps = false;
  std::optional<Stamp> mixed_seen;  ///< the last check() that found them
  /// Since the last check(), a body took a second timed pose (BodyState::new_stamps): a source
  /// outran the checks, and what it did between them is caught up. setPose() keeps poses from
  /// then on (the two before are still held: the body's pose at the last check and the first
  /// since), the next check() counts it as stamps apart.
  bool outran = false;
  /// The last check()'s CycleResult::stamp: no pair was checked at an older stamp then. While
  /// catching up, the broad phase sweeps the bodies' boxes from it too, so that every pair's
  /// stretch since its last check is boxed.
  Stamp last_verdict;
  std::size_t count = 0;
  std::vector<Event> pending;  ///< END events of removed bodies' pairs, for the next check()

  std::vector<int> rank;  ///< by slot: position of the id in id order (for sorting outputs)
  bool ranks_dirty = true;
  /// min_distance beyond the broad phase's reach (farMinimum): a second grid with a wider margin
  /// and its pairs, each with its exact distance once computed (NaN before; kept while neither
  /// body moves) and a lower bound. Followed incrementally like the broad phase while cycles need
  /// it (far_active); rebuilt from the boxes when one does after one that did not, when the
  /// margin changes or a slot is freed.
  struct FarPair {
    std::uint64_t key;
    double lower;  ///< the distance is at least this: box gap (-inf: boxes touch), or a GJK cutoff
                   ///< it exceeded
    double exact;  ///< NaN while unknown
    Stamp at;      ///< the pair's time `lower` and `exact` are of (pairTime())
  };
  HashGrid far_grid;
  double far_margin = 0.0;
  bool far_active = false;
  std::vector<FarPair> far_pairs;
  std::vector<FarPair> far_next;
  std::vector<int> far_order;

  /// The fresh bodies' stamps of one check(), gathered in its pass over the slots.
  struct Stamps {
    std::optional<Stamp> oldest;         ///< of the timed poses
    std::optional<Stamp> newest;         ///< of the timed poses
    std::optional<Stamp> oldest_moving;  ///< of those of a moving body (BodyState::moving())
    std::optional<Stamp> still[2];       ///< the two oldest of those of a still body
    bool fixed = false;                  ///< a static pose

    void add(const BodyState& b) {
      if (b.stamp.isStatic()) {
        fixed = true;
        return;
      }
      oldest = oldest ? std::min(*oldest, b.stamp) : b.stamp;
      newest = newest ? std::max(*newest, b.stamp) : b.stamp;
      if (b.moving()) {
        oldest_moving = oldest_moving ? std::min(*oldest_moving, b.stamp) : b.stamp;
      } else if (!still[0] || b.stamp < *still[0]) {
        still[1] = still[0];
        still[0] = b.stamp;
      } else if (!still[1] || b.stamp < *still[1]) {
        still[1] = b.stamp;
      }
    }
    /// CycleResult::stamp: the oldest pairStamp() over the pairs of fresh bodies (the oldest
    /// timed stamp without align_poses or when no pair says sooner; `now` without one).
    Stamp verdict(bool align_poses, Stamp now) const {
      if (!align_poses) return oldest.value_or(now);
      // Pairs of a moving body carry its stamp or a later one; of two still ones, the later; of
      // a still one and a static one, the still one's.
      std::optional<Stamp> out = oldest_moving;
      for (const std::optional<Stamp>& s : {still[1], fixed ? still[0] : std::nullopt}) {
        if (s) out = out ? std::min(*out, *s) : *s;
      }
      return out ? *out : oldest.value_or(now);
    }
  };

  // Scratch, reused across cycles.
  std::vector<int> active;
  std::vector<int> stale;
  std::vector<char> moved;      ///< by slot: box changed or newly active (all 0 between cycles)
  std::vector<int> moved_list;  ///< the slots flagged in `moved`
  std::vector<std::uint64_t> candidates;       ///< this cycle's broad-phase pairs (orderedKey)
  std::vector<std::uint64_t> next_candidates;  ///< built from the previous cycle's
  std::vector<std::uint64_t> pair_keys;        ///< rankKey per output pair
  std::vector<std::uint64_t> event_keys;       ///< rankKey per output event
  std::vector<Stamp> catch_stamps;             ///< catchUp()'s
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order;
  struct PartPair {
    double lower_bound;
    int i;
    int j;
  };
  mutable std::vector<PartPair> part_pairs;
  mutable Placement scratch_a, scratch_b;  ///< placedPair()'s bodies taken back in time
  std::atomic<bool> abandoned{false};      ///< abandonChecks(): from another thread

  /// The pairs that may collide (allowed()) with at least one stale body, counted without
  /// visiting them: every pair with a stale body, less those sharing a group, less the disabled
  /// ones. O(bodies + disabled pairs), where visiting them is O(stale x bodies).
  std::size_t countUnknownPairs() const {
    const std::size_t ns = stale.size();
    if (ns == 0) return 0;
    const std::size_t nf = active.size();
    std::size_t n = ns * nf + ns * (ns - 1) / 2;
    std::vector<std::size_t> gs(group_ids.size() + 1, 0), gf(group_ids.size() + 1, 0);
    for (const BodyState& b : bodies) {
      if (b.used && b.group != 0) ++(b.fresh ? gf : gs)[b.group];
    }
    for (std::size_t g = 1; g < gs.size(); ++g) {
      n -= gs[g] * gf[g];
      if (gs[g] > 1) n -= gs[g] * (gs[g] - 1) / 2;
    }
    for (std::uint64_t key : disabled_slots) {
      const BodyState& a = bodies[keyLo(key)];
      const BodyState& b = bodies[keyHi(key)];
      if (!a.used || !b.used || (a.fresh && b.fresh)) continue;
      if (a.group != 0 && a.group == b.group) continue;  // left out above already
      --n;
    }
    return n;
  }

  bool allowed(int i, int j) const {
    if (i == j) return false;
    const int gi = bodies[i].group;
    if (gi != 0 && gi == bodies[j].group) return false;
    return disabled_slots.empty() || disabled_slots.count(orderedKey(i, j)) == 0;
  }

  int groupId(const std::string& group) {
    if (group.empty()) return 0;
    auto it = group_ids.find(group);
    if (it != group_ids.end()) return it->second;
    // Groups no body uses any more are forgotten once they outnumber the bodies: a stream of
    // bodies with ever new group names does not grow the table without bound.
    if (group_ids.size() >= 2 * count + 64) {
      renumberGroups();  // the body asking may already hold `group`
      it = group_ids.find(group);
      if (it != group_ids.end()) return it->second;
    }
    const int id = static_cast<int>(group_ids.size()) + 1;
    group_ids.emplace(group, id);
    return id;
  }

  /// group_ids from the bodies' groups only (ids renumbered alike in the bodies).
  void renumberGroups() {
    group_ids.clear();
    for (BodyState& b : bodies) {
      if (!b.used || b.spec.group.empty()) continue;
      const int id = static_cast<int>(group_ids.size()) + 1;
      b.group = group_ids.emplace(b.spec.group, id).first->second;
    }
  }

  void refreshRanks() {
    if (!ranks_dirty) return;
    std::vector<int> slots;
    slots.reserve(count);
    for (int i = 0; i < static_cast<int>(bodies.size()); ++i) {
      if (bodies[i].used) slots.push_back(i);
    }
    std::sort(slots.begin(), slots.end(),
              [&](int x, int y) { return bodies[x].spec.id < bodies[y].spec.id; });
    rank.assign(bodies.size(), 0);
    for (std::size_t k = 0; k < slots.size(); ++k)
      rank[slots[k]] = static_cast<int>(k);
    ranks_dirty = false;
  }
  /// Sort key of a pair in id order: (lower rank, higher rank).
  std::uint64_t rankKey(int i, int j) const { return orderedKey(rank[i], rank[j]); }

  /// Sorts `items` by `keys` (stable), reusing `order` as scratch.
  template <class T>
  void sortByKeys(std::vector<T>* items, const std::vector<std::uint64_t>& keys) {
    if (items->size() < 2) return;
    order.clear();
    for (std::size_t k = 0; k < items->size(); ++k) {
      order.emplace_back(keys[k], static_cast<std::uint32_t>(k));
    }
    std::sort(order.begin(), order.end());
    std::vector<T> sorted;
    sorted.reserve(items->size());
    for (const auto& o : order)
      sorted.push_back(std::move((*items)[o.second]));
    items->swap(sorted);
  }

  static bool named(const std::unordered_map<std::string, std::unordered_set<std::string>>& pairs,
                    const std::string& a, const std::string& b) {
    auto it = pairs.find(a);
    return it != pairs.end() && it->second.count(b) != 0;
  }

  bool isDisabled(const std::string& a, const std::string& b) const {
    if (named(disabled, a, b)) return true;
    return (default_off.count(a) != 0 || default_off.count(b) != 0) && !named(enabled, a, b);
  }

  /// The orderedKey of two bodies present, else nothing.
  std::optional<std::uint64_t> slotPair(const std::string& a, const std::string& b) const {
    auto ia = slot_of.find(a);
    auto ib = slot_of.find(b);
    if (ia == slot_of.end() || ib == slot_of.end()) return std::nullopt;
    return orderedKey(ia->second, ib->second);
  }

  /// Brings disabled_slots up to date for the pairs of the body in `slot` and the bodies
  /// present.
  void markDisabledPairsOf(int slot) {
    const std::string& id = bodies[slot].spec.id;
    const auto mark = [&](const std::string& other) {
      auto o = slot_of.find(other);
      if (o != slot_of.end() && o->second != slot && isDisabled(id, other)) {
        disabled_slots.insert(orderedKey(slot, o->second));
      }
    };
    auto dis = disabled.find(id);
    if (dis != disabled.end()) {
      for (const std::string& other : dis->second)
        mark(other);
    }
    if (default_off.empty()) return;
    if (default_off.count(id) != 0 || default_off.size() > count) {  // the shorter loop
      for (const BodyState& o : bodies) {
        if (o.used) mark(o.spec.id);
      }
    } else {
      for (const std::string& other : default_off)
        mark(other);
    }
  }

  /// Compound narrow phase: min over part pairs of the signed distance. Part pairs are visited
  /// in increasing order of a lower bound on their signed distance (box gap when the boxes are
  /// apart, bounding-sphere gap otherwise); the loop stops once the bound passes the best found
  /// or `cutoff`. `caches` may be null.
  Narrow narrowPhase(const Placed& A, const Placed& B, double cutoff, PartCaches* caches) const {
    Narrow out;
    const std::size_t na = A.body.spec.parts.size();
    const std::size_t nb = B.body.spec.parts.size();
    part_pairs.clear();
    double skipped = kInf;  // the smallest lower bound of the part pairs left out
    const auto abandon = [&] {
      out.distance = std::numeric_limits<double>::quiet_NaN();  // a failed query
      out.exact = true;
      return out;
    };
    for (std::size_t i = 0; i < na; ++i) {
      if (abandoned.load(std::memory_order_relaxed)) return abandon();
      for (std::size_t j = 0; j < nb; ++j) {
        const double gap = A.at.part_boxes[i].distance(B.at.part_boxes[j]);
        const double sphere = ballGap(A.at.part_centres[i], A.at.part_radii[i],
                                      B.at.part_centres[j], B.at.part_radii[j]);
        const double lb = gap > 0.0 ? std::max(gap, sphere) : sphere;
        if (lb > cutoff) {
          skipped = std::min(skipped, lb);
          continue;
        }
        part_pairs.push_back(PartPair{lb, static_cast<int>(i), static_cast<int>(j)});
      }
    }
    if (part_pairs.size() > 1) {
      std::sort(part_pairs.begin(), part_pairs.end(),
                [](const PartPair& x, const PartPair& y) { return x.lower_bound < y.lower_bound; });
    }
    for (const PartPair& pp : part_pairs) {
      if (out.exact && pp.lower_bound >= out.distance) break;
      if (abandoned.load(std::memory_order_relaxed)) return abandon();
      core::PairCache* cache = caches ? caches->get(pp.i * nb + pp.j, na * nb) : nullptr;
      const core::ContactResult r =
          narrow->signedDistance(A.body.spec.parts[pp.i].shape, A.at.part_poses[pp.i],
                                 B.body.spec.parts[pp.j].shape, B.at.part_poses[pp.j], cache);
      ++out.gjk_runs;
      if (!std::isfinite(r.distance)) {
        // A failed query poisons the pair: UNKNOWN, never CLEAR. Shapes have finite distances;
        // +inf is a query that did not run (a pair whose size overflows: two 1e308 m spheres).
        out.distance = std::numeric_limits<double>::quiet_NaN();
        out.exact = true;
        return out;
      }
      if (!out.exact || r.distance < out.distance) {
        out.distance = r.distance;
        out.point_a = r.point_a;
        out.point_b = r.point_b;
        out.normal = r.normal;
        out.exact = true;
      }
    }
    // A part pair left out may be nearer than one computed beyond the cutoff: then the pair is
    // only known to be beyond it, like one whose part pairs were all left out.
    if (out.exact && out.distance > skipped) out.exact = false;
    // All part pairs beyond the cutoff: the pair is at least that far apart.
    out.lower_bound = std::min(out.distance, skipped);
    return out;
  }

  /// Adds pair (i, j) to `out` when it may collide and its boxes are within far_margin. Its lower
  /// bound is the boxes' gap, or -inf when they touch: the pair may then overlap, by any depth.
  void addFar(int i, int j, std::vector<FarPair>* out) const {
    if (!allowed(i, j)) return;
    const double gap = boxes[i].distance(boxes[j]);
    if (gap > far_margin) return;
    out->push_back(FarPair{orderedKey(i, j), gap > 0.0 ? gap : -kInf,
                           std::numeric_limits<double>::quiet_NaN(), pairTime(i, j)});
  }

  /// far_pairs of this cycle while far_active: the pairs of two unmoved fresh bodies from the
  /// last cycle (with their distances), those of the moved ones from the grid (call with the
  /// `moved` flags of this cycle set).
  void updateFar() {
    far_grid.prepare();
    far_next.clear();
    for (const FarPair& p : far_pairs) {
      const int i = keyLo(p.key);
      const int j = keyHi(p.key);
      if (!bodies[i].fresh || !bodies[j].fresh || moved[i] || moved[j] || !allowed(i, j)) continue;
      far_next.push_back(p);
    }
    far_grid.forEachPairWith(moved_list, moved, [&](int i, int j) { addFar(i, j, &far_next); });
    far_pairs.swap(far_next);
  }

  /// The smallest signed distance over the pairs of fresh bodies that may collide, given `best`
  /// (the smallest exact distance of the broad phase's pairs, which is beyond the clear cutoff):
  /// the exact distances held, then GJK (with the best so far as cutoff) on the pairs not yet
  /// known whose lower bound is below it, nearest first. Pairs outside the far grid are more
  /// than far_margin apart on some axis: when the best is farther, the margin grows (the grid is
  /// rebuilt) until it is not, or until it spans every box. A pair with no verdict yet at `now`
  /// (verdictPending(): check() holds it UNKNOWN) is left out, as a pair of a stale body is.
  double farMinimum(double best, double reach, Stamp now, CycleResult* res) {
    double span = -1.0;  // of every box; computed only when the margin has to grow
    if (!far_active || far_margin < 2.0 * reach) {
      far_margin = std::max(far_margin, 2.0 * reach);
      rebuildFar();
    }
    for (FarPair& p : far_pairs) {
      const Stamp at = pairTime(keyLo(p.key), keyHi(p.key));
      if (p.at == at) continue;
      // Another time than its distance's (a stamp changed, not a box): only the box gap holds.
      const double gap = boxes[keyLo(p.key)].distance(boxes[keyHi(p.key)]);
      p = FarPair{p.key, gap > 0.0 ? gap : -kInf, std::numeric_limits<double>::quiet_NaN(), at};
    }
    for (;;) {
      far_order.clear();
      for (int k = 0; k < static_cast<int>(far_pairs.size()); ++k) {
        const FarPair& p = far_pairs[k];
        const bool known = !std::isnan(p.exact);
        if (!(known ? p.exact < best : p.lower < best)) continue;  // cannot lower it
        if (verdictPending(keyLo(p.key), keyHi(p.key), now)) continue;
        if (known) {
          best = p.exact;
        } else {
          far_order.push_back(k);  // measured below, nearest first, while its bound is below best
        }
      }
      std::sort(far_order.begin(), far_order.end(),
                [&](int x, int y) { return far_pairs[x].lower < far_pairs[y].lower; });
      for (int k : far_order) {
        FarPair& p = far_pairs[k];
        if (p.lower >= best) break;
        const Narrow n = narrowPhase(keyLo(p.key), keyHi(p.key), p.at, best, nullptr);
        ++res->num_pairs_checked;
        res->num_part_checks += static_cast<std::size_t>(n.gjk_runs);
        if (!n.exact) {
          p.lower = best;  // beyond it
        } else if (std::isnan(n.distance)) {
          p.lower = kInf;  // a failed query: the narrow phase reports the pair UNKNOWN if near
        } else {
          p.exact = n.distance;
          best = std::min(best, n.distance);
        }
      }
      if (best <= far_margin) break;
      if (span < 0.0) {
        core::Aabb all;
        for (int slot : active)
          all.extend(boxes[slot]);
        span = all.empty() ? 0.0 : (all.max - all.min).norm();
      }
      if (far_margin >= span) break;
      // From a zero margin (every threshold at or below 0: no reach) four times is still zero:
      // start from a share of the span instead, so the margin reaches it in a few rebuilds.
      const double grown = std::max(4.0 * far_margin, std::isfinite(best) ? 2.0 * best : 0.0);
      far_margin = grown > far_margin ? grown : span / 1024.0;
      rebuildFar();
    }
    // A margin far wider than needed costs every cycle: narrow it, keeping the pairs within the
    // new one with their distances.
    if (best < far_margin / 8.0) {
      far_margin = std::max(2.0 * best, 2.0 * reach);
      far_grid.setMargin(far_margin);  // re-enters the boxes at the next prepare()
      far_pairs.erase(std::remove_if(far_pairs.begin(), far_pairs.end(),
                                     [&](const FarPair& p) {
                                       return boxes[keyLo(p.key)].distance(boxes[keyHi(p.key)]) >
                                              far_margin;
                                     }),
                      far_pairs.end());
    }
    return best;
  }

  void rebuildFar() {
    far_grid = HashGrid();
    far_grid.setMargin(far_margin);
    for (int slot : active)
      far_grid.set(slot, boxes[slot]);
    far_grid.prepare();
    far_pairs.clear();
    far_grid.forEachPair([&](int i, int j) { addFar(i, j, &far_pairs); });
    far_active = true;
  }

  /// PairResult::time_to_collision of A and B (r: their result): the time until their distance
  /// reaches contact_distance under the bodies' twists, by conservative advancement over their
  /// convex part pairs. For one part pair at distance d with normal n, the separation along n is a
  /// lower bound of d and falls at most at mu = -(w . n) + |n x w_a| rho_a + |n x w_b| rho_b (w the
  /// relative linear velocity, w_a and w_b the angular ones, rho the part's bounding radius about
  /// its body's origin: a point r from the origin moves along n at (w_a x r) . n = r . (n x w_a),
  /// so a turn about n itself closes no gap): that pair cannot reach the contact in less than
  /// (d - contact) / mu, and never when mu <= 0. The bodies advance by the least of these over the
  /// part pairs (a part pair whose bounding spheres cannot close the gap sooner is skipped) and the
  /// part pairs are measured again. Without a rotation mu is the exact rate and each part pair's
  /// distance is convex in time: the time is exact, and bodies that pass each other get +inf (and
  /// so do bodies whose velocities are equal to within kSameVelocity of their speed). With
  /// one the bound is loose and the steps shorter: a contact later than settings.ttc_horizon is
  /// +inf, and after kMaxSteps the time reached is returned (a lower bound: the contact is no
  /// earlier).
  static constexpr double kSameVelocity = 1e-9;
  double timeToCollisionOf(const Placed& A, const Placed& B, const PairResult& r) const {
    const double c = settings.contact_distance;
    if (!std::isfinite(r.distance)) return kInf;
    if (r.distance <= c) return 0.0;
    if (!A.body.has_twist && !B.body.has_twist) return kInf;
    Twist ta = A.body.has_twist ? A.body.twist : Twist();
    Twist tb = B.body.has_twist ? B.body.twist : Twist();
    const Vec3 w = tb.linear - ta.linear;
    const double speed = w.norm();
    const bool rotating = !ta.angular.isZero() || !tb.angular.isZero();
    if (!rotating) {
      // Translating: the time is the relative motion's. Velocities within kSameVelocity of the
      // faster one's speed of each other are equal ones, rounded (two bodies moving together,
      // their twists estimated from their poses: 1e-14 m/s apart at 5.8 m/s gave 3.4e13 s).
      if (speed <= kSameVelocity * std::max(ta.linear.norm(), tb.linear.norm())) return kInf;
      // B moves by it and A stays: no coordinate grows with the time (each body placed by its
      // own velocity at 3.4e13 s was 1.7e14 m out, where doubles are 0.03 m apart).
      ta.linear.setZero();
      tb.linear = w;
    }
    // Per part: its bounding radius about the body's origin.
    const auto reaches = [](const Placed& S) {
      std::vector<double> out(S.body.spec.parts.size());
      for (std::size_t i = 0; i < out.size(); ++i)
        out[i] = (S.at.part_centres[i] - S.at.pose.t).norm() + S.at.part_radii[i];
      return out;
    };
    const std::vector<double> reach_a = reaches(A), reach_b = reaches(B);
    const double omega_a = ta.angular.norm(), omega_b = tb.angular.norm();
    // How fast a turn can close the gap along n: |n x w| times the part's reach (none without one).
    const auto across = [](const Vec3& n, const Twist& tw, double reach) {
      return reach > 0.0 ? n.cross(tw.angular).norm() * reach : 0.0;
    };
    constexpr int kMaxSteps = 128;
    constexpr double kTolerance = 1e-9;  // m
    MovedParts a_at, b_at;               // A's and B's parts at time t
    double t = 0.0;
    for (int k = 0; k < kMaxSteps; ++k) {
      a_at.place(A, ta, t);
      b_at.place(B, tb, t);
      double step = kInf;
      for (std::size_t i = 0; i < A.body.spec.parts.size(); ++i) {
        for (std::size_t j = 0; j < B.body.spec.parts.size(); ++j) {
          // Any point pair's closing speed.
          const double bound = speed + omega_a * reach_a[i] + omega_b * reach_b[j];
          const double gap =
              ballGap(a_at.centres[i], A.at.part_radii[i], b_at.centres[j], B.at.part_radii[j]);
          if (!(bound > 0.0) || (gap - c) / bound >= step) continue;
          if (abandoned.load(std::memory_order_relaxed)) return kInf;
          const core::ContactResult x =
              narrow->signedDistance(A.body.spec.parts[i].shape, a_at.poses[i],
                                     B.body.spec.parts[j].shape, b_at.poses[j], nullptr);
          if (!std::isfinite(x.distance)) return t;  // the bound so far
          if (x.distance - c <= kTolerance) return t;
          const double mu = -w.dot(x.normal) + across(x.normal, ta, reach_a[i]) +
                            across(x.normal, tb, reach_b[j]);
          if (mu > 0.0) step = std::min(step, (x.distance - c) / mu);
        }
      }
      t += step;
      if (!(t < kInf) || (rotating && t > settings.ttc_horizon)) return kInf;
    }
    return t;
  }

  /// The pair's result from `n`, of the bodies placed at pair time `at` (placedPair()).
  PairResult makeResult(int a, int b, PairStatus status, const Narrow& n, Stamp at) const {
    PairResult r;
    r.body_a = bodies[a].spec.id;
    r.body_b = bodies[b].spec.id;
    r.status = status;
    // A failed query (NaN, status UNKNOWN): +inf, as for every UNKNOWN pair, never NaN.
    r.distance = n.exact && status != PairStatus::Unknown ? n.distance : kInf;
    if (status != PairStatus::Unknown) {  // a failed query: no points, no normal
      r.point_a = n.point_a;
      r.point_b = n.point_b;
      r.normal = n.normal;
      if (n.exact) {
        // Without a twist the time comes from the distance alone (0 or +inf) and reads no
        // placement: the held ones, not placed again.
        const bool twist = bodies[a].has_twist || bodies[b].has_twist;
        const auto [A, B] = placedPair(a, b, twist ? at : Stamp());
        r.time_to_collision = timeToCollisionOf(A, B, r);
      }
    }
    // Report in id order so that a pair always reads the same way.
    if (r.body_b < r.body_a) flipPair(&r);
    return r;
  }

  /// The exact result of pair (a, b), however far, computed unless the entry holds it for the
  /// bodies' current poses; nullptr when the query fails (the entry is left as it was). For the
  /// END event of a pair turning CLEAR, so that it says where the pair is: the narrow phase stops
  /// at the clear cutoff, and the broad phase does not run it on pairs beyond reach.
  const Narrow* exactResult(int a, int b, PairEntry* e, std::size_t* part_checks) const {
    const BodyState& A = bodies[a];
    const BodyState& B = bodies[b];
    const Stamp at = pairTime(a, b);
    if (e->has_result && e->result.exact && e->version_a == A.version &&
        e->version_b == B.version && e->aligned_at == at) {
      return &e->result;
    }
    const Narrow n = narrowPhase(a, b, at, kInf, &e->caches);
    *part_checks += static_cast<std::size_t>(n.gjk_runs);
    if (!std::isfinite(n.distance)) return nullptr;
    store(e, n, A, B, at, kInf);
    return &e->result;
  }

  /// Keeps `n` as the entry's result for the bodies' current versions at pair time `at`.
  static void store(PairEntry* e, const Narrow& n, const BodyState& A, const BodyState& B, Stamp at,
                    double cutoff) {
    e->result = n;
    e->version_a = A.version;
    e->version_b = B.version;
    e->aligned_at = at;
    e->cutoff_used = cutoff;
    e->has_result = true;
  }

  PairResult unknownResult(int a, int b) const {
    PairResult r;
    r.body_a = bodies[a].spec.id;
    r.body_b = bodies[b].spec.id;
    r.status = PairStatus::Unknown;
    if (r.body_b < r.body_a) std::swap(r.body_a, r.body_b);
    return r;
  }

  /// The time pair (a, b) is checked at when a body of it has to be taken back to it
  /// (align_poses): the older of its two timed stamps (or the newer body's first kept pose's,
  /// if later), when the body of that one is moving and the other's history places it
  /// elsewhere then; zero when each is checked at its held pose
  /// (a static pose holds at any time, and a body still as far as it is known is taken to be
  /// there since: an obstacle posed once is not met by the robot of its time).
  Stamp pairTime(int a, int b) const {
    if (!settings.align_poses) return Stamp();
    const BodyState& A = bodies[a];
    const BodyState& B = bodies[b];
    if (A.stamp.isStatic() || B.stamp.isStatic() || A.stamp == B.stamp) return Stamp();
    const BodyState& older = A.stamp < B.stamp ? A : B;
    const BodyState& newer = A.stamp < B.stamp ? B : A;
    if (!older.moving() || !newer.elsewhereAt(older.stamp)) return Stamp();
    // Before its first kept pose the newer body is at that pose (poseAt()): the time that places
    // it, so that a result kept under it is of the same placement however far back the stamp.
    return std::max(older.stamp, newer.history.front().stamp);
  }

  /// Body `slot` at pair time `t` (pairTime()): its held placement, or `scratch` placed at its
  /// pose at `t` when it moved after it.
  Placed placedAt(int slot, Stamp t, Placement* scratch) const {
    const BodyState& b = bodies[slot];
    if (t.isStatic() || !b.elsewhereAt(t)) return Placed{b, b.at};
    scratch->place(b.spec, b.poseAt(t));
    return Placed{b, *scratch};
  }
  /// Pair (a, b) at pair time `t`. The placements taken back live in scratch_a and scratch_b:
  /// valid until the next call (the callers use them at once and keep nothing).
  std::pair<Placed, Placed> placedPair(int a, int b, Stamp t) const {
    return {placedAt(a, t, &scratch_a), placedAt(b, t, &scratch_b)};
  }
  /// narrowPhase() of pair (a, b) at its pair time `t` (pairTime()).
  Narrow narrowPhase(int a, int b, Stamp t, double cutoff, PartCaches* caches) const {
    const auto [A, B] = placedPair(a, b, t);
    return narrowPhase(A, B, cutoff, caches);
  }

  /// Stamp of the poses a pair's verdict was computed from: the older non-static stamp (the newer
  /// when the older body is still, align_poses), else `now` (static poses hold at any time).
  Stamp pairStamp(int a, int b, Stamp now) const {
    const BodyState& A = bodies[a];
    const BodyState& B = bodies[b];
    return pairStampOf(A.stamp, A.moving(), B.stamp, B.moving(), now);
  }
  /// pairStamp() at the last check(), from the stamps and stillness the bodies had then; zero
  /// unless both were fresh then, or when both are static.
  Stamp lastPairStamp(int a, int b) const {
    const BodyState& A = bodies[a];
    const BodyState& B = bodies[b];
    if (!A.fresh_prev || !B.fresh_prev) return Stamp();
    return pairStampOf(A.checked_stamp[0], A.checked_moving[0], B.checked_stamp[0],
                       B.checked_moving[0], Stamp());
  }
  /// pairStamp() of bodies of stamps `sa`, `sb`, moving (BodyState::moving()) or not.
  Stamp pairStampOf(Stamp sa, bool moving_a, Stamp sb, bool moving_b, Stamp now) const {
    if (sa.isStatic()) return sb.isStatic() ? now : sb;
    if (sb.isStatic()) return sa;
    // A body still as far as it is known holds its pose since (pairTime()): the verdict is the
    // newer pose's.
    const bool older_moving = sa < sb ? moving_a : moving_b;
    if (settings.align_poses && !older_moving) return std::max(sa, sb);
    return std::min(sa, sb);
  }

  /// The stamp of an event of the pair of `e` whose poses are of `stamp`: never before the last
  /// such event's, so that a pair's verdicts stay in stamp order. A body taken as still
  /// (pairStamp(), the newer stamp) that turns out to have moved puts the pair back to its own
  /// older stamp. (UNKNOWN_BEGIN and removal events carry the check's time and are not compared;
  /// an UNKNOWN_END comes with a verdict and carries its stamp.)
  static Stamp eventStamp(PairEntry* e, Stamp stamp) {
    e->last_event = std::max(e->last_event, stamp);
    return e->last_event;
  }

  /// Catch-up (align_poses, while poses of different stamps are kept): pair (a, b), whose stamp
  /// moves on from `from` to `to` (pairStamp()) in this check, is checked at every stamp in
  /// between of the kept poses of a body of it that moved after `from`, both bodies placed there
  /// (poseAt(): the other one interpolated, or held). A pass between two poses of the slower
  /// body, which neither of its stamps sees, turns into its events, stamped when it happened.
  /// `from_too`: at `from` as well, which no check of the pair saw (a body's first known pose:
  /// the pair UNKNOWN, or new, before it). The statuses step with hysteresis as at the live
  /// checks (from UNKNOWN as at a live check too); an END to CLEAR says where the
  /// pair is then, however far. Stops at a failed query (the stretch after it is not gone over;
  /// the live check that follows reports the pair UNKNOWN if its query fails too) and when checks
  /// are abandoned.
  void catchUp(int a, int b, PairEntry* e, Stamp from, bool from_too, Stamp to, CycleResult* res) {
    catch_stamps.clear();
    if (from_too) catch_stamps.push_back(from);
    for (const int slot : {a, b}) {
      const BodyState& X = bodies[slot];
      if (!X.elsewhereAt(from)) continue;  // held since before `from`: at the live check's pose
      for (const StampedPose* p = X.history.at(from); p != X.history.end() && p->stamp < to; ++p) {
        if (from < p->stamp) catch_stamps.push_back(p->stamp);
      }
    }
    std::sort(catch_stamps.begin(), catch_stamps.end());
    catch_stamps.erase(std::unique(catch_stamps.begin(), catch_stamps.end()), catch_stamps.end());
    // A stamp is passed over when the status cannot have changed since the last one checked,
    // at poses `ref_a`, `ref_b` and distance `near` (its lower bound beyond the cutoff, where
    // only CLEAR holds, for any distance above): from there no point of a body moved farther
    // than pointShift(), and the pair's signed distance changed by at most the sum of both (a
    // body within that of where it was). The slack covers our queries' error, which grows with
    // the bodies' size and distance from the origin. libccd's depths (cores overlapping) are
    // not that close (docs/reliability.md): with it, only a stretch that stays apart is passed
    // over. A bound that overflowed (+inf: bodies 1e154 m apart) is no reference.
    const double reach_a = bodies[a].reachFromOrigin();
    const double reach_b = bodies[b].reachFromOrigin();
    const double slack = 4e-9 * (1.0 + reach_a + reach_b);
    const double floor = settings.backend == core::BackendType::Libccd ? 0.0 : -kInf;
    const auto far = [](const Transform3& x) { return x.t.lpNorm<Eigen::Infinity>(); };
    bool have_ref = false;
    Transform3 ref_a, ref_b;
    double near = 0.0;
    for (const Stamp t : catch_stamps) {
      if (abandoned.load(std::memory_order_relaxed)) return;
      const Transform3 pose_a = bodies[a].poseAt(t);
      const Transform3 pose_b = bodies[b].poseAt(t);
      if (have_ref) {
        const double ulps = 16.0 * std::numeric_limits<double>::epsilon() *
                            std::max({far(ref_a), far(ref_b), far(pose_a), far(pose_b)});
        const double shift =
            pointShift(ref_a, pose_a, reach_a) + pointShift(ref_b, pose_b, reach_b) + slack + ulps;
        if (near - shift > floor && holdsThrough(e->status, near - shift, near + shift, settings)) {
          ++res->num_catch_up_skips;
          continue;
        }
      }
      Narrow n = narrowPhase(a, b, t, clearCutoff(e->status, settings), &e->caches);
      ++res->num_pairs_checked;
      ++res->num_pairs_caught_up;
      res->num_part_checks += static_cast<std::size_t>(n.gjk_runs);
      if (n.exact && !std::isfinite(n.distance)) return;
      const PairStatus next = nextStatus(e->status, n.exact ? n.distance : kInf, settings);
      if (next == PairStatus::Clear && next != e->status && !n.exact) {
        const Narrow x = narrowPhase(a, b, t, kInf, &e->caches);  // the END says where it is
        res->num_part_checks += static_cast<std::size_t>(x.gjk_runs);
        if (std::isfinite(x.distance)) n = x;
      }
      have_ref = std::isfinite(n.lower_bound);
      ref_a = pose_a;
      ref_b = pose_b;
      near = n.lower_bound;
      if (next == e->status) continue;
      emit(e->status, next, makeResult(a, b, next, n, t), eventStamp(e, t), &res->events,
           &event_keys, rankKey(a, b));
      e->status = next;
    }
  }

  /// The stamp a timed body is known from at `now` (BodyState::known_from, as the next check()
  /// sets it when it is not set yet: a body stale at the last check, new or renewed since); zero
  /// for a static pose, which holds at any time.
  Stamp knownAt(const BodyState& x, Stamp now) const {
    if (x.stamp.isStatic()) return Stamp();
    if (x.fresh && !x.renewed) return x.known_from;
    return x.firstFreshPose(now, settings.pose_timeout);
  }
  /// The later of knownAt() of pair (a, b): a verdict at a time before it would place that body
  /// where it is not known to have been (at its first pose; poseAt()).
  Stamp knownFrom(int a, int b, Stamp now) const {
    return std::max(knownAt(bodies[a], now), knownAt(bodies[b], now));
  }
  /// Whether pair (a, b), both fresh, has no verdict at `now`: aligned, its time is before
  /// knownFrom(). check() holds it UNKNOWN (holdUnknown()), the queries refuse it.
  bool verdictPending(int a, int b, Stamp now) const {
    return settings.align_poses && pairStamp(a, b, now) < knownFrom(a, b, now);
  }
  /// Why verdictPending(); empty when the pair has a verdict.
  std::string noVerdictYet(int a, int b, Stamp now) const {
    if (!verdictPending(a, b, now)) return {};
    const Stamp known = knownFrom(a, b, now);
    const Stamp t = pairStamp(a, b, now);
    const int late = knownAt(bodies[a], now) == known ? a : b;
    std::ostringstream os;
    os << std::fixed << std::setprecision(9) << "the pair of '" << bodies[a].spec.id << "' and '"
       << bodies[b].spec.id << "' has no verdict yet: its time (" << t.seconds()
       << " s, the older moving body's stamp) is before the first pose of body '"
       << bodies[late].spec.id << "' since it came or came back (" << known.seconds() << " s)";
    return os.str();
  }
  /// Pair (a, b) while verdictPending(): no verdict yet. It is UNKNOWN
  /// (UNKNOWN_BEGIN at the check's time, after the END of a status it had) and listed so, until
  /// a check finds its time at or after that pose; then it is checked there (catch-up) and from
  /// there on. A body back from a spell, or new, beside an older moving one stays UNKNOWN for as
  /// long as the other's stamp lags its first pose.
  void holdUnknown(int a, int b, PairEntry* e, Stamp now, CycleResult* res) {
    e->last_seen = cycle;
    PairResult r = unknownResult(a, b);
    const std::uint64_t rk = rankKey(a, b);
    if (e->status != PairStatus::Unknown) {
      emit(e->status, PairStatus::Unknown, r, now, &res->events, &event_keys, rk);
      e->status = PairStatus::Unknown;
    }
    res->pairs.push_back(std::move(r));
    pair_keys.push_back(rk);
  }

  static void emit(PairStatus from, PairStatus to, const PairResult& r, Stamp stamp,
                   std::vector<Event>* events, std::vector<std::uint64_t>* keys = nullptr,
                   std::uint64_t key = 0) {
    EventType types[2];
    const int n = transitionEvents(from, to, types);
    for (int k = 0; k < n; ++k) {
      events->push_back(Event{types[k], r, stamp});
      if (keys) keys->push_back(key);
    }
  }

  std::string whyStale(int slot, Stamp now) const {
    const BodyState& b = bodies[slot];
    const std::string why =
        b.unresolved && !b.unresolved_why.empty() ? ": " + b.unresolved_why : "";
    if (!b.has_pose) return "body '" + b.spec.id + "' has no pose yet" + why;
    if (b.unresolved) return "body '" + b.spec.id + "' has an unresolved pose" + why;
    std::ostringstream os;
    os << "body '" << b.spec.id << "' has a stale pose (" << (now - b.fresh_from)
       << " s old, pose_timeout " << settings.pose_timeout << " s)";
    return os.str();
  }
};

WorldModel::WorldModel(const Settings& settings) : impl_(std::make_unique<Impl>()) {
  impl_->settings = settings;
  impl_->narrow = core::makeNarrowPhase(settings.backend);
}

WorldModel::~WorldModel() = default;

const Settings& WorldModel::settings() const {
  return impl_->settings;
}

void WorldModel::abandonChecks() {
  impl_->abandoned.store(true, std::memory_order_relaxed);
}

void WorldModel::setSettings(const Settings& settings) {
  Impl& m = *impl_;
  Settings next = settings;
  next.max_bodies = m.settings.max_bodies;
  next.max_vertices_per_part = m.settings.max_vertices_per_part;
  next.max_parts_per_body = m.settings.max_parts_per_body;
  next.max_unknown_pairs = m.settings.max_unknown_pairs;
  const bool new_reach = clearCutoffAny(next) != clearCutoffAny(m.settings);
  const bool new_backend = next.backend != m.settings.backend;
  m.settings = next;
  if (new_backend) {
    m.narrow = core::makeNarrowPhase(next.backend);
    for (auto& [key, e] : m.pairs) {
      e.has_result = false;
      e.caches.clear();
    }
  }
  if (new_reach || new_backend) {
    // The pairs kept from the last cycle are those whose bodies did not move: check() takes
    // every body as moved, and queries the grid (at its new margin) for each. (It bumped each
    // body's swept version instead: one pose or replace before the check bumped the version to
    // match, the body counted as still, and its grid box and new pairs were never seen.) The
    // far grid's exact distances are rebuilt too.
    m.sweep_all = true;
    m.far_active = false;
  }
}

std::string WorldModel::checkSpec(const BodySpec& spec) const {
  const std::string name =
      spec.id.empty() ? std::string("body with an empty id") : "body '" + spec.id + "'";
  if (spec.id.empty()) return name + " refused: the id must not be empty";
  if (spec.id.find_first_not_of(" \t\n\v\f\r") == std::string::npos) {
    return name + " refused: the id is only white space";
  }
  if (spec.parts.empty()) return name + " refused: it has no parts";
  if (spec.parts.size() > impl_->settings.max_parts_per_body) {
    return name + " refused: " + std::to_string(spec.parts.size()) +
           " parts exceed max_parts_per_body = " +
           std::to_string(impl_->settings.max_parts_per_body);
  }
  if (!std::isfinite(spec.padding) || spec.padding < 0.0) {
    std::ostringstream os;
    os << name << " refused: padding " << spec.padding << " must be finite and >= 0";
    return os.str();
  }
  for (std::size_t i = 0; i < spec.parts.size(); ++i) {
    const Part& p = spec.parts[i];
    if (!validTransform(p.pose)) {
      return name + " refused: part " + std::to_string(i) +
             " has a non-finite or non-rigid pose in the body frame";
    }
    // Its farthest point from the body origin a double: a 2.7e303 m box 1.797e308 m out (its
    // end past 1.7977e308), or a unit ball at (1.7e308, 1.7e308, 0), has no distance to anything
    // near the body (fuzz/regressions/ros/body-box-past-the-largest-double).
    const double reach =
        (p.pose * p.shape.offset()).stableNorm() + p.shape.localRadius();  // norm() squares
    if (!std::isfinite(reach)) {
      return name + " refused: part " + std::to_string(i) +
             " reaches beyond the largest double (1.8e308 m) from the body origin";
    }
    using PolyPtr = std::shared_ptr<const core::Polytope<3>>;
    if (const PolyPtr* poly = std::get_if<PolyPtr>(&p.shape.core())) {
      const std::size_t nv = *poly ? static_cast<std::size_t>((*poly)->size()) : 0;
      if (nv == 0) return name + " refused: part " + std::to_string(i) + " is an empty polytope";
      if (nv > impl_->settings.max_vertices_per_part) {
        return name + " refused: part " + std::to_string(i) + " has " + std::to_string(nv) +
               " vertices, more than max_vertices_per_part = " +
               std::to_string(impl_->settings.max_vertices_per_part);
      }
    }
  }
  return {};
}

std::string WorldModel::addBody(BodySpec spec) {
  Impl& m = *impl_;
  std::string why = checkSpec(spec);
  if (!why.empty()) return why;
  auto it = m.slot_of.find(spec.id);
  if (it != m.slot_of.end()) {
    // Replace.
    const int slot = it->second;
    BodyState& b = m.bodies[slot];
    if (b.spec.origin != spec.origin) {
      return "body '" + spec.id + "' refused: the id is already declared by the " +
             toString(b.spec.origin) + " and cannot be replaced from the " + toString(spec.origin);
    }
    // The held pose stays while it still comes from the same place: a TF body's frame, a topic
    // body's pose_topic (empty: ~body_poses). A topic body's frame poses nothing.
    const bool same_source =
        b.spec.pose_source == spec.pose_source &&
        (spec.pose_source == PoseSource::Topic ? b.spec.pose_topic == spec.pose_topic
                                               : b.spec.frame == spec.frame);
    b.spec = std::move(spec);
    b.group = m.groupId(b.spec.group);
    ++b.version;
    if (same_source && b.has_pose) {
      b.place();
    } else {
      b.has_pose = false;
      b.has_twist = false;
      b.stamp = Stamp();
      b.fresh_from = Stamp();
      b.at.box = core::Aabb();
      b.forget();
      b.renewed = true;  // a first pose of the new source, perhaps before the next check
    }
    m.boxes[slot] = b.at.box;
    for (auto& kv : m.pairs) {
      if (keyLo(kv.first) == slot || keyHi(kv.first) == slot) {
        kv.second.caches.clear();
        kv.second.has_result = false;
      }
    }
    return {};
  }
  if (m.count >= m.settings.max_bodies) {
    return "body '" + spec.id + "' refused: the world already holds max_bodies = " +
           std::to_string(m.settings.max_bodies) + " bodies";
  }
  int slot;
  if (!m.free_slots.empty()) {
    slot = m.free_slots.back();
    m.free_slots.pop_back();
  } else {
    slot = static_cast<int>(m.bodies.size());
    m.bodies.emplace_back();
    m.boxes.emplace_back();
  }
  BodyState& b = m.bodies[slot];
  b = BodyState();
  b.used = true;
  b.spec = std::move(spec);
  b.group = m.groupId(b.spec.group);
  m.boxes[slot] = b.at.box;
  m.slot_of.emplace(b.spec.id, slot);
  m.fast_slot_of.insert(b.spec.id, slot);
  ++m.count;
  m.ranks_dirty = true;
  m.markDisabledPairsOf(slot);
  return {};
}

bool WorldModel::removeBody(const std::string& id) {
  Impl& m = *impl_;
  auto it = m.slot_of.find(id);
  if (it == m.slot_of.end()) return false;
  const int slot = it->second;
  for (auto p = m.pairs.begin(); p != m.pairs.end();) {
    const int lo = keyLo(p->first);
    const int hi = keyHi(p->first);
    if (lo != slot && hi != slot) {
      ++p;
      continue;
    }
    if (p->second.status != PairStatus::Clear) {
      PairResult r;
      r.body_a = m.bodies[lo].spec.id;
      r.body_b = m.bodies[hi].spec.id;
      if (r.body_b < r.body_a) std::swap(r.body_a, r.body_b);
      r.status = PairStatus::Clear;
      // Stamp filled in by the next check().
      Impl::emit(p->second.status, PairStatus::Clear, r, 0.0, &m.pending);
    }
    p = m.pairs.erase(p);
  }
  for (auto ds = m.disabled_slots.begin(); ds != m.disabled_slots.end();) {
    if (keyLo(*ds) == slot || keyHi(*ds) == slot) {
      ds = m.disabled_slots.erase(ds);
    } else {
      ++ds;
    }
  }
  m.grid.remove(slot);
  m.fast_slot_of.erase(id, slot);
  m.bodies[slot] = BodyState();
  m.boxes[slot] = core::Aabb();
  m.slot_of.erase(it);
  m.free_slots.push_back(slot);
  --m.count;
  m.ranks_dirty = true;
  m.far_active = false;  // the slot may be reused
  return true;
}

bool WorldModel::hasBody(const std::string& id) const {
  return impl_->slot_of.count(id) != 0;
}

std::vector<BodyInfo> WorldModel::listBodies(Stamp now) const {
  std::vector<BodyInfo> out;
  out.reserve(impl_->count);
  for (const BodyState& b : impl_->bodies) {
    if (!b.used) continue;
    out.push_back(BodyInfo{b.spec.id, b.spec.frame, b.spec.group,
                           !b.isFresh(now, impl_->settings.pose_timeout)});
  }
  std::sort(out.begin(), out.end(),
            [](const BodyInfo& x, const BodyInfo& y) { return x.id < y.id; });
  return out;
}

void WorldModel::disablePair(const std::string& a, const std::string& b) {
  Impl& m = *impl_;
  if (a == b) return;
  m.disabled[a].insert(b);
  m.disabled[b].insert(a);
  if (auto key = m.slotPair(a, b)) m.disabled_slots.insert(*key);
}

void WorldModel::disableByDefault(const std::string& id) {
  Impl& m = *impl_;
  m.default_off.insert(id);
  auto it = m.slot_of.find(id);
  if (it != m.slot_of.end()) m.markDisabledPairsOf(it->second);
}

void WorldModel::enablePair(const std::string& a, const std::string& b) {
  Impl& m = *impl_;
  if (a == b) return;
  m.enabled[a].insert(b);
  m.enabled[b].insert(a);
  auto key = m.slotPair(a, b);
  if (key && !m.isDisabled(a, b)) m.disabled_slots.erase(*key);
}

bool WorldModel::isPairDisabled(const std::string& a, const std::string& b) const {
  return impl_->isDisabled(a, b);
}

bool WorldModel::setPose(const std::string& id, const Transform3& pose, Stamp stamp,
                         const std::optional<Twist>& twist, std::optional<Stamp> received) {
  Impl& m = *impl_;
  const int slot =
      m.fast_slot_of.find(id, [&](int k) -> const std::string& { return m.bodies[k].spec.id; });
  if (slot < 0) return false;
  if (!stamp.valid() || !validTransform(pose)) return false;
  if (received && !received->valid()) return false;
  if (twist && !(core::allFinite(twist->linear) && core::allFinite(twist->angular))) return false;
  BodyState& b = m.bodies[slot];
  // Out of order: only between two timed stamps. A static pose (stamp <= 0) always applies,
  // and any timed pose may follow a static one.
  if (b.has_pose && !stamp.isStatic() && !b.stamp.isStatic() && stamp < b.stamp) return false;
  // Settings::estimate_twists: from the held pose to this one (at the held stamp: as it was).
  const bool estimate = !twist && m.settings.estimate_twists && b.has_pose && !stamp.isStatic() &&
                        !b.stamp.isStatic();
  const bool keep_twist = estimate && stamp == b.stamp;
  const std::optional<Twist> estimated =
      estimate && !keep_twist
          ? twistBetween(b.at.pose, pose, stamp - b.stamp, m.settings.pose_timeout)
          : std::nullopt;
  if (!stamp.isStatic() && stamp != b.stamp && b.new_stamps < 255) ++b.new_stamps;
  if (b.new_stamps >= 2) m.outran = true;
  const bool moved = !b.has_pose || !(b.at.pose.R == pose.R) || !(b.at.pose.t == pose.t);
  // Where it was before is not known from here on: a static pose moved, one turned timed or
  // static (a first pose is a fresh one's).
  if (b.has_pose && (stamp.isStatic() != b.stamp.isStatic() || (stamp.isStatic() && moved))) {
    b.renewed = true;
  }
  if (!b.has_pose || b.stamp.isStatic()) b.forget();  // a first timed pose starts its history
  b.has_pose = true;
  b.unresolved = false;
  b.stamp = stamp;
  b.fresh_from = received && !received->isStatic() && *received < stamp ? *received : stamp;
  if (!keep_twist) {
    const std::optional<Twist>& motion = twist ? twist : estimated;
    b.has_twist = motion.has_value();
    b.twist = motion ? *motion : Twist();
  }
  if (moved) {
    ++b.version;
    b.at.place(b.spec, pose);  // the broad phase's box follows in check()
  }
  // Poses are kept only while checks find fresh timed poses of different stamps, or a source
  // that outruns them: a world posed at one time (one robot_state_publisher, one BodyPoses
  // stream) and checked at each of its poses never takes a body back, and keeping them cost
  // 21 ns a pose (a world of 1,000 bodies posed together: 332 to 404 us a cycle). Else the last
  // two are, which tell whether the body moves.
  b.remember(moved, m.settings.pose_timeout, keepsPoses() ? BodyState::kMaxHistory : 2);
  return true;
}

bool WorldModel::keepsPoses() const {
  return (impl_->mixed_stamps || impl_->outran) && impl_->settings.align_poses;
}

void WorldModel::markUnresolved(const std::string& id, const std::string& why) {
  auto it = impl_->slot_of.find(id);
  if (it == impl_->slot_of.end()) return;
  BodyState& b = impl_->bodies[it->second];
  b.unresolved = true;
  b.unresolved_why = why;  // the same text again each check: no allocation
}

void WorldModel::clearPoses() {
  for (BodyState& b : impl_->bodies) {
    if (!b.used) continue;
    b.renewed = true;  // its first known stamp is of the time before the jump
    if (b.has_pose && !b.unresolved && b.stamp.isStatic()) continue;  // holds at any time
    b.has_pose = false;
    b.unresolved = false;
    b.stamp = Stamp();
    b.fresh_from = Stamp();
    b.has_twist = false;
    b.forget();
  }
  // Time went back: the stamps of the last events and of mixed poses are of the future now.
  for (auto& kv : impl_->pairs) {
    kv.second.last_event = Stamp();
    kv.second.checked_to = Stamp();
  }
  impl_->last_verdict = Stamp();
  impl_->mixed_seen.reset();
  impl_->mixed_stamps = false;
  impl_->outran = false;
}

CycleResult WorldModel::check(Stamp now) {
  const auto t0 = std::chrono::steady_clock::now();
  Impl& m = *impl_;
  const Settings& s = m.settings;
  CycleResult res;
  const std::uint64_t cycle = ++m.cycle;
  res.num_bodies = m.count;

  // 1. Freshness, and which bodies entered, left or moved in the broad phase since the last
  // cycle (one pass over the slots; the broad phase itself only touches those).
  m.active.clear();
  m.stale.clear();
  m.moved_list.clear();
  if (m.moved.size() < m.bodies.size()) m.moved.resize(m.bodies.size(), 0);
  // Box distances are never negative: a negative cutoff (warning_distance and contact_distance
  // below 0) would drop every pair, the overlapping ones too (COLLISION_END while nothing moved).
  const double reach = std::max(0.0, clearCutoffAny(s));
  m.grid.setMargin(reach);
  Impl::Stamps stamps;                 // of the fresh bodies
  std::optional<Stamp> returned_from;  // the earliest known_from set anew: catch-up starts there
  // The clock went back (a little: further, the node forgets every pose): a pose that arrived
  // after `now` ages from now. From its arrival it stayed fresh for as long again as the jump.
  const bool clock_back = m.last_check_now && now < *m.last_check_now;
  m.last_check_now = now;
  for (int slot = 0; slot < static_cast<int>(m.bodies.size()); ++slot) {
    BodyState& b = m.bodies[slot];
    if (!b.used) continue;
    if (clock_back && !b.stamp.isStatic() && now < b.fresh_from) b.fresh_from = now;
    b.fresh_prev = b.fresh;
    b.fresh = b.isFresh(now, s.pose_timeout);
    if (b.fresh) {
      // Fresh again without a new pose (the clock went back, or pose_timeout grew): the held
      // pose, forgotten with the others while the body was stale, is where its next move starts.
      if (!b.stamp.isStatic() && b.history.empty()) b.history.push(b.stamp, b.at.pose, b.at.box);
      m.active.push_back(slot);
      stamps.add(b);
      b.new_stamps = 0;
      if (!b.fresh_prev || b.renewed) {
        b.known_from = b.stamp.isStatic() ? now : b.firstFreshPose(now, s.pose_timeout);
        b.renewed = false;
        if (!b.stamp.isStatic() && (!returned_from || b.known_from < *returned_from)) {
          returned_from = b.known_from;
        }
      }
      b.checked_stamp[0] = b.checked_stamp[1];  // lastPairStamp()'s, when fresh_prev
      b.checked_moving[0] = b.checked_moving[1];
      b.checked_stamp[1] = b.stamp;
      b.checked_moving[1] = b.moving();
    } else {
      b.new_stamps = 0;
      // Its next pose starts its history again, as a first one: it was not on the line between
      // its poses before and after the spell (interpolated there, a body 10 m away that came back
      // 0.35 m from another "collided" with it at the other's older stamp).
      b.forget();
      m.stale.push_back(slot);
      if (b.was_active) m.grid.remove(slot);
      if (m.far_active) m.far_grid.remove(slot);
      b.was_active = false;
      b.swept = false;
      b.swept_from = Stamp();
      b.swept_version = b.version;
    }
  }
  // Stamps apart now, or since the last check a body posed more than once: a 100 Hz and a 5 Hz
  // source checked just after each 5 Hz pose (equal stamps at every check), or one source that
  // outran the checks (a world posed at one time, checked slower than it is posed).
  if ((stamps.oldest && *stamps.oldest < *stamps.newest) || m.outran ||
      (m.mixed_seen && now < *m.mixed_seen)) {
    m.mixed_seen = now;
  }
  m.outran = false;
  // Sources whose stamps meet now and then (10 Hz and 100 Hz ones at every tenth) stay mixed.
  const bool kept_since = m.mixed_stamps;  // setPose() kept every pose since the last check
  m.mixed_stamps = m.mixed_seen && now - *m.mixed_seen <= s.pose_timeout;
  res.stamp = stamps.verdict(s.align_poses, now);
  // A body elsewhere at the oldest stamp of a moving body is boxed over every place it was
  // since: a pair of such a stamp takes it back there (pairTime()). Catching up, from the last
  // check's oldest pair stamp too, so that every pair's stretch since is boxed.
  const Stamp earliest = s.align_poses && stamps.oldest_moving ? *stamps.oldest_moving : Stamp();
  // Also when the check before was mixed, however long ago: setPose() has kept every pose since
  // (keepsPoses()), and checks farther apart than pose_timeout would otherwise go over nothing.
  const bool catch_up = s.align_poses && (m.mixed_stamps || kept_since);
  Stamp caught_from = earliest;
  if (catch_up && !m.last_verdict.isStatic() &&
      (caught_from.isStatic() || m.last_verdict < caught_from)) {
    caught_from = m.last_verdict;
  }
  if (catch_up && returned_from && (caught_from.isStatic() || *returned_from < caught_from)) {
    caught_from = *returned_from;
  }
  m.last_verdict = res.stamp;
  for (int slot : m.active) {
    BodyState& b = m.bodies[slot];
    const bool swept = !caught_from.isStatic() && !b.stamp.isStatic() && b.elsewhereAt(caught_from);
    const Stamp from = swept ? b.sweepStart(caught_from) : Stamp();
    if (!b.was_active || b.swept_version != b.version || m.sweep_all || swept != b.swept ||
        from != b.swept_from) {
      m.boxes[slot] = swept ? b.sweptBox(from) : b.at.box;
      m.moved[slot] = 1;
      m.moved_list.push_back(slot);
      m.grid.set(slot, m.boxes[slot]);
      if (m.far_active) m.far_grid.set(slot, m.boxes[slot]);
    }
    b.swept = swept;
    b.swept_from = from;
    b.was_active = true;
    b.swept_version = b.version;
  }
  m.sweep_all = false;

  m.refreshRanks();
  m.pair_keys.clear();
  m.event_keys.clear();

  // 2. Broad phase. Pairs between bodies whose boxes did not change since the last cycle are
  // kept from it; only moved (or newly fresh) bodies are queried in the grid.
  m.grid.prepare();
  m.next_candidates.clear();
  const auto consider = [&](int i, int j) {
    if (!m.allowed(i, j)) return;
    if (m.boxes[i].distance(m.boxes[j]) > reach) return;
    m.next_candidates.push_back(orderedKey(i, j));
  };
  for (std::uint64_t key : m.candidates) {
    const int i = keyLo(key);
    const int j = keyHi(key);
    if (!m.bodies[i].fresh || !m.bodies[j].fresh || m.moved[i] || m.moved[j]) continue;
    if (!m.allowed(i, j)) continue;
    m.next_candidates.push_back(key);
  }
  if (!m.moved_list.empty()) m.grid.forEachPairWith(m.moved_list, m.moved, consider);
  if (m.far_active) m.updateFar();
  for (int slot : m.moved_list)
    m.moved[slot] = 0;
  m.candidates.swap(m.next_candidates);
  res.num_broad_phase_pairs = m.candidates.size();

  // 3. Narrow phase, hysteresis, events.
  for (std::uint64_t key : m.candidates) {
    const int a = keyLo(key);
    const int b = keyHi(key);
    const BodyState& A = m.bodies[a];
    const BodyState& B = m.bodies[b];
    PairEntry& e = m.pairs[key];
    e.last_seen = cycle;
    const Stamp to = m.pairStamp(a, b, now);
    if (m.verdictPending(a, b, now)) {
      m.holdUnknown(a, b, &e, now, &res);
      continue;
    }
    if (catch_up) {
      // Not before a time already checked (at the last check, by the broad phase alone too; the
      // pair's stamp may go back when a body taken as still turns out to have moved) or an event
      // of the pair: those verdicts stand as reported. Nor before a body's first known pose;
      // when that is later (the pair UNKNOWN or new since), the pair is checked there too.
      const Stamp checked = std::max({e.checked_to, e.last_event, m.lastPairStamp(a, b)});
      const Stamp known = std::max(A.known_from, B.known_from);
      const Stamp from = std::max(checked, known);
      if (from < to) m.catchUp(a, b, &e, from, checked < known, to, &res);
    }
    e.checked_to = std::max(e.checked_to, to);
    const double cutoff = clearCutoff(e.status, s);
    const Stamp at = m.pairTime(a, b);
    const bool reusable = e.has_result && e.version_a == A.version && e.version_b == B.version &&
                          e.aligned_at == at && (e.result.exact || e.cutoff_used >= cutoff);
    if (reusable) {
      ++res.num_pairs_cached;
    } else {
      Impl::store(&e, m.narrowPhase(a, b, at, cutoff, &e.caches), A, B, at, cutoff);
      ++res.num_pairs_checked;
      res.num_part_checks += static_cast<std::size_t>(e.result.gjk_runs);
    }
    const double d = e.result.exact ? e.result.distance : kInf;
    const PairStatus next = nextStatus(e.status, d, s);
    // exact_min_distance off: pairs within the clear cutoff only (a pair beyond it whose boxes
    // touch is measured too, and counted only when min_distance searches beyond).
    if (e.result.exact && d < res.min_distance && (s.exact_min_distance || d <= clearCutoffAny(s)))
      res.min_distance = d;
    if (next != e.status || next != PairStatus::Clear) {
      if (next == PairStatus::Clear && !e.result.exact) {
        m.exactResult(a, b, &e, &res.num_part_checks);  // the END event says where the pair is
      }
      const PairResult r = m.makeResult(a, b, next, e.result, at);
      const std::uint64_t rk = m.rankKey(a, b);
      if (next != e.status) {
        Impl::emit(e.status, next, r, Impl::eventStamp(&e, to), &res.events, &m.event_keys, rk);
      }
      if (next != PairStatus::Clear) {
        res.pairs.push_back(r);
        m.pair_keys.push_back(rk);
      }
      if (next == PairStatus::Collision) res.in_collision = true;
      e.status = next;
    }
  }

  // 3b. min_distance over every pair that may collide: a pair beyond the clear cutoff of every
  // status may be nearer than the ones the narrow phase answered exactly, or than none.
  if (s.exact_min_distance &&
      !(res.min_distance <=
        std::min(clearCutoff(PairStatus::Clear, s), clearCutoff(PairStatus::Warning, s)))) {
    res.min_distance = m.farMinimum(res.min_distance, reach, now, &res);
  } else {
    m.far_active = false;  // not needed: not followed either, until a cycle needs it again
  }

  // 4. Pairs with a stale body: UNKNOWN. A pair that becomes UNKNOWN gets UNKNOWN_BEGIN, also
  // one never known (a body without a pose yet), so that a consumer of the events never takes it
  // for clear. Pairs never known are tracked only while listed (max_unknown_pairs): that bounds
  // the cost of many bodies without poses, and the rest are implied by stale_bodies. Once the
  // list is full, a body that was stale before has nothing more to list or announce: its pairs
  // are counted (countUnknownPairs) and its tracked ones kept UNKNOWN below, not visited.
  res.num_unknown_pairs = m.countUnknownPairs();
  std::size_t visited = 0;  // pairs visited, in the listing's order
  bool skipped = false;
  for (int sl : m.stale) {
    if (visited >= s.max_unknown_pairs && !m.bodies[sl].fresh_prev) {
      skipped = true;
      continue;
    }
    for (int o = 0; o < static_cast<int>(m.bodies.size()); ++o) {
      const BodyState& O = m.bodies[o];
      if (!O.used || !m.allowed(sl, o)) continue;
      if (!O.fresh && o < sl) continue;  // both stale: visited from o
      const std::uint64_t key = orderedKey(sl, o);
      const std::uint64_t rk = m.rankKey(sl, o);
      const bool listed = visited++ < s.max_unknown_pairs;
      auto it = m.pairs.empty() ? m.pairs.end() : m.pairs.find(key);
      const bool known_before = m.bodies[sl].fresh_prev && O.fresh_prev;
      if (it == m.pairs.end() && !known_before && !listed) continue;  // nothing to say
      PairResult r = m.unknownResult(sl, o);
      if (it != m.pairs.end()) {
        PairEntry& e = it->second;
        e.last_seen = cycle;
        if (e.status != PairStatus::Unknown) {
          Impl::emit(e.status, PairStatus::Unknown, r, now, &res.events, &m.event_keys, rk);
          e.status = PairStatus::Unknown;
        }
      } else {
        Impl::emit(PairStatus::Clear, PairStatus::Unknown, r, now, &res.events, &m.event_keys, rk);
        PairEntry& e = m.pairs[key];
        e.status = PairStatus::Unknown;
        e.last_seen = cycle;
      }
      if (listed) {
        res.pairs.push_back(std::move(r));
        m.pair_keys.push_back(rk);
      }
    }
  }
  if (skipped) {  // the tracked pairs of the bodies not visited stay UNKNOWN
    for (auto& [key, e] : m.pairs) {
      const int a = keyLo(key);
      const int b = keyHi(key);
      if (e.last_seen == cycle || (m.bodies[a].fresh && m.bodies[b].fresh) || !m.allowed(a, b)) {
        continue;
      }
      e.last_seen = cycle;
      if (e.status != PairStatus::Unknown) {
        Impl::emit(e.status, PairStatus::Unknown, m.unknownResult(a, b), now, &res.events,
                   &m.event_keys, m.rankKey(a, b));
        e.status = PairStatus::Unknown;
      }
    }
  }

  // 5. Tracked pairs not seen: known and beyond reach (or no longer allowed) -> CLEAR.
  for (auto it = m.pairs.begin(); it != m.pairs.end();) {
    PairEntry& e = it->second;
    if (e.last_seen != cycle) {
      const int a = keyLo(it->first);
      const int b = keyHi(it->first);
      if (e.status == PairStatus::Unknown && m.bodies[a].fresh && m.bodies[b].fresh &&
          m.allowed(a, b) && m.verdictPending(a, b, now)) {
        m.holdUnknown(a, b, &e, now, &res);  // seen now: kept
      } else if (e.status != PairStatus::Clear) {
        // The END event says where the pair is when both poses are fresh (+inf otherwise), and
        // the pair is still checked: one no longer checked (a group or a disabled pair) has no
        // distance the monitor stands behind, and an END to CLEAR at -0.05 m read as a contact.
        const Narrow* x = m.bodies[a].fresh && m.bodies[b].fresh && m.allowed(a, b)
                              ? m.exactResult(a, b, &e, &res.num_part_checks)
                              : nullptr;
        PairResult r =
            x ? m.makeResult(a, b, PairStatus::Clear, *x, m.pairTime(a, b)) : m.unknownResult(a, b);
        r.status = PairStatus::Clear;
        Impl::emit(e.status, PairStatus::Clear, r, Impl::eventStamp(&e, m.pairStamp(a, b, now)),
                   &res.events, &m.event_keys, m.rankKey(a, b));
        e.status = PairStatus::Clear;
      }
      if (cycle - e.last_seen > kForgetAfterCycles && now - e.last_event > s.pose_timeout) {
        it = m.pairs.erase(it);
        continue;
      }
    }
    res.num_part_caches += e.caches.size();
    ++it;
  }

  for (int sl : m.stale)
    res.stale_bodies.push_back(m.bodies[sl].spec.id);

  // Deterministic order: pairs and events by (body_a, body_b) in id order, a pair's END before
  // its BEGIN; END events of removed bodies first.
  m.sortByKeys(&res.pairs, m.pair_keys);
  m.sortByKeys(&res.events, m.event_keys);
  if (!m.pending.empty()) {
    std::stable_sort(m.pending.begin(), m.pending.end(), [](const Event& x, const Event& y) {
      return std::tie(x.pair.body_a, x.pair.body_b) < std::tie(y.pair.body_a, y.pair.body_b);
    });
    for (Event& e : m.pending)
      e.stamp = now;
    res.events.insert(res.events.begin(), std::make_move_iterator(m.pending.begin()),
                      std::make_move_iterator(m.pending.end()));
    m.pending.clear();
  }
  std::sort(res.stale_bodies.begin(), res.stale_bodies.end());

  res.abandoned = m.abandoned.load(std::memory_order_relaxed);
  res.compute_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

std::optional<PairResult> WorldModel::distance(const std::string& a, const std::string& b,
                                               Stamp now, std::string* why, Stamp* stamp) const {
  const Impl& m = *impl_;
  auto fail = [&](std::string msg) -> std::optional<PairResult> {
    if (why) *why = std::move(msg);
    return std::nullopt;
  };
  auto ia = m.slot_of.find(a);
  if (ia == m.slot_of.end()) return fail("unknown body '" + a + "'");
  auto ib = m.slot_of.find(b);
  if (ib == m.slot_of.end()) return fail("unknown body '" + b + "'");
  if (ia->second == ib->second) return fail("body '" + a + "' has no distance to itself");
  const BodyState& A = m.bodies[ia->second];
  const BodyState& B = m.bodies[ib->second];
  if (!A.isFresh(now, m.settings.pose_timeout)) return fail(m.whyStale(ia->second, now));
  if (!B.isFresh(now, m.settings.pose_timeout)) return fail(m.whyStale(ib->second, now));
  if (std::string w = m.noVerdictYet(ia->second, ib->second, now); !w.empty()) return fail(w);
  const Stamp at = m.pairTime(ia->second, ib->second);
  const Narrow n = m.narrowPhase(ia->second, ib->second, at, kInf, nullptr);
  if (m.abandoned.load(std::memory_order_relaxed)) return fail(kAbandoned);
  // UNKNOWN in check() too; a NaN distance with success would read as an answer.
  if (std::isnan(n.distance)) return fail("the query between '" + a + "' and '" + b + "' failed");
  PairStatus tracked = PairStatus::Clear;
  auto it = m.pairs.find(orderedKey(ia->second, ib->second));
  if (it != m.pairs.end()) tracked = it->second.status;
  PairResult r =
      m.makeResult(ia->second, ib->second, nextStatus(tracked, n.distance, m.settings), n, at);
  // Keep the caller's order.
  if (r.body_a != a) flipPair(&r);
  if (stamp) *stamp = m.pairStamp(ia->second, ib->second, Stamp());
  return r;
}

std::optional<PairResult> WorldModel::nearest(const std::string& a, Stamp now, std::string* why,
                                              Stamp* stamp) const {
  const Impl& m = *impl_;
  auto fail = [&](std::string msg) -> std::optional<PairResult> {
    if (why) *why = std::move(msg);
    return std::nullopt;
  };
  auto ia = m.slot_of.find(a);
  if (ia == m.slot_of.end()) return fail("unknown body '" + a + "'");
  const int sa = ia->second;
  const BodyState& A = m.bodies[sa];
  if (!A.isFresh(now, m.settings.pose_timeout)) return fail(m.whyStale(sa, now));
  // Candidates by a lower bound on the signed distance (box gap, or -inf when boxes overlap).
  // A body without a fresh pose may be the nearest: then the nearest is unknown (its pairs are
  // UNKNOWN, never CLEAR), not the nearest of the others.
  std::vector<std::pair<double, int>> order;
  std::vector<int> stale;
  std::string unsettled;  // a pair without a verdict yet (noVerdictYet()), the first in id order
  std::string unsettled_id;
  for (int o = 0; o < static_cast<int>(m.bodies.size()); ++o) {
    const BodyState& O = m.bodies[o];
    if (!O.used || !m.allowed(sa, o)) continue;
    if (!O.isFresh(now, m.settings.pose_timeout)) {
      stale.push_back(o);
      continue;
    }
    if (std::string w = m.noVerdictYet(sa, o, now);
        !w.empty() && (unsettled.empty() || O.spec.id < unsettled_id)) {
      unsettled = std::move(w);
      unsettled_id = O.spec.id;
    }
    const auto [pa, po] = m.placedPair(sa, o, m.pairTime(sa, o));  // as the pair is checked
    const double gap = pa.at.box.distance(po.at.box);
    // Less its rounding: boxes 9.6 and 9.9 m out have a gap of 0.30000000000000071, above the
    // 0.3 of bodies in them, and a tie there went to whichever was measured first.
    const double coordinates =
        std::max({pa.at.box.min.cwiseAbs().maxCoeff(), pa.at.box.max.cwiseAbs().maxCoeff(),
                  po.at.box.min.cwiseAbs().maxCoeff(), po.at.box.max.cwiseAbs().maxCoeff()});
    const double rounding = 8.0 * std::numeric_limits<double>::epsilon() * coordinates;
    order.emplace_back(gap > rounding ? gap - rounding : -kInf, o);
  }
  if (!stale.empty()) {
    std::sort(stale.begin(), stale.end(),
              [&](int x, int y) { return m.bodies[x].spec.id < m.bodies[y].spec.id; });
    std::string msg = "the nearest body to '" + a + "' is unknown: " + m.whyStale(stale[0], now);
    if (stale.size() > 1) msg += " (and " + std::to_string(stale.size() - 1) + " more)";
    return fail(msg);
  }
  if (!unsettled.empty()) return fail("the nearest body to '" + a + "' is unknown: " + unsettled);
  if (order.empty()) return fail("no other body that '" + a + "' may touch");
  std::sort(order.begin(), order.end());
  int best_slot = -1;
  Narrow best;
  for (const auto& [lb, o] : order) {
    // At a gap equal to the best distance, measure: a tie goes to the smaller id.
    if (best_slot >= 0 && lb > best.distance) break;
    const Narrow n = m.narrowPhase(sa, o, m.pairTime(sa, o), kInf, nullptr);
    if (m.abandoned.load(std::memory_order_relaxed)) return fail(kAbandoned);
    if (std::isnan(n.distance)) {
      // A failed query may hide the nearest, as a stale pose does (the pair is UNKNOWN in
      // check()): the answer depended on the order the bodies were added in.
      return fail("the nearest body to '" + a + "' is unknown: the query against '" +
                  m.bodies[o].spec.id + "' failed");
    }
    if (best_slot < 0 || n.distance < best.distance ||
        (n.distance == best.distance && m.bodies[o].spec.id < m.bodies[best_slot].spec.id)) {
      best = n;
      best_slot = o;
    }
  }
  PairStatus tracked = PairStatus::Clear;
  auto it = m.pairs.find(orderedKey(sa, best_slot));
  if (it != m.pairs.end()) tracked = it->second.status;
  PairResult r = m.makeResult(sa, best_slot, nextStatus(tracked, best.distance, m.settings), best,
                              m.pairTime(sa, best_slot));
  if (r.body_a != a) flipPair(&r);
  if (stamp) *stamp = m.pairStamp(sa, best_slot, Stamp());
  return r;
}

std::optional<std::vector<PairResult>> WorldModel::checkHypothetical(
    const BodySpec& body, const Transform3& pose, double margin, Stamp now, bool anonymous,
    std::size_t* num_unknown, std::string* why) const {
  const Impl& m = *impl_;
  std::vector<PairResult> out;
  std::size_t unknown = 0;
  if (num_unknown) *num_unknown = 0;
  std::string refused = checkSpec(body);
  if (refused.empty() && !validTransform(pose)) {
    refused = "the pose in the fixed frame is not finite (or not rigid)";
  }
  if (!refused.empty()) {
    if (why) *why = std::move(refused);
    return std::nullopt;
  }
  // "That body, moved": its own group applies too (get_distance and the cycle skip those pairs).
  std::string tracked_group;
  if (!anonymous) {
    const auto it = m.slot_of.find(body.id);
    if (it != m.slot_of.end()) tracked_group = m.bodies[it->second].spec.group;
  }
  const auto sameGroup = [&](const std::string& g) {
    return !g.empty() && (g == body.group || g == tracked_group);
  };
  if (std::isnan(margin)) margin = 0.0;
  BodyState H;
  H.spec = body;
  H.has_pose = true;
  H.at.place(H.spec, pose);
  // Report every body closer than `margin`, and every one in COLLISION whatever the margin; a body
  // without a fresh pose (or whose query failed) as UNKNOWN, as in ~state: never left out as if
  // clear. UNKNOWN pairs sort last (distance +inf).
  const double reach = std::max(margin, m.settings.contact_distance);
  const auto addUnknown = [&](const BodyState& O) {
    if (unknown++ >= m.settings.max_unknown_pairs) return;
    PairResult r;
    r.body_a = body.id;
    r.body_b = O.spec.id;
    out.push_back(std::move(r));  // PairResult's defaults: UNKNOWN, distance +inf
  };
  for (int o = 0; o < static_cast<int>(m.bodies.size()); ++o) {
    const BodyState& O = m.bodies[o];
    if (!O.used || (!anonymous && O.spec.id == body.id)) continue;
    if (sameGroup(O.spec.group)) continue;
    // A nameless body is in no pair rule, but the links off by default are off for it too.
    if (m.isDisabled(anonymous ? std::string() : body.id, O.spec.id)) continue;
    if (!O.isFresh(now, m.settings.pose_timeout)) {
      addUnknown(O);
      continue;
    }
    // Every body at its held pose: the hypothetical one has no time.
    if (H.at.box.distance(O.at.box) > std::max(0.0, reach)) continue;  // never negative
    const Narrow n = m.narrowPhase(Placed{H, H.at}, Placed{O, O.at}, reach, nullptr);
    if (n.exact && std::isnan(n.distance)) {
      addUnknown(O);
      continue;
    }
    if (!n.exact || !(n.distance <= reach)) continue;
    PairResult r;
    r.body_a = body.id;
    r.body_b = O.spec.id;
    r.status = nextStatus(PairStatus::Clear, n.distance, m.settings);
    r.distance = n.distance;
    r.point_a = n.point_a;
    r.point_b = n.point_b;
    r.normal = n.normal;
    r.time_to_collision = m.timeToCollisionOf(Placed{H, H.at}, Placed{O, O.at}, r);
    out.push_back(std::move(r));
  }
  std::sort(out.begin(), out.end(), [](const PairResult& x, const PairResult& y) {
    return x.distance != y.distance ? x.distance < y.distance : x.body_b < y.body_b;
  });
  if (num_unknown) *num_unknown = unknown;
  return out;
}

std::optional<Transform3> WorldModel::pose(const std::string& id) const {
  auto it = impl_->slot_of.find(id);
  if (it == impl_->slot_of.end() || !impl_->bodies[it->second].has_pose) return std::nullopt;
  return impl_->bodies[it->second].at.pose;
}

const BodySpec* WorldModel::body(const std::string& id) const {
  auto it = impl_->slot_of.find(id);
  if (it == impl_->slot_of.end()) return nullptr;
  return &impl_->bodies[it->second].spec;
}

std::size_t WorldModel::size() const {
  return impl_->count;
}

std::size_t WorldModel::groupNames() const {
  return impl_->group_ids.size();
}

}  // namespace world
}  // namespace collision_monitor
