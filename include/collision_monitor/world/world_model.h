/// \file
/// The ROS-free world model of the monitor: bodies (unions of convex parts), their poses in the
/// fixed frame, which pairs may collide, the broad phase, the narrow phase with warm starts, and
/// per-pair status with hysteresis and edge-triggered events. The ROS layer only converts
/// messages into these calls; everything here is unit-tested without a master.
///
/// Times are Stamps (stamp.h: integer nanoseconds, from seconds or ros::Time); lengths metres;
/// every pose and point is in the fixed frame. Not thread-safe: the owner serialises access (the
/// node holds one mutex).
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "collision_monitor/core/backend.h"
#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/core/math.h"
#include "collision_monitor/world/stamp.h"

namespace collision_monitor {
namespace world {

using core::Transform3;
using core::Vec3;

/// One convex part of a body, placed in the body frame.
struct Part {
  core::ConvexShape shape;                   ///< already padded by the body's padding
  Transform3 pose = Transform3::Identity();  ///< part frame -> body frame
};

/// Where a body's pose comes from.
enum class PoseSource {
  Tf,     ///< attached to a TF frame (`frame`), looked up by the ROS layer each cycle
  Topic,  ///< set from ~body_poses or the body's own pose_topic
};

/// Where a body was declared. An id declared by one origin cannot be replaced from another
/// (e.g. a topic cannot overwrite a URDF link); the same origin replaces freely.
enum class BodyOrigin { Urdf, Parameter, Topic };
const char* toString(BodyOrigin origin);

struct BodySpec {
  std::string id;
  std::string frame;  ///< TF frame the body is attached to (PoseSource::Tf)
  std::string group;  ///< non-empty: never checked against bodies of the same group
  std::vector<Part> parts;
  double padding = 0.0;  ///< m, already applied to parts; kept for reporting
  PoseSource pose_source = PoseSource::Tf;
  std::string pose_topic;  ///< optional geometry_msgs/PoseStamped topic (ROS layer subscribes)
  BodyOrigin origin = BodyOrigin::Topic;
};

/// Linear (m/s) and angular (rad/s) velocity in the fixed frame, angular about the body origin.
struct Twist {
  Vec3 linear = Vec3::Zero();
  Vec3 angular = Vec3::Zero();
};

/// Values match collision_monitor/PairState.
enum class PairStatus : std::uint8_t { Clear = 0, Warning = 1, Collision = 2, Unknown = 3 };

struct PairResult {
  std::string body_a;
  std::string body_b;
  PairStatus status = PairStatus::Unknown;
  double distance = std::numeric_limits<double>::infinity();  ///< signed, m
  Vec3 point_a = Vec3::Zero();                                ///< fixed frame
  Vec3 point_b = Vec3::Zero();                                ///< fixed frame
  Vec3 normal = Vec3::Zero();  ///< unit, from a towards b; zero while UNKNOWN (no distance)
  double time_to_collision = std::numeric_limits<double>::infinity();  ///< s
};

/// Values match collision_monitor/CollisionEvent.
enum class EventType : std::uint8_t {
  CollisionBegin = 1,
  CollisionEnd = 2,
  WarningBegin = 3,
  WarningEnd = 4,
  UnknownBegin = 5,
  UnknownEnd = 6,
};

/// Event scheme (see pair_logic.h): a transition X -> Y emits END(X) unless X is CLEAR, then
/// BEGIN(Y) unless Y is CLEAR; every BEGIN of a pair is matched by exactly one END.
struct Event {
  EventType type = EventType::UnknownBegin;
  PairResult pair;
  Stamp stamp;  ///< time of the poses the verdict was computed from
};

struct Settings {
  double warning_distance = 0.05;  ///< m
  double contact_distance = 0.0;   ///< m
  double hysteresis = 0.005;       ///< m: a status is left only once past its threshold by this
  double pose_timeout = 0.5;       ///< s
  /// s: with a rotating body, a contact later than this is reported as time_to_collision +inf
  /// (a body spinning near another, without ever touching it, would otherwise be followed for
  /// ever). Bodies that only translate get their exact time however far.
  double ttc_horizon = 10.0;
  core::BackendType backend = core::BackendType::Gjk;
  std::size_t max_bodies = 10000;
  std::size_t max_vertices_per_part = 100000;
  std::size_t max_parts_per_body = 1000;
  /// At most this many UNKNOWN pairs are listed in CycleResult::pairs (those of the stale bodies
  /// in slot order: the order of addition until a new body takes a removed one's slot); the rest
  /// are counted in CycleResult::num_unknown_pairs and implied by stale_bodies. Pairs whose bodies
  /// never had a pose get events and are tracked only while listed. Unlimited by default, as the
  /// contract asks; 1,000 bodies without poses are ~500k pairs (first cycle ~0.6 s and ~370 MB with
  /// their UNKNOWN_BEGIN events), so a node may want to set a cap.
  std::size_t max_unknown_pairs = std::numeric_limits<std::size_t>::max();
  /// CycleResult::min_distance over every pair however far (true), or only over the pairs within
  /// max(warning, contact) + hysteresis, +inf beyond (false: no search past the broad phase).
  bool exact_min_distance = true;
  /// Each pair at one time (true): of two timed poses of different stamps, the body with the
  /// newer one is taken back to the older stamp along its recent poses (interpolated: translation
  /// linear, rotation along the shortest arc), so the verdict is the pair's at the stamp it
  /// carries. false: each body at its held (latest) pose, which mixes times when the sources'
  /// rates or lags differ. While poses are kept (fresh timed poses of different stamps within
  /// pose_timeout), a pair whose stamp moves on is also checked at every kept stamp in between
  /// of a body of it that moved (catch-up): a pass between two poses of the slower body gets its
  /// events, stamped when it happened.
  bool align_poses = true;
  /// A timed pose given without a twist (setPose()) whose body's held pose is timed, older and
  /// within pose_timeout moves as the two say: linear velocity the origin's displacement over the
  /// time between them, angular the rotation from one to the other over that time (the twist
  /// that takes the older pose to the newer one, as time_to_collision reads a twist). Again at the
  /// held stamp, the body keeps the twist it has. Without the two (its first pose, a static
  /// one, a gap longer than pose_timeout) or where they are the same, the body is at rest. For
  /// the sources that give no twist (TF, PoseStamped). false: a pose without a twist is at rest.
  bool estimate_twists = false;
};

/// Everything one check cycle produced.
struct CycleResult {
  /// The time the verdict holds for: the oldest of the pairs' stamps (Settings::align_poses: a
  /// pair of a still older body carries the newer stamp; every fresh body counted, groups and
  /// disabled pairs alike); the oldest timed pose stamp without align_poses.
  Stamp stamp;
  bool in_collision = false;
  double min_distance = std::numeric_limits<double>::infinity();
  std::vector<PairResult> pairs;  ///< every pair in WARNING, COLLISION or UNKNOWN
  std::vector<Event> events;      ///< transitions since the previous cycle
  std::vector<std::string> stale_bodies;
  std::size_t num_bodies = 0;
  std::size_t num_pairs_checked = 0;  ///< narrow-phase (GJK) pair checks this cycle
  /// Of num_pairs_checked, those at stamps between a pair's last check and this one (catch-up,
  /// Settings::align_poses).
  std::size_t num_pairs_caught_up = 0;
  /// Stamps catch-up passed over without a check: neither body can have moved far enough since
  /// the last stamp it checked the pair at to change the pair's status.
  std::size_t num_catch_up_skips = 0;
  double compute_time = 0.0;  ///< s, wall time of check()
  /// Pairs the broad phase handed on (may collide, boxes within warning_distance + hysteresis);
  /// each is either checked (num_pairs_checked) or answered from its previous result because
  /// neither body moved since (num_pairs_cached).
  std::size_t num_broad_phase_pairs = 0;
  std::size_t num_pairs_cached = 0;
  /// Pairs with a stale body, listed or not (pairs whose query failed are not counted).
  std::size_t num_unknown_pairs = 0;
  std::size_t num_part_checks = 0;  ///< convex part-pair GJK runs (<= parts_a * parts_b per pair)
  /// Warm-start caches (sizeof(core::PairCache), 224 bytes, each) held over every tracked pair
  /// after this check: one per part pair, at most 4,096 a pair; for a pair of more part pairs, one
  /// per part pair queried since its caches were last dropped (when 4,096 are held).
  std::size_t num_part_caches = 0;
  /// WorldModel::abandonChecks() cut this check short: nothing in it is a verdict.
  bool abandoned = false;
};

struct BodyInfo {
  std::string id;
  std::string frame;
  std::string group;
  bool stale = true;
};

/// Exact bounding box of `shape` at `pose` (fixed frame), equal to ConvexShape::aabb() up to
/// rounding but in closed form for points, segments, boxes, ellipsoids and cylinders, and by one
/// pass over the vertices for polytopes of up to 64 vertices (ConvexShape::aabb() otherwise).
/// What the world model boxes its parts with on every pose change.
core::Aabb shapeAabb(const core::ConvexShape& shape, const Transform3& pose);

class WorldModel {
 public:
  explicit WorldModel(const Settings& settings = Settings());
  ~WorldModel();
  WorldModel(const WorldModel&) = delete;
  WorldModel& operator=(const WorldModel&) = delete;

