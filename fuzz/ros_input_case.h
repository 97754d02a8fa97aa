/// \file
/// One ROS-input fuzz case, shared by the libFuzzer target (fuzz/fuzz_ros_input.cpp, clang, ASan +
/// UBSan) and the replay gtest (test/robustness/test_ros_fuzz_regressions.cpp, g++).
///
/// The ROS layer's untrusted input, without a master: the bytes and strings the node takes from
/// other processes, through the same functions the node calls. The first byte
/// picks the input, the rest is its payload:
///   0 a `~bodies` message on the wire: Checked<Body> (layout walk, then deserialization),
///     bodyFromMsg(), the world's own checks (addBody), and a check against a box;
///   1 a `~body_poses` message: Checked<BodyPoses>, posesFromMsg();
///   2 a `~check_collision` request: Checked<CheckCollision::Request>, bodyFromMsg() as the
///     service does, the placement's toTransform(), checkHypothetical() against a box;
///   3 a `robot_description` URDF: bodiesFromUrdf() (checkUrdfStructure(), urdfdom), the bodies
///     added to a world;
///   4 a `robot_description_semantic` SRDF: collisionsFromSrdf();
///   5 an entry of the `~bodies` parameter (an XML-RPC value): bodyFromXmlRpc(), bodyFromMsg();
///     the same value as `~robot_link_padding` and `~robot_link_groups`.
/// What must hold (the fuzz target aborts on a failure, so that libFuzzer saves the input; copy it
/// to fuzz/regressions/ros/, which test_ros_fuzz_regressions and scripts/fuzz.sh replay): a message
/// the layout walk passes deserializes without an exception (roscpp would otherwise drop it
/// silently); every refusal has a reason; no function throws (the node would log "internal error"
/// and count a bug); an accepted body has parts, and once posed it gets a verdict against a box
/// (never UNKNOWN: input that can never be checked must be refused at the door); no check gives a
/// NaN distance. Allocations are bounded by libFuzzer's -malloc_limit_mb (scripts/fuzz.sh), and
/// memory errors by ASan and UBSan. Meshes are refused (no files are read).
#pragma once

#include <cmath>
#include <cstdint>
#include <exception>
#include <string>
#include <vector>

#include <XmlRpcValue.h>
#include <collision_monitor/Body.h>
#include <collision_monitor/BodyPoses.h>
#include <collision_monitor/CheckCollision.h>
#include <ros/serialization.h>

#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/ros/conversions.h"
#include "collision_monitor/ros/params.h"
#include "collision_monitor/ros/robot_model.h"
#include "collision_monitor/ros/wire_check.h"
#include "collision_monitor/world/world_model.h"

