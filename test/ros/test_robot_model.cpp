// Plain gtests (no master) of URDF -> bodies, SRDF parsing and meshes split into pieces on the
// real Panda and PR2 descriptions of example-robot-data (CM_ROBOT_DATA, default ../shared/data).
#include <pthread.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <geometric_shapes/mesh_operations.h>
#include <geometric_shapes/shapes.h>
#include <gtest/gtest.h>

#include "collision_monitor/core/query.h"
#include "collision_monitor/ros/mesh_loader.h"
#include "collision_monitor/ros/robot_model.h"

using namespace collision_monitor;
using namespace collision_monitor::ros_layer;

namespace {

std::string robotData() {
  const char* env = std::getenv("CM_ROBOT_DATA");
  return std::string(env && *env ? env : CM_ROBOT_DATA) + "/example-robot-data";
}

std::string readFile(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

PackageResolver resolver() {
  return [](const std::string& pkg) {
    return pkg == "example-robot-data" ? robotData() : std::string();
  };
}

/// The node's loader over `cache`.
MeshLoader loaderOf(MeshCache& cache) {
  return [&cache](const std::string& uri, const core::Vec3& s) { return cache.load(uri, s); };
}

bool hasPair(const std::vector<IdPair>& pairs, const std::string& a, const std::string& b) {
  return std::find(pairs.begin(), pairs.end(), IdPair{a, b}) != pairs.end() ||
         std::find(pairs.begin(), pairs.end(), IdPair{b, a}) != pairs.end();
}

/// A URDF link `name` whose collision is the PR2's upper arm roll mesh at `scale` ("x y z").
std::string armLink(const std::string& name, const std::string& scale) {
  return "<link name=\"" + name +
         "\"><collision><geometry><mesh filename=\"package://example-robot-data/robots/"
         "pr2_description/meshes/shoulder_v0/upper_arm_roll_L.stl\" scale=\"" +
         scale + "\"/></geometry></collision></link>";
}

}  // namespace

TEST(Urdf, PandaPrimitives) {
  const std::string xml =
      readFile(robotData() + "/robots/panda_description/urdf/panda_collision.urdf");
  ASSERT_FALSE(xml.empty()) << "no Panda URDF under " << robotData();
  MeshLoader no_meshes;  // the collision model has primitives only
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), no_meshes);
  ASSERT_TRUE(robot) << robot.error();
  EXPECT_EQ(robot->robot_name, "panda");
  EXPECT_EQ(robot->root_link, "panda_link0");
  EXPECT_TRUE(robot->errors.empty()) << robot->errors.front();
  std::set<std::string> ids;
  std::size_t parts = 0;
  for (const auto& b : robot->bodies) {
    ids.insert(b.id);
    parts += b.parts.size();
    EXPECT_EQ(b.frame, b.id);
    EXPECT_EQ(b.origin, world::BodyOrigin::Urdf);
    EXPECT_EQ(b.pose_source, world::PoseSource::Tf);
  }
  const std::set<std::string> want = {"panda_link0",      "panda_link1",      "panda_link2",
                                      "panda_link3",      "panda_link4",      "panda_link5",
                                      "panda_link6",      "panda_link7",      "panda_hand",
                                      "panda_leftfinger", "panda_rightfinger"};
  EXPECT_EQ(ids, want);
  EXPECT_EQ(parts, 39u);  // every <collision> element
  EXPECT_TRUE(hasPair(robot->adjacent, "panda_link0", "panda_link1"));
  EXPECT_TRUE(hasPair(robot->adjacent, "panda_hand", "panda_leftfinger"));
  // Through the geometry-less panda_link8.
  EXPECT_TRUE(hasPair(robot->adjacent, "panda_link7", "panda_hand"));
  EXPECT_FALSE(hasPair(robot->adjacent, "panda_link0", "panda_link2"));
  EXPECT_EQ(robot->adjacent.size(), 10u);
}

// robot_state_publisher's tf_prefix (ROS 1, 1.15.2: prefix_frame(), as tf 1's resolve): the
// values worked out by hand from its rules, then the Panda's links under one.
TEST(Urdf, TfPrefixAsRobotStatePublisherAppliesIt) {
  EXPECT_EQ(prefixedFrame("", "panda_link0"), "panda_link0");
  EXPECT_EQ(prefixedFrame("left", "panda_link0"), "left/panda_link0");
  EXPECT_EQ(prefixedFrame("/left", "panda_link0"), "left/panda_link0");  // one '/' dropped
  EXPECT_EQ(prefixedFrame("cell/left", "hand"), "cell/left/hand");
  EXPECT_EQ(prefixedFrame("left/", "hand"), "left//hand");  // as it publishes it
  EXPECT_EQ(prefixedFrame("left", "/base"), "base");        // a global name takes no prefix
  EXPECT_EQ(prefixedFrame("", "/base"), "base");

  const std::string xml =
      readFile(robotData() + "/robots/panda_description/urdf/panda_collision.urdf");
  ASSERT_FALSE(xml.empty()) << "no Panda URDF under " << robotData();
  auto plain = bodiesFromUrdf(xml, 0.0, Limits(), MeshLoader());
  auto left = bodiesFromUrdf(xml, 0.0, Limits(), MeshLoader(), {}, "left");
  ASSERT_TRUE(plain && left);
  ASSERT_EQ(left->bodies.size(), 11u);
  ASSERT_EQ(left->bodies.size(), plain->bodies.size());
  for (std::size_t i = 0; i < left->bodies.size(); ++i) {
    EXPECT_EQ(left->bodies[i].id, plain->bodies[i].id);  // ids stay the link names
    EXPECT_EQ(left->bodies[i].frame, "left/" + plain->bodies[i].id);
    EXPECT_EQ(left->bodies[i].parts.size(), plain->bodies[i].parts.size());
  }
  EXPECT_EQ(left->root_link, "panda_link0");
  EXPECT_EQ(left->adjacent, plain->adjacent);  // by ids
}

