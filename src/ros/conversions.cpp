#include "collision_monitor/ros/conversions.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <exception>
#include <set>
#include <sstream>

#include <ros/names.h>

namespace collision_monitor {
namespace ros_layer {

namespace {

using core::ConvexShape;
using core::Transform3;
using core::Vec3;

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

/// What a Shape type is called (in messages and the `~bodies` parameter) and its dimensions.
struct ShapeTypeInfo {
  std::uint8_t type;
  const char* name;
  int dimensions;         ///< expected count (0: none, CONVEX and MESH)
  const char* dim_names;  ///< for messages
};
constexpr ShapeTypeInfo kShapeTypes[] = {
    {collision_monitor::Shape::SPHERE, "sphere", 1, "[radius]"},
    {collision_monitor::Shape::BOX, "box", 3, "[x, y, z]"},
    {collision_monitor::Shape::CYLINDER, "cylinder", 2, "[height, radius]"},
    {collision_monitor::Shape::CONE, "cone", 2, "[height, radius]"},
    {collision_monitor::Shape::CAPSULE, "capsule", 2, "[length, radius]"},
    {collision_monitor::Shape::ELLIPSOID, "ellipsoid", 3, "[a, b, c]"},
    {collision_monitor::Shape::CONVEX, "convex", 0, "[]"},
    {collision_monitor::Shape::MESH, "mesh", 0, "[]"},
};

const ShapeTypeInfo* shapeTypeInfo(std::uint8_t type) {
  for (const ShapeTypeInfo& t : kShapeTypes) {
    if (t.type == type) return &t;
  }
  return nullptr;
}

int dimensionCount(std::uint8_t type) {
  const ShapeTypeInfo* t = shapeTypeInfo(type);
  return t ? t->dimensions : 0;
}

const char* dimensionNames(std::uint8_t type) {
  const ShapeTypeInfo* t = shapeTypeInfo(type);
  return t ? t->dim_names : "[]";
}

/// Scale of a part: 0,0,0 -> 1,1,1; else every component finite and > 0.
Expected<Vec3> scaleOf(const geometry_msgs::Vector3& s) {
  if (!finite(s)) return Error{"scale is not finite"};
  if (s.x == 0.0 && s.y == 0.0 && s.z == 0.0) return Vec3(1.0, 1.0, 1.0);
  // A negative factor mirrors (a URDF's scale="-1 1 1" for a left/right pair), a zero one
  // flattens: the part is the hull of the scaled vertices either way (a part whose vertices then
  // all coincide is refused as degenerate).
  return Vec3(s.x, s.y, s.z);
}

Expected<ConvexShape> primitive(const collision_monitor::Shape& msg) {
  const std::uint8_t type = msg.type;
  const auto& d = msg.dimensions;
  const int want = dimensionCount(type);
  if (static_cast<int>(d.size()) != want) {
    return Error{shapeTypeName(type) + " needs " + std::to_string(want) + " dimensions " +
                 dimensionNames(type) + ", got " + std::to_string(d.size())};
  }
  for (std::size_t i = 0; i < d.size(); ++i) {
    if (!std::isfinite(d[i])) return Error{"dimension " + std::to_string(i) + " is not finite"};
    if (d[i] < 0.0) {
      return Error{"negative dimension " + std::to_string(i) + " " + dimensionNames(type) + ": " +
                   num(d[i])};
    }
  }
  const bool all_zero = std::all_of(d.begin(), d.end(), [](double v) { return v == 0.0; });
  if (all_zero) return Error{"degenerate " + shapeTypeName(type) + ": every dimension is zero"};
  switch (type) {
    case collision_monitor::Shape::SPHERE:
      return ConvexShape::sphere(d[0]);
    case collision_monitor::Shape::BOX:
      return ConvexShape::box(Vec3(d[0], d[1], d[2]));
    case collision_monitor::Shape::CYLINDER:
      return ConvexShape::cylinder(d[0], d[1]);
    case collision_monitor::Shape::CONE:
      return ConvexShape::cone(d[0], d[1]);
    case collision_monitor::Shape::CAPSULE:
      return ConvexShape::capsule(d[0], d[1]);
    case collision_monitor::Shape::ELLIPSOID:
      return ConvexShape::ellipsoid(Vec3(d[0], d[1], d[2]));
    default:
      return Error{"unknown shape type " + std::to_string(type)};
  }
}

}  // namespace

bool finite(const geometry_msgs::Point& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z);
}
bool finite(const geometry_msgs::Vector3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

bool allCoincide(const std::vector<Vec3>& points) {
  double spread = 0.0;
  for (const Vec3& p : points)
    spread = std::max(spread, (p - points.front()).norm());
  return !(spread > 0.0);
}

std::string escapeInput(const std::string& s, std::size_t max_bytes) {
  const std::size_t n = std::min(s.size(), max_bytes);
  std::string out;
  out.reserve(n + 32);
  static const char kHex[] = "0123456789abcdef";
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c >= 0x7f) {
      out += "\\x";
      out.push_back(kHex[c >> 4]);
      out.push_back(kHex[c & 0xf]);
    } else {
      out.push_back(static_cast<char>(c));
    }
  }
  return out;
}