namespace cm_fuzz_ros {

namespace cm = collision_monitor;
namespace rl = collision_monitor::ros_layer;
namespace world = collision_monitor::world;

/// A failed check (caught by runRosInput()).
struct CheckFailed {
  std::string what;
};

/// What became of the input, for CM_FUZZ_PRINT and the replay test (last note wins).
inline thread_local std::string last_note;

inline void note(const std::string& what) {
  last_note = what;
}

[[noreturn]] inline void fail(const std::string& what) {
  throw CheckFailed{what};
}

inline const rl::MeshLoader kNoMeshes = [](const std::string&, const cm::core::Vec3&)
    -> rl::Expected<std::vector<cm::core::ConvexShape>> { return rl::Error{"no meshes here"}; };

/// Checked<M> read from the payload as roscpp reads it from a connection. A failed check when
/// roscpp's deserializer throws although the layout walk passed the bytes.
template <class M>
inline rl::Checked<M> readChecked(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> bytes(data, data + size);  // IStream takes a mutable buffer
  ros::serialization::IStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  rl::Checked<M> msg;
  try {
    ros::serialization::deserialize(stream, msg);
  } catch (const std::exception& e) {
    fail(std::string("the layout walk passed a message that roscpp cannot read: ") + e.what());
  }
  return msg;
}

/// Adds a 1 m box at the origin, posed from a topic at t = 1 s.
inline void addBox(world::WorldModel& w) {
  world::BodySpec box;
  box.id = "fuzz_box";
  box.pose_source = world::PoseSource::Topic;
  box.parts.push_back(world::Part{cm::core::ConvexShape::box(cm::core::Vec3(1.0, 1.0, 1.0)),
                                  cm::core::Transform3::Identity()});
  const std::string err = w.addBody(box);
  if (!err.empty()) fail("the fuzzer's box refused: " + err);
  w.setPose("fuzz_box", cm::core::Transform3::Identity(), world::Stamp(1.0));
}

inline void checkSpec(const world::BodySpec& spec, const char* where) {
  if (spec.parts.empty()) fail(std::string(where) + ": a body without parts accepted");
}

inline void checkPairs(const std::vector<world::PairResult>& pairs, const char* where) {
  for (const auto& p : pairs) {
    if (std::isnan(p.distance)) fail(std::string(where) + ": NaN distance for " + p.body_b);
  }
}

/// Adds an accepted body to a world with a box, poses it at the identity, checks.
inline void addAndCheck(world::BodySpec spec) {
  checkSpec(spec, "~bodies");
  world::WorldModel w;
  addBox(w);
  const std::string id = spec.id;
  const std::string err = w.addBody(std::move(spec));
  if (!err.empty()) return note("addBody refused: " + err);  // ids of white space, ...
  w.setPose(id, cm::core::Transform3::Identity(), world::Stamp(1.0));
  const world::CycleResult r = w.check(world::Stamp(1.0));
  checkPairs(r.pairs, "check()");
  // Accepted and freshly posed: a verdict, never UNKNOWN (input that can never be checked must
  // be refused at the door, with its reason).
  std::string why;
  const auto d = w.distance(id, "fuzz_box", world::Stamp(1.0), &why);
  if (!d) fail("an accepted body has no distance to a box: " + why);
  if (d->status == world::PairStatus::Unknown || std::isnan(d->distance)) {
    fail("an accepted body's distance to a box is UNKNOWN (" + std::to_string(d->distance) + ")");
  }
  note("body " + id + " added and checked: " + std::to_string(r.num_pairs_checked) + " pair(s)");
}

inline void refusedWithReason(const std::string& why, const char* where) {
  if (why.empty()) fail(std::string(where) + ": refused without a reason");
  note(std::string(where) + " refused: " + why);
}

inline void fuzzBody(const std::uint8_t* data, std::size_t size) {
  const auto msg = readChecked<cm::Body>(data, size);
  if (!msg.refused.empty()) return note("~bodies layout refused: " + msg.refused);
  if (msg.operation != cm::Body::ADD) return note("operation " + std::to_string(msg.operation));
  auto spec = rl::bodyFromMsg(msg, world::BodyOrigin::Topic, rl::Limits(), kNoMeshes);
  if (!spec) return refusedWithReason(spec.error(), "bodyFromMsg");
  addAndCheck(std::move(spec).value());
}

inline void fuzzBodyPoses(const std::uint8_t* data, std::size_t size) {
  const auto msg = readChecked<cm::BodyPoses>(data, size);
  if (!msg.refused.empty()) return note("~body_poses layout refused: " + msg.refused);
  const auto updates = rl::posesFromMsg(msg);
  if (!updates) return refusedWithReason(updates.error(), "posesFromMsg");
  if (updates->size() != msg.ids.size()) fail("posesFromMsg lost or made up updates");
  note(std::to_string(updates->size()) + " pose update(s)");
}

inline void fuzzCheckCollision(const std::uint8_t* data, std::size_t size) {
  const auto req = readChecked<cm::CheckCollision::Request>(data, size);
  if (!req.refused.empty()) return note("~check_collision layout refused: " + req.refused);
  if (!std::isfinite(req.margin)) return note("margin not finite");
  bool anonymous = false;
  const cm::Body body = rl::hypotheticalBody(req.body, "world", &anonymous);
  auto spec = rl::bodyFromMsg(body, world::BodyOrigin::Topic, rl::Limits(), kNoMeshes);
  if (!spec) return refusedWithReason(spec.error(), "bodyFromMsg (check_collision)");
  checkSpec(*spec, "~check_collision");
  const auto pose = rl::toTransform(req.pose, rl::ZeroQuaternion::Identity);
  if (!pose) return refusedWithReason(pose.error(), "toTransform");
  world::WorldModel w;
  addBox(w);
  std::string why;
  const auto pairs =
      w.checkHypothetical(*spec, *pose, req.margin, world::Stamp(1.0), anonymous, nullptr, &why);
  if (!pairs) return refusedWithReason(why, "checkHypothetical");
  checkPairs(*pairs, "checkHypothetical()");
  note("check_collision: " + std::to_string(pairs->size()) + " pair(s)");
}

inline void fuzzUrdf(const std::string& xml) {
  const auto robot = rl::bodiesFromUrdf(xml, 0.0, rl::Limits(), kNoMeshes);
  if (!robot) return refusedWithReason(robot.error(), "bodiesFromUrdf");
  world::WorldModel w;
  for (const auto& b : robot->bodies) {
    checkSpec(b, "bodiesFromUrdf");
    w.addBody(b);
    w.setPose(b.id, cm::core::Transform3::Identity(), world::Stamp(1.0));
  }
  checkPairs(w.check(world::Stamp(1.0)).pairs, "check() of a URDF");
  note("URDF: " + std::to_string(robot->bodies.size()) + " bodies, " +
       std::to_string(robot->errors.size()) + " elements refused");
}

inline void fuzzSrdf(const std::string& xml) {
  const auto rules = rl::collisionsFromSrdf(xml);
  if (!rules) return refusedWithReason(rules.error(), "collisionsFromSrdf");
  if (rules->num_skipped > 0 && rules->first_skipped.empty()) fail("an SRDF skip without reason");
  note("SRDF: " + std::to_string(rules->disabled.size()) + " disabled, " +
       std::to_string(rules->num_skipped) + " skipped");
}

/// The same value as `~robot_link_padding` and `~robot_link_groups`: every entry kept is valid,
/// every one left out has a reason.
inline void fuzzLinkMaps(const XmlRpc::XmlRpcValue& value) {
  const auto padding = rl::linkPaddingFromXmlRpc(value);
  for (const auto& [link, pad] : padding.values) {
    if (!std::isfinite(pad) || pad < 0.0) fail("robot_link_padding kept a bad padding of " + link);
  }
  const auto groups = rl::linkGroupsFromXmlRpc(value);
  for (const auto& [link, group] : groups.values) {
    if (group.empty() || group.size() > rl::kMaxNameLength) {
      fail("robot_link_groups kept a bad group of " + link);
    }
  }
  for (const auto* errors : {&padding.errors, &groups.errors}) {
    for (const auto& e : *errors) {
      if (e.empty()) fail("a link map entry left out without a reason");
    }
  }
}

inline void fuzzXmlRpc(const std::string& xml) {
  int offset = 0;
  XmlRpc::XmlRpcValue value(xml, &offset);
  if (!value.valid()) return note("no XML-RPC value");
  fuzzLinkMaps(value);
  const auto msg = rl::bodyFromXmlRpc(value);
  if (!msg) return refusedWithReason(msg.error(), "bodyFromXmlRpc");
  auto spec = rl::bodyFromMsg(*msg, world::BodyOrigin::Parameter, rl::Limits(), kNoMeshes);
  if (!spec) return refusedWithReason(spec.error(), "bodyFromMsg (parameter)");
  addAndCheck(std::move(spec).value());
}

/// Outcome of one input.
struct Outcome {
  std::string failure;  ///< empty: every check held
  std::string note;     ///< what became of the input ("body b added and checked: 1 pair(s)", ...)
};

/// Runs one input (first byte: the kind, see the file comment) through its checks.
inline Outcome runRosInput(const std::uint8_t* data, std::size_t size) {
  Outcome out;
  last_note.clear();
  if (size == 0) return out;
  const std::uint8_t* payload = data + 1;
  const std::size_t n = size - 1;
  const std::string text(reinterpret_cast<const char*>(payload), n);
  try {
    switch (data[0] % 6) {
      case 0:
        fuzzBody(payload, n);
        break;
      case 1:
        fuzzBodyPoses(payload, n);
        break;
      case 2:
        fuzzCheckCollision(payload, n);
        break;
      case 3:
        fuzzUrdf(text);
        break;
      case 4:
        fuzzSrdf(text);
        break;
      default:
        fuzzXmlRpc(text);
        break;
    }
  } catch (const CheckFailed& f) {
    out.failure = f.what;
  } catch (const std::exception& e) {
    out.failure = std::string("exception: ") + e.what();
  }
  out.note = last_note;
  return out;
}

}  // namespace cm_fuzz_ros
