// MarkerBuilder without a master: colours per status, hull triangles, labels, normals, stamps,
// padding shells, cache invalidation and the deletions that keep rviz free of ghosts.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "collision_monitor/ros/markers.h"

namespace cm = collision_monitor;
using cm::core::ConvexShape;
using cm::core::Transform3;
using cm::core::Vec3;
using cm::ros_layer::MarkerBuilder;
using cm::ros_layer::MarkerOptions;
using cm::world::PairResult;
using cm::world::PairStatus;
using visualization_msgs::Marker;
using visualization_msgs::MarkerArray;

namespace {

const char* const kFrame = "world";

Transform3 at(double x, double y, double z) {
  Transform3 t;
  t.t = Vec3(x, y, z);
  return t;
}

/// A body without parts, posed from a topic in the fixed frame.
cm::world::BodySpec topicBody(const std::string& id) {
  cm::world::BodySpec spec;
  spec.id = id;
  spec.frame = kFrame;
  spec.pose_source = cm::world::PoseSource::Topic;
  return spec;
}

cm::world::BodySpec boxBody(const std::string& id, double padding = 0.0) {
  cm::world::BodySpec spec = topicBody(id);
  const ConvexShape box = ConvexShape::box(Vec3(0.1, 0.1, 0.1));
  // Parts are stored already padded (world_model.h); padding keeps the amount for reporting.
  spec.parts.push_back(
      cm::world::Part{padding > 0.0 ? box.padded(padding) : box, Transform3::Identity()});
  spec.padding = padding;
  return spec;
}

void addBody(cm::world::WorldModel& world, cm::world::BodySpec spec, const Transform3& pose) {
  const std::string id = spec.id;
  ASSERT_EQ(world.addBody(std::move(spec)), "") << id;
  ASSERT_TRUE(world.setPose(id, pose, 0.0)) << id;  // stamp 0: static, never stale
}

PairResult pair(const std::string& a, const std::string& b, PairStatus status, double distance) {
  PairResult p;
  p.body_a = a;
  p.body_b = b;
  p.status = status;
  p.distance = distance;
  p.point_a = Vec3(0.0, 0.0, 0.0);
  p.point_b = Vec3(std::max(distance, 0.0), 0.0, 0.0);
  p.normal = Vec3::UnitX();
  return p;
}

std::vector<const Marker*> find(const MarkerArray& a, const std::string& ns, int action) {
  std::vector<const Marker*> out;
  for (const auto& m : a.markers) {
    if (m.ns == ns && m.action == action) out.push_back(&m);
  }
  return out;
}

/// Options without the rate limit: every build() produces markers.
MarkerOptions everyCycle() {
  MarkerOptions o;
  o.max_rate = 0.0;
  return o;
}

bool isGreen(const std_msgs::ColorRGBA& c) {
  return c.g > 0.6 && c.r < 0.4 && c.b < 0.4;
}
bool isAmber(const std_msgs::ColorRGBA& c) {
  return c.r > 0.9 && c.g > 0.3 && c.g < 0.9 && c.b < 0.1;
}
bool isRed(const std_msgs::ColorRGBA& c) {
  return c.r > 0.8 && c.g < 0.2 && c.b < 0.2;
}
bool isGrey(const std_msgs::ColorRGBA& c) {
  return std::abs(c.r - c.g) < 0.01 && std::abs(c.g - c.b) < 0.01 && c.r > 0.3 && c.r < 0.7;
}

/// The "bodies" marker of each body id, in build order (one part per body in these tests).
std::map<std::string, const Marker*> bodyMarkers(const MarkerArray& a,
                                                 const std::vector<std::string>& ids) {
  // Bodies are emitted in the world's listing order; match them by position instead of relying
  // on the builder's id numbering: each body here is at a distinct x.
  std::map<std::string, const Marker*> out;
  const auto bodies = find(a, "bodies", Marker::ADD);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    for (const Marker* m : bodies) {
      if (std::abs(m->pose.position.x - static_cast<double>(i)) < 1e-9) out[ids[i]] = m;
    }
  }
  return out;
}

}  // namespace

TEST(MarkerColours, OnePerStatus) {
  EXPECT_TRUE(isGreen(MarkerBuilder::statusColor(PairStatus::Clear, 1.0, 0.05)));
  EXPECT_TRUE(isAmber(MarkerBuilder::statusColor(PairStatus::Warning, 0.02, 0.05)));
  EXPECT_TRUE(isRed(MarkerBuilder::statusColor(PairStatus::Collision, -0.01, 0.05)));
  EXPECT_TRUE(isGrey(MarkerBuilder::statusColor(PairStatus::Unknown, 0.0, 0.05)));
  // The warning ramp: closer is more orange (less green), and stays amber at both ends.
  const auto near = MarkerBuilder::statusColor(PairStatus::Warning, 0.001, 0.05);
  const auto far = MarkerBuilder::statusColor(PairStatus::Warning, 0.049, 0.05);
  EXPECT_LT(near.g, far.g);
  EXPECT_TRUE(isAmber(near));
  EXPECT_TRUE(isAmber(far));
  // Defined for odd input.
  EXPECT_TRUE(isAmber(MarkerBuilder::statusColor(PairStatus::Warning, 0.01, 0.0)));
}

TEST(MarkerLabels, MillimetresWithSign) {
  EXPECT_EQ(MarkerBuilder::distanceLabel(0.0234), "23.4 mm");
  EXPECT_EQ(MarkerBuilder::distanceLabel(-0.004), "-4.0 mm");
  EXPECT_EQ(MarkerBuilder::distanceLabel(0.0), "0.0 mm");
  EXPECT_EQ(MarkerBuilder::distanceLabel(-1e-6), "0.0 mm");
  EXPECT_EQ(MarkerBuilder::distanceLabel(1.5), "1500.0 mm");
}