TEST(Urdf, PaddingAndOrigins) {
  const std::string xml = R"(<robot name="r">
    <link name="base"><collision><origin xyz="1 0 0" rpy="0 0 0"/>
      <geometry><sphere radius="0.5"/></geometry></collision></link>
    <link name="arm"><collision><geometry><box size="1 2 3"/></geometry></collision></link>
    <joint name="j" type="fixed"><parent link="base"/><child link="arm"/></joint>
  </robot>)";
  auto robot = bodiesFromUrdf(xml, 0.1, Limits(), MeshLoader());
  ASSERT_TRUE(robot) << robot.error();
  ASSERT_EQ(robot->bodies.size(), 2u);
  std::map<std::string, const world::BodySpec*> by_id;
  for (const auto& b : robot->bodies)
    by_id[b.id] = &b;
  ASSERT_EQ(by_id.count("base"), 1u);
  ASSERT_EQ(by_id.count("arm"), 1u);
  const world::BodySpec& base = *by_id["base"];
  ASSERT_EQ(base.parts.size(), 1u);
  EXPECT_EQ(base.parts[0].pose.t, core::Vec3(1, 0, 0));
  EXPECT_NEAR(base.parts[0].shape.support(core::Vec3::UnitX()).x(), 0.6, 1e-12);
  // The padding on the box too: half-extents 0.5, 1, 1.5 plus 0.1 along each axis.
  const world::BodySpec& arm = *by_id["arm"];
  ASSERT_EQ(arm.parts.size(), 1u);
  EXPECT_EQ(arm.parts[0].pose.t, core::Vec3::Zero());
  EXPECT_NEAR(arm.parts[0].shape.support(core::Vec3::UnitX()).x(), 0.6, 1e-12);
  EXPECT_NEAR(arm.parts[0].shape.support(core::Vec3::UnitY()).y(), 1.1, 1e-12);
  EXPECT_NEAR(arm.parts[0].shape.support(-core::Vec3::UnitZ()).z(), -1.6, 1e-12);
  EXPECT_TRUE(hasPair(robot->adjacent, "base", "arm"));
}

// robot_link_padding: a named link takes its own padding (more, or none) in place of
// robot_padding; robot_link_groups puts links in groups; a name that applies to nothing is
// reported, and the links load as they would.
TEST(Urdf, LinkSettingsApplyToTheLinksTheyName) {
  const std::string xml = R"(<robot name="r">
    <link name="base"><collision><origin xyz="1 0 0" rpy="0 0 0"/>
      <geometry><sphere radius="0.5"/></geometry></collision></link>
    <link name="arm"><collision><geometry><box size="1 2 3"/></geometry></collision></link>
    <link name="hand"><collision><geometry><sphere radius="0.25"/></geometry></collision></link>
    <link name="tool"/>
    <joint name="j" type="fixed"><parent link="base"/><child link="arm"/></joint>
    <joint name="k" type="fixed"><parent link="arm"/><child link="hand"/></joint>
    <joint name="l" type="fixed"><parent link="hand"/><child link="tool"/></joint>
  </robot>)";
  LinkSettings own;
  own.padding = {{"base", 0.0}, {"arm", 0.25}, {"tool", 0.3}, {"nosuch", 0.2}};
  own.group = {{"arm", "g"}, {"hand", "g"}, {"tool", "g"}, {"ghost", "h"}};
  auto robot = bodiesFromUrdf(xml, 0.1, Limits(), MeshLoader(), own);
  ASSERT_TRUE(robot) << robot.error();
  EXPECT_TRUE(robot->errors.empty());
  std::map<std::string, const world::BodySpec*> by_id;
  for (const auto& b : robot->bodies)
    by_id[b.id] = &b;
  ASSERT_EQ(by_id.size(), 3u);
  const world::BodySpec& base = *by_id.at("base");
  EXPECT_EQ(base.padding, 0.0);
  EXPECT_EQ(base.parts[0].shape.support(core::Vec3::UnitX()).x(), 0.5);
  const world::BodySpec& arm = *by_id.at("arm");
  EXPECT_EQ(arm.padding, 0.25);
  EXPECT_NEAR(arm.parts[0].shape.support(core::Vec3::UnitX()).x(), 0.75, 1e-12);
  EXPECT_NEAR(arm.parts[0].shape.support(core::Vec3::UnitY()).y(), 1.25, 1e-12);
  EXPECT_NEAR(arm.parts[0].shape.support(-core::Vec3::UnitZ()).z(), -1.75, 1e-12);
  const world::BodySpec& hand = *by_id.at("hand");  // not named: robot_padding
  EXPECT_EQ(hand.padding, 0.1);
  EXPECT_NEAR(hand.parts[0].shape.support(core::Vec3::UnitZ()).z(), 0.35, 1e-12);
  EXPECT_EQ(base.group, "");
  EXPECT_EQ(arm.group, "g");
  EXPECT_EQ(hand.group, "g");
  EXPECT_EQ(robot->link_errors, (std::vector<std::string>{
                                    "robot_link_padding: 'nosuch' is not a link of robot 'r'",
                                    "robot_link_padding: link 'tool' has no <collision> geometry",
                                    "robot_link_groups: 'ghost' is not a link of robot 'r'",
                                    "robot_link_groups: link 'tool' has no <collision> geometry"}));
  // Without link settings every link takes robot_padding, no group, and nothing is reported.
  auto plain = bodiesFromUrdf(xml, 0.1, Limits(), MeshLoader());
  ASSERT_TRUE(plain) << plain.error();
  EXPECT_TRUE(plain->link_errors.empty());
  for (const auto& b : plain->bodies) {
    EXPECT_EQ(b.padding, 0.1) << b.id;
    EXPECT_EQ(b.group, "") << b.id;
  }
}