  const Settings& settings() const;
  /// Changes the settings of a running model (the node's dynamic_reconfigure). The limits
  /// (max_bodies, max_vertices_per_part, max_parts_per_body, max_unknown_pairs) stay as
  /// constructed: they bound what is already admitted. Statuses move to the new thresholds at
  /// the next check(), with the usual hysteresis and events; when the broad phase's reach
  /// changes, every box is swept again there (a pair now within reach is found although neither
  /// body moved). A new backend drops every cached result and warm start.
  void setSettings(const Settings& settings);

  /// Adds, or replaces a body with the same id (same origin only). Returns an empty string on
  /// success, else the reason it was refused (nothing changed then).
  ///
  /// Replacing keeps the body's pair statuses (no END/BEGIN flapping when the new geometry still
  /// collides: the next check() decides with the usual hysteresis) but drops their warm-start
  /// caches and cached results. The held pose is kept when frame and pose source are unchanged,
  /// else dropped (the body is UNKNOWN until its new source delivers a pose).
  std::string addBody(BodySpec spec);
  /// Removes a body and its pair states and warm-start caches. False when unknown. Pairs of it
  /// that were WARNING, COLLISION or UNKNOWN get their END event (pair status CLEAR) in the next
  /// check(), so every BEGIN stays matched; pairs never seen in such a status vanish silently.
  bool removeBody(const std::string& id);
  bool hasBody(const std::string& id) const;
  /// Every body, sorted by id.
  std::vector<BodyInfo> listBodies(Stamp now) const;