TEST(MarkerBuilder, BodiesColouredByWorstPairStatus) {
  cm::world::WorldModel world;
  const std::vector<std::string> ids = {"a", "b", "c", "d", "e"};
  for (std::size_t i = 0; i < ids.size(); ++i) {
    addBody(world, boxBody(ids[i]), at(static_cast<double>(i), 0.0, 0.0));
  }
  cm::world::CycleResult cycle;
  cycle.stamp = 12.5;
  cycle.pairs.push_back(pair("a", "b", PairStatus::Collision, -0.01));
  cycle.pairs.push_back(pair("b", "c", PairStatus::Warning, 0.02));
  cycle.pairs.push_back(pair("d", "e", PairStatus::Unknown, 0.0));
  cycle.stale_bodies.push_back("e");

  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cycle, kFrame);
  const auto bodies = bodyMarkers(out, ids);
  ASSERT_EQ(bodies.size(), ids.size());
  EXPECT_TRUE(isRed(bodies.at("a")->color));
  EXPECT_TRUE(isRed(bodies.at("b")->color)) << "worst of collision and warning";
  EXPECT_TRUE(isAmber(bodies.at("c")->color));
  // d-e is UNKNOWN because e is stale: e is grey, d is coloured by its known pairs (none: clear).
  // Greying d too greyed every body of a scene with one stale body, the stale one not told apart.
  EXPECT_TRUE(isGreen(bodies.at("d")->color));
  EXPECT_TRUE(isGrey(bodies.at("e")->color));
  for (const auto& [id, m] : bodies) {
    EXPECT_EQ(m->type, Marker::CUBE) << id;
    EXPECT_NEAR(m->scale.x, 0.1, 1e-12) << id;
    EXPECT_GT(m->color.a, 0.5) << id;
  }

  // Every marker is in the fixed frame and stamped like the state.
  for (const auto& m : out.markers) {
    EXPECT_EQ(m.header.frame_id, kFrame);
    EXPECT_DOUBLE_EQ(m.header.stamp.toSec(), 12.5);
  }

  // Everything clear: all green.
  cm::world::CycleResult clear;
  clear.stamp = 13.0;
  const MarkerArray out2 = builder.build(world, clear, kFrame);
  for (const auto& [id, m] : bodyMarkers(out2, ids))
    EXPECT_TRUE(isGreen(m->color)) << id;
}

// A body with two pairs of one status is coloured by the closer one: b in warning at 40 mm of
// a and at 10 mm of c is as deep an amber as c, not as pale as a.
TEST(MarkerBuilder, BodyColouredByItsClosestPairOfTheWorstStatus) {
  cm::world::WorldModel world;
  const std::vector<std::string> ids = {"a", "b", "c"};
  for (std::size_t i = 0; i < ids.size(); ++i) {
    addBody(world, boxBody(ids[i]), at(static_cast<double>(i), 0.0, 0.0));
  }
  cm::world::CycleResult cycle;
  cycle.stamp = 1.0;
  cycle.pairs.push_back(pair("a", "b", PairStatus::Warning, 0.04));
  cycle.pairs.push_back(pair("b", "c", PairStatus::Warning, 0.01));
  MarkerBuilder builder(everyCycle());
  const auto bodies = bodyMarkers(builder.build(world, cycle, kFrame), ids);
  ASSERT_EQ(bodies.size(), ids.size());
  for (const auto& [id, m] : bodies)
    EXPECT_TRUE(isAmber(m->color)) << id;
  EXPECT_EQ(bodies.at("b")->color.g, bodies.at("c")->color.g);
  EXPECT_LT(bodies.at("b")->color.g, bodies.at("a")->color.g);
}

TEST(MarkerBuilder, CubeHullIsTwelveTriangles) {
  cm::world::WorldModel world;
  cm::world::BodySpec spec = topicBody("cube");
  std::vector<Vec3> corners;
  for (int i = 0; i < 8; ++i) {
    corners.emplace_back(i & 1 ? 0.1 : -0.1, i & 2 ? 0.1 : -0.1, i & 4 ? 0.1 : -0.1);
  }
  spec.parts.push_back(cm::world::Part{ConvexShape::convexHull(corners), Transform3::Identity()});
  addBody(world, spec, at(0.0, 0.0, 0.0));

  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cm::world::CycleResult(), kFrame);
  const auto bodies = find(out, "bodies", Marker::ADD);
  ASSERT_EQ(bodies.size(), 1u);
  EXPECT_EQ(bodies[0]->type, Marker::TRIANGLE_LIST);
  EXPECT_EQ(bodies[0]->points.size(), 36u);
  // One shaded colour per face (rviz draws uncoloured triangle lists unlit), all green here.
  ASSERT_EQ(bodies[0]->colors.size(), 12u);
  for (const auto& c : bodies[0]->colors) {
    EXPECT_GT(c.g, 1.5f * c.r);
    EXPECT_LE(c.g, bodies[0]->color.g + 1e-6f);
    EXPECT_GE(c.g, 0.5f * bodies[0]->color.g);
  }
  for (const auto& p : bodies[0]->points) {
    EXPECT_NEAR(std::abs(p.x), 0.1, 1e-12);
    EXPECT_NEAR(std::abs(p.y), 0.1, 1e-12);
    EXPECT_NEAR(std::abs(p.z), 0.1, 1e-12);
  }
}

TEST(MarkerBuilder, ShapesGivenFarOutAreDrawnWhereTheyAre) {
  // Coordinates 1e4 m out are kept about their centre (ConvexShape::offset()): the hull's
  // triangles, its padding shell and a padded point still land on the given coordinates.
  cm::world::WorldModel world;
  cm::world::BodySpec spec = topicBody("far");
  const Vec3 c(1e4, -2e4, 3.0);
  std::vector<Vec3> corners;
  for (int i = 0; i < 8; ++i)
    corners.push_back(c + Vec3(i & 1 ? 0.1 : -0.1, i & 2 ? 0.1 : -0.1, i & 4 ? 0.1 : -0.1));
  const ConvexShape hull = ConvexShape::convexHull(corners);
  ASSERT_NE(hull.offset(), Vec3::Zero());
  spec.parts.push_back(cm::world::Part{hull.padded(0.02), Transform3::Identity()});
  spec.parts.push_back(
      cm::world::Part{ConvexShape::point(c + Vec3(0, 0, 1)).padded(0.05), Transform3::Identity()});
  spec.padding = 0.02;
  addBody(world, spec, at(0.0, 0.0, 0.0));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cm::world::CycleResult(), kFrame);
  const auto bodies = find(out, "bodies", Marker::ADD);
  ASSERT_EQ(bodies.size(), 2u);
  int triangles = 0, spheres = 0;
  for (const Marker* m : bodies) {
    if (m->type == Marker::TRIANGLE_LIST) {
      ++triangles;
      EXPECT_EQ(m->points.size(), 36u);
      for (const auto& p : m->points) {
        EXPECT_NEAR(std::abs(p.x - c.x()), 0.1, 1e-9);
        EXPECT_NEAR(std::abs(p.y - c.y()), 0.1, 1e-9);
        EXPECT_NEAR(std::abs(p.z - c.z()), 0.1, 1e-9);
      }
    } else {
      ++spheres;
      EXPECT_EQ(m->type, Marker::SPHERE);
      EXPECT_NEAR(m->pose.position.x, c.x(), 1e-9);
      EXPECT_NEAR(m->pose.position.y, c.y(), 1e-9);
      EXPECT_NEAR(m->pose.position.z, c.z() + 1.0, 1e-9);
    }
  }
  EXPECT_EQ(triangles, 1);
  EXPECT_EQ(spheres, 1);
  const auto shell = find(out, "padding", Marker::ADD);
  ASSERT_EQ(shell.size(), 2u);
  int hull_shells = 0;  // the cube's (the padded point's shell is a sphere)
  for (const Marker* m : shell) {
    if (m->type != Marker::TRIANGLE_LIST) continue;
    ++hull_shells;
    ASSERT_GT(m->points.size(), 30u);
    double max_x = -1e300;
    for (const auto& p : m->points) {
      EXPECT_LE((Vec3(p.x, p.y, p.z) - c).cwiseAbs().maxCoeff(), 0.12 + 1e-9);
      max_x = std::max(max_x, p.x);
    }
    EXPECT_NEAR(max_x, c.x() + 0.12, 1e-9) << "the shell is the hull inflated by the padding";
  }
  EXPECT_EQ(hull_shells, 1);
}