// The Panda's hand padded by 2 cm of its own: every part's support moves out by exactly 2 cm
// along every direction; the other links stay as without.
TEST(Urdf, PandaHandPaddedOnItsOwn) {
  const std::string xml =
      readFile(robotData() + "/robots/panda_description/urdf/panda_collision.urdf");
  ASSERT_FALSE(xml.empty()) << "no Panda URDF under " << robotData();
  auto plain = bodiesFromUrdf(xml, 0.0, Limits(), MeshLoader());
  LinkSettings hand;
  hand.padding = {{"panda_hand", 0.02}};
  auto padded = bodiesFromUrdf(xml, 0.0, Limits(), MeshLoader(), hand);
  ASSERT_TRUE(plain) << plain.error();
  ASSERT_TRUE(padded) << padded.error();
  EXPECT_TRUE(padded->link_errors.empty());
  ASSERT_EQ(plain->bodies.size(), padded->bodies.size());
  std::mt19937 g(3);
  std::normal_distribution<double> n;
  std::size_t hand_parts = 0;
  for (std::size_t i = 0; i < plain->bodies.size(); ++i) {
    const world::BodySpec& a = plain->bodies[i];
    const world::BodySpec& b = padded->bodies[i];
    ASSERT_EQ(a.id, b.id);
    ASSERT_EQ(a.parts.size(), b.parts.size());
    const double pad = a.id == "panda_hand" ? 0.02 : 0.0;
    EXPECT_EQ(b.padding, pad) << b.id;
    for (std::size_t k = 0; k < a.parts.size(); ++k) {
      hand_parts += pad > 0.0 ? 1 : 0;
      for (int trial = 0; trial < 20; ++trial) {
        const core::Vec3 d(n(g), n(g), n(g));
        const core::Vec3 want = a.parts[k].shape.support(d) + pad * d.normalized();
        EXPECT_LE((b.parts[k].shape.support(d) - want).norm(), 1e-15) << b.id << " part " << k;
      }
    }
  }
  EXPECT_EQ(hand_parts, 3u) << "the Panda's hand: 3 <collision> elements";
}

TEST(Urdf, BadLinkIsLeftOutOthersLoad) {
  const std::string xml = R"(<robot name="r">
    <link name="good"><collision><geometry><sphere radius="0.5"/></geometry></collision></link>
    <link name="bad"><collision><geometry><mesh filename="file:///etc/passwd"/></geometry>
      </collision></link>
    <joint name="j" type="fixed"><parent link="good"/><child link="bad"/></joint>
  </robot>)";
  MeshCache cache({}, 1000, resolver());
  const MeshLoader loader = loaderOf(cache);
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), loader);
  ASSERT_TRUE(robot) << robot.error();
  ASSERT_EQ(robot->bodies.size(), 1u);
  EXPECT_EQ(robot->bodies[0].id, "good");
  ASSERT_EQ(robot->errors.size(), 1u);
  EXPECT_NE(robot->errors[0].find("outside mesh_roots"), std::string::npos) << robot->errors[0];
}

// A URDF mesh's scale="-1 1 1" mirrors it (a left part drawn from the right one's mesh), as
// rviz and MoveIt draw it: the link was refused ("scale must be all > 0") and left unchecked.
// A zero factor flattens it; scale="0 0 0" is a point (a Shape message's 0,0,0 means 1,1,1).
TEST(Urdf, MirroredAndFlattenedMeshes) {
  const std::string xml = "<robot name=\"r\">" + armLink("right", "1 1 1") +
                          armLink("left", "-1 1 1") + armLink("flat", "1 0 1") +
                          armLink("point", "0 0 0") + R"(
    <joint name="a" type="fixed"><parent link="right"/><child link="left"/></joint>
    <joint name="b" type="fixed"><parent link="right"/><child link="flat"/></joint>
    <joint name="c" type="fixed"><parent link="right"/><child link="point"/></joint>
  </robot>)";
  MeshCache cache({}, 100000, resolver());
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), loaderOf(cache));
  ASSERT_TRUE(robot) << robot.error();
  ASSERT_EQ(robot->errors.size(), 1u);
  EXPECT_EQ(robot->errors[0].rfind("point: ", 0), 0u) << robot->errors[0];
  EXPECT_NE(robot->errors[0].find("mesh scale 0 0 0 makes it a point"), std::string::npos)
      << robot->errors[0];
  std::map<std::string, const world::BodySpec*> by_id;
  for (const auto& b : robot->bodies)
    by_id[b.id] = &b;
  ASSERT_EQ(by_id.size(), 3u);
  const core::ConvexShape& right = by_id["right"]->parts.at(0).shape;
  const core::ConvexShape& left = by_id["left"]->parts.at(0).shape;
  const core::ConvexShape& flat = by_id["flat"]->parts.at(0).shape;
  for (const core::Vec3& d :
       {core::Vec3(1, 0.25, 0.5), core::Vec3(-0.5, 1, -0.25), core::Vec3(0.125, -0.5, 1)}) {
    const core::Vec3 m(-d.x(), d.y(), d.z());
    const core::Vec3 r = right.support(m);
    EXPECT_EQ(left.support(d), core::Vec3(-r.x(), r.y(), r.z()));
    EXPECT_EQ(flat.support(d).y(), 0.0);
    EXPECT_EQ(flat.support(d).x(), right.support(core::Vec3(d.x(), 0, d.z())).x());
  }
}

// One refused <collision> element left its whole link unchecked (a box and a missing mesh: no
// body), and an element urdfdom drops for want of geometry went unreported; a link whose only
// element it drops counted as geometry-less, so its parent and child were taken as adjacent
// (never checked).
TEST(Urdf, RefusedElementsAreLeftOutOfTheirLinkAlone) {
  const std::string xml = R"(<robot name="r">
    <link name="a"><collision><geometry><sphere radius="0.5"/></geometry></collision></link>
    <link name="mixed">
      <collision><geometry><box size="1 2 3"/></geometry></collision>
      <collision><geometry><mesh filename="file:///nowhere/x.stl"/></geometry></collision>
      <collision><origin xyz="1 0 0"/></collision>
    </link>
    <link name="ghost"><collision><geometry/></collision></link>
    <link name="early">
      <collision><origin xyz="1 0 0"/></collision>
      <collision><geometry><box size="1 2 3"/></geometry></collision>
      <collision><geometry><sphere radius="0.5"/></geometry></collision>
    </link>
    <link name="c"><collision><geometry><sphere radius="0.5"/></geometry></collision></link>
    <joint name="j1" type="fixed"><parent link="a"/><child link="mixed"/></joint>
    <joint name="j2" type="fixed"><parent link="mixed"/><child link="ghost"/></joint>
    <joint name="j3" type="fixed"><parent link="ghost"/><child link="c"/></joint>
    <joint name="j4" type="fixed"><parent link="c"/><child link="early"/></joint>
  </robot>)";
  MeshCache cache({}, 1000, resolver());
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), loaderOf(cache));
  ASSERT_TRUE(robot) << robot.error();
  std::vector<std::string> ids;
  for (const auto& b : robot->bodies) {
    ids.push_back(b.id);
    if (b.id == "mixed") {
      ASSERT_EQ(b.parts.size(), 1u);
      EXPECT_EQ(b.parts[0].shape.support(core::Vec3(1, 1, 1)), core::Vec3(0.5, 1, 1.5));
    }
  }
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(ids, (std::vector<std::string>{"a", "c", "mixed"}));
  std::vector<std::string> errors = robot->errors;
  std::sort(errors.begin(), errors.end());
  // urdfdom stops at the first element it cannot parse: early's valid box and sphere after it
  // are gone too (it said "1 of 3 ... elements without usable <geometry>").
  ASSERT_EQ(errors.size(), 4u);
  EXPECT_EQ(errors[0],
            "early: <collision> 1 of 3 could not be parsed, e.g. no usable <geometry> (urdfdom "
            "dropped it and the 2 after it)");
  EXPECT_EQ(errors[1],
            "ghost: <collision> 1 of 1 could not be parsed, e.g. no usable <geometry> (urdfdom "
            "dropped it)");
  EXPECT_EQ(errors[2],
            "mixed: <collision> 3 of 3 could not be parsed, e.g. no usable <geometry> (urdfdom "
            "dropped it)");
  EXPECT_EQ(errors[3].rfind("mixed: collision 1 (mesh): ", 0), 0u) << errors[3];
  // realpath's errno in words (strerror_r: the mesh loader runs beside other threads).
  EXPECT_NE(errors[3].find("cannot resolve '/nowhere/x.stl': No such file or directory"),
            std::string::npos)
      << errors[3];
  EXPECT_TRUE(hasPair(robot->adjacent, "a", "mixed"));
  EXPECT_FALSE(hasPair(robot->adjacent, "mixed", "c"));  // ghost is between them
}

