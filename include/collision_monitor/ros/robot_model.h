/// \file
/// Robot descriptions -> world bodies: URDF links (urdfdom) and SRDF <disable_collisions>
/// (tinyxml2). Pure functions: the XML comes in as strings, meshes through the MeshLoader.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <unordered_map>
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
  /// One body per link with <collision> elements: id = link name, frame = the link's TF frame
  /// (prefixedFrame() of the tf_prefix and the link name), origin Urdf, pose from TF, parts = its
  /// collision geometries (box, sphere, cylinder, mesh hull).
  std::vector<world::BodySpec> bodies;
  /// Links joined by a joint, where links without collision geometry are skipped over: each
  /// body's nearest ancestor that is itself a body (so panda_link7 and panda_hand are adjacent
  /// through the geometry-less panda_link8).
  std::vector<IdPair> adjacent;
  /// Elements and links left out, each with the reason ("panda_hand: collision 1 (mesh): ...";
  /// collision elements are counted as urdfdom keeps them). Other links load.
  std::vector<std::string> errors;
  /// Entries of the LinkSettings that apply to nothing: no such link, or a link without
  /// <collision> elements ("robot_link_padding: 'panda_hnd' is not a link of robot 'panda'").
  std::vector<std::string> link_errors;
};

/// Settings of single links, by link name (`~robot_link_padding`, `~robot_link_groups`).
struct LinkSettings {
  std::map<std::string, double> padding;     ///< m, >= 0, in place of the robot's padding
  std::map<std::string, std::string> group;  ///< the link's group (as Body.group); else none
};

/// Links a URDF may declare (any link, with or without geometry): urdfdom's memory and parse time
/// grow with the count (10,000 links: ~60 MB, 0.4 s; 100,000: ~600 MB, 4 s).
constexpr std::size_t kMaxUrdfLinks = 10000;
/// Joints between a link and its root link: tf2 resolves at most 1,000 hops
/// (tf2::BufferCore::MAX_GRAPH_DEPTH; deeper lookups fail as "contains a loop"), so deeper links
/// could never be posed. It also bounds the recursion when urdfdom frees a chain.
constexpr std::size_t kMaxUrdfDepth = 1000;

/// The structure of a URDF, checked with tinyxml2 before urdfdom (TinyXML, recursive) sees it:
/// XML nested at most TINYXML2_MAX_ELEMENT_DEPTH (100) deep, a <robot> root, at most
/// kMaxUrdfLinks links, unique link and joint names, no link that is its own parent, no link with
/// two parent joints, no cycle of joints, no link more than kMaxUrdfDepth joints below its root.
/// Empty when fine, else the reason. Linear time, no recursion beyond the XML depth limit.
/// `collisions`, if given: link name -> its number of <collision> elements (links with any).
std::string checkUrdfStructure(const std::string& urdf_xml,
                               std::unordered_map<std::string, std::size_t>* collisions = nullptr);

/// The TF frame robot_state_publisher (ROS 1, 1.15.2 and later) publishes for link `frame` under
/// its `tf_prefix` parameter, as tf 1 resolved names: a frame with a leading '/' loses it and takes
/// no prefix; else the prefix, less one leading '/', and a '/' when it is not empty, then the
/// frame ("left" and "panda_link0": "left/panda_link0"; "" and "panda_link0": "panda_link0").
std::string prefixedFrame(const std::string& tf_prefix, const std::string& frame);

/// Parses a URDF string with urdf::parseURDF after checkUrdfStructure. Fails when the XML is not a
/// URDF or its structure is refused. A refused <collision> element (and one urdfdom dropped for
/// want of geometry) is listed in `errors` and left out of its link, which keeps the others; a
/// link whose every element is refused is left out. `padding` (m, >= 0) inflates every part of
/// a link that `links.padding` does not name; a named link takes its own. Links are in no group
/// unless `links.group` names them. Each link is attached to prefixedFrame(tf_prefix, link).
Expected<RobotBodies> bodiesFromUrdf(const std::string& urdf_xml, double padding,
                                     const Limits& limits, const MeshLoader& load_mesh,
                                     const LinkSettings& links = {},
                                     const std::string& tf_prefix = "");

/// The collision rules of an SRDF (srdfdom 0.6, as MoveIt's allowed collision matrix reads
/// them): a pair is never checked when <disable_collisions> names it; else it is checked when
/// <enable_collisions> names it; else it is never checked when either link is named by
/// <disable_default_collisions link=""/>.
struct SrdfCollisions {
  std::string robot_name;                ///< <robot name="">: whose rules they are
  std::vector<IdPair> disabled;          ///< <disable_collisions link1 link2>, document order
  std::vector<std::string> default_off;  ///< <disable_default_collisions link>
  std::vector<IdPair> enabled;           ///< <enable_collisions link1 link2>
  std::size_t num_skipped = 0;           ///< elements with a missing or empty link attribute
  std::string first_skipped;             ///< why the first of them was skipped
};

/// Reads the collision rules of an SRDF string. Fails when the XML does not parse or has no
/// <robot> root; an element with a missing or empty link attribute is skipped and counted.
Expected<SrdfCollisions> collisionsFromSrdf(const std::string& srdf_xml);

}  // namespace ros_layer
}  // namespace collision_monitor