  /// Pairs never checked: adjacent links, SRDF <disable_collisions>, the disabled_pairs param.
  /// Order of a and b does not matter; ids need not exist yet.
  void disablePair(const std::string& a, const std::string& b);
  /// SRDF <disable_default_collisions>: the body `id` is checked against no other body (those of
  /// later bodies included) but the ones enablePair() names with it. It need not exist yet.
  void disableByDefault(const std::string& id);
  /// SRDF <enable_collisions>: the pair is checked although a body of it is disabled by default;
  /// disablePair() still wins.
  void enablePair(const std::string& a, const std::string& b);
  /// disablePair() named the pair, or a body of it is disabled by default and enablePair() did
  /// not name it.
  bool isPairDisabled(const std::string& a, const std::string& b) const;

  /// Sets a body's pose (body frame -> fixed frame) valid at `stamp` (s). A stamp older than the
  /// one held is ignored (returns false): out-of-order input never replaces newer data. `twist`:
  /// its velocity, for time_to_collision; without one the body is at rest, or moves as its last
  /// two poses say (Settings::estimate_twists).
  /// `stamp` <= 0 means static (never stale). `received`: when the pose came, if that was before
  /// `stamp` (a publisher whose clock runs ahead): the pose ages from then, not from its stamp,
  /// which is kept for everything else (ordering, the verdict's time). A static `received` (0:
  /// no clock yet) is not used. A check() whose `now` is before the last check's (the clock went
  /// back) ages the poses that arrived after `now` from `now`.
  bool setPose(const std::string& id, const Transform3& pose, Stamp stamp,
               const std::optional<Twist>& twist = std::nullopt,
               std::optional<Stamp> received = std::nullopt);
  /// Whether setPose() keeps every timed pose (for catch-up, Settings::align_poses) rather than
  /// the last two: while the last checks within pose_timeout found fresh timed poses of
  /// different stamps or a body posed more than once between two checks (a source that outran
  /// them), and from such a body's second pose since the last check on. A source that knows
  /// poses between two checks (TF) gives them with align_poses: its second turns keeping on.
  bool keepsPoses() const;
  /// Marks a body's pose as unresolvable now (e.g. TF lookup failed): its pairs turn UNKNOWN.
  /// `why`, if given, ends the queries' "no pose yet" or "unresolved pose" message until the
  /// body's next pose.
  void markUnresolved(const std::string& id, const std::string& why = {});
  /// Forgets every held pose (e.g. time jumped backwards) except static ones (stamp 0, which
  /// hold at any time and are not sent again): their pairs UNKNOWN until new poses.
  void clearPoses();