TEST(Urdf, NotAUrdf) {
  EXPECT_FALSE(bodiesFromUrdf("<html/>", 0.0, Limits(), MeshLoader()));
  EXPECT_FALSE(bodiesFromUrdf("not xml at all", 0.0, Limits(), MeshLoader()));
}

// A URDF <cylinder> is `length` along its frame's z with `radius` (URDF XML spec), and a
// <collision>'s <origin> places it in the link: xyz a translation, rpy roll, pitch, yaw about
// fixed x, y, z.
TEST(Urdf, CylinderAxisAndCollisionOrigin) {
  const std::string xml = R"(<robot name="r">
    <link name="pole"><collision><origin xyz="0.1 0.2 0.4" rpy="0 0 1.5707963267948966"/>
      <geometry><cylinder radius="0.05" length="0.6"/></geometry></collision></link>
  </robot>)";
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), MeshLoader());
  ASSERT_TRUE(robot) << robot.error();
  ASSERT_EQ(robot->bodies.size(), 1u);
  ASSERT_EQ(robot->bodies[0].parts.size(), 1u);
  const world::Part& part = robot->bodies[0].parts[0];
  EXPECT_NEAR(part.shape.support(core::Vec3::UnitX()).x(), 0.05, 1e-12);
  EXPECT_NEAR(part.shape.support(core::Vec3::UnitZ()).z(), 0.3, 1e-12);
  EXPECT_NEAR((part.pose.t - core::Vec3(0.1, 0.2, 0.4)).norm(), 0.0, 1e-12);
  // Yaw of 90 degrees: the part's x along the link's y, its z along the link's z.
  EXPECT_NEAR((part.pose.R * core::Vec3::UnitX() - core::Vec3::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((part.pose.R * core::Vec3::UnitZ() - core::Vec3::UnitZ()).norm(), 0.0, 1e-12);
}

// Only scale="0 0 0" is refused as a point: "0 0 1" squeezes a mesh onto its z axis, a segment
// as long as the mesh is tall, and the link is kept.
TEST(Urdf, MeshScaledOntoALineIsKept) {
  const std::string xml = "<robot name=\"r\">" + armLink("whole", "1 1 1") +
                          armLink("line", "0 0 1") +
                          R"(<joint name="a" type="fixed"><parent link="whole"/>
                             <child link="line"/></joint></robot>)";
  MeshCache cache({}, 100000, resolver());
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), loaderOf(cache));
  ASSERT_TRUE(robot) << robot.error();
  EXPECT_TRUE(robot->errors.empty()) << robot->errors.front();
  std::map<std::string, const world::BodySpec*> by_id;
  for (const auto& b : robot->bodies)
    by_id[b.id] = &b;
  ASSERT_EQ(by_id.count("line"), 1u);
  ASSERT_EQ(by_id.count("whole"), 1u);
  const core::ConvexShape& line = by_id["line"]->parts.at(0).shape;
  const core::ConvexShape& whole = by_id["whole"]->parts.at(0).shape;
  for (const core::Vec3& d : {core::Vec3(1, 0.5, 0.25), core::Vec3(-0.5, 1, -0.25)}) {
    EXPECT_NEAR(line.support(d).x(), 0.0, 1e-12);
    EXPECT_NEAR(line.support(d).y(), 0.0, 1e-12);
  }
  EXPECT_NEAR(line.support(core::Vec3::UnitZ()).z(), whole.support(core::Vec3::UnitZ()).z(), 1e-9);
  EXPECT_NEAR(line.support(-core::Vec3::UnitZ()).z(), whole.support(-core::Vec3::UnitZ()).z(),
              1e-9);
}

TEST(Urdf, Pr2MeshesLoadAsHulls) {
  const std::string xml = readFile(robotData() + "/robots/pr2_description/urdf/pr2.urdf");
  ASSERT_FALSE(xml.empty());
  MeshCache cache({}, 100000, resolver());
  const MeshLoader loader = loaderOf(cache);
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), loader);
  ASSERT_TRUE(robot) << robot.error();
  EXPECT_TRUE(robot->errors.empty()) << robot->errors.front();
  EXPECT_EQ(robot->bodies.size(), 32u);
  EXPECT_EQ(robot->root_link, "base_footprint");
}

