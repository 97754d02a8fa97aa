/// \file
/// The boundary between ROS messages and the ROS-free world model. Every function here is pure
/// (no NodeHandle, no master, no I/O except through the injected MeshLoader) and returns either
/// the converted value or the reason the input was refused; nothing here throws.
///
/// Validation rules (docs/node.md, "Input validation"):
/// - every number must be finite;
/// - quaternions: |q| within kQuaternionTolerance of 1 is accepted and normalised; a zero
///   quaternion means identity in Shape.pose only (as Shape.msg says) and is refused elsewhere;
///   anything else is refused;
/// - sizes >= 0 with the exact dimension count of the type; a part with no extent at all
///   (zero-radius sphere, all-zero box, coincident CONVEX points) is degenerate and refused;
/// - scale: 0,0,0 means 1,1,1; otherwise every component > 0. It applies to MESH and CONVEX
///   parts; primitives accept only 0,0,0 or 1,1,1;
/// - CONVEX: 1..max_vertices_per_part vertices; MESH: a non-empty resource (resolved and loaded by
///   the MeshLoader, which enforces mesh_roots);
/// - bodies: non-empty id, 1..max_parts_per_body parts, padding >= 0, a frame_id unless the pose
///   comes from a topic; a non-empty pose_topic implies pose_from_topic;
/// - lengths: ids, frame ids, groups and topic names at most kMaxNameLength bytes, mesh resources
///   at most kMaxResourceLength bytes. Messages quote input strings through quoteInput() only, so
///   no error text grows with the input.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <collision_monitor/Body.h>
#include <collision_monitor/BodyPoses.h>
#include <collision_monitor/CollisionEvent.h>
#include <collision_monitor/CollisionState.h>
#include <collision_monitor/PairState.h>
#include <collision_monitor/Shape.h>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Twist.h>

#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/core/math.h"
#include "collision_monitor/ros/expected.h"
#include "collision_monitor/world/world_model.h"