  /// One cycle at time `now` (s): staleness, broad phase, narrow phase, hysteresis, events.
  ///
  /// Every pair that may collide (not the same body, not disabled, not sharing a non-empty
  /// group) gets a status. A pair with a stale body (no pose, older than pose_timeout at `now`,
  /// or unresolved) is UNKNOWN, with an UNKNOWN_BEGIN when it becomes so, also a pair of a body
  /// that never had a pose (while listed: Settings::max_unknown_pairs). Pairs whose padded
  /// boxes are farther apart than max(warning, contact) + hysteresis are CLEAR without GJK; a
  /// pair whose bodies both kept their pose and geometry reuses its previous result (counted in
  /// num_pairs_cached, not in num_pairs_checked). Pairs and events are sorted by (body_a,
  /// body_b), with body_a < body_b; a pair's END comes before its BEGIN. Event stamps: the older
  /// timed pose stamp of the pair (the newer when the older body is still, align_poses), or a
  /// stamp between the pair's last check and this one (catch-up, Settings::align_poses: such
  /// events come first among the pair's, in stamp order, and may be older than
  /// CycleResult::stamp), never before the pair's last such event's; `now` when both are static,
  /// and for UNKNOWN_BEGIN and removal (an UNKNOWN_END carries the stamp of the verdict it comes
  /// with).
  CycleResult check(Stamp now);

  /// For shutdown: the check running in another thread, and every later one, stops within one
  /// part pair's query and returns with CycleResult::abandoned set; queries return failures.
  /// A check of bodies of a thousand parts each runs for seconds, which a process that is asked
  /// to stop should not wait for. The model is for destruction only afterwards. The one call
  /// that may come from another thread while a check runs.
  void abandonChecks();

  /// Signed distance between two bodies at their current poses. nullopt with `why` set when an
  /// id is unknown, a pose is stale/unresolved at `now`, or the pair has no verdict yet (aligned,
  /// its time is before a body's first pose since it came or came back: check() lists it
  /// UNKNOWN). `stamp` (optional): the time the
  /// answer holds for, as an event's (the older pose stamp of a moving body; a zero Stamp when
  /// both bodies are static).
  std::optional<PairResult> distance(const std::string& a, const std::string& b, Stamp now,
                                     std::string* why, Stamp* stamp = nullptr) const;
  /// Nearest body to `a` among those it may collide with (respects groups and disabled pairs);
  /// of bodies exactly as near, the smallest id. nullopt (the nearest unknown) while one of them
  /// is stale or its pair with `a` has no verdict yet (distance()). `stamp`: as distance()'s.
  std::optional<PairResult> nearest(const std::string& a, Stamp now, std::string* why,
                                    Stamp* stamp = nullptr) const;
  /// A hypothetical body at `pose` (body frame -> fixed frame) against every body with a fresh
  /// pose (respecting its group); returns all within `margin`, sorted by distance.
  /// Also every body in COLLISION whatever the margin; a body with the same id as `body` and the
  /// disabled pairs of that id are skipped ("that body, moved to `pose`"), unless `anonymous`
  /// (the id is only a label: no pair rule of it applies, but bodies off by default, SRDF
  /// <disable_default_collisions>, are skipped for it too). Status from the thresholds without
  /// hysteresis. nullopt with `why` set when checkSpec(body) refuses it or the pose is not rigid
  /// (a finite pose composed with a finite frame may overflow): an empty answer would read as
  /// "nothing near". A tracked id's own group applies as well as `body.group`. Bodies without a
  /// fresh pose (or whose query failed) are UNKNOWN pairs, at most max_unknown_pairs of them;
  /// `num_unknown`, if given, gets how many there are in all.
  std::optional<std::vector<PairResult>> checkHypothetical(const BodySpec& body,
                                                           const Transform3& pose, double margin,
                                                           Stamp now, bool anonymous = false,
                                                           std::size_t* num_unknown = nullptr,
                                                           std::string* why = nullptr) const;

  /// Current pose of a body (fixed frame) if it has one.
  std::optional<Transform3> pose(const std::string& id) const;
  const BodySpec* body(const std::string& id) const;
  std::size_t size() const;
  /// Group names the model keeps an id for (at most about twice the bodies: unused ones are
  /// forgotten).
  std::size_t groupNames() const;

  /// Why `spec` is not an acceptable body, ignoring capacity and origin ownership (checked by
  /// addBody() too); empty when acceptable. For the ~check_collision service.
  std::string checkSpec(const BodySpec& spec) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace world
}  // namespace collision_monitor