TEST(MarkerBuilder, PrimitivesAndTessellations) {
  cm::world::WorldModel world;
  cm::world::BodySpec spec = topicBody("mixed");
  for (const ConvexShape& s : {ConvexShape::sphere(0.05), ConvexShape::cylinder(0.2, 0.05),
                               ConvexShape::capsule(0.2, 0.05), ConvexShape::cone(0.2, 0.05),
                               ConvexShape::ellipsoid(Vec3(0.1, 0.05, 0.02))}) {
    spec.parts.push_back(cm::world::Part{s, at(0.0, 0.0, 0.5)});
  }
  addBody(world, spec, at(1.0, 0.0, 0.0));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cm::world::CycleResult(), kFrame);
  const auto bodies = find(out, "bodies", Marker::ADD);
  ASSERT_EQ(bodies.size(), 5u);
  std::vector<int> types;
  for (const Marker* m : bodies) {
    types.push_back(m->type);
    EXPECT_NEAR(m->pose.position.x, 1.0, 1e-12);
    EXPECT_NEAR(m->pose.position.z, 0.5, 1e-12);  // body pose * part pose
  }
  std::sort(types.begin(), types.end());
  // SPHERE (sphere, ellipsoid), CYLINDER, TRIANGLE_LIST (capsule, cone).
  EXPECT_EQ(types, (std::vector<int>{Marker::SPHERE, Marker::SPHERE, Marker::CYLINDER,
                                     Marker::TRIANGLE_LIST, Marker::TRIANGLE_LIST}));
  for (const Marker* m : bodies) {
    if (m->type != Marker::TRIANGLE_LIST) continue;
    ASSERT_GT(m->points.size(), 30u);
    EXPECT_EQ(m->points.size() % 3, 0u);
    for (const auto& p : m->points) {
      // Capsule: |z| <= 0.1 + 0.05, radius 0.05; cone: |z| <= 0.1.
      EXPECT_LE(std::abs(p.z), 0.15 + 1e-9);
      EXPECT_LE(std::hypot(p.x, p.y), 0.05 + 1e-9);
    }
  }
}

// rviz's CUBE, CYLINDER and SPHERE markers take full sizes: a box's sides, a cylinder's diameter
// (x, y) and height (z), an ellipsoid's diameters.
TEST(MarkerBuilder, PrimitiveMarkersHaveFullSizes) {
  cm::world::WorldModel world;
  cm::world::BodySpec spec = topicBody("sizes");
  for (const ConvexShape& s :
       {ConvexShape::box(Vec3(0.1, 0.2, 0.3)), ConvexShape::cylinder(0.2, 0.05),
        ConvexShape::ellipsoid(Vec3(0.1, 0.05, 0.02))}) {
    spec.parts.push_back(cm::world::Part{s, Transform3::Identity()});
  }
  addBody(world, spec, at(0.0, 0.0, 0.0));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cm::world::CycleResult(), kFrame);
  std::map<int, Vec3> scales;  // marker type -> scale
  for (const Marker* m : find(out, "bodies", Marker::ADD))
    scales[m->type] = Vec3(m->scale.x, m->scale.y, m->scale.z);
  ASSERT_EQ(scales.size(), 3u);
  EXPECT_NEAR((scales[Marker::CUBE] - Vec3(0.1, 0.2, 0.3)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((scales[Marker::CYLINDER] - Vec3(0.1, 0.1, 0.2)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((scales[Marker::SPHERE] - Vec3(0.2, 0.1, 0.04)).norm(), 0.0, 1e-12);
}

// Normals are drawn for penetrating pairs only: bodies that just touch (distance 0, in
// COLLISION at contact_distance 0) get no arrow. A deep arrow keeps a head of at most 2 cm.
TEST(MarkerBuilder, NoNormalForTouchingPairsAndShortHeads) {
  cm::world::WorldModel world;
  addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
  addBody(world, boxBody("b"), at(1.0, 0.0, 0.0));
  cm::world::CycleResult touching;
  touching.pairs.push_back(pair("a", "b", PairStatus::Collision, 0.0));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, touching, kFrame, 0.0);
  EXPECT_EQ(find(out, "witness", Marker::ADD).size(), 1u);
  EXPECT_EQ(find(out, "normals", Marker::ADD).size(), 0u);
  cm::world::CycleResult deep;
  deep.pairs.push_back(pair("a", "b", PairStatus::Collision, -0.2));
  const MarkerArray d = builder.build(world, deep, kFrame, 0.1);
  const auto arrows = find(d, "normals", Marker::ADD);
  ASSERT_EQ(arrows.size(), 1u);
  ASSERT_EQ(arrows[0]->points.size(), 2u);
  EXPECT_NEAR(arrows[0]->points[1].x - arrows[0]->points[0].x, 0.2, 1e-12);
  EXPECT_GT(arrows[0]->scale.z, 0.0);
  EXPECT_LE(arrows[0]->scale.z, 0.02);
}

TEST(MarkerBuilder, PaddingShell) {
  cm::world::WorldModel world;
  addBody(world, boxBody("padded", 0.02), at(0.0, 0.0, 0.0));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cm::world::CycleResult(), kFrame);
  const auto solid = find(out, "bodies", Marker::ADD);
  const auto shell = find(out, "padding", Marker::ADD);
  ASSERT_EQ(solid.size(), 1u);
  ASSERT_EQ(shell.size(), 1u);
  EXPECT_EQ(solid[0]->type, Marker::CUBE);
  EXPECT_NEAR(solid[0]->scale.x, 0.1, 1e-12) << "the solid is drawn without its padding";
  EXPECT_EQ(shell[0]->type, Marker::TRIANGLE_LIST);
  EXPECT_LT(shell[0]->color.a, solid[0]->color.a);
  double max_x = 0.0;
  for (const auto& p : shell[0]->points)
    max_x = std::max(max_x, p.x);
  EXPECT_NEAR(max_x, 0.05 + 0.02, 1e-9) << "the shell is the box inflated by the padding";
}

TEST(MarkerBuilder, WitnessLabelAndNormal) {
  cm::world::WorldModel world;
  addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
  addBody(world, boxBody("b"), at(1.0, 0.0, 0.0));
  addBody(world, boxBody("c"), at(2.0, 0.0, 0.0));
  cm::world::CycleResult cycle;
  cycle.stamp = 3.0;
  cycle.pairs.push_back(pair("a", "b", PairStatus::Warning, 0.0234));
  cycle.pairs.push_back(pair("b", "c", PairStatus::Collision, -0.004));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cycle, kFrame);

  const auto lines = find(out, "witness", Marker::ADD);
  ASSERT_EQ(lines.size(), 2u);
  for (const Marker* m : lines) {
    EXPECT_EQ(m->type, Marker::LINE_LIST);
    EXPECT_EQ(m->points.size(), 2u);
  }
  const auto labels = find(out, "labels", Marker::ADD);
  ASSERT_EQ(labels.size(), 2u);
  std::vector<std::string> texts;
  for (const Marker* m : labels) {
    EXPECT_EQ(m->type, Marker::TEXT_VIEW_FACING);
    texts.push_back(m->text);
  }
  std::sort(texts.begin(), texts.end());
  EXPECT_EQ(texts, (std::vector<std::string>{"-4.0 mm", "23.4 mm"}));
  // Labels: the pair's colour, lightened (amber -> light yellow, red -> pink).
  const auto& warn_label = labels[0]->text == "23.4 mm" ? labels[0]->color : labels[1]->color;
  const auto& hit_label = labels[0]->text == "23.4 mm" ? labels[1]->color : labels[0]->color;
  EXPECT_GT(warn_label.r, 0.9);
  EXPECT_GT(warn_label.g, 0.6);
  EXPECT_LT(warn_label.b, warn_label.g);
  EXPECT_GT(hit_label.r, 0.9);
  EXPECT_LT(hit_label.g, 0.7);

  // Only the penetrating pair gets a normal, along +x (a towards b), at least min length long.
  const auto arrows = find(out, "normals", Marker::ADD);
  ASSERT_EQ(arrows.size(), 1u);
  EXPECT_EQ(arrows[0]->type, Marker::ARROW);
  ASSERT_EQ(arrows[0]->points.size(), 2u);
  const double dx = arrows[0]->points[1].x - arrows[0]->points[0].x;
  EXPECT_GE(dx, 0.004);
  EXPECT_NEAR(arrows[0]->points[1].y - arrows[0]->points[0].y, 0.0, 1e-12);
  EXPECT_TRUE(isRed(arrows[0]->color));
}