namespace {

using Tri = std::array<std::size_t, 3>;

/// A tetrahedron as an STL stores it: every triangle with its own copies of its corners (so
/// pieces join by position, not by index). The first `faces` of its 4 faces.
void addTetrahedron(const std::array<core::Vec3, 4>& c, int faces, std::vector<core::Vec3>* v,
                    std::vector<Tri>* t) {
  const int f[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  for (int k = 0; k < faces; ++k) {
    t->push_back({v->size(), v->size() + 1, v->size() + 2});
    for (int j = 0; j < 3; ++j)
      v->push_back(c[f[k][j]]);
  }
}

/// The corner tetrahedron at `o` with edges `size` along the axes.
std::array<core::Vec3, 4> corner(const core::Vec3& o, double size) {
  return {o, o + size * core::Vec3::UnitX(), o + size * core::Vec3::UnitY(),
          o + size * core::Vec3::UnitZ()};
}

std::set<std::tuple<double, double, double>> asSet(const std::vector<core::Vec3>& points) {
  std::set<std::tuple<double, double, double>> out;
  for (const auto& p : points)
    out.emplace(p.x(), p.y(), p.z());
  return out;
}

std::string pr2Mesh(const std::string& name) {
  return robotData() + "/robots/pr2_description/meshes/" + name;
}

double signedDistance(const core::ConvexShape& a, const core::ConvexShape& b) {
  const auto id = core::Transform3::Identity();
  return core::signedDistance(a, id, b, id).distance;
}

}  // namespace

TEST(MeshPieces, ClosedPiecesJoinByPosition) {
  using V = core::Vec3;
  std::vector<V> v;
  std::vector<Tri> t;
  addTetrahedron(corner(V(0, 0, 0), 1.0), 4, &v, &t);
  addTetrahedron(corner(V(5, 0, 0), 2.0), 4, &v, &t);
  MeshPieces split = meshPieces(v, t);
  EXPECT_EQ(split.open, "");
  ASSERT_EQ(split.pieces.size(), 2u);
  // Each piece's distinct corners, once.
  EXPECT_EQ(split.pieces[0].size(), 4u);
  EXPECT_EQ(asSet(split.pieces[0]), asSet({V(0, 0, 0), V(1, 0, 0), V(0, 1, 0), V(0, 0, 1)}));
  EXPECT_EQ(asSet(split.pieces[1]), asSet({V(5, 0, 0), V(7, 0, 0), V(5, 2, 0), V(5, 0, 2)}));
  // A tetrahedron sharing one corner with the first joins it.
  addTetrahedron(corner(V(1, 0, 0), 1.0), 4, &v, &t);
  split = meshPieces(v, t);
  EXPECT_EQ(split.open, "");
  ASSERT_EQ(split.pieces.size(), 2u);
  EXPECT_EQ(split.pieces[0].size(), 7u);
  // One sharing an edge (then on four triangles: closed, not manifold) joins too.
  addTetrahedron({V(5, 0, 0), V(7, 0, 0), V(5, -1, 0), V(5, 0, -1)}, 4, &v, &t);
  split = meshPieces(v, t);
  EXPECT_EQ(split.open, "");
  ASSERT_EQ(split.pieces.size(), 2u);
  EXPECT_EQ(split.pieces[1].size(), 6u);
}

TEST(MeshPieces, OpenPiecesStrayVerticesAndBadIndicesAreNamed) {
  using V = core::Vec3;
  std::vector<V> v;
  std::vector<Tri> t;
  addTetrahedron(corner(V(0, 0, 0), 1.0), 4, &v, &t);
  addTetrahedron(corner(V(5, 0, 0), 1.0), 3, &v, &t);  // one face missing
  EXPECT_EQ(meshPieces(v, t).open, "piece 2 of 2 is not closed (an edge on 1 triangle)");
  std::vector<V> v2;
  std::vector<Tri> t2;
  addTetrahedron(corner(V(0, 0, 0), 1.0), 4, &v2, &t2);
  v2.emplace_back(9, 9, 9);
  EXPECT_EQ(meshPieces(v2, t2).open, "vertex 12 is on no triangle");
  t2.push_back({0, 1, 13});
  EXPECT_EQ(meshPieces(v2, t2).open, "triangle 4 has a vertex index out of range");
  EXPECT_EQ(meshPieces({}, {}).pieces.size(), 0u);
  EXPECT_EQ(meshPieces({}, {}).open, "");
}

TEST(MeshPieces, Pr2UpperArmRollIsThreeClosedPiecesTighterThanItsHull) {
  const std::string path = pr2Mesh("shoulder_v0/upper_arm_roll_L.stl");
  auto hull = loadMeshParts(path, core::Vec3(1, 1, 1), 100000, MeshDecomposition::Hull);
  auto pieces = loadMeshParts(path, core::Vec3(1, 1, 1), 100000, MeshDecomposition::Pieces);
  ASSERT_TRUE(hull) << hull.error();
  ASSERT_TRUE(pieces) << pieces.error();
  ASSERT_EQ(hull->parts.size(), 1u);
  ASSERT_EQ(pieces->parts.size(), 3u);  // a disc and two blocks (STL: 100 triangles)
  EXPECT_EQ(pieces->note, "");
  // Conservative: every vertex of the mesh lies in a piece.
  std::unique_ptr<shapes::Mesh> mesh(shapes::createMeshFromResource("file://" + path));
  ASSERT_TRUE(mesh);
  for (unsigned i = 0; i < mesh->vertex_count; ++i) {
    const auto p = core::ConvexShape::point(
        core::Vec3(mesh->vertices[3 * i], mesh->vertices[3 * i + 1], mesh->vertices[3 * i + 2]));
    double best = 1e9;
    for (const auto& part : pieces->parts)
      best = std::min(best, signedDistance(part, p));
    EXPECT_LE(best, 1e-12) << "vertex " << i;
  }
  // Tighter: a point between the two blocks, beyond the disc's face (x = its largest x), is
  // inside the one hull and that far from the pieces.
  const auto probe = core::ConvexShape::point(core::Vec3(0.135, 0.0, 0.0));
  EXPECT_LT(signedDistance(hull->parts[0], probe), -0.005);
  double disc_face = -1e9;  // the disc is the piece reaching lowest in x
  double nearest = 1e9;
  for (const auto& part : pieces->parts) {
    if (part.support(-core::Vec3::UnitX()).x() < 0.12)
      disc_face = part.support(core::Vec3::UnitX()).x();
    nearest = std::min(nearest, signedDistance(part, probe));
  }
  EXPECT_NEAR(disc_face, 0.1214, 5e-5);
  EXPECT_NEAR(nearest, 0.135 - disc_face, 1e-12);
}

TEST(MeshPieces, AnOpenPieceKeepsTheWholeHull) {
  // PR2's full-detail head_tilt.stl (not its collision mesh): 9 pieces, two of them open.
  const std::string path = pr2Mesh("head_v0/head_tilt.stl");
  auto pieces = loadMeshParts(path, core::Vec3(1, 1, 1), 100000, MeshDecomposition::Pieces);
  ASSERT_TRUE(pieces) << pieces.error();
  EXPECT_EQ(pieces->parts.size(), 1u);
  EXPECT_EQ(pieces->note,
            "not split into pieces: piece 3 of 9 is not closed (an edge on 1 triangle); one "
            "convex hull");
  auto hull = loadMeshParts(path, core::Vec3(1, 1, 1), 100000, MeshDecomposition::Hull);
  ASSERT_TRUE(hull);
  EXPECT_EQ(hull->note, "");
  const auto far = core::ConvexShape::point(core::Vec3(1, 2, 3));
  EXPECT_EQ(signedDistance(pieces->parts[0], far), signedDistance(hull->parts[0], far));
  // One piece is its hull, closed or not, without a note (torso_lift_L.stl has a boundary).
  pieces = loadMeshParts(pr2Mesh("torso_v0/torso_lift_L.stl"), core::Vec3(1, 1, 1), 100000,
                         MeshDecomposition::Pieces);
  ASSERT_TRUE(pieces) << pieces.error();
  EXPECT_EQ(pieces->parts.size(), 1u);
  EXPECT_EQ(pieces->note, "");
}

TEST(MeshPieces, Pr2InPiecesHasFiveMorePartsAndTheLimitCountsThem) {
  const std::string xml = readFile(robotData() + "/robots/pr2_description/urdf/pr2.urdf");
  ASSERT_FALSE(xml.empty());
  std::map<std::string, std::size_t> parts[2];
  for (int mode = 0; mode < 2; ++mode) {
    MeshCache cache({}, 100000, resolver(),
                    mode == 0 ? MeshDecomposition::Hull : MeshDecomposition::Pieces);
    const MeshLoader loader = loaderOf(cache);
    auto robot = bodiesFromUrdf(xml, 0.0, Limits(), loader);
    ASSERT_TRUE(robot) << robot.error();
    EXPECT_TRUE(robot->errors.empty()) << robot->errors.front();
    for (const auto& b : robot->bodies)
      parts[mode][b.id] = b.parts.size();
  }
  ASSERT_EQ(parts[0].size(), 32u);
  ASSERT_EQ(parts[1].size(), 32u);
  // upper_arm_roll_L.stl (both arms) is 3 pieces, tilting_hokuyo_L.stl 2; the rest one each.
  std::size_t more = 0;
  for (const auto& [id, n] : parts[0])
    more += parts[1].at(id) - n;
  EXPECT_EQ(more, 5u);
  EXPECT_EQ(parts[1].at("r_upper_arm_roll_link"), parts[0].at("r_upper_arm_roll_link") + 2);
  EXPECT_EQ(parts[1].at("l_upper_arm_roll_link"), parts[0].at("l_upper_arm_roll_link") + 2);

  // max_parts_per_body counts the pieces: a body of that one mesh part is refused at 2.
  MeshCache cache({}, 100000, resolver(), MeshDecomposition::Pieces);
  const MeshLoader loader = loaderOf(cache);
  collision_monitor::Body msg;
  msg.id = "arm";
  msg.header.frame_id = "world";
  msg.parts.resize(1);
  msg.parts[0].type = collision_monitor::Shape::MESH;
  msg.parts[0].resource =
      "package://example-robot-data/robots/pr2_description/meshes/shoulder_v0/upper_arm_roll_L.stl";
  Limits limits;
  limits.max_parts_per_body = 3;
  auto ok = bodyFromMsg(msg, world::BodyOrigin::Topic, limits, loader);
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_EQ(ok->parts.size(), 3u);
  limits.max_parts_per_body = 2;
  auto refused = bodyFromMsg(msg, world::BodyOrigin::Topic, limits, loader);
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error(),
            "with its mesh pieces the body has 3 parts by part 0, more than max_parts_per_body 2");
  // The node's loader knows the limit too: a mesh of more pieces keeps its one hull, as `hull`
  // would give it (a link is not lost to the option), decided before hulling the pieces.
  const std::string path = pr2Mesh("shoulder_v0/upper_arm_roll_L.stl");
  auto too_many = loadMeshParts(path, core::Vec3(1, 1, 1), 100000, MeshDecomposition::Pieces, 2);
  ASSERT_TRUE(too_many) << too_many.error();
  EXPECT_EQ(too_many->parts.size(), 1u);
  EXPECT_EQ(too_many->note,
            "not split into pieces: 3 pieces, more than max_parts_per_body 2; one convex hull");
  auto three = loadMeshParts(path, core::Vec3(1, 1, 1), 100000, MeshDecomposition::Pieces, 3);
  ASSERT_TRUE(three);
  EXPECT_EQ(three->parts.size(), 3u);
}

