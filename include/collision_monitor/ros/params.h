/// \file
/// Parameter-server values (XmlRpc, as loaded from YAML) -> messages. Pure: no master needed,
/// unit-tested with hand-built XmlRpcValues.
///
/// `~bodies` is a list of maps with the fields of collision_monitor/Body:
/// ```yaml
/// bodies:
///   - id: table
///     frame_id: world          # TF frame (or pose_from_topic: true / pose_topic: /table_pose)
///     group: furniture
///     padding: 0.01
///     parts:
///       - type: box            # sphere|box|cylinder|cone|capsule|ellipsoid|convex|mesh, or 1..8
///         dimensions: [1.2, 0.8, 0.05]
///         pose: {position: [0, 0, 0.7], orientation: [0, 0, 0, 1]}   # or {x:, y:, z:(, w:)}
///       - type: mesh
///         resource: package://my_pkg/meshes/leg.stl
///         scale: [1, 1, 1]
///       - type: convex
///         vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]
/// ```
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <XmlRpcValue.h>
#include <collision_monitor/Body.h>

#include "collision_monitor/ros/expected.h"

namespace collision_monitor {
namespace ros_layer {

/// For a value that should have been a number: when it is text that reads as a number with an
/// exponent and no '.' ("5e-2", as roslaunch and PyYAML keep it), " (the text '5e-2': ...; write
/// 5.0e-2)" to end the error with; else empty.
std::string numberWrittenAsText(const XmlRpc::XmlRpcValue& value);

/// One entry of `~bodies` -> a Body message with operation ADD (not yet validated beyond its
/// structure: bodyFromMsg() does that). Errors name the field ("parts[1].dimensions[0]: ...").
Expected<collision_monitor::Body> bodyFromXmlRpc(const XmlRpc::XmlRpcValue& value);

/// `~disabled_pairs`: a list of two-string lists, [[a, b], ...].
Expected<std::vector<std::pair<std::string, std::string>>> pairsFromXmlRpc(
    const XmlRpc::XmlRpcValue& value);

/// A list of strings (`~mesh_roots`); a single string is a one-element list.
Expected<std::vector<std::string>> stringsFromXmlRpc(const XmlRpc::XmlRpcValue& value);

/// A map parameter from URDF link names to a setting of each link, read entry by entry.
template <typename T>
struct LinkMap {
  std::map<std::string, T> values;  ///< the valid entries
  /// One per entry left out (its link keeps the robot's setting), or the whole value when it is
  /// not a map; each names the entry ("robot_link_padding['panda_hand']: ...").
  std::vector<std::string> errors;
};

/// `~robot_link_padding`: a link's padding in metres (finite, >= 0), in place of
/// `robot_padding`: `{panda_hand: 0.02, panda_link0: 0}`.
LinkMap<double> linkPaddingFromXmlRpc(const XmlRpc::XmlRpcValue& value);

/// `~robot_link_groups`: a link's group (a non-empty string of at most kMaxNameLength bytes, as
/// Body.group; robot links are in none by default): `{panda_hand: gripper}`.
LinkMap<std::string> linkGroupsFromXmlRpc(const XmlRpc::XmlRpcValue& value);

}  // namespace ros_layer
}  // namespace collision_monitor