std::string tfFrameName(const std::string& frame) {
  return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
}

std::string quoteInput(const std::string& s, std::size_t max_bytes) {
  const std::size_t n = std::min(s.size(), max_bytes);
  std::string out = "'" + escapeInput(s, n);
  if (n < s.size()) {
    out += "...' (" + std::to_string(s.size()) + " bytes)";
  } else {
    out.push_back('\'');
  }
  return out;
}

std::string checkLength(const std::string& s, std::size_t max_bytes, const std::string& what) {
  if (s.size() <= max_bytes) return {};
  return what + " is " + std::to_string(s.size()) + " bytes, longer than the limit of " +
         std::to_string(max_bytes) + ": " + quoteInput(s);
}

Expected<Transform3> toTransform(const geometry_msgs::Pose& pose, ZeroQuaternion zero) {
  const auto& p = pose.position;
  const auto& o = pose.orientation;
  if (!finite(p)) return Error{"position is not finite"};
  if (!(std::isfinite(o.x) && std::isfinite(o.y) && std::isfinite(o.z) && std::isfinite(o.w))) {
    return Error{"orientation is not finite"};
  }
  const double norm = std::sqrt(o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w);
  if (norm == 0.0) {
    if (zero == ZeroQuaternion::Identity)
      return core::makeTransform(Eigen::Quaterniond::Identity(), Vec3(p.x, p.y, p.z));
    return Error{"orientation is a zero quaternion"};
  }
  if (std::abs(norm - 1.0) > kQuaternionTolerance) {
    return Error{"orientation is not a unit quaternion (|q| = " + num(norm) + ")"};
  }
  return core::makeTransform(Eigen::Quaterniond(o.w, o.x, o.y, o.z), Vec3(p.x, p.y, p.z));
}

std::optional<std::uint8_t> shapeTypeFromString(const std::string& name) {
  std::string s;
  s.reserve(name.size());
  for (char c : name) {
    if (!std::isspace(static_cast<unsigned char>(c))) {
      s.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
    }
  }
  for (const ShapeTypeInfo& t : kShapeTypes) {
    if (s == t.name) return t.type;
  }
  if (!s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
      s.size() <= 3) {
    const int v = std::stoi(s);
    if (v >= collision_monitor::Shape::SPHERE && v <= collision_monitor::Shape::MESH) {
      return static_cast<std::uint8_t>(v);
    }
  }
  return std::nullopt;
}

std::string shapeTypeName(std::uint8_t type) {
  const ShapeTypeInfo* t = shapeTypeInfo(type);
  return t ? std::string(t->name) : "type " + std::to_string(type);
}

