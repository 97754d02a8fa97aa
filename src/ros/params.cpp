#include "collision_monitor/ros/params.h"

#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>
#include <utility>

#include <XmlRpcException.h>

#include "collision_monitor/ros/conversions.h"

namespace collision_monitor {
namespace ros_layer {

namespace {

using XmlRpc::XmlRpcValue;

/// Thrown inside this file only, caught at the public functions.
struct FieldError {
  std::string what;
};

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError{field + ": " + why};
}

double number(const XmlRpcValue& v, const std::string& field) {
  if (v.getType() == XmlRpcValue::TypeDouble) return static_cast<const double&>(v);
  if (v.getType() == XmlRpcValue::TypeInt) return static_cast<const int&>(v);
  fail(field, "expected a number" + numberWrittenAsText(v));
}

std::string string(const XmlRpcValue& v, const std::string& field) {
  if (v.getType() != XmlRpcValue::TypeString) fail(field, "expected a string");
  return static_cast<const std::string&>(v);
}

bool boolean(const XmlRpcValue& v, const std::string& field) {
  if (v.getType() == XmlRpcValue::TypeBoolean) return static_cast<const bool&>(v);
  fail(field, "expected true or false");
}

const XmlRpcValue& array(const XmlRpcValue& v, const std::string& field) {
  if (v.getType() != XmlRpcValue::TypeArray) fail(field, "expected a list");
  return v;
}

void checkKeys(const XmlRpcValue& v, const std::string& field, const std::set<std::string>& known) {
  if (v.getType() != XmlRpcValue::TypeStruct) fail(field, "expected a map");
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (!known.count(it->first)) fail(field, "unknown field '" + it->first + "'");
  }
}

/// [x, y, z] or {x:, y:, z:} into three doubles.
void triple(const XmlRpcValue& v, const std::string& field, double* x, double* y, double* z) {
  if (v.getType() == XmlRpcValue::TypeArray) {
    if (v.size() != 3) fail(field, "expected 3 numbers, got " + std::to_string(v.size()));
    *x = number(v[0], field + "[0]");
    *y = number(v[1], field + "[1]");
    *z = number(v[2], field + "[2]");
    return;
  }
  checkKeys(v, field, {"x", "y", "z"});
  *x = v.hasMember("x") ? number(v["x"], field + ".x") : 0.0;
  *y = v.hasMember("y") ? number(v["y"], field + ".y") : 0.0;
  *z = v.hasMember("z") ? number(v["z"], field + ".z") : 0.0;
}

geometry_msgs::Pose pose(const XmlRpcValue& v, const std::string& field) {
  checkKeys(v, field, {"position", "orientation"});
  geometry_msgs::Pose p;
  p.orientation.w = 1.0;
  if (v.hasMember("position")) {
    triple(v["position"], field + ".position", &p.position.x, &p.position.y, &p.position.z);
  }
  if (v.hasMember("orientation")) {
    const XmlRpcValue& o = v["orientation"];
    const std::string f = field + ".orientation";
    if (o.getType() == XmlRpcValue::TypeArray) {
      if (o.size() != 4) fail(f, "expected [x, y, z, w], got " + std::to_string(o.size()));
      p.orientation.x = number(o[0], f + "[0]");
      p.orientation.y = number(o[1], f + "[1]");
      p.orientation.z = number(o[2], f + "[2]");
      p.orientation.w = number(o[3], f + "[3]");
    } else {
      checkKeys(o, f, {"x", "y", "z", "w"});
      p.orientation.x = o.hasMember("x") ? number(o["x"], f + ".x") : 0.0;
      p.orientation.y = o.hasMember("y") ? number(o["y"], f + ".y") : 0.0;
      p.orientation.z = o.hasMember("z") ? number(o["z"], f + ".z") : 0.0;
      p.orientation.w = o.hasMember("w") ? number(o["w"], f + ".w") : 0.0;
    }
  }
  return p;
}

collision_monitor::Shape shape(const XmlRpcValue& v, const std::string& field) {
  checkKeys(v, field, {"type", "dimensions", "vertices", "resource", "scale", "pose"});
  collision_monitor::Shape s;
  s.pose.orientation.w = 1.0;
  if (!v.hasMember("type")) fail(field, "missing 'type'");
  const XmlRpcValue& t = v["type"];
  if (t.getType() == XmlRpcValue::TypeInt) {
    const int n = static_cast<const int&>(t);
    if (n < 0 || n > 255) fail(field + ".type", "unknown shape type " + std::to_string(n));
    s.type = static_cast<std::uint8_t>(n);  // range checked by shapesFromMsg
  } else {
    const std::string name = string(t, field + ".type");
    auto type = shapeTypeFromString(name);
    if (!type) fail(field + ".type", "unknown shape type '" + name + "'");
    s.type = *type;
  }
  if (v.hasMember("dimensions")) {
    const XmlRpcValue& d = array(v["dimensions"], field + ".dimensions");
    for (int i = 0; i < d.size(); ++i) {
      s.dimensions.push_back(number(d[i], field + ".dimensions[" + std::to_string(i) + "]"));
    }
  }
  if (v.hasMember("vertices")) {
    const XmlRpcValue& vs = array(v["vertices"], field + ".vertices");
    for (int i = 0; i < vs.size(); ++i) {
      geometry_msgs::Point p;
      triple(vs[i], field + ".vertices[" + std::to_string(i) + "]", &p.x, &p.y, &p.z);
      s.vertices.push_back(p);
    }
  }
  if (v.hasMember("resource")) s.resource = string(v["resource"], field + ".resource");
  if (v.hasMember("scale"))
    triple(v["scale"], field + ".scale", &s.scale.x, &s.scale.y, &s.scale.z);
  if (v.hasMember("pose")) s.pose = pose(v["pose"], field + ".pose");
  return s;
}

}  // namespace