TEST(MeshPieces, ManyTrianglesOnFewVerticesAreNotSplit) {
  // Two tetrahedra (8 vertices), each face written 10 times: 80 triangles, closed (even counts).
  const std::string path = testing::TempDir() + "/cm_dense_tetrahedra.stl";
  {
    std::ofstream f(path);
    f << "solid t\n";
    for (double x : {0.0, 5.0}) {
      const double c[4][3] = {{x, 0, 0}, {x + 1, 0, 0}, {x, 1, 0}, {x, 0, 1}};
      const int faces[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
      for (int rep = 0; rep < 10; ++rep) {
        for (const auto& face : faces) {
          f << "facet normal 0 0 0\nouter loop\n";
          for (int k : face)
            f << "vertex " << c[k][0] << " " << c[k][1] << " " << c[k][2] << "\n";
          f << "endloop\nendfacet\n";
        }
      }
    }
    f << "endsolid t\n";
  }
  auto split = loadMeshParts(path, core::Vec3(1, 1, 1), 10, MeshDecomposition::Pieces);
  ASSERT_TRUE(split) << split.error();
  EXPECT_EQ(split->parts.size(), 2u);  // 80 triangles <= 8 x 10
  EXPECT_EQ(split->note, "");
  auto dense = loadMeshParts(path, core::Vec3(1, 1, 1), 8, MeshDecomposition::Pieces);
  ASSERT_TRUE(dense) << dense.error();
  EXPECT_EQ(dense->parts.size(), 1u);  // 80 > 8 x 8
  EXPECT_EQ(dense->note,
            "not split into pieces: 80 triangles, more than 8 x max_vertices_per_part; one convex "
            "hull");
  std::remove(path.c_str());
}

TEST(MeshPieces, ModeNames) {
  EXPECT_EQ(parseMeshDecomposition("hull"), MeshDecomposition::Hull);
  EXPECT_EQ(parseMeshDecomposition("pieces"), MeshDecomposition::Pieces);
  EXPECT_FALSE(parseMeshDecomposition("Pieces"));
  EXPECT_FALSE(parseMeshDecomposition(""));
  EXPECT_STREQ(toString(MeshDecomposition::Pieces), "pieces");
  EXPECT_STREQ(toString(MeshDecomposition::Hull), "hull");
}

TEST(Srdf, PandaDisabledPairs) {
  auto rules =
      collisionsFromSrdf(readFile(robotData() + "/robots/panda_description/srdf/panda.srdf"));
  ASSERT_TRUE(rules) << rules.error();
  EXPECT_EQ(rules->robot_name, "panda");
  EXPECT_EQ(rules->disabled.size(), 35u);
  EXPECT_TRUE(hasPair(rules->disabled, "panda_link0", "panda_link1"));
  EXPECT_TRUE(rules->default_off.empty());
  EXPECT_TRUE(rules->enabled.empty());
  EXPECT_EQ(rules->num_skipped, 0u);
}

TEST(Srdf, MalformedAndPartial) {
  EXPECT_FALSE(collisionsFromSrdf("<robot><disable_collisions"));
  EXPECT_FALSE(collisionsFromSrdf("<notrobot/>"));
  EXPECT_EQ(collisionsFromSrdf("<robot/>")->robot_name, "");  // no name: not that of a URDF
  auto p = collisionsFromSrdf(
      R"(<robot name="r"><disable_collisions link1="a" link2="b" reason="Adjacent"/>
         <disable_collisions link1="c"/></robot>)");
  ASSERT_TRUE(p) << p.error();
  ASSERT_EQ(p->disabled.size(), 1u);
  EXPECT_EQ(p->disabled[0], IdPair("a", "b"));
  EXPECT_EQ(p->num_skipped, 1u);
  EXPECT_EQ(p->first_skipped, "<disable_collisions> on line 2 has no 'link2' attribute");
}

TEST(Srdf, DefaultCollisionsAndEnabledPairs) {
  // srdfdom 0.6's elements, mixed with others, in document order.
  auto p = collisionsFromSrdf(R"(<robot name="r">
    <group name="arm"><chain base_link="a" tip_link="c"/></group>
    <disable_default_collisions link="cam"/>
    <enable_collisions link1="cam" link2="table" reason="User"/>
    <disable_collisions link1="a" link2="b" reason="Never"/>
    <disable_default_collisions link=""/>
    <enable_collisions link2="x"/>
    <disable_default_collisions link="mount"/>
    <enable_collisions link1=" mount" link2="cam&#9;"/>
    <disable_default_collisions link="  "/>
  </robot>)");
  ASSERT_TRUE(p) << p.error();
  EXPECT_EQ(p->default_off, (std::vector<std::string>{"cam", "mount"}));
  EXPECT_EQ(p->enabled, (std::vector<IdPair>{{"cam", "table"}, {"mount", "cam"}}));
  EXPECT_EQ(p->disabled, (std::vector<IdPair>{{"a", "b"}}));
  EXPECT_EQ(p->num_skipped, 3u);  // the last: white space only
  EXPECT_EQ(p->first_skipped, "<disable_default_collisions> on line 6 has no 'link' attribute");
}

// ---------------------------------------------------------------------------------------------
// Hostile structure: deep chains, deep XML, cycles, duplicates (checkUrdfStructure).

namespace {

/// A chain of `n` links l0 -> l1 -> ..., every link with a box when `geometry`.
std::string chainUrdf(std::size_t n, bool geometry = true) {
  std::string xml = "<robot name=\"chain\">\n";
  for (std::size_t i = 0; i < n; ++i) {
    xml += "<link name=\"l" + std::to_string(i) + "\">";
    if (geometry)
      xml += "<collision><geometry><box size=\"0.02 0.02 0.1\"/></geometry></collision>";
    xml += "</link>\n";
  }
  for (std::size_t i = 1; i < n; ++i) {
    xml += "<joint name=\"j" + std::to_string(i) + "\" type=\"fixed\"><parent link=\"l" +
           std::to_string(i - 1) + "\"/><child link=\"l" + std::to_string(i) +
           "\"/><origin xyz=\"0 0 0.1\"/></joint>\n";
  }
  return xml + "</robot>\n";
}

/// Runs `f` on a thread with a `stack_bytes` stack (pthread): a recursion per link would
/// overflow it.
void onSmallStack(std::size_t stack_bytes, void (*f)(void*), void* arg) {
  struct Call {
    void (*f)(void*);
    void* arg;
  } call{f, arg};
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  pthread_attr_setstacksize(&attr, stack_bytes);
  pthread_t t;
  ASSERT_EQ(pthread_create(
                &t, &attr,
                [](void* c) -> void* {
                  auto* k = static_cast<Call*>(c);
                  k->f(k->arg);
                  return nullptr;
                },
                &call),
            0);
  pthread_join(t, nullptr);
  pthread_attr_destroy(&attr);
}

}  // namespace

TEST(UrdfHostile, ChainAtTheDepthLimitLoadsOnASmallStack) {
  // kMaxUrdfDepth joints (tf2's limit). Unflattened, urdfdom frees this chain with one nested
  // destructor per link (~100 kB of stack); bodiesFromUrdf releases the child pointers first.
  struct Out {
    std::string xml;
    Expected<RobotBodies> robot;
  } out{chainUrdf(kMaxUrdfDepth + 1), Error{"not run"}};
  onSmallStack(
      64 * 1024,
      [](void* p) {
        auto* o = static_cast<Out*>(p);
        o->robot = bodiesFromUrdf(o->xml, 0.0, Limits(), MeshLoader());
      },
      &out);
  ASSERT_TRUE(out.robot) << out.robot.error();
  EXPECT_EQ(out.robot->bodies.size(), kMaxUrdfDepth + 1);
  EXPECT_EQ(out.robot->adjacent.size(), kMaxUrdfDepth);
  EXPECT_EQ(out.robot->root_link, "l0");
  EXPECT_TRUE(hasPair(out.robot->adjacent, "l999", "l1000"));
}

TEST(UrdfHostile, DeeperChainsRefused) {
  auto robot = bodiesFromUrdf(chainUrdf(kMaxUrdfDepth + 2), 0.0, Limits(), MeshLoader());
  ASSERT_FALSE(robot);
  EXPECT_EQ(robot.error(),
            "URDF link 'l1001' is more than 1000 joints below its root link (tf2 resolves at most "
            "that many)");
  robot = bodiesFromUrdf(chainUrdf(kMaxUrdfLinks), 0.0, Limits(), MeshLoader());
  ASSERT_FALSE(robot);
  EXPECT_NE(robot.error().find("more than 1000 joints below its root link"), std::string::npos);
}

TEST(UrdfHostile, TenThousandLinksWideLoadMoreRefused) {
  // A root with kMaxUrdfLinks - 1 children: within both limits.
  auto star = [](std::size_t n) {
    std::string xml = "<robot name=\"star\">";
    for (std::size_t i = 0; i < n; ++i) {
      xml += "<link name=\"l" + std::to_string(i) +
             "\"><collision><geometry><sphere radius=\"0.1\"/></geometry></collision></link>";
    }
    for (std::size_t i = 1; i < n; ++i) {
      xml += "<joint name=\"j" + std::to_string(i) +
             "\" type=\"fixed\"><parent link=\"l0\"/><child link=\"l" + std::to_string(i) +
             "\"/></joint>";
    }
    return xml + "</robot>";
  };
  auto robot = bodiesFromUrdf(star(kMaxUrdfLinks), 0.0, Limits(), MeshLoader());
  ASSERT_TRUE(robot) << robot.error();
  EXPECT_EQ(robot->bodies.size(), kMaxUrdfLinks);
  EXPECT_EQ(robot->adjacent.size(), kMaxUrdfLinks - 1);
  robot = bodiesFromUrdf(star(kMaxUrdfLinks + 1), 0.0, Limits(), MeshLoader());
  ASSERT_FALSE(robot);
  EXPECT_EQ(robot.error(), "URDF has more than 10000 links");
}

TEST(UrdfHostile, DeepXmlRefusedBeforeUrdfdom) {
  // TinyXML (urdfdom) parses and frees elements recursively: 200,000 nested elements overflow an
  // 8 MB stack there. tinyxml2 stops at depth 100.
  std::string xml = "<robot name=\"r\"><link name=\"a\"/>";
  for (int i = 0; i < 200000; ++i)
    xml += "<x>";
  for (int i = 0; i < 200000; ++i)
    xml += "</x>";
  xml += "</robot>";
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), MeshLoader());
  ASSERT_FALSE(robot);
  EXPECT_EQ(robot.error(), "URDF nests XML elements more than 100 deep");
}

