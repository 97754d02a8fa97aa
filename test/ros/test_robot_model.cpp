// Plain gtests (no master) of URDF -> bodies and SRDF parsing on the real Panda and PR2
// descriptions of example-robot-data (CM_ROBOT_DATA, default ../shared/data).
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

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

bool hasPair(const std::vector<IdPair>& pairs, const std::string& a, const std::string& b) {
  return std::find(pairs.begin(), pairs.end(), IdPair{a, b}) != pairs.end() ||
         std::find(pairs.begin(), pairs.end(), IdPair{b, a}) != pairs.end();
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
  for (const auto& b : robot->bodies) {
    if (b.id != "base") continue;
    ASSERT_EQ(b.parts.size(), 1u);
    EXPECT_EQ(b.parts[0].pose.t, core::Vec3(1, 0, 0));
    EXPECT_NEAR(b.parts[0].shape.support(core::Vec3::UnitX()).x(), 0.6, 1e-12);
  }
  EXPECT_TRUE(hasPair(robot->adjacent, "base", "arm"));
}

TEST(Urdf, BadLinkIsLeftOutOthersLoad) {
  const std::string xml = R"(<robot name="r">
    <link name="good"><collision><geometry><sphere radius="0.5"/></geometry></collision></link>
    <link name="bad"><collision><geometry><mesh filename="file:///etc/passwd"/></geometry>
      </collision></link>
    <joint name="j" type="fixed"><parent link="good"/><child link="bad"/></joint>
  </robot>)";
  MeshCache cache({}, 1000, resolver());
  MeshLoader loader = [&](const std::string& uri, const core::Vec3& s) {
    return cache.load(uri, s);
  };
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), loader);
  ASSERT_TRUE(robot) << robot.error();
  ASSERT_EQ(robot->bodies.size(), 1u);
  EXPECT_EQ(robot->bodies[0].id, "good");
  ASSERT_EQ(robot->errors.size(), 1u);
  EXPECT_NE(robot->errors[0].find("outside mesh_roots"), std::string::npos) << robot->errors[0];
}

TEST(Urdf, NotAUrdf) {
  EXPECT_FALSE(bodiesFromUrdf("<html/>", 0.0, Limits(), MeshLoader()));
  EXPECT_FALSE(bodiesFromUrdf("not xml at all", 0.0, Limits(), MeshLoader()));
}

TEST(Urdf, Pr2MeshesLoadAsHulls) {
  const std::string xml = readFile(robotData() + "/robots/pr2_description/urdf/pr2.urdf");
  ASSERT_FALSE(xml.empty());
  MeshCache cache({}, 100000, resolver());
  MeshLoader loader = [&](const std::string& uri, const core::Vec3& s) {
    return cache.load(uri, s);
  };
  auto robot = bodiesFromUrdf(xml, 0.0, Limits(), loader);
  ASSERT_TRUE(robot) << robot.error();
  EXPECT_TRUE(robot->errors.empty()) << robot->errors.front();
  EXPECT_EQ(robot->bodies.size(), 32u);
  EXPECT_EQ(robot->root_link, "base_footprint");
}

TEST(Srdf, PandaDisabledPairs) {
  auto pairs =
      disabledPairsFromSrdf(readFile(robotData() + "/robots/panda_description/srdf/panda.srdf"));
  ASSERT_TRUE(pairs) << pairs.error();
  EXPECT_EQ(pairs->size(), 35u);
  EXPECT_TRUE(hasPair(*pairs, "panda_link0", "panda_link1"));
}

TEST(Srdf, MalformedAndPartial) {
  EXPECT_FALSE(disabledPairsFromSrdf("<robot><disable_collisions"));
  EXPECT_FALSE(disabledPairsFromSrdf("<notrobot/>"));
  auto p = disabledPairsFromSrdf(
      R"(<robot name="r"><disable_collisions link1="a" link2="b" reason="Adjacent"/>
         <disable_collisions link1="c"/></robot>)");
  ASSERT_TRUE(p) << p.error();
  ASSERT_EQ(p->size(), 1u);
  EXPECT_EQ((*p)[0], IdPair("a", "b"));
}