std::string numberWrittenAsText(const XmlRpcValue& value) {
  if (value.getType() != XmlRpcValue::TypeString) return {};
  const std::string& text = static_cast<const std::string&>(value);
  const std::size_t e = text.find_first_of("eE");
  if (text.empty() || text.size() > 32 || e == std::string::npos ||
      text.find_first_not_of("0123456789+-.eE") != std::string::npos)
    return {};
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || !std::isfinite(v)) return {};
  // PyYAML's float: a '.' in the mantissa and a sign after the 'e' (1.0e2 is text to it too).
  std::string mantissa = text.substr(0, e + 1), exponent = text.substr(e + 1);
  if (mantissa.find('.') == std::string::npos) mantissa.insert(e, ".0");
  if (exponent[0] != '+' && exponent[0] != '-') exponent.insert(0, "+");
  return " (the text '" + text +
         "': YAML reads a number with an exponent as text unless it has a '.' and a signed "
         "exponent, roslaunch unless it has a '.'; write " +
         mantissa + exponent + ")";
}

Expected<collision_monitor::Body> bodyFromXmlRpc(const XmlRpcValue& v) {
  try {
    // The fields of Body (INTERFACE.md), and `frame_id` for `header: {frame_id: ...}`.
    checkKeys(v, "body",
              {"id", "operation", "header", "frame_id", "group", "padding", "pose_from_topic",
               "pose_topic", "parts"});
    collision_monitor::Body b;
    b.operation = collision_monitor::Body::ADD;
    if (!v.hasMember("id")) fail("body", "missing 'id'");
    b.id = string(v["id"], "id");
    if (v.hasMember("operation")) {
      const XmlRpcValue& op = v["operation"];
      const std::string name = op.getType() == XmlRpcValue::TypeInt
                                   ? std::to_string(static_cast<const int&>(op))
                                   : string(op, "operation");
      if (name != "0" && name != "ADD" && name != "add") {
        fail("operation", "'" + name + "': a body of ~bodies is added (ADD, 0), never removed");
      }
    }
    if (v.hasMember("header")) {
      const XmlRpcValue& h = v["header"];
      checkKeys(h, "header", {"frame_id", "stamp", "seq"});  // stamp and seq: unused
      if (h.hasMember("frame_id")) {
        if (v.hasMember("frame_id")) fail("body", "both 'frame_id' and 'header.frame_id'");
        b.header.frame_id = string(h["frame_id"], "header.frame_id");
      }
    }
    if (v.hasMember("frame_id")) b.header.frame_id = string(v["frame_id"], "frame_id");
    if (v.hasMember("group")) b.group = string(v["group"], "group");
    if (v.hasMember("padding")) b.padding = number(v["padding"], "padding");
    if (v.hasMember("pose_from_topic")) {
      b.pose_from_topic = boolean(v["pose_from_topic"], "pose_from_topic");
    }
    if (v.hasMember("pose_topic")) b.pose_topic = string(v["pose_topic"], "pose_topic");
    if (!v.hasMember("parts")) fail("body", "missing 'parts'");
    const XmlRpcValue& parts = array(v["parts"], "parts");
    for (int i = 0; i < parts.size(); ++i) {
      b.parts.push_back(shape(parts[i], "parts[" + std::to_string(i) + "]"));
    }
    return b;
  } catch (const FieldError& e) {
    return Error{e.what};
  } catch (const XmlRpc::XmlRpcException& e) {
    return Error{e.getMessage()};
  }
}

