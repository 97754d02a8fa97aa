#include "collision_monitor/ros/robot_model.h"

#include <exception>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <unordered_map>
#include <vector>

#include <tinyxml2.h>
#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

namespace collision_monitor {
namespace ros_layer {

namespace {

/// A URDF collision element as a Shape message, so that URDF links go through the same
/// validation as bodies from topics and parameters.
Expected<collision_monitor::Shape> shapeOf(const urdf::Collision& c) {
  collision_monitor::Shape s;
  const urdf::Geometry* g = c.geometry.get();
  if (g == nullptr) return Error{"collision element without geometry"};
  switch (g->type) {
    case urdf::Geometry::SPHERE:
      s.type = collision_monitor::Shape::SPHERE;
      s.dimensions = {static_cast<const urdf::Sphere*>(g)->radius};
      break;
    case urdf::Geometry::BOX: {
      const auto& d = static_cast<const urdf::Box*>(g)->dim;
      s.type = collision_monitor::Shape::BOX;
      s.dimensions = {d.x, d.y, d.z};
      break;
    }
    case urdf::Geometry::CYLINDER: {
      const auto* cyl = static_cast<const urdf::Cylinder*>(g);
      s.type = collision_monitor::Shape::CYLINDER;
      s.dimensions = {cyl->length, cyl->radius};
      break;
    }
    case urdf::Geometry::MESH: {
      const auto* mesh = static_cast<const urdf::Mesh*>(g);
      // Shape's scale 0,0,0 means 1,1,1 (an unset message field); in a URDF it is a point.
      if (mesh->scale.x == 0.0 && mesh->scale.y == 0.0 && mesh->scale.z == 0.0)
        return Error{"mesh scale 0 0 0 makes it a point"};
      s.type = collision_monitor::Shape::MESH;
      s.resource = mesh->filename;
      s.scale.x = mesh->scale.x;
      s.scale.y = mesh->scale.y;
      s.scale.z = mesh->scale.z;
      break;
    }
    default:
      return Error{"unsupported URDF geometry type " + std::to_string(g->type)};
  }
  s.pose.position.x = c.origin.position.x;
  s.pose.position.y = c.origin.position.y;
  s.pose.position.z = c.origin.position.z;
  c.origin.rotation.getQuaternion(s.pose.orientation.x, s.pose.orientation.y, s.pose.orientation.z,
                                  s.pose.orientation.w);
  return s;
}

/// A name from the URDF for an error text: at most 120 bytes, escaped (quoteInput).
std::string quoted(const char* name) {
  return quoteInput(name ? std::string(name) : std::string());
}

/// Releases the links' child pointers before the model is freed: urdfdom's links own their
/// children (shared_ptr), so freeing a chain recurses once per link.
struct FlattenOnExit {
  urdf::ModelInterfaceSharedPtr* model;
  ~FlattenOnExit() {
    if (!*model) return;
    for (auto& [name, link] : (*model)->links_) {
      if (!link) continue;
      link->child_links.clear();
      link->child_joints.clear();
    }
  }
};

}  // namespace

std::string checkUrdfStructure(const std::string& urdf_xml,
                               std::unordered_map<std::string, std::size_t>* collisions) {
  tinyxml2::XMLDocument doc;
  const tinyxml2::XMLError parsed = doc.Parse(urdf_xml.c_str(), urdf_xml.size());
  if (parsed == tinyxml2::XML_ELEMENT_DEPTH_EXCEEDED) {
    return "URDF nests XML elements more than " + std::to_string(TINYXML2_MAX_ELEMENT_DEPTH) +
           " deep";
  }
  if (parsed != tinyxml2::XML_SUCCESS) {
    return std::string("URDF does not parse as XML: ") + doc.ErrorStr();
  }
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) return "URDF has no <robot> root element";

