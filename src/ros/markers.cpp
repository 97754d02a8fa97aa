#include "collision_monitor/ros/markers.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <random>
#include <type_traits>
#include <variant>

#include <Eigen/Geometry>

#include "collision_monitor/core/convex_hull.h"
#include "collision_monitor/ros/conversions.h"

namespace collision_monitor {
namespace ros_layer {

namespace {

using core::ConvexShape;
using core::Vec3;
using visualization_msgs::Marker;
using world::PairStatus;

const char* const kBodies = "bodies";
const char* const kPadding = "padding";
const char* const kWitness = "witness";
const char* const kLabels = "labels";
const char* const kNormals = "normals";

/// Body and padding markers live this many times MarkerOptions::lifetime (they are refreshed
/// between a quarter and a half of it: ten refreshes or more per lifetime).
constexpr double kBodyLifetimes = 5.0;
bool isBodyMarker(const std::string& ns) {
  return ns == kBodies || ns == kPadding;
}

/// Smallest drawn size (m): zero-thickness shapes (flat boxes, segments, flat hulls) stay visible.
constexpr double kMinSize = 0.002;

/// A label's lines are this many text heights apart, the first one above its witness segment.
constexpr double kLabelLine = 1.2;
/// Width of a label's character in text heights (rviz's font is narrower: a little to spare).
constexpr double kLabelCharWidth = 0.65;

/// A label with more than this many labels placed before it within its reach sideways is left on
/// its first line: a crowd is unreadable anyway, and the bound keeps the placement cheap.
constexpr int kMaxLabelRise = 8;

/// Where a label goes: on the first line above `anchor` where it meets none of the labels placed
/// so far. Two labels meet when their lines overlap and they are closer sideways (in x-y, as seen
/// from any side) than half the one's width plus half the other's: the labels of pairs that meet
/// at one place (a ball between two fingers) are stacked, not printed over each other.
struct LabelSlot {
  Vec3 position;
  double half_width;
};
Vec3 placeLabel(const Vec3& anchor, double half_width, double height,
                std::vector<LabelSlot>* placed) {
  Vec3 at = anchor + Vec3(0.0, 0.0, kLabelLine * height);
  std::array<double, kMaxLabelRise> near_z{};  // the lines of the labels within reach sideways
  int near = 0;
  for (const LabelSlot& other : *placed) {
    if ((other.position - at).head<2>().norm() >= other.half_width + half_width) continue;
    if (near == kMaxLabelRise) {  // a crowd
      near = 0;
      break;
    }
    near_z[near++] = other.position.z();
  }
  // Each move puts the label above one of them for good (it only rises): at most `near` moves.
  for (bool moved = true; moved;) {
    moved = false;
    for (int i = 0; i < near; ++i) {
      if (std::abs(near_z[i] - at.z()) < height) {
        at.z() = near_z[i] + kLabelLine * height;
        moved = true;
      }
    }
  }
  placed->push_back({at, half_width});
  return at;
}

std_msgs::ColorRGBA rgba(double r, double g, double b, double a = 1.0) {
  std_msgs::ColorRGBA c;
  c.r = static_cast<float>(r);
  c.g = static_cast<float>(g);
  c.b = static_cast<float>(b);
  c.a = static_cast<float>(a);
  return c;
}

geometry_msgs::Pose identityPose() {
  geometry_msgs::Pose pose;
  pose.orientation.w = 1.0;
  return pose;
}

/// Removes every marker of the display (what an earlier run, or this one, showed).
visualization_msgs::Marker deleteAll(const std_msgs::Header& header) {
  visualization_msgs::Marker m;
  m.header = header;
  m.action = visualization_msgs::Marker::DELETEALL;
  m.pose = identityPose();
  return m;
}

/// Per-face light factors of a TRIANGLE_LIST, in [0.55, 1]: Lambert-like shading by a fixed
/// light direction in the marker's frame, wrapped so that faces turned away stay visible.
std::vector<float> shadeFaces(const Marker& m) {
  std::vector<float> shade;
  if (m.type != Marker::TRIANGLE_LIST) return shade;
  const Vec3 light = Vec3(0.35, 0.25, 0.9).normalized();
  shade.reserve(m.points.size() / 3);
  auto v = [&m](std::size_t i) { return Vec3(m.points[i].x, m.points[i].y, m.points[i].z); };
  for (std::size_t i = 0; i + 2 < m.points.size(); i += 3) {
    const Vec3 n = (v(i + 1) - v(i)).cross(v(i + 2) - v(i));
    const double len = n.norm();
    const double c = len > 0.0 ? n.dot(light) / len : 0.0;
    shade.push_back(static_cast<float>(0.55 + 0.45 * (0.5 + 0.5 * c)));
  }
  return shade;
}

/// Face colours: `color` (its alpha goes on the marker) times each face's shade.
void applyShade(const std::vector<float>& shade, const std_msgs::ColorRGBA& color, Marker* m) {
  m->colors.resize(shade.size());
  for (std::size_t i = 0; i < shade.size(); ++i) {
    m->colors[i].r = color.r * shade[i];
    m->colors[i].g = color.g * shade[i];
    m->colors[i].b = color.b * shade[i];
    m->colors[i].a = 1.0f;
  }
}

/// Severity for "worst status" of a body: collision > warning > unknown > clear.
int severity(PairStatus s) {
  switch (s) {
    case PairStatus::Collision:
      return 3;
    case PairStatus::Warning:
      return 2;
    case PairStatus::Unknown:
      return 1;
    case PairStatus::Clear:
      break;
  }
  return 0;
}

/// True when two shapes have the same geometry (so cached triangles stay valid).
bool sameShape(const ConvexShape& a, const ConvexShape& b) {
  if (a.radius() != b.radius() || a.offset() != b.offset() || a.core().index() != b.core().index())
    return false;
  return std::visit(
      [&b](const auto& ca) -> bool {
        using T = std::decay_t<decltype(ca)>;
        const T& cb = std::get<T>(b.core());
        if constexpr (std::is_same_v<T, core::PointShape<3>>) {
          return ca.p == cb.p;
        } else if constexpr (std::is_same_v<T, core::SegmentShape<3>>) {
          return ca.a == cb.a && ca.b == cb.b;
        } else if constexpr (std::is_same_v<T, core::BoxShape<3>>) {
          return ca.half == cb.half;
        } else if constexpr (std::is_same_v<T, core::CylinderShape> ||
                             std::is_same_v<T, core::ConeShape>) {
          return ca.half_height == cb.half_height && ca.radius == cb.radius;
        } else if constexpr (std::is_same_v<T, core::EllipsoidShape<3>>) {
          return ca.semi == cb.semi;
        } else {
          return ca == cb;  // shared, immutable polytope: same object, same geometry
        }
      },
      a.core());
}

/// A TRIANGLE_LIST approximating `core` inflated by `radius`, by sampling its support mapping on
/// a latitude/longitude grid of directions (the Gauss map): each grid cell becomes two triangles
/// between the support points of its corner directions. Exact at the sampled directions; flat
/// faces and sharp edges come out right because all directions of a face's normal cone map to
/// its vertices. Degenerate (zero-area) triangles are dropped, the rest face outwards.
void tessellate(const ConvexShape& shape, double radius, int n, Marker* m) {
  n = std::max(n, 4);
  const int rings = n;         // polar angle steps over [0, pi]
  const int segments = 2 * n;  // azimuth steps over [0, 2 pi)
  std::vector<Vec3> dirs;
  std::vector<Vec3> pts;
  dirs.reserve(static_cast<std::size_t>(rings + 1) * static_cast<std::size_t>(segments));
  pts.reserve(dirs.capacity());
  for (int i = 0; i <= rings; ++i) {
    // The poles exactly: sin(pi) is 1.2e-16, enough to pick rim points of a face whose normal
    // is -z (a cone's base, a padded box's bottom), which then had no triangles.
    const double theta = M_PI * i / rings;
    const double st = (i == 0 || i == rings) ? 0.0 : std::sin(theta);
    const double ct = i == 0 ? 1.0 : i == rings ? -1.0 : std::cos(theta);
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * M_PI * j / segments;
      const Vec3 d(st * std::cos(phi), st * std::sin(phi), ct);
      dirs.push_back(d);
      pts.emplace_back(shape.coreSupport(d) + radius * d);
    }
  }
  const double scale = std::max(shape.localRadius(), radius) + kMinSize;
  const double min_area2 = 1e-14 * scale * scale * scale * scale;
  auto idx = [segments](int i, int j) { return i * segments + (j % segments); };
  auto add = [&](int a, int b, int c) {
    const Vec3 normal = (pts[b] - pts[a]).cross(pts[c] - pts[a]);
    if (normal.squaredNorm() <= min_area2) return;
    const Vec3 outward = dirs[a] + dirs[b] + dirs[c];
    if (normal.dot(outward) < 0.0) std::swap(b, c);
    m->points.push_back(toPointMsg(pts[a]));
    m->points.push_back(toPointMsg(pts[b]));
    m->points.push_back(toPointMsg(pts[c]));
  };
  m->type = Marker::TRIANGLE_LIST;
  m->scale.x = m->scale.y = m->scale.z = 1.0;
  m->points.clear();
  for (int i = 0; i < rings; ++i) {
    for (int j = 0; j < segments; ++j) {
      add(idx(i, j), idx(i + 1, j), idx(i + 1, j + 1));
      add(idx(i, j), idx(i + 1, j + 1), idx(i, j + 1));
    }
  }
}

/// The solid (unpadded) look of a part: native rviz primitives where there is one, the hull's
/// triangles for polytopes, a tessellation otherwise. `radius` is the part's own radius without
/// the body's padding (a sphere's or capsule's radius).
void solidMarker(const ConvexShape& shape, double radius, int n, Marker* m) {
  m->scale.x = m->scale.y = m->scale.z = 1.0;
  const auto& c = shape.core();
  if (std::holds_alternative<core::PointShape<3>>(c)) {
    m->type = Marker::SPHERE;
    m->scale.x = m->scale.y = m->scale.z = std::max(2.0 * radius, kMinSize);
    return;
  }
  if (radius <= 0.0) {
    if (const auto* box = std::get_if<core::BoxShape<3>>(&c)) {
      m->type = Marker::CUBE;
      m->scale.x = std::max(2.0 * box->half.x(), kMinSize);
      m->scale.y = std::max(2.0 * box->half.y(), kMinSize);
      m->scale.z = std::max(2.0 * box->half.z(), kMinSize);
      return;
    }
    if (const auto* cyl = std::get_if<core::CylinderShape>(&c)) {
      m->type = Marker::CYLINDER;
      m->scale.x = m->scale.y = std::max(2.0 * cyl->radius, kMinSize);
      m->scale.z = std::max(2.0 * cyl->half_height, kMinSize);
      return;
    }
    if (const auto* ell = std::get_if<core::EllipsoidShape<3>>(&c)) {
      m->type = Marker::SPHERE;
      m->scale.x = std::max(2.0 * ell->semi.x(), kMinSize);
      m->scale.y = std::max(2.0 * ell->semi.y(), kMinSize);
      m->scale.z = std::max(2.0 * ell->semi.z(), kMinSize);
      return;
    }
    if (const auto* poly = std::get_if<std::shared_ptr<const core::Polytope<3>>>(&c)) {
      const auto triangles = core::hullTriangles(**poly);
      if (!triangles.empty()) {
        m->type = Marker::TRIANGLE_LIST;
        m->points.reserve(triangles.size() * 3);
        const auto& v = (*poly)->vertices();
        for (const auto& t : triangles) {
          for (int k : t)
            m->points.push_back(toPointMsg(v[static_cast<std::size_t>(k)] + shape.offset()));
        }
        return;
      }
      // Flat or lower-dimensional hull: a thin tessellated slab below.
    }
  }
  // Capsules, cones, rounded shapes and degenerate hulls.
  const bool thin = std::holds_alternative<core::SegmentShape<3>>(c) ||
                    std::holds_alternative<std::shared_ptr<const core::Polytope<3>>>(c);
  tessellate(shape, thin ? std::max(radius, 0.5 * kMinSize) : radius, n, m);
}

}  // namespace

std_msgs::ColorRGBA MarkerBuilder::statusColor(PairStatus status, double distance,
                                               double warning_distance) {
  switch (status) {
    case PairStatus::Clear:
      return rgba(0.15, 0.75, 0.25);
    case PairStatus::Warning: {
      // Ramp by clearance: yellow at the warning distance, orange at contact.
      double t = warning_distance > 0.0 ? distance / warning_distance : 0.0;
      if (!std::isfinite(t)) t = 1.0;
      t = std::clamp(t, 0.0, 1.0);
      return rgba(1.0, 0.45 + 0.4 * t, 0.0);
    }
    case PairStatus::Collision:
      return rgba(0.9, 0.08, 0.08);
    case PairStatus::Unknown:
      break;
  }
  return rgba(0.55, 0.55, 0.55);
}

std::string MarkerBuilder::distanceLabel(double distance) {
  if (!std::isfinite(distance)) return distance > 0 ? "inf" : "?";
  char buf[48];
  double mm = distance * 1000.0;
  if (std::abs(mm) < 0.05) mm = 0.0;  // no "-0.0 mm"
  std::snprintf(buf, sizeof(buf), "%.1f mm", mm);
  return buf;
}

visualization_msgs::MarkerArray MarkerBuilder::clear(const std::string& fixed_frame) {
  std_msgs::Header header;
  header.frame_id = fixed_frame;
  visualization_msgs::MarkerArray out;
  out.markers.push_back(deleteAll(header));
  reset();
  return out;
}

void MarkerBuilder::reset() {
  shown_.clear();
  sent_.clear();
  deleting_.clear();
  ids_.clear();
  free_ids_.clear();
  next_id_ = 0;  // after the DELETEALL
  geometry_.clear();
  first_ = true;
  last_build_ = -1.0;
}

int MarkerBuilder::markerId(const std::string& ns, const std::string& key) {
  const auto it = ids_.find({ns, key});
  if (it != ids_.end()) return it->second;
  int id;
  if (!free_ids_.empty()) {
    id = free_ids_.back();
    free_ids_.pop_back();
  } else {
    id = next_id_++;
  }
  ids_.emplace(std::make_pair(ns, key), id);
  return id;
}

const MarkerBuilder::BodyGeometry& MarkerBuilder::geometryOf(const world::BodySpec& spec) {
  auto it = geometry_.find(spec.id);
  if (it != geometry_.end()) {
    const BodyGeometry& g = it->second;
    bool same = g.padding == spec.padding && g.parts.size() == spec.parts.size();
    for (std::size_t i = 0; same && i < spec.parts.size(); ++i) {
      same = sameShape(g.parts[i].shape, spec.parts[i].shape);
    }
    if (same) return g;
  }
  BodyGeometry g;
  g.parts = spec.parts;
  g.padding = spec.padding;
  g.generation = next_generation_++;
  g.geometry.resize(spec.parts.size());
  const double padding = std::max(spec.padding, 0.0);
  for (std::size_t i = 0; i < spec.parts.size(); ++i) {
    const ConvexShape& shape = spec.parts[i].shape;
    PartGeometry& pg = g.geometry[i];
    // The part is already padded: its own radius is what remains without the padding.
    const double own_radius = std::max(shape.radius() - padding, 0.0);
    pg.solid.action = Marker::ADD;
    pg.solid.pose = identityPose();
    // Spheres are drawn as SPHERE markers centred on their core point; everything else is
    // given in the part frame itself.
    if (const auto* point = std::get_if<core::PointShape<3>>(&shape.core()))
      pg.offset = shape.offset() + point->p;
    solidMarker(shape, own_radius, options_.tessellation, &pg.solid);
    pg.solid_shade = shadeFaces(pg.solid);
    if (padding > 0.0 && shape.radius() > 0.0) {
      pg.has_shell = true;
      pg.shell.action = Marker::ADD;
      pg.shell.pose = identityPose();
      if (std::holds_alternative<core::PointShape<3>>(shape.core())) {
        pg.shell.type = Marker::SPHERE;
        pg.shell.scale.x = pg.shell.scale.y = pg.shell.scale.z = 2.0 * shape.radius();
      } else {
        tessellate(shape, shape.radius(), options_.tessellation, &pg.shell);
        pg.shell_shade = shadeFaces(pg.shell);
      }
    }
  }
  auto& slot = geometry_[spec.id];
  slot = std::move(g);
  return slot;
}

visualization_msgs::MarkerArray MarkerBuilder::build(const world::WorldModel& world,
                                                     const world::CycleResult& cycle,
                                                     const std::string& fixed_frame) {
  return build(
      world, cycle, fixed_frame,
      std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count());
}

visualization_msgs::MarkerArray MarkerBuilder::build(const world::WorldModel& world,
                                                     const world::CycleResult& cycle,
                                                     const std::string& fixed_frame, double now) {
  visualization_msgs::MarkerArray out;
  if (options_.max_rate > 0.0 && last_build_ >= 0.0 &&
      now - last_build_ < 1.0 / options_.max_rate) {
    return out;  // too soon: nothing to publish this cycle
  }
  last_build_ = now;
  std_msgs::Header header;
  header.frame_id = fixed_frame;
  header.stamp = toRosTime(cycle.stamp);

  if (first_) {
    out.markers.push_back(deleteAll(header));
    first_ = false;
  }

  // Every marker has a lifetime: a subscriber that missed the arrays with its DELETE (the
  // publisher's queue is 1) drops it that long after the last array that showed it, and rviz
  // drops the picture of a monitor that stopped. Body and padding markers live kBodyLifetimes
  // times as long: they are sent again only when they change or to refresh.
  const double life = std::max(options_.lifetime, 0.0);
  const ros::Duration lifetime(life), body_lifetime(kBodyLifetimes * life);
  std::map<std::pair<std::string, int>, std::string> shown;
  auto emit = [&](Marker&& m, const std::string& key) {
    m.lifetime = isBodyMarker(m.ns) ? body_lifetime : lifetime;
    shown.emplace(std::make_pair(m.ns, m.id), key);
    out.markers.push_back(std::move(m));
  };
  // A body marker goes out again when anything in it changed, or when its refresh is due: at a
  // random time between a quarter and a half of `lifetime` (of 2 s for markers that live
  // forever) after it last went out. At random, so that refreshes spread evenly over the arrays
  // (arrays of one size, no burst of every body at once) and a subscriber that drops arrays
  // does not keep missing the same markers' refreshes; at least ten of them per body lifetime.
  const double refresh = life > 0.0 ? life : 2.0;
  auto unchanged = [&](const char* ns, int id, const std::string& key, const std::string& frame,
                       const geometry_msgs::Pose& pose, const std_msgs::ColorRGBA& color,
                       std::uint64_t generation) {
    const auto ns_id = std::make_pair(std::string(ns), id);
    Sent& s = sent_[ns_id];
    if (s.generation == generation && s.frame == frame && s.pose == pose && s.color == color &&
        now < s.refresh_due) {
      shown.emplace(ns_id, key);
      return true;
    }
    std::uniform_real_distribution<double> quarter_to_half(0.25, 0.5);
    s = Sent{frame, pose, color, generation, now + refresh * quarter_to_half(random_)};
    return false;
  };

  // Worst status (and smallest distance within it) per body.
  struct Worst {
    PairStatus status = PairStatus::Clear;
    double distance = std::numeric_limits<double>::infinity();
  };
  std::map<std::string, Worst> worst;
  auto note = [&worst](const std::string& id, PairStatus status, double distance) {
    Worst& w = worst[id];
    const int s = severity(status), ws = severity(w.status);
    if (s > ws || (s == ws && distance < w.distance)) {
      w.status = status;
      w.distance = distance;
    }
  };
  // A pair is UNKNOWN because one of its bodies is stale: that body is grey, the other keeps
  // the colour of its pairs that are known (all pairs of a stale body are UNKNOWN, and only some
  // of them are listed, so colouring by them would grey the listed partners only).
  for (const auto& p : cycle.pairs) {
    if (p.status == PairStatus::Unknown) continue;
    note(p.body_a, p.status, p.distance);
    note(p.body_b, p.status, p.distance);
  }
  for (const auto& id : cycle.stale_bodies)
    note(id, PairStatus::Unknown, 0.0);
  const double warning_distance = world.settings().warning_distance;

  // Bodies.
  for (const auto& info : world.listBodies(cycle.stamp)) {
    const world::BodySpec* spec = world.body(info.id);
    const auto body_pose = world.pose(info.id);
    if (spec == nullptr || !body_pose) continue;  // nothing to draw yet: deleted below if shown
    const BodyGeometry& g = geometryOf(*spec);
    const auto w = worst.find(info.id);
    std_msgs::ColorRGBA color =
        w == worst.end() ? statusColor(PairStatus::Clear, 0.0, warning_distance)
                         : statusColor(w->second.status, w->second.distance, warning_distance);
    std_msgs::ColorRGBA shell_color = color;
    color.a = static_cast<float>(options_.body_alpha);
    shell_color.a = static_cast<float>(options_.padding_alpha);
    // In the body's TF frame, where rviz moves it with TF (its pose there never changes), or in
    // the fixed frame at the pose the check used.
    const bool locked =
        options_.frame_locked && spec->pose_source == world::PoseSource::Tf && !spec->frame.empty();
    std_msgs::Header body_header = header;
    if (locked) {
      // Stamp 0, "the latest TF": rviz waits (in its message filter) for TF at a marker's stamp,
      // and a body whose TF stopped (stale, grey) has none at the cycle's stamp, so it vanished.
      body_header.frame_id = spec->frame;
      body_header.stamp = ros::Time();
    }
    // A part's solid or padding shell, unless unchanged since it was last sent.
    auto part = [&](const char* ns, const Marker& shape, const std::vector<float>& shade,
                    const std_msgs::ColorRGBA& c, const geometry_msgs::Pose& pose,
                    const std::string& key) {
      const int id = markerId(ns, key);
      if (unchanged(ns, id, key, body_header.frame_id, pose, c, g.generation)) return;
      Marker m = shape;
      m.header = body_header;
      m.ns = ns;
      m.id = id;
      m.color = c;
      m.pose = pose;
      m.frame_locked = locked;
      if (!shade.empty()) applyShade(shade, c, &m);
      emit(std::move(m), key);
    };
    for (std::size_t i = 0; i < g.geometry.size(); ++i) {
      const PartGeometry& pg = g.geometry[i];
      const core::Transform3 in_body =
          spec->parts[i].pose * core::makeTransform(Eigen::Quaterniond::Identity(), pg.offset);
      const geometry_msgs::Pose pose = toPoseMsg(locked ? in_body : *body_pose * in_body);
      const std::string key = info.id + '#' + std::to_string(i);
      part(kBodies, pg.solid, pg.solid_shade, color, pose, key);
      if (pg.has_shell) part(kPadding, pg.shell, pg.shell_shade, shell_color, pose, key);
    }
  }
  for (auto it = geometry_.begin(); it != geometry_.end();) {
    it = world.hasBody(it->first) ? std::next(it) : geometry_.erase(it);
  }

  // Pairs in WARNING or COLLISION: witness segment, label, and the normal when penetrating.
  std::vector<LabelSlot> labels;
  for (const auto& p : cycle.pairs) {
    if (p.status != PairStatus::Warning && p.status != PairStatus::Collision) continue;
    if (!p.point_a.allFinite() || !p.point_b.allFinite()) continue;
    // Length first: ids may hold any byte, and ("a\nb", "c") and ("a", "b\nc") joined by a
    // newline were one key (one pair's markers drawn, the other's not).
    const std::string key = std::to_string(p.body_a.size()) + ':' + p.body_a + p.body_b;
    const std_msgs::ColorRGBA color = statusColor(p.status, p.distance, warning_distance);

    Marker line;
    line.header = header;
    line.ns = kWitness;
    line.id = markerId(kWitness, key);
    line.type = Marker::LINE_LIST;
    line.action = Marker::ADD;
    line.pose = identityPose();
    line.scale.x = options_.line_width;
    line.color = color;
    line.points = {toPointMsg(p.point_a), toPointMsg(p.point_b)};
    emit(std::move(line), key);

    Marker label;
    label.header = header;
    label.ns = kLabels;
    label.id = markerId(kLabels, key);
    label.type = Marker::TEXT_VIEW_FACING;
    label.action = Marker::ADD;
    label.pose = identityPose();
    label.text = distanceLabel(p.distance);
    label.pose.position = toPointMsg(placeLabel(
        0.5 * (p.point_a + p.point_b),
        0.5 * kLabelCharWidth * options_.text_height * static_cast<double>(label.text.size()),
        options_.text_height, &labels));
    label.scale.z = options_.text_height;
    // Lighter than the bodies so that the text stays readable in front of them.
    label.color = rgba(0.5 + 0.5 * color.r, 0.5 + 0.5 * color.g, 0.5 + 0.5 * color.b);
    emit(std::move(label), key);

    if (p.distance < 0.0 && p.normal.allFinite() && p.normal.norm() > 0.5) {
      const double length = std::max(-p.distance, options_.min_arrow_length);
      Marker arrow;
      arrow.header = header;
      arrow.ns = kNormals;
      arrow.id = markerId(kNormals, key);
      arrow.type = Marker::ARROW;
      arrow.action = Marker::ADD;
      arrow.pose = identityPose();
      arrow.scale.x = 1.5 * options_.line_width;     // shaft diameter
      arrow.scale.y = 3.0 * options_.line_width;     // head diameter
      arrow.scale.z = std::min(0.4 * length, 0.02);  // head length
      arrow.color = color;
      arrow.points = {toPointMsg(p.point_a),
                      toPointMsg(p.point_a + length * p.normal.normalized())};
      emit(std::move(arrow), key);
    }
  }

  // Deletions: whatever was shown last time and is gone now, sent again in every array for as
  // long as the marker would live (1 s for markers that live forever): a subscriber that missed
  // one array gets it with the next. An id is reused only once its DELETEs have stopped, so no
  // DELETE comes after a new marker's ADD. (Never reused, ids grew by two for each pair that
  // flapped: a signed overflow after weeks.)
  for (const auto& [ns_id, key] : shown_) {
    if (shown.count(ns_id) != 0) continue;
    // Body markers for as long as they live (a subscriber that misses every DELETE would keep
    // a removed body that long); the others for a lifetime.
    deleting_[ns_id] =
        now + (isBodyMarker(ns_id.first) ? kBodyLifetimes : 1.0) * (life > 0.0 ? life : 1.0);
    ids_.erase({ns_id.first, key});
    sent_.erase(ns_id);
  }
  for (auto it = deleting_.begin(); it != deleting_.end();) {
    if (now > it->second) {
      free_ids_.push_back(it->first.second);
      it = deleting_.erase(it);
      continue;
    }
    Marker del;
    del.header = header;
    del.ns = it->first.first;
    del.id = it->first.second;
    del.action = Marker::DELETE;
    del.pose = identityPose();
    out.markers.push_back(std::move(del));
    ++it;
  }
  shown_ = std::move(shown);
  return out;
}

}  // namespace ros_layer
}  // namespace collision_monitor