// The labels of pairs that meet at one place (a ball between two fingers: the Panda demo's
// screenshot) were printed over each other. Each now goes on the first line above its witness
// segment's middle where it meets no label placed before it; a label elsewhere stays on its first.
TEST(MarkerBuilder, LabelsOfPairsThatMeetAtOnePlaceAreStacked) {
  cm::world::WorldModel world;
  for (const char* id : {"ball", "finger_l", "finger_r", "lamp", "hand"})
    addBody(world, boxBody(id), at(0.0, 0.0, 0.0));
  auto witness = [](PairResult p, const Vec3& a, const Vec3& b) {
    p.point_a = a;
    p.point_b = b;
    return p;
  };
  const Vec3 ball(0.3, 0.2, 0.5);
  cm::world::CycleResult cycle;
  cycle.stamp = 3.0;
  // Sides of the ball 1 cm apart, two labels of 7 characters (0.14 m wide at 3 cm): they meet.
  cycle.pairs.push_back(witness(pair("ball", "finger_l", PairStatus::Warning, 0.0367), ball,
                                ball + Vec3(0.0, 0.0367, 0.0)));
  cycle.pairs.push_back(witness(pair("ball", "finger_r", PairStatus::Warning, 0.0287),
                                ball + Vec3(0.01, 0.0, 0.0), ball + Vec3(0.01, -0.0287, 0.0)));
  // Below the ball by 2 cm: meets the first label's line, then the second's.
  cycle.pairs.push_back(witness(pair("ball", "hand", PairStatus::Collision, -0.004),
                                ball - Vec3(0.0, 0.0, 0.02), ball - Vec3(0.0, 0.0, 0.024)));
  // 0.5 m away sideways at the same height: meets none.
  cycle.pairs.push_back(witness(pair("hand", "lamp", PairStatus::Warning, 0.04),
                                ball + Vec3(0.5, 0.0, 0.0), ball + Vec3(0.54, 0.0, 0.0)));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cycle, kFrame);
  std::map<std::string, geometry_msgs::Point> at_text;
  for (const Marker* m : find(out, "labels", Marker::ADD))
    at_text[m->text] = m->pose.position;
  ASSERT_EQ(at_text.size(), 4u);
  const double h = MarkerOptions().text_height, line = 1.2 * h;
  // x and y: the middle of each witness segment; z: 1.2 text heights a line.
  const std::map<std::string, Vec3> expected{{"36.7 mm", ball + Vec3(0.0, 0.01835, line)},
                                             {"28.7 mm", ball + Vec3(0.01, -0.01435, 2.0 * line)},
                                             {"-4.0 mm", ball + Vec3(0.0, 0.0, 3.0 * line)},
                                             {"40.0 mm", ball + Vec3(0.52, 0.0, line)}};
  for (const auto& [text, where] : expected) {
    ASSERT_EQ(at_text.count(text), 1u) << text;
    EXPECT_NEAR(at_text[text].x, where.x(), 1e-12) << text;
    EXPECT_NEAR(at_text[text].y, where.y(), 1e-12) << text;
    EXPECT_NEAR(at_text[text].z, where.z(), 1e-12) << text;
  }

  // A crowd: ten pairs at one place. The first nine go on lines 1 to 9, the tenth, with nine
  // labels within reach before it (more than 8), stays on its first line.
  cycle.pairs.clear();
  for (int i = 0; i < 10; ++i) {
    const std::string obstacle = "o" + std::to_string(i);
    addBody(world, boxBody(obstacle), at(0.0, 0.0, 0.0));
    const double d = 0.011 + 0.001 * i;
    cycle.pairs.push_back(witness(pair("ball", obstacle, PairStatus::Warning, d),
                                  ball - Vec3(0.0, 0.0, 0.5 * d), ball + Vec3(0.0, 0.0, 0.5 * d)));
  }
  MarkerBuilder crowd_builder(everyCycle());
  const MarkerArray crowd = crowd_builder.build(world, cycle, kFrame);
  at_text.clear();
  for (const Marker* m : find(crowd, "labels", Marker::ADD))
    at_text[m->text] = m->pose.position;
  ASSERT_EQ(at_text.size(), 10u);
  for (int i = 0; i < 10; ++i) {
    const double d = 0.011 + 0.001 * i;
    const std::string text = MarkerBuilder::distanceLabel(d);
    ASSERT_EQ(at_text.count(text), 1u) << text;
    EXPECT_NEAR(at_text[text].z, ball.z() + (i < 9 ? i + 1 : 1) * line, 1e-12) << text;
  }
}