TEST(UrdfHostile, CyclesAndDuplicatesRefused) {
  const std::string links =
      "<link name=\"r\"/><link name=\"a\"/>"
      "<link name=\"b\"><collision><geometry><sphere radius=\"1\"/></geometry></collision></link>";
  auto joint = [](const char* name, const char* p, const char* c) {
    return std::string("<joint name=\"") + name + "\" type=\"fixed\"><parent link=\"" + p +
           "\"/><child link=\"" + c + "\"/></joint>";
  };
  auto refused = [](const std::string& body) {
    auto robot =
        bodiesFromUrdf("<robot name=\"c\">" + body + "</robot>", 0.0, Limits(), MeshLoader());
    return robot ? std::string("loaded") : robot.error();
  };
  // a -> b -> a below the root r: urdfdom accepts it (and leaks the cycle); walking up from b
  // would never end.
  EXPECT_EQ(refused(links + joint("j0", "r", "a") + joint("j1", "a", "b") + joint("j2", "b", "a")),
            "URDF link 'a' is the child of more than one joint (joint 'j2')");
  EXPECT_EQ(refused(links + joint("j1", "a", "b") + joint("j2", "b", "a")),
            "URDF joints form a cycle (through link 'a')");
  EXPECT_EQ(refused(links + joint("j1", "a", "a")), "URDF joint 'j1' joins link 'a' to itself");
  EXPECT_EQ(refused(links + "<link name=\"a\"/>"), "URDF declares link 'a' more than once");
  EXPECT_EQ(refused(links + joint("j1", "r", "a") + joint("j1", "a", "b")),
            "URDF declares joint 'j1' more than once");
  EXPECT_EQ(refused(links + joint("j1", "r", "a") + joint("j2", "a", "b")), "loaded");
}