Expected<std::vector<ConvexShape>> shapesFromMsg(const collision_monitor::Shape& msg,
                                                 const Limits& limits,
                                                 const MeshLoader& load_mesh) {
  using Shapes = std::vector<ConvexShape>;
  try {
    const std::uint8_t type = msg.type;
    if (type < collision_monitor::Shape::SPHERE || type > collision_monitor::Shape::MESH) {
      return Error{"unknown shape type " + std::to_string(type)};
    }
    auto scale = scaleOf(msg.scale);
    if (!scale) return Error{scale.error()};
    if (type == collision_monitor::Shape::CONVEX || type == collision_monitor::Shape::MESH) {
      if (!msg.dimensions.empty()) {
        return Error{shapeTypeName(type) + " takes no dimensions, got " +
                     std::to_string(msg.dimensions.size())};
      }
      if (type == collision_monitor::Shape::CONVEX && !msg.resource.empty()) {
        return Error{"convex part takes no resource (use a MESH part)"};
      }
    } else {
      if (*scale != Vec3(1.0, 1.0, 1.0)) {
        return Error{"scale applies to mesh and convex parts only; a " + shapeTypeName(type) +
                     " takes its size from dimensions"};
      }
      if (!msg.vertices.empty()) return Error{shapeTypeName(type) + " takes no vertices"};
      if (!msg.resource.empty()) return Error{shapeTypeName(type) + " takes no resource"};
      auto shape = primitive(msg);
      if (!shape) return Error{shape.error()};
      return Shapes{std::move(shape).value()};
    }

    if (type == collision_monitor::Shape::CONVEX) {
      if (msg.vertices.empty()) return Error{"convex part has no vertices"};
      if (msg.vertices.size() > limits.max_vertices_per_part) {
        return Error{"convex part has " + std::to_string(msg.vertices.size()) +
                     " vertices, more than max_vertices_per_part " +
                     std::to_string(limits.max_vertices_per_part)};
      }
      std::vector<Vec3> points;
      points.reserve(msg.vertices.size());
      for (std::size_t i = 0; i < msg.vertices.size(); ++i) {
        if (!finite(msg.vertices[i])) {
          return Error{"vertex " + std::to_string(i) + " is not finite"};
        }
        points.emplace_back(toVec3(msg.vertices[i]).cwiseProduct(*scale));
      }
      if (allCoincide(points)) return Error{"degenerate convex part: every vertex coincides"};
      return Shapes{ConvexShape::convexHull(points)};
    }

    // MESH
    if (!msg.vertices.empty()) return Error{"mesh part takes no vertices (use resource)"};
    if (msg.resource.empty()) return Error{"mesh part has an empty resource"};
    const std::string too_long = checkLength(msg.resource, kMaxResourceLength, "mesh resource");
    if (!too_long.empty()) return Error{too_long};
    if (!load_mesh) return Error{"mesh parts are not supported here"};
    auto shapes = load_mesh(msg.resource, *scale);
    if (!shapes) return Error{"mesh " + quoteInput(msg.resource) + ": " + shapes.error()};
    if (shapes->empty()) return Error{"mesh " + quoteInput(msg.resource) + " gave no parts"};
    return shapes;
  } catch (const std::exception& e) {
    return Error{shapeTypeName(msg.type) + ": " + e.what()};
  }
}

Expected<std::vector<world::Part>> partsFromMsg(const collision_monitor::Shape& msg, double padding,
                                                const Limits& limits, const MeshLoader& load_mesh) {
  auto pose = toTransform(msg.pose, ZeroQuaternion::Identity);
  if (!pose) return Error{"pose: " + pose.error()};
  auto shapes = shapesFromMsg(msg, limits, load_mesh);
  if (!shapes) return Error{shapes.error()};
  try {
    std::vector<world::Part> parts;
    parts.reserve(shapes->size());
    for (const ConvexShape& shape : *shapes)
      parts.push_back(world::Part{padding > 0.0 ? shape.padded(padding) : shape, *pose});
    return parts;
  } catch (const std::exception& e) {
    return Error{std::string("padding: ") + e.what()};
  }
}

collision_monitor::Body hypotheticalBody(const collision_monitor::Body& msg,
                                         const std::string& fixed_frame, bool* anonymous) {
  collision_monitor::Body body = msg;
  *anonymous = body.id.empty();
  if (*anonymous) body.id = "check_collision";
  body.operation = collision_monitor::Body::ADD;
  body.pose_from_topic = false;
  body.pose_topic.clear();
  if (body.header.frame_id.empty()) body.header.frame_id = fixed_frame;
  return body;
}

