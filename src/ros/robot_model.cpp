#include "collision_monitor/ros/robot_model.h"

#include <exception>
#include <map>
#include <memory>
#include <set>

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

}  // namespace

Expected<RobotBodies> bodiesFromUrdf(const std::string& urdf_xml, double padding,
                                     const Limits& limits, const MeshLoader& load_mesh) {
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(urdf_xml);
  } catch (const std::exception& e) {
    return Error{std::string("URDF does not parse: ") + e.what()};
  }
  if (!model) return Error{"URDF does not parse (see the urdfdom message above)"};
  RobotBodies out;
  out.robot_name = model->getName();
  if (auto root = model->getRoot()) out.root_link = root->name;

  for (const auto& [name, link] : model->links_) {
    if (!link) continue;
    std::vector<urdf::CollisionSharedPtr> elements = link->collision_array;
    if (elements.empty() && link->collision) elements.push_back(link->collision);
    if (elements.empty()) continue;
    collision_monitor::Body msg;
    msg.id = name;
    msg.header.frame_id = name;
    msg.operation = collision_monitor::Body::ADD;
    msg.padding = padding;
    std::string error;
    for (std::size_t i = 0; i < elements.size() && error.empty(); ++i) {
      if (!elements[i]) continue;
      auto shape = shapeOf(*elements[i]);
      if (!shape) {
        error = "collision " + std::to_string(i) + ": " + shape.error();
      } else {
        msg.parts.push_back(*shape);
      }
    }
    if (error.empty()) {
      auto spec = bodyFromMsg(msg, world::BodyOrigin::Urdf, limits, load_mesh);
      if (spec) {
        out.bodies.push_back(std::move(spec).value());
        continue;
      }
      error = spec.error();
    }
    out.errors.push_back(name + ": " + error);
  }

  // Adjacency: each body with its nearest ancestor that has collision geometry (whether or not
  // it loaded: a refused link still counts as the physical neighbour).
  std::set<std::string> with_geometry;
  for (const auto& [name, link] : model->links_) {
    if (link && (!link->collision_array.empty() || link->collision)) with_geometry.insert(name);
  }
  std::set<IdPair> seen;
  for (const auto& body : out.bodies) {
    urdf::LinkConstSharedPtr link = model->getLink(body.id);
    for (auto parent = link ? link->getParent() : nullptr; parent; parent = parent->getParent()) {
      if (with_geometry.count(parent->name)) {
        IdPair p =
            parent->name < body.id ? IdPair{parent->name, body.id} : IdPair{body.id, parent->name};
        if (seen.insert(p).second) out.adjacent.push_back(p);
        break;
      }
    }
  }
  return out;
}

Expected<std::vector<IdPair>> disabledPairsFromSrdf(const std::string& srdf_xml) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(srdf_xml.c_str(), srdf_xml.size()) != tinyxml2::XML_SUCCESS) {
    return Error{std::string("SRDF does not parse: ") + doc.ErrorStr()};
  }
  const tinyxml2::XMLElement* robot = doc.FirstChildElement("robot");
  if (robot == nullptr) return Error{"SRDF has no <robot> root element"};
  std::vector<IdPair> pairs;
  for (const tinyxml2::XMLElement* e = robot->FirstChildElement("disable_collisions"); e;
       e = e->NextSiblingElement("disable_collisions")) {
    const char* a = e->Attribute("link1");
    const char* b = e->Attribute("link2");
    if (a == nullptr || b == nullptr || *a == '\0' || *b == '\0') continue;
    pairs.emplace_back(a, b);
  }
  return pairs;
}

}  // namespace ros_layer
}  // namespace collision_monitor