// Bug: a pair's markers were keyed by its ids joined by a newline, which ids may contain: pairs
// ("a\nb", "c") and ("a", "b\nc") shared one witness segment and one label.
TEST(MarkerBuilder, PairsWhoseIdsJoinAlikeAreBothDrawn) {
  cm::world::WorldModel world;
  for (const char* id : {"a", "a\nb", "b\nc", "c"}) {
    addBody(world, boxBody(id), at(0.0, 0.0, 0.0));
  }
  cm::world::CycleResult cycle;
  cycle.stamp = 3.0;
  cycle.pairs.push_back(pair("a\nb", "c", PairStatus::Warning, 0.0234));
  cycle.pairs.push_back(pair("a", "b\nc", PairStatus::Warning, 0.0125));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cycle, kFrame);
  // Two markers of one id are one in rviz: the second replaces the first.
  for (const char* ns : {"witness", "labels"}) {
    std::set<int> ids;
    for (const Marker* m : find(out, ns, Marker::ADD))
      ids.insert(m->id);
    EXPECT_EQ(ids.size(), 2u) << ns;
  }
}

TEST(MarkerBuilder, DeletesRemovedBodiesAndClearedPairs) {
  cm::world::WorldModel world;
  addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
  addBody(world, boxBody("b", 0.01), at(1.0, 0.0, 0.0));
  addBody(world, boxBody("c"), at(2.0, 0.0, 0.0));
  cm::world::CycleResult cycle;
  cycle.stamp = 1.0;
  cycle.pairs.push_back(pair("a", "b", PairStatus::Collision, -0.01));
  cycle.pairs.push_back(pair("a", "c", PairStatus::Warning, 0.03));
  MarkerBuilder builder(everyCycle());

  const MarkerArray first = builder.build(world, cycle, kFrame, 0.0);
  ASSERT_FALSE(first.markers.empty());
  EXPECT_EQ(first.markers.front().action, Marker::DELETEALL) << "first build clears old markers";
  EXPECT_EQ(builder.numShown(), 3u + 1u + 2u * 2u + 1u);  // bodies, shell, 2 x (line, label), arrow

  // Same cycle again: the pairs' markers, nothing deleted, no DELETEALL; the bodies are
  // unchanged and were sent less than a third of their lifetime ago (UnchangedBodiesAreNotSent).
  const MarkerArray again = builder.build(world, cycle, kFrame, 0.01);
  for (const auto& m : again.markers)
    EXPECT_EQ(m.action, Marker::ADD);
  EXPECT_EQ(again.markers.size(), first.markers.size() - 1 - 4);
  EXPECT_EQ(builder.numShown(), 3u + 1u + 2u * 2u + 1u);

  // Body b removed, pair a-c cleared: b's body and shell markers, both pairs' markers go.
  ASSERT_TRUE(world.removeBody("b"));
  cm::world::CycleResult later;
  later.stamp = 2.0;
  const MarkerArray second = builder.build(world, later, kFrame, 0.02);
  std::map<std::string, int> deleted;
  for (const auto& m : second.markers) {
    if (m.action == Marker::DELETE) {
      ++deleted[m.ns];
      EXPECT_EQ(m.header.frame_id, kFrame);
    }
  }
  EXPECT_EQ(deleted,
            (std::map<std::string, int>{
                {"bodies", 1}, {"padding", 1}, {"witness", 2}, {"labels", 2}, {"normals", 1}}));
  EXPECT_EQ(find(second, "bodies", Marker::ADD).size(), 2u);
  EXPECT_EQ(builder.numShown(), 2u);

  // The DELETEs again in every array for as long as the markers would live (1 s, bodies 5 s),
  // then no more.
  const MarkerArray third = builder.build(world, later, kFrame, 1.0);
  EXPECT_EQ(find(third, "witness", Marker::DELETE).size(), 2u);
  EXPECT_EQ(find(third, "bodies", Marker::DELETE).size(), 1u);
  const MarkerArray after = builder.build(world, later, kFrame, 1.03);
  EXPECT_EQ(find(after, "witness", Marker::DELETE).size(), 0u);
  EXPECT_EQ(find(after, "bodies", Marker::DELETE).size(), 1u);
  EXPECT_EQ(find(after, "padding", Marker::DELETE).size(), 1u);
  const MarkerArray long_after = builder.build(world, later, kFrame, 5.03);
  for (const auto& m : long_after.markers)
    EXPECT_EQ(m.action, Marker::ADD);

  // A pair that clears and comes back is shown again.
  cycle.pairs.erase(cycle.pairs.begin());  // a-b: b is gone
  const MarkerArray fourth = builder.build(world, cycle, kFrame, 5.04);
  EXPECT_EQ(find(fourth, "witness", Marker::ADD).size(), 1u);
  EXPECT_EQ(find(fourth, "labels", Marker::ADD).size(), 1u);
}

// Ids were never reused: a pair that flapped took new ones each time it came back, and the int
// counter grew without bound (100 flapping pairs at 15 Hz overflowed it in about 16 days). An id
// is now reused once its DELETEs have stopped: the ids stay few, and a subscriber that applies
// every array in order (as rviz does) always shows exactly the pair's markers.
TEST(MarkerBuilder, IdsAreReusedOnceTheirDeletionsStop) {
  cm::world::WorldModel world;
  addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
  addBody(world, boxBody("c"), at(2.0, 0.0, 0.0));
  cm::world::CycleResult present, absent;
  present.pairs.push_back(pair("a", "c", PairStatus::Collision, -0.01));
  MarkerBuilder builder(everyCycle());
  std::map<std::pair<std::string, int>, int> rviz;  // (ns, id) -> action of what it holds
  int max_id = 0;
  for (int step = 0; step < 2000; ++step) {
    const bool shown = step % 4 < 2;  // two arrays with the pair, two without: 0.5 s each
    const MarkerArray a = builder.build(world, shown ? present : absent, kFrame, 0.25 * step);
    for (const auto& m : a.markers) {
      if (m.action == Marker::DELETEALL) {
        rviz.clear();
      } else if (m.action == Marker::DELETE) {
        rviz.erase({m.ns, m.id});
      } else {
        rviz[{m.ns, m.id}] = m.action;
        max_id = std::max(max_id, m.id);
      }
    }
    std::map<std::string, int> per_ns;
    for (const auto& [ns_id, action] : rviz)
      ++per_ns[ns_id.first];
    const std::map<std::string, int> want = shown ? std::map<std::string, int>{{"bodies", 2},
                                                                               {"witness", 1},
                                                                               {"labels", 1},
                                                                               {"normals", 1}}
                                                  : std::map<std::string, int>{{"bodies", 2}};
    ASSERT_EQ(per_ns, want) << "step " << step;
  }
  EXPECT_LE(max_id, 12);  // 2 bodies and up to 3 sets of 3 pair markers (was 1,500 by the end)
}