Expected<world::BodySpec> bodyFromMsg(const collision_monitor::Body& msg, world::BodyOrigin origin,
                                      const Limits& limits, const MeshLoader& load_mesh) {
  if (msg.id.empty()) return Error{"body id is empty"};
  for (const auto& [field, value] :
       {std::make_pair("body id", &msg.id), std::make_pair("header.frame_id", &msg.header.frame_id),
        std::make_pair("group", &msg.group), std::make_pair("pose_topic", &msg.pose_topic)}) {
    const std::string too_long = checkLength(*value, kMaxNameLength, field);
    if (!too_long.empty()) return Error{too_long};
  }
  if (std::string why; !msg.pose_topic.empty() && !ros::names::validate(msg.pose_topic, why)) {
    // Refused here, before anything changes: roscpp's subscribe() throws on it. Its reason names
    // the character, then repeats the name (quoted already).
    why = why.substr(0, why.find(" in Graph Resource Name"));
    return Error{"pose_topic " + quoteInput(msg.pose_topic) +
                 " is not a valid ROS name: " + escapeInput(why, kQuoteLength)};
  }
  if (msg.operation != collision_monitor::Body::ADD) {
    return Error{"operation " + std::to_string(msg.operation) + " is not ADD"};
  }
  if (!std::isfinite(msg.padding) || msg.padding < 0.0) {
    return Error{"padding must be finite and >= 0, got " + num(msg.padding)};
  }
  if (msg.parts.empty()) return Error{"body has no parts"};
  if (msg.parts.size() > limits.max_parts_per_body) {
    return Error{"body has " + std::to_string(msg.parts.size()) +
                 " parts, more than max_parts_per_body " +
                 std::to_string(limits.max_parts_per_body)};
  }
  const bool from_topic = msg.pose_from_topic || !msg.pose_topic.empty();
  // Without a leading '/': the body's markers and ~list_bodies named "/f1", which tf2 (and so
  // rviz) refuses. "/" names no frame: it was kept as the frame '', never posed and never refused.
  const std::string& given = msg.header.frame_id;
  std::string frame = tfFrameName(given);
  if (!from_topic && frame.empty()) {
    return Error{"header.frame_id " +
                 (given.empty() ? std::string("is empty") : quoteInput(given) + " names no frame") +
                 ": a body needs a TF frame unless pose_from_topic is set"};
  }
  world::BodySpec spec;
  spec.id = msg.id;
  spec.frame = std::move(frame);
  spec.group = msg.group;
  spec.padding = msg.padding;
  spec.pose_source = from_topic ? world::PoseSource::Topic : world::PoseSource::Tf;
  spec.pose_topic = msg.pose_topic;
  spec.origin = origin;
  spec.parts.reserve(msg.parts.size());
  for (std::size_t i = 0; i < msg.parts.size(); ++i) {
    auto parts = partsFromMsg(msg.parts[i], msg.padding, limits, load_mesh);
    if (!parts) {
      return Error{"part " + std::to_string(i) + " (" + shapeTypeName(msg.parts[i].type) +
                   "): " + parts.error()};
    }
    for (world::Part& part : *parts)
      spec.parts.push_back(std::move(part));
    if (spec.parts.size() > limits.max_parts_per_body) {
      return Error{"with its mesh pieces the body has " + std::to_string(spec.parts.size()) +
                   " parts by part " + std::to_string(i) + ", more than max_parts_per_body " +
                   std::to_string(limits.max_parts_per_body)};
    }
  }
  return spec;
}

Expected<std::vector<PoseUpdate>> posesFromMsg(const collision_monitor::BodyPoses& msg) {
  const std::string frame_too_long =
      checkLength(msg.header.frame_id, kMaxNameLength, "header.frame_id");
  if (!frame_too_long.empty()) return Error{frame_too_long};
  if (msg.ids.size() != msg.poses.size()) {
    return Error{"ids and poses differ in length (" + std::to_string(msg.ids.size()) + " vs " +
                 std::to_string(msg.poses.size()) + ")"};
  }
  if (!msg.twists.empty() && msg.twists.size() != msg.ids.size()) {
    return Error{"twists must be empty or one per id (" + std::to_string(msg.twists.size()) +
                 " twists for " + std::to_string(msg.ids.size()) + " ids)"};
  }
  std::vector<PoseUpdate> out;
  out.reserve(msg.ids.size());
  std::set<std::string> seen;
  for (std::size_t i = 0; i < msg.ids.size(); ++i) {
    const std::string& id = msg.ids[i];
    if (id.empty()) return Error{"ids[" + std::to_string(i) + "] is empty"};
    const std::string too_long = checkLength(id, kMaxNameLength, "ids[" + std::to_string(i) + "]");
    if (!too_long.empty()) return Error{too_long};
    if (!seen.insert(id).second) return Error{"id " + quoteInput(id) + " appears twice"};
    auto pose = toTransform(msg.poses[i], ZeroQuaternion::Refuse);
    if (!pose) return Error{"pose of " + quoteInput(id) + ": " + pose.error()};
    PoseUpdate u{id, *pose, std::nullopt};
    if (!msg.twists.empty()) {
      const auto& t = msg.twists[i];
      if (!finite(t.linear) || !finite(t.angular)) {
        return Error{"twist of " + quoteInput(id) + " is not finite"};
      }
      u.twist = world::Twist{toVec3(t.linear), toVec3(t.angular)};
    }
    out.push_back(std::move(u));
  }
  return out;
}