namespace collision_monitor {
namespace ros_layer {

/// |q| may differ from 1 by this much; such quaternions are normalised, others refused.
constexpr double kQuaternionTolerance = 1e-3;

/// Longest id, frame id, group or topic name accepted (bytes).
constexpr std::size_t kMaxNameLength = 256;
/// Longest mesh resource URI accepted (bytes; PATH_MAX).
constexpr std::size_t kMaxResourceLength = 4096;
/// How many bytes of an input string an error message quotes.
constexpr std::size_t kQuoteLength = 120;

/// `s` (at most `max_bytes` of it) with control characters and bytes >= 0x7f escaped as \xNN:
/// input-derived text in a log line keeps it one line.
std::string escapeInput(const std::string& s, std::size_t max_bytes = std::string::npos);

/// A frame name as tf2 names it: without one leading '/' (tf2 drops one from a transform's frames;
/// its lookups refuse it). "/" gives "".
std::string tfFrameName(const std::string& frame);

/// `s` in single quotes for an error message: at most `max_bytes` of it, then "...' (N bytes)";
/// control characters and bytes >= 0x7f are escaped as \xNN (a log line stays one line).
std::string quoteInput(const std::string& s, std::size_t max_bytes = kQuoteLength);

/// Empty when `s` is at most `max_bytes` long; else the error ("<what> is N bytes, longer than
/// the limit of M: '<first bytes>...' (N bytes)").
std::string checkLength(const std::string& s, std::size_t max_bytes, const std::string& what);

/// Every coordinate finite.
bool finite(const geometry_msgs::Point& p);
bool finite(const geometry_msgs::Vector3& v);

/// True when no point is apart from the first (a CONVEX part or a mesh refused as a point; the
/// core would take it).
bool allCoincide(const std::vector<core::Vec3>& points);

/// What a zero quaternion means where a pose enters.
enum class ZeroQuaternion {
  Identity,  ///< Shape.pose: "zero quaternion means identity"
  Refuse,    ///< every other pose
};

/// Size limits applied to every body, wherever it comes from.
struct Limits {
  std::size_t max_vertices_per_part = 100000;
  std::size_t max_parts_per_body = 1000;
};

/// Loads a MESH part: `uri` (package:// or file://) scaled by `scale` -> its convex hull (or one
/// per piece, parameter `mesh_decomposition`), or the reason it cannot be (outside mesh_roots,
/// unreadable, too many vertices, ...). The node passes a caching loader confined to mesh_roots
/// (mesh_loader.h); tests pass fakes.
using MeshLoader = std::function<Expected<std::vector<core::ConvexShape>>(const std::string& uri,
                                                                          const core::Vec3& scale)>;

/// A geometry_msgs/Pose as a rigid transform. Refuses non-finite values and quaternions whose
/// norm is off by more than kQuaternionTolerance (a zero quaternion per `zero`).
Expected<core::Transform3> toTransform(const geometry_msgs::Pose& pose,
                                       ZeroQuaternion zero = ZeroQuaternion::Refuse);

/// "sphere", "BOX", "3", ... -> Shape type constant (1..8); nullopt when unknown.
std::optional<std::uint8_t> shapeTypeFromString(const std::string& name);
/// Shape type constant -> lower-case name ("sphere"); "type N" when unknown.
std::string shapeTypeName(std::uint8_t type);

/// One Shape message -> its convex shapes (unpadded, in the part frame): one, or a mesh's pieces.
Expected<std::vector<core::ConvexShape>> shapesFromMsg(const collision_monitor::Shape& msg,
                                                       const Limits& limits,
                                                       const MeshLoader& load_mesh);

/// One Shape message -> world parts (shapes padded by `padding`, placed by msg.pose).
Expected<std::vector<world::Part>> partsFromMsg(const collision_monitor::Shape& msg, double padding,
                                                const Limits& limits, const MeshLoader& load_mesh);

/// A Body message with operation ADD -> the world's body spec. Errors name the part
/// ("part 1 (sphere): negative radius -1"). max_parts_per_body counts the message's parts, and
/// again the world parts they became (a mesh split into pieces is several).
Expected<world::BodySpec> bodyFromMsg(const collision_monitor::Body& msg, world::BodyOrigin origin,
                                      const Limits& limits, const MeshLoader& load_mesh);

/// The body of a `~check_collision` request as the service checks it: an ADD posed by the request
/// (pose_from_topic and pose_topic cleared), in `fixed_frame` when its frame is empty, labelled
/// "check_collision" when its id is empty. `anonymous`: the id was empty (a label only, never a
/// tracked body's id).
collision_monitor::Body hypotheticalBody(const collision_monitor::Body& msg,
                                         const std::string& fixed_frame, bool* anonymous);

/// One validated entry of a BodyPoses message, still in the message's header frame.
struct PoseUpdate {
  std::string id;
  core::Transform3 pose;              ///< body frame -> header frame
  std::optional<world::Twist> twist;  ///< header frame (linear m/s, angular rad/s)
};

/// Validates a BodyPoses message as a whole (array lengths, empty or duplicated ids, finite
/// values, unit quaternions). Any error refuses the whole message.
Expected<std::vector<PoseUpdate>> posesFromMsg(const collision_monitor::BodyPoses& msg);

/// The same update expressed in another frame: pose and twist mapped by `frame_to_fixed`
/// (header frame -> fixed frame; twists are rotated, the motion of the frame itself is ignored).
PoseUpdate transformUpdate(const PoseUpdate& update, const core::Transform3& frame_to_fixed);

/// Eigen/ROS glue.
core::Vec3 toVec3(const geometry_msgs::Point& p);
core::Vec3 toVec3(const geometry_msgs::Vector3& v);
geometry_msgs::Point toPointMsg(const core::Vec3& v);
geometry_msgs::Vector3 toVector3Msg(const core::Vec3& v);
geometry_msgs::Pose toPoseMsg(const core::Transform3& t);

/// A pair result as a message; points and normal mapped by `to_frame` (fixed frame -> the frame
/// of the message; identity keeps the fixed frame).
collision_monitor::PairState toMsg(const world::PairResult& pair,
                                   const core::Transform3& to_frame = core::Transform3::Identity());

/// ROS time <-> the world model's stamps, both in integer nanoseconds: exact both ways for every
/// ros::Time (a stamp <= 0 becomes ros::Time(0)).
inline world::Stamp toStamp(const ros::Time& t) {
  return world::Stamp::fromNanoseconds(static_cast<std::int64_t>(t.toNSec()));
}
inline ros::Time toRosTime(world::Stamp s) {
  ros::Time t;
  if (!s.isStatic()) t.fromNSec(static_cast<std::uint64_t>(s.nanoseconds()));
  return t;
}

/// Event and state messages in `fixed_frame`. A stamp <= 0 (only static poses were used) is
/// replaced by `now`.
collision_monitor::CollisionEvent toMsg(const world::Event& event, const std::string& fixed_frame,
                                        world::Stamp now);
collision_monitor::CollisionState toMsg(const world::CycleResult& cycle,
                                        const std::string& fixed_frame, world::Stamp now);

}  // namespace ros_layer
}  // namespace collision_monitor