TEST(MarkerBuilder, AMissedDeletionComesAgainOrExpires) {
  // A subscriber that misses the array with the DELETEs (a slow link; the publisher's queue is 1)
  // kept cleared pairs' segments and labels, and removed bodies, for good. DELETEs now come again
  // in every array for as long as the marker would live, and every marker has a lifetime
  // (bodies five): rviz (simulated: expiry = receipt + lifetime) drops them that long after the
  // last array that showed them, while what is refreshed stays.
  for (const double missed_until : {0.65, 2.55}) {
    cm::world::WorldModel world;
    addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
    addBody(world, boxBody("b"), at(1.0, 0.0, 0.0));
    cm::world::CycleResult warning;
    warning.stamp = 1.0;
    warning.pairs.push_back(pair("a", "b", PairStatus::Warning, 0.03));
    MarkerOptions options = everyCycle();
    options.lifetime = 0.5;
    MarkerBuilder builder(options);
    std::map<std::pair<std::string, int>, std::pair<Marker, double>> rviz;  // marker, expiry
    const auto receive = [&rviz](const MarkerArray& array, double t) {
      for (const auto& m : array.markers) {
        if (m.action == Marker::DELETEALL) {
          rviz.clear();
        } else if (m.action == Marker::DELETE) {
          rviz.erase({m.ns, m.id});
        } else {
          EXPECT_EQ(m.lifetime.toSec(), m.ns == "bodies" ? 2.5 : 0.5) << m.ns;
          rviz[{m.ns, m.id}] = {m, t + m.lifetime.toSec()};
        }
      }
      for (auto it = rviz.begin(); it != rviz.end();)
        it = it->second.second <= t ? rviz.erase(it) : std::next(it);
    };
    receive(builder.build(world, warning, kFrame, 0.0), 0.0);
    EXPECT_EQ(rviz.size(), 4u);  // 2 bodies, segment, label
    ASSERT_TRUE(world.removeBody("b"));
    cm::world::CycleResult clear;
    clear.stamp = 2.0;
    const MarkerArray missed = builder.build(world, clear, kFrame, 0.1);  // b, the pair deleted
    EXPECT_EQ(find(missed, "witness", Marker::DELETE).size(), 1u);
    EXPECT_EQ(find(missed, "bodies", Marker::ADD).size(), 1u);  // a: green now (no pair)
    const MarkerArray again = builder.build(world, clear, kFrame, 0.2);
    EXPECT_EQ(find(again, "witness", Marker::DELETE).size(), 1u);  // the same DELETEs again
    EXPECT_EQ(find(again, "bodies", Marker::DELETE).size(), 1u);
    EXPECT_EQ(find(again, "bodies", Marker::ADD).size(), 0u);  // a unchanged, not due
    // Arrays missed until `missed_until`: the segment and label expire 0.5 s after the array
    // that showed them, b's body with the first array received (its DELETE comes for 2.5 s) or
    // when it expires, 2.5 s after that array; a is refreshed before it expires.
    for (double t = 0.3; t < missed_until; t += 0.1)
      builder.build(world, clear, kFrame, t);
    for (double t = missed_until + 0.05; t < 6.0; t += 0.1) {
      receive(builder.build(world, clear, kFrame, t), t);
      ASSERT_EQ(rviz.size(), 1u) << missed_until << " " << t;
      EXPECT_EQ(rviz.begin()->second.first.pose.position.x, 0.0);  // a
    }
  }
}

// Markers that live forever (lifetime 0): a DELETE comes again in every array for 1 s (bodies
// 5 s), as MarkerBuilder's header says, so a subscriber that missed one still gets it.
TEST(MarkerBuilder, DeletionsOfMarkersThatLiveForeverComeForOneSecond) {
  cm::world::WorldModel world;
  addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
  addBody(world, boxBody("b"), at(1.0, 0.0, 0.0));
  cm::world::CycleResult warning, clear;
  warning.pairs.push_back(pair("a", "b", PairStatus::Warning, 0.03));
  MarkerOptions options = everyCycle();
  options.lifetime = 0.0;
  MarkerBuilder builder(options);
  const MarkerArray first = builder.build(world, warning, kFrame, 0.0);
  ASSERT_EQ(find(first, "witness", Marker::ADD).size(), 1u);
  EXPECT_EQ(find(first, "witness", Marker::ADD)[0]->lifetime.toSec(), 0.0);
  ASSERT_TRUE(world.removeBody("b"));
  EXPECT_EQ(find(builder.build(world, clear, kFrame, 0.1), "witness", Marker::DELETE).size(), 1u);
  EXPECT_EQ(find(builder.build(world, clear, kFrame, 0.6), "witness", Marker::DELETE).size(), 1u);
  EXPECT_EQ(find(builder.build(world, clear, kFrame, 4.0), "bodies", Marker::DELETE).size(), 1u);
  const MarkerArray later = builder.build(world, clear, kFrame, 5.2);
  EXPECT_EQ(find(later, "witness", Marker::DELETE).size(), 0u);
  EXPECT_EQ(find(later, "bodies", Marker::DELETE).size(), 0u);
}