TEST(UrdfHostile, AdjacencyThroughALongGeometryLessStretch) {
  // root (geometry) -> 999 links without geometry -> 5,000 leaves with geometry: every leaf is
  // adjacent to the root (and the stretch is walked once, not once per leaf).
  std::string xml =
      "<robot name=\"s\"><link name=\"root\"><collision><geometry><sphere radius=\"1\"/>"
      "</geometry></collision></link>";
  const int stretch = 999, leaves = 5000;
  for (int i = 0; i < stretch; ++i)
    xml += "<link name=\"s" + std::to_string(i) + "\"/>";
  for (int i = 0; i < leaves; ++i) {
    xml += "<link name=\"leaf" + std::to_string(i) +
           "\"><collision><geometry><sphere radius=\"1\"/></geometry></collision></link>";
  }
  for (int i = 0; i < stretch; ++i) {
    xml += "<joint name=\"js" + std::to_string(i) + "\" type=\"fixed\"><parent link=\"" +
           (i ? "s" + std::to_string(i - 1) : std::string("root")) + "\"/><child link=\"s" +
           std::to_string(i) + "\"/></joint>";
  }
  for (int i = 0; i < leaves; ++i) {
    xml += "<joint name=\"jl" + std::to_string(i) + "\" type=\"fixed\"><parent link=\"s" +
           std::to_string(stretch - 1) + "\"/><child link=\"leaf" + std::to_string(i) +
           "\"/></joint>";
  }
  xml += "</robot>";
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), MeshLoader());
  ASSERT_TRUE(robot) << robot.error();
  EXPECT_EQ(robot->bodies.size(), static_cast<std::size_t>(leaves + 1));
  ASSERT_EQ(robot->adjacent.size(), static_cast<std::size_t>(leaves));
  for (const auto& [a, b] : robot->adjacent)
    EXPECT_TRUE(a == "root" || b == "root") << a << " " << b;
}
