/// \file
/// Robot descriptions -> world bodies: URDF links (urdfdom) and SRDF <disable_collisions>
/// (tinyxml2). Pure functions: the XML comes in as strings, meshes through the MeshLoader.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "collision_monitor/ros/conversions.h"
#include "collision_monitor/ros/expected.h"
#include "collision_monitor/world/world_model.h"

namespace collision_monitor {
namespace ros_layer {

using IdPair = std::pair<std::string, std::string>;

struct RobotBodies {
  std::string robot_name;
  std::string root_link;
  /// One body per link with <collision> elements: id = frame = link name, origin Urdf,
  /// pose from TF, parts = its collision geometries (box, sphere, cylinder, mesh hull).
  std::vector<world::BodySpec> bodies;
  /// Links joined by a joint, where links without collision geometry are skipped over: each
  /// body's nearest ancestor that is itself a body (so panda_link7 and panda_hand are adjacent
  /// through the geometry-less panda_link8).
  std::vector<IdPair> adjacent;
  /// Links left out, each with the reason ("panda_hand: part 0 (mesh): ..."). Other links load.
  std::vector<std::string> errors;
};

/// Parses a URDF string with urdf::parseURDF. Fails only when the XML is not a URDF; a link whose
/// geometry is refused is listed in `errors` and left out. `padding` (m, >= 0) inflates every part.
Expected<RobotBodies> bodiesFromUrdf(const std::string& urdf_xml, double padding,
                                     const Limits& limits, const MeshLoader& load_mesh);

/// Every <disable_collisions link1="" link2=""/> of an SRDF string, in document order. Fails when
/// the XML does not parse or has no <robot> root; entries with a missing attribute are skipped.
Expected<std::vector<IdPair>> disabledPairsFromSrdf(const std::string& srdf_xml);

}  // namespace ros_layer
}  // namespace collision_monitor