TEST(MarkerBuilder, UnchangedBodiesAreNotSent) {
  // A body marker goes out when its pose, colour or geometry changed, else only as a refresh at
  // a random time between a quarter and a half of its lifetime after it last went out (lifetime
  // 0.4 s here: 0.1 to 0.2 s).
  cm::world::WorldModel world;
  addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
  addBody(world, boxBody("b"), at(1.0, 0.0, 0.0));
  cm::world::CycleResult cycle;
  cycle.stamp = 1.0;
  MarkerOptions options = everyCycle();
  options.lifetime = 0.4;
  MarkerBuilder builder(options);
  auto sent = [&](double t) {
    std::vector<double> xs;
    for (const Marker* m : find(builder.build(world, cycle, kFrame, t), "bodies", Marker::ADD))
      xs.push_back(m->pose.position.x);
    std::sort(xs.begin(), xs.end());
    return xs;
  };
  EXPECT_EQ(sent(0.0), (std::vector<double>{0.0, 1.0}));
  EXPECT_EQ(sent(0.05), std::vector<double>{});
  EXPECT_EQ(builder.numShown(), 2u);
  ASSERT_TRUE(world.setPose("b", at(1.5, 0.0, 0.0), 0.0));  // moved
  EXPECT_EQ(sent(0.06), std::vector<double>{1.5});
  cycle.pairs.push_back(pair("a", "b", PairStatus::Warning, 0.04));  // both amber now
  EXPECT_EQ(sent(0.07), (std::vector<double>{0.0, 1.5}));
  EXPECT_EQ(sent(0.08), std::vector<double>{});
  cycle.pairs.back().distance = 0.03;  // a deeper amber
  EXPECT_EQ(sent(0.09), (std::vector<double>{0.0, 1.5}));
  EXPECT_EQ(sent(0.18), std::vector<double>{});  // not due before 0.09 + 0.1
  // Due between 0.19 and 0.29: each of a and b goes out exactly once in that time.
  std::vector<double> refreshed;
  for (double t = 0.19; t < 0.2899; t += 0.01) {
    for (double x : sent(t))
      refreshed.push_back(x);
  }
  std::sort(refreshed.begin(), refreshed.end());
  EXPECT_EQ(refreshed, (std::vector<double>{0.0, 1.5}));
  EXPECT_EQ(builder.numShown(), 2u + 2u);  // and the segment and label
  builder.reset();                         // a new start sends everything
  EXPECT_EQ(sent(0.3), (std::vector<double>{0.0, 1.5}));
  EXPECT_EQ(sent(0.31), std::vector<double>{});  // not due before 0.4
  builder.resendAll();                           // a new subscriber: everything in the next array
  EXPECT_EQ(sent(0.32), (std::vector<double>{0.0, 1.5}));
}

TEST(MarkerBuilder, RefreshesSpreadAndSurviveASlowLink) {
  // 32 hull bodies (as the PR2's links), arrays at 12.5 Hz for 60 s, to a subscriber behind a
  // link of a given bandwidth with the publisher's queue of 1 (an array published while the link
  // is busy waits, replaced by any newer one). Refreshes were due at one time for every body, so
  // every fifth array carried all of them and a slow link kept dropping those: markers vanished
  // for seconds. Now arrays keep about one size, and on a link slower than the mean load (a
  // fifth of the arrays dropped) no body marker ever expires.
  cm::world::WorldModel world;
  const int n = 32;
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  for (int i = 0; i < n; ++i) {
    std::vector<Vec3> points;
    for (int k = 0; k < 60; ++k)
      points.push_back(0.1 * Vec3(normal(rng), normal(rng), normal(rng)).normalized());
    cm::world::BodySpec spec = topicBody("b" + std::to_string(i));
    spec.parts.push_back(cm::world::Part{ConvexShape::convexHull(points), Transform3::Identity()});
    addBody(world, spec, at(i, 0.0, 0.0));
  }
  cm::world::CycleResult cycle;
  cycle.stamp = 1.0;
  const double period = 0.08;
  MarkerBuilder builder(everyCycle());  // lifetime 1 s: bodies 5 s, refreshed 0.25 to 0.5 s
  std::vector<std::pair<double, MarkerArray>> published;
  for (int k = 0; k * period < 60.0; ++k)
    published.emplace_back(k * period, builder.build(world, cycle, kFrame, k * period));
  std::size_t most = 0, total = 0, bytes = 0, full = 0;
  for (const auto& [t, a] : published) {
    const std::size_t count = find(a, "bodies", Marker::ADD).size();
    if (t == 0.0) {
      full = ros::serialization::serializationLength(a);
    } else if (t > 2.0) {  // after the first refreshes
      most = std::max(most, count);
      total += count;
      bytes += ros::serialization::serializationLength(a);
    }
  }
  const double arrays = static_cast<double>(published.size()) - 1.0 - 2.0 / period;
  const double mean = static_cast<double>(total) / arrays;
  // Refreshed on the first array at or after a due time 0.25 to 0.5 s after the last.
  EXPECT_NEAR(mean, n * period / (0.375 + period / 2), 0.5);
  EXPECT_LE(most, 2.5 * mean);                                    // no burst of every body at once
  const double load = static_cast<double>(bytes) / (60.0 - 2.0);  // B/s
  EXPECT_LT(load, 0.4 * static_cast<double>(full) / period);      // a full array each time
  for (const double capacity : {1.25 * load, 0.8 * load}) {
    std::map<int, double> expiry;  // body marker id -> expiry in the simulated rviz
    std::size_t delivered = 0, lost = 0;
    double busy_until = 0.0;
    const MarkerArray* waiting = nullptr;
    double arrival = 0.0;
    auto deliver = [&](const MarkerArray& a, double t) {
      ++delivered;
      for (const Marker* m : find(a, "bodies", Marker::ADD))
        expiry[m->id] = t + m->lifetime.toSec();
    };
    for (const auto& [t, a] : published) {
      while (waiting != nullptr && busy_until <= t) {  // the link is free: the waiting one goes
        const double start = std::max(busy_until, arrival);
        busy_until = start + ros::serialization::serializationLength(*waiting) / capacity;
        deliver(*waiting, busy_until);
        waiting = nullptr;
      }
      waiting = &a;  // replaces any array still waiting (queue of 1)
      arrival = t;
      for (const auto& [id, until] : expiry)
        lost += until <= t;
    }
    EXPECT_EQ(expiry.size(), static_cast<std::size_t>(n)) << capacity;
    EXPECT_EQ(lost, 0u) << "link at " << capacity / load << " of the load";
    if (capacity < load) {
      EXPECT_LT(delivered, published.size() * 9 / 10);  // the link did drop arrays
    }
  }
}