PoseUpdate transformUpdate(const PoseUpdate& update, const Transform3& frame_to_fixed) {
  PoseUpdate out = update;
  out.pose = frame_to_fixed * update.pose;
  if (update.twist) {
    out.twist = world::Twist{frame_to_fixed.R * update.twist->linear,
                             frame_to_fixed.R * update.twist->angular};
  }
  return out;
}

Vec3 toVec3(const geometry_msgs::Point& p) {
  return Vec3(p.x, p.y, p.z);
}
Vec3 toVec3(const geometry_msgs::Vector3& v) {
  return Vec3(v.x, v.y, v.z);
}

geometry_msgs::Point toPointMsg(const Vec3& v) {
  geometry_msgs::Point p;
  p.x = v.x();
  p.y = v.y();
  p.z = v.z();
  return p;
}

geometry_msgs::Vector3 toVector3Msg(const Vec3& v) {
  geometry_msgs::Vector3 m;
  m.x = v.x();
  m.y = v.y();
  m.z = v.z();
  return m;
}

geometry_msgs::Pose toPoseMsg(const Transform3& t) {
  geometry_msgs::Pose p;
  p.position = toPointMsg(t.t);
  // Normalised: a rotation off orthonormal by rounding still gives a unit quaternion.
  const Eigen::Quaterniond q = Eigen::Quaterniond(t.R).normalized();
  p.orientation.x = q.x();
  p.orientation.y = q.y();
  p.orientation.z = q.z();
  p.orientation.w = q.w();
  return p;
}

collision_monitor::PairState toMsg(const world::PairResult& pair, const Transform3& to_frame) {
  collision_monitor::PairState m;
  m.body_a = pair.body_a;
  m.body_b = pair.body_b;
  m.status = static_cast<std::uint8_t>(pair.status);
  m.distance = pair.distance;
  m.point_a = toPointMsg(to_frame * pair.point_a);
  m.point_b = toPointMsg(to_frame * pair.point_b);
  m.normal = toVector3Msg(to_frame.R * pair.normal);
  m.time_to_collision = pair.time_to_collision;
  return m;
}

collision_monitor::CollisionEvent toMsg(const world::Event& event, const std::string& fixed_frame,
                                        world::Stamp now) {
  collision_monitor::CollisionEvent m;
  m.header.frame_id = fixed_frame;
  m.header.stamp = toRosTime(event.stamp.isStatic() ? now : event.stamp);
  m.type = static_cast<std::uint8_t>(event.type);
  m.pair = toMsg(event.pair);
  return m;
}

collision_monitor::CollisionState toMsg(const world::CycleResult& cycle,
                                        const std::string& fixed_frame, world::Stamp now) {
  collision_monitor::CollisionState m;
  m.header.frame_id = fixed_frame;
  m.header.stamp = toRosTime(cycle.stamp.isStatic() ? now : cycle.stamp);
  m.in_collision = cycle.in_collision;
  m.min_distance = cycle.min_distance;
  m.pairs.reserve(cycle.pairs.size());
  for (const auto& p : cycle.pairs)
    m.pairs.push_back(toMsg(p));
  m.stale_bodies = cycle.stale_bodies;
  m.num_bodies = static_cast<std::uint32_t>(cycle.num_bodies);
  m.num_pairs_checked = static_cast<std::uint32_t>(cycle.num_pairs_checked);
  m.compute_time = cycle.compute_time;
  return m;
}

}  // namespace ros_layer
}  // namespace collision_monitor