Expected<std::vector<std::pair<std::string, std::string>>> pairsFromXmlRpc(const XmlRpcValue& v) {
  try {
    std::vector<std::pair<std::string, std::string>> out;
    array(v, "disabled_pairs");
    for (int i = 0; i < v.size(); ++i) {
      const std::string f = "disabled_pairs[" + std::to_string(i) + "]";
      const XmlRpcValue& p = array(v[i], f);
      if (p.size() != 2) fail(f, "expected [a, b]");
      std::string a = string(p[0], f + "[0]");  // [0] first: the first bad element is named
      out.emplace_back(std::move(a), string(p[1], f + "[1]"));
    }
    return out;
  } catch (const FieldError& e) {
    return Error{e.what};
  } catch (const XmlRpc::XmlRpcException& e) {
    return Error{e.getMessage()};
  }
}

Expected<std::vector<std::string>> stringsFromXmlRpc(const XmlRpcValue& v) {
  try {
    if (v.getType() == XmlRpcValue::TypeString) {
      return std::vector<std::string>{static_cast<const std::string&>(v)};
    }
    std::vector<std::string> out;
    array(v, "list");
    out.reserve(static_cast<std::size_t>(v.size()));
    for (int i = 0; i < v.size(); ++i)
      out.push_back(string(v[i], "[" + std::to_string(i) + "]"));
    return out;
  } catch (const FieldError& e) {
    return Error{e.what};
  } catch (const XmlRpc::XmlRpcException& e) {
    return Error{e.getMessage()};
  }
}

namespace {

/// `param`, a map of link name -> T, each value read by `read` (which fails on a bad one).
template <typename T, typename Read>
LinkMap<T> linkMap(const XmlRpcValue& v, const std::string& param, const std::string& example,
                   const std::string& otherwise, Read read) {
  LinkMap<T> out;
  if (v.getType() != XmlRpcValue::TypeStruct) {
    out.errors.push_back(param + ": expected a map of link names to " + example);
    return out;
  }
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string field = param + "[" + quoteInput(it->first) + "]";
    try {
      out.values.emplace(it->first, read(it->second, field));
    } catch (const FieldError& e) {
      out.errors.push_back(e.what + "; " + otherwise);
    }
  }
  return out;
}

}  // namespace

LinkMap<double> linkPaddingFromXmlRpc(const XmlRpcValue& v) {
  return linkMap<double>(v, "robot_link_padding", "metres, e.g. {panda_hand: 0.02}",
                         "robot_padding used", [](const XmlRpcValue& x, const std::string& f) {
                           const double pad = number(x, f);
                           if (!std::isfinite(pad) || pad < 0.0) {
                             std::ostringstream got;
                             got << pad;
                             fail(f, "must be finite and >= 0, got " + got.str());
                           }
                           return pad;
                         });
}

LinkMap<std::string> linkGroupsFromXmlRpc(const XmlRpcValue& v) {
  return linkMap<std::string>(
      v, "robot_link_groups", "groups, e.g. {panda_hand: gripper}", "the link is in no group",
      [](const XmlRpcValue& x, const std::string& f) {
        std::string group = string(x, f);
        if (group.empty()) fail(f, "the group name is empty");
        const std::string too_long = checkLength(group, kMaxNameLength, "the group name");
        if (!too_long.empty()) fail(f, too_long);
        return group;
      });
}

}  // namespace ros_layer
}  // namespace collision_monitor