TEST(MarkerBuilder, TfBodiesDrawnInTheirFrameLocked) {
  // A body on a TF frame is drawn in that frame with frame_locked: rviz moves it with TF, and
  // its marker does not change (is not sent again) when it moves. Without frame_locked it is
  // drawn in the fixed frame at the pose the check used.
  cm::world::BodySpec spec;
  spec.id = "link";
  spec.frame = "link_frame";
  spec.pose_source = cm::world::PoseSource::Tf;
  spec.parts.push_back(cm::world::Part{ConvexShape::box(Vec3(0.1, 0.2, 0.3)), at(0.0, 0.0, 0.25)});
  for (const bool locked : {true, false}) {
    cm::world::WorldModel world;
    addBody(world, spec, at(1.0, 2.0, 3.0));
    cm::world::CycleResult cycle;
    cycle.stamp = 1.0;
    MarkerOptions options = everyCycle();
    options.frame_locked = locked;
    MarkerBuilder builder(options);
    const MarkerArray first = builder.build(world, cycle, kFrame, 0.0);
    const auto bodies = find(first, "bodies", Marker::ADD);
    ASSERT_EQ(bodies.size(), 1u);
    EXPECT_EQ(bodies[0]->header.frame_id, locked ? "link_frame" : kFrame);
    EXPECT_EQ(bodies[0]->frame_locked, locked);
    // Locked: stamp 0, the latest TF (rviz waits for TF at a marker's stamp; a stale link has
    // none at the cycle's stamp, and its grey marker never showed).
    EXPECT_EQ(bodies[0]->header.stamp.toSec(), locked ? 0.0 : 1.0);
    EXPECT_EQ(bodies[0]->type, Marker::CUBE);
    EXPECT_EQ(bodies[0]->pose.position.x, locked ? 0.0 : 1.0);
    EXPECT_EQ(bodies[0]->pose.position.y, locked ? 0.0 : 2.0);
    EXPECT_EQ(bodies[0]->pose.position.z, locked ? 0.25 : 3.25);
    ASSERT_TRUE(world.setPose("link", at(1.0, 2.0, 4.0), 0.0));  // the link moved
    const MarkerArray moved = builder.build(world, cycle, kFrame, 0.01);
    const auto again = find(moved, "bodies", Marker::ADD);
    ASSERT_EQ(again.size(), locked ? 0u : 1u);
    if (!locked) {
      EXPECT_EQ(again[0]->pose.position.z, 4.25);
    }
  }
}

/// Signed volume enclosed by a TRIANGLE_LIST, from the origin `o`: the same from any origin only
/// when the surface is closed.
double volumeFrom(const Marker& m, const Vec3& o) {
  double v = 0.0;
  for (std::size_t k = 0; k + 2 < m.points.size(); k += 3) {
    const auto p = [&](std::size_t i) -> Vec3 {
      return Vec3(m.points[i].x, m.points[i].y, m.points[i].z) - o;
    };
    v += p(k).dot(p(k + 1).cross(p(k + 2))) / 6.0;
  }
  return v;
}

TEST(MarkerBuilder, TessellationsAreClosed) {
  // The cone's base and the padded shells' bottoms (faces whose normal is -z) had no triangles:
  // the grid's last ring took sin(pi) = 1.2e-16 for 0, and its support points were rim points.
  cm::world::WorldModel world;
  cm::world::BodySpec spec = topicBody("parts");
  const double pad = 0.01;
  for (const ConvexShape& s :
       {ConvexShape::cone(0.2, 0.05).padded(pad), ConvexShape::cylinder(0.2, 0.05).padded(pad),
        ConvexShape::box(Vec3(0.1, 0.2, 0.3)).padded(pad),
        ConvexShape::capsule(0.2, 0.05).padded(pad)}) {
    spec.parts.push_back(cm::world::Part{s, Transform3::Identity()});
  }
  spec.padding = pad;
  addBody(world, spec, at(0.0, 0.0, 0.0));
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cm::world::CycleResult(), kFrame);
  int lists = 0;
  for (const auto& m : out.markers) {
    if (m.type != Marker::TRIANGLE_LIST) continue;
    ++lists;
    const double v = volumeFrom(m, Vec3::Zero());
    EXPECT_GT(v, 0.0) << m.ns << " " << m.id;
    EXPECT_NEAR(volumeFrom(m, Vec3(0.3, -0.2, 0.5)), v, 1e-12 * 0.3) << m.ns << " " << m.id;
  }
  EXPECT_EQ(lists, 2 + 4);  // the cone's and the capsule's solids, the four shells
  // The cone's solid is the pyramid over the 24 sampled rim points: 24 triangles of
  // 0.05^2 sin(15 deg) / 2 each, height 0.2.
  const auto solids = find(out, "bodies", Marker::ADD);
  const auto cone = std::find_if(solids.begin(), solids.end(),
                                 [](const Marker* m) { return m->type == Marker::TRIANGLE_LIST; });
  ASSERT_NE(cone, solids.end());
  EXPECT_NEAR(volumeFrom(**cone, Vec3::Zero()),
              24 * 0.5 * 0.05 * 0.05 * std::sin(M_PI / 12) * 0.2 / 3.0, 1e-15);
}

TEST(MarkerBuilder, ReplacedBodyGetsNewGeometry) {
  cm::world::WorldModel world;
  addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
  MarkerBuilder builder(everyCycle());
  const MarkerArray before = builder.build(world, cm::world::CycleResult(), kFrame);
  ASSERT_EQ(find(before, "bodies", Marker::ADD).size(), 1u);
  EXPECT_EQ(find(before, "bodies", Marker::ADD)[0]->type, Marker::CUBE);

  cm::world::BodySpec sphere = boxBody("a");
  sphere.parts.clear();
  sphere.parts.push_back(cm::world::Part{ConvexShape::sphere(0.3), Transform3::Identity()});
  addBody(world, sphere, at(0.0, 0.0, 0.0));
  const MarkerArray after = builder.build(world, cm::world::CycleResult(), kFrame);
  const auto bodies = find(after, "bodies", Marker::ADD);
  ASSERT_EQ(bodies.size(), 1u);
  EXPECT_EQ(bodies[0]->type, Marker::SPHERE);
  EXPECT_NEAR(bodies[0]->scale.x, 0.6, 1e-12);
}

TEST(MarkerBuilder, BodyWithoutPoseIsNotDrawn) {
  cm::world::WorldModel world;
  ASSERT_EQ(world.addBody(boxBody("nopose")), "");
  MarkerBuilder builder(everyCycle());
  const MarkerArray out = builder.build(world, cm::world::CycleResult(), kFrame);
  EXPECT_TRUE(find(out, "bodies", Marker::ADD).empty());
}

TEST(MarkerBuilder, RateLimited) {
  cm::world::WorldModel world;
  addBody(world, boxBody("a"), at(0.0, 0.0, 0.0));
  MarkerOptions options;
  options.max_rate = 0.5;  // at most one array every 2 s
  MarkerBuilder builder(options);
  EXPECT_FALSE(builder.build(world, cm::world::CycleResult(), kFrame).markers.empty());
  // Called again at once: nothing to publish, and what is shown is unchanged.
  ASSERT_TRUE(world.removeBody("a"));
  EXPECT_TRUE(builder.build(world, cm::world::CycleResult(), kFrame).markers.empty());
  EXPECT_EQ(builder.numShown(), 1u);
  // After reset() the limit starts over, with a DELETEALL that also clears the removed body.
  builder.reset();
  const MarkerArray after = builder.build(world, cm::world::CycleResult(), kFrame);
  ASSERT_EQ(after.markers.size(), 1u);
  EXPECT_EQ(after.markers[0].action, Marker::DELETEALL);
}