  std::unordered_map<std::string, std::size_t> index;  // link name -> number
  for (const tinyxml2::XMLElement* e = robot->FirstChildElement("link"); e;
       e = e->NextSiblingElement("link")) {
    if (index.size() >= kMaxUrdfLinks) {
      return "URDF has more than " + std::to_string(kMaxUrdfLinks) + " links";
    }
    const char* name = e->Attribute("name");
    if (name == nullptr) continue;  // urdfdom reports it
    if (!index.emplace(name, index.size()).second) {
      return "URDF declares link " + quoted(name) + " more than once";
    }
    if (collisions) {
      std::size_t n = 0;
      for (const tinyxml2::XMLElement* c = e->FirstChildElement("collision"); c;
           c = c->NextSiblingElement("collision")) {
        ++n;
      }
      if (n > 0) (*collisions)[name] = n;
    }
  }
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  std::vector<std::size_t> parent(index.size(), kNone);
  std::set<std::string> joints;
  for (const tinyxml2::XMLElement* e = robot->FirstChildElement("joint"); e;
       e = e->NextSiblingElement("joint")) {
    const char* name = e->Attribute("name");
    if (name != nullptr && !joints.insert(name).second) {
      return "URDF declares joint " + quoted(name) + " more than once";
    }
    const tinyxml2::XMLElement* pe = e->FirstChildElement("parent");
    const tinyxml2::XMLElement* ce = e->FirstChildElement("child");
    const char* p = pe ? pe->Attribute("link") : nullptr;
    const char* c = ce ? ce->Attribute("link") : nullptr;
    if (p == nullptr || c == nullptr) continue;  // urdfdom reports it
    auto pi = index.find(p);
    auto ci = index.find(c);
    if (pi == index.end() || ci == index.end()) continue;  // urdfdom reports unknown links
    if (pi->second == ci->second) {
      return "URDF joint " + quoted(name) + " joins link " + quoted(c) + " to itself";
    }
    if (parent[ci->second] != kNone) {
      return "URDF link " + quoted(c) + " is the child of more than one joint (joint " +
             quoted(name) + ")";
    }
    parent[ci->second] = pi->second;
  }
  // Walking up from any link must end at a root (no cycle) within kMaxUrdfDepth joints. Each
  // link is walked over once: depth[] is known (>= 0) once a walk reached a root through it;
  // kOnWalk marks the links of the current walk.
  constexpr long kUnknown = -1, kOnWalk = -2;
  std::vector<long> depth(parent.size(), kUnknown);
  std::vector<std::size_t> walk;
  auto nameOf = [&index](std::size_t i) {
    for (const auto& [n, k] : index) {
      if (k == i) return n;
    }
    return std::string();
  };
  for (std::size_t start = 0; start < parent.size(); ++start) {
    walk.clear();
    std::size_t i = start;
    while (i != kNone && depth[i] == kUnknown) {
      depth[i] = kOnWalk;
      walk.push_back(i);
      i = parent[i];
    }
    if (i != kNone && depth[i] == kOnWalk) {
      return "URDF joints form a cycle (through link " + quoteInput(nameOf(i)) + ")";
    }
    long d = i == kNone ? -1 : depth[i];  // the depth of the link above the walk
    for (auto k = walk.rbegin(); k != walk.rend(); ++k) {
      depth[*k] = ++d;
      if (static_cast<std::size_t>(d) > kMaxUrdfDepth) {
        return "URDF link " + quoteInput(nameOf(*k)) + " is more than " +
               std::to_string(kMaxUrdfDepth) +
               " joints below its root link (tf2 resolves at most that many)";
      }
    }
  }
  return {};
}

std::string prefixedFrame(const std::string& tf_prefix, const std::string& frame) {
  if (tf_prefix.empty() || (!frame.empty() && frame[0] == '/')) return tfFrameName(frame);
  return tfFrameName(tf_prefix) + '/' + frame;
}

Expected<RobotBodies> bodiesFromUrdf(const std::string& urdf_xml, double padding,
                                     const Limits& limits, const MeshLoader& load_mesh,
                                     const LinkSettings& links, const std::string& tf_prefix) {
  std::unordered_map<std::string, std::size_t> xml_collisions;  // link -> <collision> elements
  const std::string refused = checkUrdfStructure(urdf_xml, &xml_collisions);
  if (!refused.empty()) return Error{refused};
  urdf::ModelInterfaceSharedPtr model;
  const FlattenOnExit flatten{&model};
  try {
    model = urdf::parseURDF(urdf_xml);
  } catch (const std::exception& e) {
    return Error{std::string("URDF does not parse: ") + e.what()};
  }
  if (!model) return Error{"URDF does not parse (see the urdfdom message above)"};
  RobotBodies out;
  out.robot_name = model->getName();
  if (auto root = model->getRoot()) out.root_link = root->name;
  // A link with <collision> elements, whether or not they load (urdfdom may drop them).
  auto has_geometry = [&xml_collisions](const urdf::Link* l) {
    return !l->collision_array.empty() || l->collision || xml_collisions.count(l->name) != 0;
  };
  const auto checkNames = [&](const auto& settings, const std::string& param) {
    for (const auto& entry : settings) {
      const std::string& name = entry.first;
      const auto link = model->links_.find(name);
      if (link == model->links_.end() || !link->second) {
        out.link_errors.push_back(param + ": " + quoteInput(name) + " is not a link of robot " +
                                  quoteInput(out.robot_name));
      } else if (!has_geometry(link->second.get())) {
        out.link_errors.push_back(param + ": link " + quoteInput(name) +
                                  " has no <collision> geometry");
      }
    }
  };
  checkNames(links.padding, "robot_link_padding");
  checkNames(links.group, "robot_link_groups");

  for (const auto& [name, link] : model->links_) {
    if (!link) continue;
    std::vector<urdf::CollisionSharedPtr> elements = link->collision_array;
    if (elements.empty() && link->collision) elements.push_back(link->collision);
    // urdfdom stops at the first <collision> it cannot parse (no usable <geometry>, a malformed
    // <origin>), dropping it and every later one of the link, and says so on stderr only.
    const auto in_xml = xml_collisions.find(name);
    if (in_xml != xml_collisions.end() && in_xml->second > elements.size()) {
      const std::size_t after = in_xml->second - elements.size() - 1;
      out.errors.push_back(
          name + ": <collision> " + std::to_string(elements.size() + 1) + " of " +
          std::to_string(in_xml->second) +
          " could not be parsed, e.g. no usable <geometry> (urdfdom dropped it" +
          (after == 0 ? std::string() : " and the " + std::to_string(after) + " after it") + ")");
    }
    if (elements.empty()) continue;
    const auto own = links.padding.find(name);
    const double pad = own == links.padding.end() ? padding : own->second;
    collision_monitor::Body msg;
    msg.id = name;
    msg.header.frame_id = prefixedFrame(tf_prefix, name);
    msg.operation = collision_monitor::Body::ADD;
    msg.padding = pad;
    if (const auto group = links.group.find(name); group != links.group.end()) {
      msg.group = group->second;
    }
    // Each element is a part. A refused one is reported and left out; the link keeps the others
    // (it was left out whole: one missing mesh left its boxes unchecked too). Each is converted
    // alone first (a mesh is loaded once: bodyFromMsg takes it from the cache).
    for (std::size_t i = 0; i < elements.size(); ++i) {
      if (!elements[i]) continue;
      auto shape = shapeOf(*elements[i]);
      if (!shape) {
        out.errors.push_back(name + ": collision " + std::to_string(i) + ": " + shape.error());
        continue;
      }
      auto parts = partsFromMsg(*shape, pad, limits, load_mesh);
      if (!parts) {
        out.errors.push_back(name + ": collision " + std::to_string(i) + " (" +
                             shapeTypeName(shape->type) + "): " + parts.error());
        continue;
      }
      msg.parts.push_back(*shape);
    }
    if (msg.parts.empty()) continue;
    auto spec = bodyFromMsg(msg, world::BodyOrigin::Urdf, limits, load_mesh);
    if (spec) {
      out.bodies.push_back(std::move(spec).value());
    } else {
      out.errors.push_back(name + ": " + spec.error());  // the link as a whole (too many parts)
    }
  }

  // Adjacency: each body with its nearest ancestor that has collision geometry (whether or not
  // it loaded: a refused link still counts as the physical neighbour). Memoised, so that many
  // bodies below one long geometry-less stretch walk it once; at most one step per link (no
  // cycles: checkUrdfStructure).
  std::unordered_map<const urdf::Link*, const urdf::Link*> nearest;  // link -> ancestor or null
  std::vector<const urdf::Link*> walk;
  auto nearestAncestor = [&](const urdf::Link* link) -> const urdf::Link* {
    walk.clear();
    const urdf::Link* found = nullptr;
    for (std::size_t steps = 0; link && steps <= model->links_.size(); ++steps) {
      auto memo = nearest.find(link);
      if (memo != nearest.end()) {
        found = memo->second;
        break;
      }
      walk.push_back(link);
      const urdf::Link* parent = link->getParent().get();
      if (parent && has_geometry(parent)) {
        found = parent;
        break;
      }
      link = parent;
    }
    for (const urdf::Link* l : walk)
      nearest[l] = found;
    return found;
  };
  std::set<IdPair> seen;
  for (const auto& body : out.bodies) {
    urdf::LinkConstSharedPtr link = model->getLink(body.id);
    const urdf::Link* parent = link ? nearestAncestor(link.get()) : nullptr;
    if (parent == nullptr) continue;
    IdPair p =
        parent->name < body.id ? IdPair{parent->name, body.id} : IdPair{body.id, parent->name};
    if (seen.insert(p).second) out.adjacent.push_back(p);
  }
  return out;
}

Expected<SrdfCollisions> collisionsFromSrdf(const std::string& srdf_xml) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(srdf_xml.c_str(), srdf_xml.size()) != tinyxml2::XML_SUCCESS) {
    return Error{std::string("SRDF does not parse: ") + doc.ErrorStr()};
  }
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) return Error{"SRDF has no <robot> root element"};
  SrdfCollisions out;
  if (const char* name = robot->Attribute("name")) out.robot_name = name;
  // Link names trimmed of white space, as srdfdom does.
  const auto attribute = [&](const tinyxml2::XMLElement* e,
                             const char* name) -> std::optional<std::string> {
    const char* v = e->Attribute(name);
    if (v != nullptr) {
      std::string link(v);
      const auto first = link.find_first_not_of(" \t\r\n");
      if (first != std::string::npos) {
        return link.substr(first, link.find_last_not_of(" \t\r\n") - first + 1);
      }
    }
    if (out.num_skipped++ == 0) {
      out.first_skipped = "<" + std::string(e->Name()) + "> on line " +
                          std::to_string(e->GetLineNum()) + " has no '" + name + "' attribute";
    }
    return std::nullopt;
  };
  for (const tinyxml2::XMLElement* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) {
    const std::string tag = e->Name();
    if (tag == "disable_default_collisions") {
      if (auto link = attribute(e, "link")) out.default_off.push_back(std::move(*link));
    } else if (tag == "disable_collisions" || tag == "enable_collisions") {
      auto a = attribute(e, "link1");
      auto b = a ? attribute(e, "link2") : std::nullopt;
      if (!b) continue;
      (tag == "enable_collisions" ? out.enabled : out.disabled).emplace_back(*a, *b);
    }
  }
  return out;
}

}  // namespace ros_layer
}  // namespace collision_monitor
