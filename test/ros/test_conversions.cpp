// Plain gtests (no master) of the ROS layer's boundary: message -> world conversions and their
// validation, BodyPoses, parameter (XmlRpc) parsing and mesh URI confinement.
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "collision_monitor/ros/conversions.h"
#include "collision_monitor/ros/log_throttle.h"
#include "collision_monitor/ros/mesh_loader.h"
#include "collision_monitor/ros/params.h"

using namespace collision_monitor;
using namespace collision_monitor::ros_layer;

namespace {

const double kNaN = std::numeric_limits<double>::quiet_NaN();
const double kInf = std::numeric_limits<double>::infinity();

collision_monitor::Shape shape(std::uint8_t type, std::vector<double> dims) {
  collision_monitor::Shape s;
  s.type = type;
  s.dimensions = std::move(dims);
  return s;
}

collision_monitor::Body body(const std::string& id, std::vector<collision_monitor::Shape> parts) {
  collision_monitor::Body b;
  b.id = id;
  b.header.frame_id = "world";
  b.operation = collision_monitor::Body::ADD;
  b.parts = std::move(parts);
  return b;
}

geometry_msgs::Pose pose(double x, double y, double z, double qx = 0, double qy = 0, double qz = 0,
                         double qw = 1) {
  geometry_msgs::Pose p;
  p.position.x = x;
  p.position.y = y;
  p.position.z = z;
  p.orientation.x = qx;
  p.orientation.y = qy;
  p.orientation.z = qz;
  p.orientation.w = qw;
  return p;
}

/// A mesh loader that must not be called.
const MeshLoader kNoMeshes = [](const std::string&,
                                const core::Vec3&) -> Expected<std::vector<core::ConvexShape>> {
  ADD_FAILURE() << "mesh loader called";
  return Error{"no meshes"};
};

/// shapesFromMsg for a part that gives one shape.
Expected<core::ConvexShape> shapeFromMsg(const collision_monitor::Shape& s, const Limits& limits,
                                         const MeshLoader& load_mesh) {
  auto r = shapesFromMsg(s, limits, load_mesh);
  if (!r) return Error{r.error()};
  EXPECT_EQ(r->size(), 1u);
  return r->front();
}

/// partsFromMsg for a part that gives one world part.
Expected<world::Part> partFromMsg(const collision_monitor::Shape& s, double padding,
                                  const Limits& limits, const MeshLoader& load_mesh) {
  auto r = partsFromMsg(s, padding, limits, load_mesh);
  if (!r) return Error{r.error()};
  EXPECT_EQ(r->size(), 1u);
  return r->front();
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

/// A CONVEX part of the corners (0,0,0), (1,0,0), (0,1,0), (0,0,1).
collision_monitor::Shape unitTetrahedron() {
  collision_monitor::Shape s;
  s.type = collision_monitor::Shape::CONVEX;
  for (auto [x, y, z] : {std::array<double, 3>{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}) {
    geometry_msgs::Point p;
    p.x = x;
    p.y = y;
    p.z = z;
    s.vertices.push_back(p);
  }
  return s;
}
}  // namespace

TEST(Transform, AcceptsUnitAndNearUnitQuaternions) {
  auto t = toTransform(pose(1, 2, 3, 0, 0, std::sqrt(0.5), std::sqrt(0.5)));
  ASSERT_TRUE(t) << t.error();
  EXPECT_NEAR((t->R * core::Vec3::UnitX() - core::Vec3::UnitY()).norm(), 0.0, 1e-12);
  EXPECT_EQ(t->t, core::Vec3(1, 2, 3));
  // 0.707 twice: |q| = 0.99985, within tolerance, normalised.
  auto n = toTransform(pose(0, 0, 0, 0, 0, 0.707, 0.707));
  ASSERT_TRUE(n) << n.error();
  EXPECT_TRUE(core::isValidRotation(n->R, 1e-12));
}

TEST(Transform, RefusesNonFiniteAndNonUnit) {
  EXPECT_TRUE(contains(toTransform(pose(kNaN, 0, 0)).error(), "position"));
  EXPECT_TRUE(contains(toTransform(pose(0, kInf, 0)).error(), "position"));
  EXPECT_TRUE(contains(toTransform(pose(0, 0, 0, 0, 0, 0, kNaN)).error(), "orientation"));
  EXPECT_TRUE(contains(toTransform(pose(0, 0, 0, 0, 0, 0, 2)).error(), "unit quaternion"));
  EXPECT_TRUE(contains(toTransform(pose(0, 0, 0, 0, 0, 0, 0)).error(), "zero quaternion"));
  auto id = toTransform(pose(1, 0, 0, 0, 0, 0, 0), ZeroQuaternion::Identity);
  ASSERT_TRUE(id) << id.error();
  EXPECT_EQ(id->R, core::Mat3::Identity());
}

// Per object, unlike ROS_*_THROTTLE's one static per call site: two monitors in one process each
// log their first line.
TEST(LogThrottle, OncePerPeriodPerObject) {
  ros::Time::init();
  LogThrottle a(0.2), b(0.2);
  EXPECT_TRUE(a.ready());
  EXPECT_FALSE(a.ready());
  EXPECT_TRUE(b.ready());
  EXPECT_FALSE(b.ready());
  ros::WallDuration(0.25).sleep();
  EXPECT_TRUE(a.ready());
  EXPECT_FALSE(a.ready());
}

TEST(ShapeType, Names) {
  EXPECT_EQ(shapeTypeFromString("Sphere"), collision_monitor::Shape::SPHERE);
  EXPECT_EQ(shapeTypeFromString("MESH"), collision_monitor::Shape::MESH);
  EXPECT_EQ(shapeTypeFromString("2"), collision_monitor::Shape::BOX);
  EXPECT_FALSE(shapeTypeFromString("torus"));
  EXPECT_FALSE(shapeTypeFromString("9"));
  EXPECT_FALSE(shapeTypeFromString("0"));
  EXPECT_EQ(shapeTypeName(collision_monitor::Shape::CAPSULE), "capsule");
}

TEST(Shape, EveryPrimitiveConverts) {
  const Limits limits;
  using S = collision_monitor::Shape;
  for (const auto& s :
       {shape(S::SPHERE, {0.5}), shape(S::BOX, {1, 2, 3}), shape(S::CYLINDER, {1, 0.2}),
        shape(S::CONE, {1, 0.2}), shape(S::CAPSULE, {1, 0.2}), shape(S::ELLIPSOID, {1, 2, 3}),
        shape(S::BOX, {1, 1, 0})}) {
    auto r = shapeFromMsg(s, limits, kNoMeshes);
    EXPECT_TRUE(r) << shapeTypeName(s.type) << ": " << r.error();
  }
  auto sphere = shapeFromMsg(shape(S::SPHERE, {0.5}), limits, kNoMeshes);
  ASSERT_TRUE(sphere);
  EXPECT_NEAR(sphere->support(core::Vec3::UnitX()).x(), 0.5, 1e-12);
  auto box = shapeFromMsg(shape(S::BOX, {1, 2, 3}), limits, kNoMeshes);
  ASSERT_TRUE(box);
  EXPECT_NEAR((box->support(core::Vec3(1, 1, 1)) - core::Vec3(0.5, 1, 1.5)).norm(), 0.0, 1e-12);
}

TEST(Shape, RefusesBadDimensions) {
  const Limits limits;
  using S = collision_monitor::Shape;
  EXPECT_TRUE(
      contains(shapeFromMsg(shape(S::SPHERE, {-1}), limits, kNoMeshes).error(), "negative"));
  EXPECT_TRUE(contains(shapeFromMsg(shape(S::SPHERE, {}), limits, kNoMeshes).error(),
                       "needs 1 dimensions"));
  EXPECT_TRUE(contains(shapeFromMsg(shape(S::BOX, {1, 1}), limits, kNoMeshes).error(),
                       "needs 3 dimensions"));
  EXPECT_TRUE(contains(shapeFromMsg(shape(S::CYLINDER, {1, kNaN}), limits, kNoMeshes).error(),
                       "not finite"));
  EXPECT_TRUE(
      contains(shapeFromMsg(shape(S::SPHERE, {0}), limits, kNoMeshes).error(), "degenerate"));
  EXPECT_TRUE(
      contains(shapeFromMsg(shape(S::BOX, {0, 0, 0}), limits, kNoMeshes).error(), "degenerate"));
  EXPECT_TRUE(contains(shapeFromMsg(shape(0, {}), limits, kNoMeshes).error(), "unknown shape"));
  EXPECT_TRUE(contains(shapeFromMsg(shape(42, {1}), limits, kNoMeshes).error(), "unknown shape"));
  auto scaled = shape(S::SPHERE, {1});
  scaled.scale.x = scaled.scale.y = scaled.scale.z = 2.0;
  EXPECT_TRUE(contains(shapeFromMsg(scaled, limits, kNoMeshes).error(), "scale applies"));
  // A resource where none belongs was ignored without a word.
  auto with_resource = shape(S::SPHERE, {1});
  with_resource.resource = "package://collision_monitor/meshes/x.stl";
  EXPECT_EQ(shapeFromMsg(with_resource, limits, kNoMeshes).error(), "sphere takes no resource");
  with_resource.type = S::CONVEX;
  with_resource.dimensions.clear();
  with_resource.vertices.resize(4);
  EXPECT_EQ(shapeFromMsg(with_resource, limits, kNoMeshes).error(),
            "convex part takes no resource (use a MESH part)");
}

TEST(Shape, Convex) {
  Limits limits;
  limits.max_vertices_per_part = 4;
  collision_monitor::Shape s;
  s.type = collision_monitor::Shape::CONVEX;
  EXPECT_TRUE(contains(shapeFromMsg(s, limits, kNoMeshes).error(), "no vertices"));
  s.vertices = unitTetrahedron().vertices;
  s.scale.x = 2;
  s.scale.y = 2;
  s.scale.z = 2;
  auto ok = shapeFromMsg(s, limits, kNoMeshes);
  ASSERT_TRUE(ok) << ok.error();
  EXPECT_NEAR(ok->support(core::Vec3::UnitX()).x(), 2.0, 1e-12);
  s.vertices.push_back(s.vertices[1]);
  EXPECT_TRUE(contains(shapeFromMsg(s, limits, kNoMeshes).error(), "max_vertices_per_part"));
  s.vertices.resize(2);
  s.vertices[1] = s.vertices[0];
  EXPECT_TRUE(contains(shapeFromMsg(s, limits, kNoMeshes).error(), "degenerate"));
  s.vertices[1].x = kNaN;
  EXPECT_TRUE(contains(shapeFromMsg(s, limits, kNoMeshes).error(), "not finite"));
  s.scale.y = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(contains(shapeFromMsg(s, limits, kNoMeshes).error(), "scale is not finite"));
  // A negative factor mirrors, a zero one flattens: the hull of the scaled vertices.
  s.vertices.resize(4);
  for (int i = 0; i < 4; ++i) {
    s.vertices[i].x = i == 1 ? 1.0 : 0.0;
    s.vertices[i].y = i == 2 ? 1.0 : 0.0;
    s.vertices[i].z = i == 3 ? 1.0 : 0.0;
  }
  s.scale.x = -2;
  s.scale.y = 0;
  s.scale.z = 1;
  auto mirrored = shapeFromMsg(s, limits, kNoMeshes);
  ASSERT_TRUE(mirrored) << mirrored.error();
  EXPECT_EQ(mirrored->support(core::Vec3(-1, 0.5, 0)), core::Vec3(-2, 0, 0));
  EXPECT_EQ(mirrored->support(core::Vec3(1, 0.5, 0.25)), core::Vec3(0, 0, 1));
  EXPECT_EQ(mirrored->support(core::Vec3(0, 1, 0)).y(), 0.0);
}

// The Shape message's dimension order (Shape.msg): [height, radius] for a cylinder and a cone,
// [length, radius] for a capsule, the axis along z. A swapped pair gave a 1 m wide, 0.2 m tall
// cylinder for a 1 m tall one, and no test noticed.
TEST(Shape, DimensionsInTheMessagesOrder) {
  const Limits limits;
  using S = collision_monitor::Shape;
  auto cylinder = shapeFromMsg(shape(S::CYLINDER, {1.0, 0.2}), limits, kNoMeshes);
  ASSERT_TRUE(cylinder) << cylinder.error();
  EXPECT_NEAR(cylinder->support(core::Vec3::UnitX()).x(), 0.2, 1e-12);
  EXPECT_NEAR(cylinder->support(core::Vec3::UnitZ()).z(), 0.5, 1e-12);
  EXPECT_NEAR(cylinder->support(-core::Vec3::UnitZ()).z(), -0.5, 1e-12);
  auto cone = shapeFromMsg(shape(S::CONE, {1.0, 0.2}), limits, kNoMeshes);
  ASSERT_TRUE(cone) << cone.error();
  EXPECT_NEAR(cone->support(core::Vec3::UnitX()).x(), 0.2, 1e-12);
  EXPECT_NEAR(cone->support(core::Vec3::UnitZ()).z(), 0.5, 1e-12);  // the apex
  auto capsule = shapeFromMsg(shape(S::CAPSULE, {1.0, 0.2}), limits, kNoMeshes);
  ASSERT_TRUE(capsule) << capsule.error();
  EXPECT_NEAR(capsule->support(core::Vec3::UnitX()).x(), 0.2, 1e-12);
  EXPECT_NEAR(capsule->support(core::Vec3::UnitZ()).z(), 0.5 + 0.2, 1e-12);
  auto ellipsoid = shapeFromMsg(shape(S::ELLIPSOID, {1, 2, 3}), limits, kNoMeshes);
  ASSERT_TRUE(ellipsoid) << ellipsoid.error();
  EXPECT_NEAR(ellipsoid->support(core::Vec3::UnitY()).y(), 2.0, 1e-12);
  EXPECT_NEAR(ellipsoid->support(core::Vec3::UnitZ()).z(), 3.0, 1e-12);
}

// |q| within kQuaternionTolerance (1e-3) of 1 is accepted and normalised, beyond it refused.
TEST(Transform, QuaternionToleranceIsOneThousandth) {
  EXPECT_TRUE(toTransform(pose(0, 0, 0, 0, 0, 0, 1.0009)));
  EXPECT_TRUE(toTransform(pose(0, 0, 0, 0, 0, 0, 0.9991)));
  EXPECT_TRUE(contains(toTransform(pose(0, 0, 0, 0, 0, 0, 1.002)).error(), "unit quaternion"));
  EXPECT_TRUE(contains(toTransform(pose(0, 0, 0, 0, 0, 0, 0.998)).error(), "unit quaternion"));
}

// Only a scale of 0,0,0 means 1,1,1 (an unset field): 0,0,2 flattens a convex part onto the z
// axis, and on a primitive it is refused like any other scale.
TEST(Shape, ScaleIsUnsetOnlyWhenAllThreeAreZero) {
  const Limits limits;
  collision_monitor::Shape s = unitTetrahedron();
  s.scale.z = 2;
  auto segment = shapeFromMsg(s, limits, kNoMeshes);
  ASSERT_TRUE(segment) << segment.error();
  EXPECT_NEAR((segment->support(core::Vec3(1, 1, 0.5)) - core::Vec3(0, 0, 2)).norm(), 0.0, 1e-12);
  EXPECT_NEAR(segment->support(core::Vec3(1, 1, -0.5)).norm(), 0.0, 1e-12);
  auto sphere = shape(collision_monitor::Shape::SPHERE, {1});
  sphere.scale.z = 1;
  EXPECT_TRUE(contains(shapeFromMsg(sphere, limits, kNoMeshes).error(), "scale applies"));
}

TEST(Shape, MeshGoesThroughTheLoader) {
  collision_monitor::Shape s;
  s.type = collision_monitor::Shape::MESH;
  s.resource = "package://p/m.stl";
  std::string seen;
  core::Vec3 seen_scale;
  MeshLoader loader = [&](const std::string& uri, const core::Vec3& scale) {
    seen = uri;
    seen_scale = scale;
    return Expected<std::vector<core::ConvexShape>>({core::ConvexShape::box(core::Vec3(1, 1, 1))});
  };
  EXPECT_TRUE(shapeFromMsg(s, Limits(), loader));
  EXPECT_EQ(seen, "package://p/m.stl");
  EXPECT_EQ(seen_scale, core::Vec3(1, 1, 1));  // 0,0,0 means 1,1,1
  MeshLoader failing = [](const std::string&,
                          const core::Vec3&) -> Expected<std::vector<core::ConvexShape>> {
    return Error{"outside mesh_roots"};
  };
  EXPECT_TRUE(contains(shapeFromMsg(s, Limits(), failing).error(), "outside mesh_roots"));
  s.resource.clear();
  EXPECT_TRUE(contains(shapeFromMsg(s, Limits(), loader).error(), "empty resource"));
}

TEST(Part, PoseAndPadding) {
  auto s = shape(collision_monitor::Shape::SPHERE, {1});
  s.pose.position.x = 2;  // zero quaternion: identity
  auto part = partFromMsg(s, 0.1, Limits(), kNoMeshes);
  ASSERT_TRUE(part) << part.error();
  EXPECT_EQ(part->pose.t, core::Vec3(2, 0, 0));
  EXPECT_NEAR(part->shape.support(core::Vec3::UnitX()).x(), 1.1, 1e-12);
  s.pose.orientation.w = 3;
  EXPECT_TRUE(contains(partFromMsg(s, 0, Limits(), kNoMeshes).error(), "pose"));
}

TEST(Body, Converts) {
  auto msg = body("cup", {shape(collision_monitor::Shape::CYLINDER, {0.1, 0.04}),
                          shape(collision_monitor::Shape::SPHERE, {0.02})});
  msg.group = "g";
  msg.padding = 0.01;
  auto spec = bodyFromMsg(msg, world::BodyOrigin::Topic, Limits(), kNoMeshes);
  ASSERT_TRUE(spec) << spec.error();
  EXPECT_EQ(spec->id, "cup");
  EXPECT_EQ(spec->frame, "world");
  EXPECT_EQ(spec->group, "g");
  EXPECT_EQ(spec->parts.size(), 2u);
  EXPECT_EQ(spec->pose_source, world::PoseSource::Tf);
  EXPECT_EQ(spec->origin, world::BodyOrigin::Topic);
  EXPECT_DOUBLE_EQ(spec->padding, 0.01);

  msg.pose_topic = "/cup_pose";
  msg.header.frame_id.clear();
  auto topic = bodyFromMsg(msg, world::BodyOrigin::Topic, Limits(), kNoMeshes);
  ASSERT_TRUE(topic) << topic.error();
  EXPECT_EQ(topic->pose_source, world::PoseSource::Topic);  // pose_topic implies topic-posed
  EXPECT_EQ(topic->pose_topic, "/cup_pose");
}

TEST(Body, RefusesWithReasons) {
  const auto sphere = shape(collision_monitor::Shape::SPHERE, {1});
  auto err = [](const collision_monitor::Body& b, Limits limits = Limits()) {
    auto r = bodyFromMsg(b, world::BodyOrigin::Topic, limits, kNoMeshes);
    EXPECT_FALSE(r);
    return r.error();
  };
  EXPECT_TRUE(contains(err(body("", {sphere})), "id is empty"));
  EXPECT_TRUE(contains(err(body("a", {})), "no parts"));
  auto padded = body("a", {sphere});
  padded.padding = -0.1;
  EXPECT_TRUE(contains(err(padded), "padding"));
  padded.padding = kNaN;
  EXPECT_TRUE(contains(err(padded), "padding"));
  auto no_frame = body("a", {sphere});
  no_frame.header.frame_id.clear();
  EXPECT_TRUE(contains(err(no_frame), "frame_id is empty"));
  auto bad_part = body("a", {sphere, shape(collision_monitor::Shape::SPHERE, {-1})});
  const std::string e = err(bad_part);
  EXPECT_TRUE(contains(e, "part 1 (sphere)")) << e;
  EXPECT_TRUE(contains(e, "negative")) << e;
  Limits few;
  few.max_parts_per_body = 1;
  EXPECT_TRUE(contains(err(body("a", {sphere, sphere}), few), "max_parts_per_body"));
  // Bug: a pose_topic that is no ROS name got as far as roscpp's subscribe(), which threw after
  // the body had been replaced (and at start-up, from the ~bodies parameter, ended the node).
  for (const std::string topic : {"/mocap/tool-1/pose", "1pose", "a b", "/x.y", "~/p\n"}) {
    auto bad_topic = body("a", {sphere});
    bad_topic.pose_topic = topic;
    const std::string t = err(bad_topic);
    EXPECT_TRUE(contains(t, "is not a valid ROS name")) << topic << ": " << t;
  }
  auto dash = body("a", {sphere});
  dash.pose_topic = "/mocap/tool-1/pose";
  EXPECT_EQ(err(dash),
            "pose_topic '/mocap/tool-1/pose' is not a valid ROS name: Character [-] at element "
            "[11] is not valid");
  auto control = body("a", {sphere});
  control.pose_topic = "/x\ny";
  EXPECT_EQ(err(control).find('\n'), std::string::npos);  // quoted, escaped: one line
  auto good = body("a", {sphere});
  for (const std::string topic : {"/mocap/tool_1/pose", "tool_pose", "~tool_pose", "ns/p"}) {
    good.pose_topic = topic;
    EXPECT_TRUE(bodyFromMsg(good, world::BodyOrigin::Topic, Limits(), kNoMeshes)) << topic;
  }
}

// tf2 frames have no leading '/': one is dropped ("/f1" is the frame "f1"), and "/" alone names
// no frame, refused as an empty one is (it was kept as the frame '': a body never posed, with no
// reason given). A topic-posed body needs no frame.
TEST(Body, LeadingSlashOfTheFrameIsDroppedAndASlashAloneRefused) {
  const auto sphere = shape(collision_monitor::Shape::SPHERE, {1});
  auto slashed = body("a", {sphere});
  slashed.header.frame_id = "/f1";
  auto spec = bodyFromMsg(slashed, world::BodyOrigin::Topic, Limits(), kNoMeshes);
  ASSERT_TRUE(spec) << spec.error();
  EXPECT_EQ(spec->frame, "f1");
  auto slash = body("a", {sphere});
  slash.header.frame_id = "/";
  EXPECT_EQ(bodyFromMsg(slash, world::BodyOrigin::Topic, Limits(), kNoMeshes).error(),
            "header.frame_id '/' names no frame: a body needs a TF frame unless pose_from_topic "
            "is set");
  slash.pose_from_topic = true;
  auto topic = bodyFromMsg(slash, world::BodyOrigin::Topic, Limits(), kNoMeshes);
  ASSERT_TRUE(topic) << topic.error();
  EXPECT_EQ(topic->frame, "");
  EXPECT_EQ(topic->pose_source, world::PoseSource::Topic);
}

TEST(InputText, EscapedForOneLogLine) {
  EXPECT_EQ(escapeInput("body 'x\n[ERROR] y'\t\x7f\xc3\xa9"),
            "body 'x\\x0a[ERROR] y'\\x09\\x7f\\xc3\\xa9");
  EXPECT_EQ(escapeInput("plain ascii: 'a' \\x0a"), "plain ascii: 'a' \\x0a");  // as it is
  EXPECT_EQ(escapeInput("abcdef", 3), "abc");
  EXPECT_EQ(quoteInput(std::string("a\0b", 3)), "'a\\x00b'");
}

TEST(BodyPoses, Validates) {
  collision_monitor::BodyPoses msg;
  msg.header.frame_id = "world";
  msg.ids = {"a", "b"};
  msg.poses = {pose(1, 0, 0), pose(0, 2, 0)};
  auto ok = posesFromMsg(msg);
  ASSERT_TRUE(ok) << ok.error();
  ASSERT_EQ(ok->size(), 2u);
  EXPECT_EQ((*ok)[1].pose.t, core::Vec3(0, 2, 0));
  EXPECT_FALSE((*ok)[0].twist);

  msg.twists.resize(1);
  EXPECT_TRUE(contains(posesFromMsg(msg).error(), "twists"));
  msg.twists.resize(2);
  msg.twists[0].linear.x = 1.0;
  auto tw = posesFromMsg(msg);
  ASSERT_TRUE(tw);
  ASSERT_TRUE((*tw)[0].twist);
  EXPECT_EQ((*tw)[0].twist->linear, core::Vec3(1, 0, 0));

  msg.poses.pop_back();
  EXPECT_TRUE(contains(posesFromMsg(msg).error(), "differ in length"));
  msg.poses = {pose(1, 0, 0), pose(kNaN, 0, 0)};
  EXPECT_TRUE(contains(posesFromMsg(msg).error(), "pose of 'b'"));
  msg.poses = {pose(1, 0, 0), pose(0, 0, 0, 0, 0, 0, 0)};
  EXPECT_TRUE(contains(posesFromMsg(msg).error(), "zero quaternion"));
  msg.poses = {pose(1, 0, 0), pose(0, 0, 0)};
  msg.ids = {"a", "a"};
  EXPECT_TRUE(contains(posesFromMsg(msg).error(), "twice"));
}

// A twist is refused when any of its six components is not finite: the angular ones too.
TEST(BodyPoses, NonFiniteTwistIsRefused) {
  collision_monitor::BodyPoses msg;
  msg.header.frame_id = "world";
  msg.ids = {"a"};
  msg.poses = {pose(1, 0, 0)};
  msg.twists.resize(1);
  msg.twists[0].angular.z = kNaN;
  EXPECT_EQ(posesFromMsg(msg).error(), "twist of 'a' is not finite");
  msg.twists[0].angular.z = 0.0;
  msg.twists[0].linear.y = kInf;
  EXPECT_EQ(posesFromMsg(msg).error(), "twist of 'a' is not finite");
}

TEST(BodyPoses, TransformUpdate) {
  PoseUpdate u{"a", core::makeTransform(Eigen::Quaterniond::Identity(), core::Vec3(1, 0, 0)),
               world::Twist{core::Vec3(1, 0, 0), core::Vec3::Zero()}};
  // frame -> fixed: rotate 90 degrees about z, then shift by (0, 0, 1).
  const auto T = core::makeTransform(
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, core::Vec3::UnitZ())), core::Vec3(0, 0, 1));
  const PoseUpdate v = transformUpdate(u, T);
  EXPECT_NEAR((v.pose.t - core::Vec3(0, 1, 1)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((v.twist->linear - core::Vec3(0, 1, 0)).norm(), 0.0, 1e-12);
}

TEST(Messages, PairStateInAnotherFrame) {
  world::PairResult p;
  p.body_a = "a";
  p.body_b = "b";
  p.status = world::PairStatus::Warning;
  p.distance = 1.0;
  p.point_a = core::Vec3(1, 0, 0);
  p.point_b = core::Vec3(2, 0, 0);
  p.normal = core::Vec3(1, 0, 0);
  auto m = toMsg(p);
  EXPECT_EQ(m.status, collision_monitor::PairState::WARNING);
  EXPECT_DOUBLE_EQ(m.point_b.x, 2.0);
  const auto shift = core::makeTransform(Eigen::Quaterniond::Identity(), core::Vec3(0, 0, 5));
  auto s = toMsg(p, shift);
  EXPECT_DOUBLE_EQ(s.point_a.z, 5.0);
  EXPECT_DOUBLE_EQ(s.normal.z, 0.0);  // directions rotate, not translate

  world::Event e{world::EventType::UnknownBegin, p, 0.0};
  auto em = toMsg(e, "world", 42.0);
  EXPECT_EQ(em.type, collision_monitor::CollisionEvent::UNKNOWN_BEGIN);
  EXPECT_EQ(em.header.frame_id, "world");
  EXPECT_DOUBLE_EQ(em.header.stamp.toSec(), 42.0);  // static poses: stamped now
}

// --- parameters ----------------------------------------------------------------------------

namespace {
XmlRpc::XmlRpcValue list3(double x, double y, double z) {
  XmlRpc::XmlRpcValue v;
  v[0] = x;
  v[1] = y;
  v[2] = z;
  return v;
}
}  // namespace

TEST(Params, BodyFromYaml) {
  XmlRpc::XmlRpcValue b;
  b["id"] = "table";
  b["frame_id"] = "world";
  b["padding"] = 0.01;
  XmlRpc::XmlRpcValue part;
  part["type"] = "box";
  part["dimensions"] = list3(1.2, 0.8, 0.05);
  part["pose"]["position"] = list3(0, 0, 0.7);
  b["parts"][0] = part;
  XmlRpc::XmlRpcValue mesh;
  mesh["type"] = 8;
  mesh["resource"] = "package://x/y.stl";
  mesh["scale"] = list3(2, 2, 2);
  b["parts"][1] = mesh;
  auto msg = bodyFromXmlRpc(b);
  ASSERT_TRUE(msg) << msg.error();
  EXPECT_EQ(msg->id, "table");
  EXPECT_EQ(msg->header.frame_id, "world");
  ASSERT_EQ(msg->parts.size(), 2u);
  EXPECT_EQ(msg->parts[0].type, collision_monitor::Shape::BOX);
  EXPECT_DOUBLE_EQ(msg->parts[0].pose.position.z, 0.7);
  EXPECT_DOUBLE_EQ(msg->parts[0].pose.orientation.w, 1.0);
  EXPECT_EQ(msg->parts[1].type, collision_monitor::Shape::MESH);
  EXPECT_DOUBLE_EQ(msg->parts[1].scale.y, 2.0);

  XmlRpc::XmlRpcValue typo = b;
  typo["parts"][0]["dimension"] = list3(1, 1, 1);
  EXPECT_TRUE(contains(bodyFromXmlRpc(typo).error(), "unknown field 'dimension'"));
  XmlRpc::XmlRpcValue bad_type = b;
  bad_type["parts"][0]["type"] = "torus";
  EXPECT_TRUE(contains(bodyFromXmlRpc(bad_type).error(), "unknown shape type 'torus'"));
  XmlRpc::XmlRpcValue no_id = b;
  no_id["id"] = 3;
  EXPECT_TRUE(contains(bodyFromXmlRpc(no_id).error(), "id"));
  // 5e-2 is text to PyYAML (and to roslaunch): the error says how to write it, as PyYAML reads
  // a float (a '.' and a signed exponent: 1.0e2 is text to it too).
  XmlRpc::XmlRpcValue as_text = b;
  as_text["padding"] = "5e-2";
  EXPECT_EQ(bodyFromXmlRpc(as_text).error(),
            "padding: expected a number (the text '5e-2': YAML reads a number with an exponent "
            "as text unless it has a '.' and a signed exponent, roslaunch unless it has a '.'; "
            "write 5.0e-2)");
  for (const auto& [text, written] : std::vector<std::pair<const char*, const char*>>{
           {"-1E3", "-1.0E+3"}, {"1.5e3", "1.5e+3"}, {"1e2", "1.0e+2"}, {"+7e+0", "+7.0e+0"}}) {
    as_text["padding"] = text;
    EXPECT_TRUE(contains(bodyFromXmlRpc(as_text).error(), std::string("write ") + written + ")"))
        << bodyFromXmlRpc(as_text).error();
  }
  for (const char* other : {"five", "5e", "0x1e5", "1e999", "5.0e-2x", "inf", "1.2.3e4"}) {
    as_text["padding"] = other;
    EXPECT_EQ(bodyFromXmlRpc(as_text).error(), "padding: expected a number") << other;
  }

  // Body's own fields (INTERFACE.md: "same fields as Body"): header.frame_id and operation ADD.
  // They were refused ("unknown field 'header'"), and the body was not loaded.
  XmlRpc::XmlRpcValue as_msg;
  as_msg["id"] = "table";
  as_msg["parts"] = b["parts"];
  as_msg["header"]["frame_id"] = "table_frame";
  as_msg["header"]["seq"] = 0;
  as_msg["operation"] = 0;
  auto m2 = bodyFromXmlRpc(as_msg);
  ASSERT_TRUE(m2) << m2.error();
  EXPECT_EQ(m2->header.frame_id, "table_frame");
  EXPECT_EQ(m2->operation, collision_monitor::Body::ADD);
  ASSERT_EQ(m2->parts.size(), 2u);
  as_msg["operation"] = "ADD";
  EXPECT_TRUE(bodyFromXmlRpc(as_msg));
  XmlRpc::XmlRpcValue remove = as_msg;
  remove["operation"] = 1;
  EXPECT_EQ(bodyFromXmlRpc(remove).error(),
            "operation: '1': a body of ~bodies is added (ADD, 0), never removed");
  remove["operation"] = "Add";
  EXPECT_EQ(bodyFromXmlRpc(remove).error(),
            "operation: 'Add': a body of ~bodies is added (ADD, 0), never removed");
  XmlRpc::XmlRpcValue both = as_msg;
  both["frame_id"] = "world";
  EXPECT_EQ(bodyFromXmlRpc(both).error(), "body: both 'frame_id' and 'header.frame_id'");
  XmlRpc::XmlRpcValue seq_only = b;  // frame_id, and a header without one
  seq_only["header"]["seq"] = 3;
  auto m3 = bodyFromXmlRpc(seq_only);
  ASSERT_TRUE(m3) << m3.error();
  EXPECT_EQ(m3->header.frame_id, "world");
  XmlRpc::XmlRpcValue header_typo = as_msg;
  header_typo["header"]["frame"] = "world";
  EXPECT_EQ(bodyFromXmlRpc(header_typo).error(), "header: unknown field 'frame'");
}

TEST(Params, PairsAndStrings) {
  XmlRpc::XmlRpcValue pairs;
  pairs[0][0] = "a";
  pairs[0][1] = "b";
  auto p = pairsFromXmlRpc(pairs);
  ASSERT_TRUE(p) << p.error();
  ASSERT_EQ(p->size(), 1u);
  EXPECT_EQ((*p)[0].second, "b");
  pairs[1][0] = "c";
  EXPECT_FALSE(pairsFromXmlRpc(pairs));
  XmlRpc::XmlRpcValue one("/meshes");
  auto s = stringsFromXmlRpc(one);
  ASSERT_TRUE(s);
  EXPECT_EQ(s->at(0), "/meshes");
}

// robot_link_padding: each valid entry is kept (an int is metres too); each bad one is named and
// left out, the others hold; a value that is no map is refused whole.
TEST(Params, LinkPaddingEntriesCheckedOneByOne) {
  XmlRpc::XmlRpcValue v;
  v["panda_hand"] = 0.02;
  v["panda_link0"] = 0;
  v["neg"] = -0.01;
  v["nan"] = std::nan("");
  v["text"] = "5e-2";
  v["list"][0] = 0.1;
  const LinkMap<double> p = linkPaddingFromXmlRpc(v);
  EXPECT_EQ(p.values, (std::map<std::string, double>{{"panda_hand", 0.02}, {"panda_link0", 0.0}}));
  // In the map's (name) order.
  const std::vector<std::string> want = {
      "robot_link_padding['list']: expected a number; robot_padding used",
      "robot_link_padding['nan']: must be finite and >= 0, got nan; robot_padding used",
      "robot_link_padding['neg']: must be finite and >= 0, got -0.01; robot_padding used",
      "robot_link_padding['text']: expected a number" + numberWrittenAsText(v["text"]) +
          "; robot_padding used"};
  EXPECT_EQ(p.errors, want);
  EXPECT_NE(numberWrittenAsText(v["text"]), "");  // the hint is there

  for (XmlRpc::XmlRpcValue whole : {XmlRpc::XmlRpcValue(0.02), XmlRpc::XmlRpcValue("hand")}) {
    const LinkMap<double> q = linkPaddingFromXmlRpc(whole);
    EXPECT_TRUE(q.values.empty());
    EXPECT_EQ(q.errors, std::vector<std::string>{"robot_link_padding: expected a map of link "
                                                 "names to metres, e.g. {panda_hand: 0.02}"});
  }
  XmlRpc::XmlRpcValue empty;
  empty.begin();  // an empty struct, as the parameter server gives {}
  EXPECT_EQ(empty.getType(), XmlRpc::XmlRpcValue::TypeStruct);
  EXPECT_TRUE(linkPaddingFromXmlRpc(empty).values.empty());
  EXPECT_TRUE(linkPaddingFromXmlRpc(empty).errors.empty());
}

// robot_link_groups: a group is a non-empty name of at most kMaxNameLength bytes, as Body.group.
TEST(Params, LinkGroupsEntriesCheckedOneByOne) {
  XmlRpc::XmlRpcValue v;
  v["panda_hand"] = "gripper";
  v["panda_leftfinger"] = "gripper";
  v["number"] = 3;
  v["empty"] = "";
  v["long"] = std::string(kMaxNameLength + 1, 'g');
  const LinkMap<std::string> g = linkGroupsFromXmlRpc(v);
  EXPECT_EQ(g.values, (std::map<std::string, std::string>{{"panda_hand", "gripper"},
                                                          {"panda_leftfinger", "gripper"}}));
  const std::vector<std::string> want = {
      "robot_link_groups['empty']: the group name is empty; the link is in no group",
      "robot_link_groups['long']: " +
          checkLength(std::string(kMaxNameLength + 1, 'g'), kMaxNameLength, "the group name") +
          "; the link is in no group",
      "robot_link_groups['number']: expected a string; the link is in no group"};
  EXPECT_EQ(g.errors, want);
  EXPECT_EQ(linkGroupsFromXmlRpc(XmlRpc::XmlRpcValue("gripper")).errors,
            std::vector<std::string>{
                "robot_link_groups: expected a map of link names to groups, e.g. {panda_hand: "
                "gripper}"});
}

// A part's orientation as a list is [x, y, z, w]; as a map, a missing component is 0. A pair of
// disabled_pairs is two names, no more; a number type beyond 255 is named as given.
TEST(Params, OrientationListsMapsPairsAndTypeNumbers) {
  XmlRpc::XmlRpcValue b;
  b["id"] = "flipped";
  b["frame_id"] = "world";
  XmlRpc::XmlRpcValue part;
  part["type"] = "sphere";
  part["dimensions"][0] = 0.1;
  part["pose"]["orientation"][0] = 1.0;  // x: half a turn about x
  part["pose"]["orientation"][1] = 0.0;
  part["pose"]["orientation"][2] = 0.0;
  part["pose"]["orientation"][3] = 0.0;
  b["parts"][0] = part;
  part["pose"]["orientation"] = XmlRpc::XmlRpcValue();
  part["pose"]["orientation"]["z"] = 1.0;  // half a turn about z, w left out
  b["parts"][1] = part;
  auto msg = bodyFromXmlRpc(b);
  ASSERT_TRUE(msg) << msg.error();
  ASSERT_EQ(msg->parts.size(), 2u);
  EXPECT_EQ(msg->parts[0].pose.orientation.x, 1.0);
  EXPECT_EQ(msg->parts[0].pose.orientation.w, 0.0);
  EXPECT_EQ(msg->parts[1].pose.orientation.z, 1.0);
  EXPECT_EQ(msg->parts[1].pose.orientation.w, 0.0);

  XmlRpc::XmlRpcValue big = b;
  big["parts"][0]["type"] = 256;
  EXPECT_EQ(bodyFromXmlRpc(big).error(), "parts[0].type: unknown shape type 256");

  XmlRpc::XmlRpcValue pairs;
  pairs[0][0] = "a";
  pairs[0][1] = "b";
  pairs[0][2] = "c";
  EXPECT_EQ(pairsFromXmlRpc(pairs).error(), "disabled_pairs[0]: expected [a, b]");
}

// operation "add" (lower case) is ADD, as "ADD" and 0 are; a position given as a map leaves the
// coordinates it does not name at 0.
TEST(Params, LowerCaseAddAndPositionMaps) {
  XmlRpc::XmlRpcValue b;
  b["id"] = "shelf";
  b["frame_id"] = "world";
  b["operation"] = "add";
  XmlRpc::XmlRpcValue part;
  part["type"] = "sphere";
  part["dimensions"][0] = 0.1;
  part["pose"]["position"]["y"] = 0.5;
  b["parts"][0] = part;
  auto msg = bodyFromXmlRpc(b);
  ASSERT_TRUE(msg) << msg.error();
  EXPECT_EQ(msg->operation, collision_monitor::Body::ADD);
  ASSERT_EQ(msg->parts.size(), 1u);
  EXPECT_EQ(msg->parts[0].pose.position.x, 0.0);
  EXPECT_EQ(msg->parts[0].pose.position.y, 0.5);
  EXPECT_EQ(msg->parts[0].pose.position.z, 0.0);
}

// --- mesh URIs ------------------------------------------------------------------------------

class MeshUris : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/cm_mesh_uris_XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    ::mkdir((dir_ + "/root").c_str(), 0755);
    ::mkdir((dir_ + "/pkg").c_str(), 0755);
    ::mkdir((dir_ + "/outside").c_str(), 0755);
    std::ofstream(dir_ + "/root/ok.stl") << "solid x\nendsolid x\n";
    std::ofstream(dir_ + "/pkg/p.stl") << "solid x\nendsolid x\n";
    std::ofstream(dir_ + "/outside/secret.stl") << "solid x\nendsolid x\n";
    ASSERT_EQ(::symlink((dir_ + "/outside/secret.stl").c_str(), (dir_ + "/root/link.stl").c_str()),
              0);
    roots_ = {dir_ + "/root"};
    resolver_ = [this](const std::string& pkg) { return pkg == "pkg" ? dir_ + "/pkg" : ""; };
  }
  void TearDown() override { std::system(("rm -rf " + dir_).c_str()); }
  std::string dir_;
  std::vector<std::string> roots_;
  PackageResolver resolver_;
};

TEST_F(MeshUris, InsideRootsAndPackages) {
  auto a = resolveMeshUri("file://" + dir_ + "/root/ok.stl", roots_, resolver_);
  ASSERT_TRUE(a) << a.error();
  EXPECT_TRUE(contains(*a, "/root/ok.stl"));
  auto b = resolveMeshUri("package://pkg/p.stl", roots_, resolver_);
  ASSERT_TRUE(b) << b.error();
}

TEST_F(MeshUris, RefusesEscapes) {
  EXPECT_TRUE(contains(resolveMeshUri("file:///etc/passwd", roots_, resolver_).error(),
                       "outside mesh_roots"));
  EXPECT_TRUE(
      contains(resolveMeshUri("file:///etc/passwd", {}, resolver_).error(), "none configured"));
  EXPECT_TRUE(contains(
      resolveMeshUri("file://" + dir_ + "/root/../outside/secret.stl", roots_, resolver_).error(),
      "outside mesh_roots"));
  EXPECT_TRUE(
      contains(resolveMeshUri("file://" + dir_ + "/root/link.stl", roots_, resolver_).error(),
               "outside mesh_roots"));
  EXPECT_TRUE(contains(
      resolveMeshUri("package://pkg/../outside/secret.stl", roots_, resolver_).error(), "outside"));
  EXPECT_TRUE(contains(resolveMeshUri("package://nope/x.stl", roots_, resolver_).error(),
                       "unknown package"));
  EXPECT_TRUE(contains(resolveMeshUri("http://example.com/x.stl", roots_, resolver_).error(),
                       "unsupported"));
  EXPECT_TRUE(contains(resolveMeshUri("/etc/passwd", roots_, resolver_).error(), "unsupported"));
  EXPECT_TRUE(
      contains(resolveMeshUri("file://" + dir_ + "/root/missing.stl", roots_, resolver_).error(),
               "cannot resolve"));
  EXPECT_TRUE(contains(resolveMeshUri("file://" + dir_ + "/root", {dir_}, resolver_).error(),
                       "not a regular file"));
  // The root itself: not a file (it was "outside mesh_roots").
  EXPECT_TRUE(contains(resolveMeshUri("file://" + dir_ + "/root", roots_, resolver_).error(),
                       "not a regular file"));
  // A root that is a prefix of another directory's name does not cover it (the file exists, so
  // it is the roots' check that refuses it).
  std::ofstream(dir_ + "/rootless.stl") << "solid x\nendsolid x\n";
  EXPECT_TRUE(contains(
      resolveMeshUri("file://" + dir_ + "/rootless.stl", {dir_ + "/root"}, resolver_).error(),
      "outside mesh_roots"));
}

// rospack printed two lines on stderr for every lookup of a package it does not find: 31 pairs
// for the PR2 with its mesh package missing. The cache asks for a missing package once.
TEST_F(MeshUris, AMissingPackageIsAskedOnce) {
  std::vector<std::string> asked;
  MeshCache cache(roots_, 1000, [&asked, this](const std::string& pkg) {
    asked.push_back(pkg);
    return resolver_(pkg);
  });
  for (const char* uri : {"package://gone/a.stl", "package://gone/b.stl", "package://pkg/x.stl",
                          "package://pkg/y.stl", "package://gone/c.stl"}) {
    auto r = cache.load(uri, core::Vec3(1, 1, 1));
    ASSERT_FALSE(r) << uri;  // neither x.stl nor y.stl exists
    EXPECT_EQ(contains(r.error(), "unknown package 'gone' (not on ROS_PACKAGE_PATH)"),
              std::string(uri).find("gone") != std::string::npos)
        << r.error();
  }
  EXPECT_EQ(asked, (std::vector<std::string>{"gone", "pkg", "pkg"}));
}

TEST_F(MeshUris, UnreadableMeshIsRefused) {
  std::ofstream(dir_ + "/root/garbage.stl") << "this is not a mesh";
  MeshCache cache(roots_, 1000, resolver_);
  auto r = cache.load("file://" + dir_ + "/root/garbage.stl", core::Vec3(1, 1, 1));
  ASSERT_FALSE(r);
  EXPECT_TRUE(contains(r.error(), "not a readable STL/DAE/OBJ mesh")) << r.error();
}

// Bug: a mesh whose vertices all coincide was accepted as a point, where a CONVEX part like it
// is refused.
TEST_F(MeshUris, MeshOfOnePointIsRefused) {
  std::ofstream(dir_ + "/root/point.stl") << "solid p\n"
                                             "facet normal 0 0 0\nouter loop\nvertex 1 2 3\n"
                                             "vertex 1 2 3\nvertex 1 2 3\nendloop\nendfacet\n"
                                             "endsolid p\n";
  MeshCache cache(roots_, 1000, resolver_);
  auto r = cache.load("file://" + dir_ + "/root/point.stl", core::Vec3(1, 1, 1));
  ASSERT_FALSE(r);
  EXPECT_TRUE(contains(r.error(), "every vertex coincides")) << r.error();
}

/// A tetrahedron (0,0,0), (k,0,0), (0,k,0), (0,0,k) as an ASCII STL.
std::string tetStl(double k) {
  const std::string a = "0 0 0", b = std::to_string(k) + " 0 0",
                    c = "0 " + std::to_string(k) + " 0", d = "0 0 " + std::to_string(k);
  std::string out = "solid t\n";
  for (const auto& f : {std::array<std::string, 3>{a, b, c}, {a, c, d}, {a, d, b}, {b, d, c}}) {
    out += "facet normal 0 0 0\nouter loop\nvertex " + f[0] + "\nvertex " + f[1] + "\nvertex " +
           f[2] + "\nendloop\nendfacet\n";
  }
  return out + "endsolid t\n";
}

// The path of a URI is read as libcurl read it for resource_retriever (and rviz): %XX decoded. The
// node checked the literal path and curl loaded the decoded one: "m%41.stl" was checked and
// "mA.stl" loaded, "root/%2E%2E/x" passed the roots' check and read outside them, and
// "hash#1.stl" loaded the file "hash". Now what is checked is what is read, by the node itself.
TEST_F(MeshUris, PercentEncodingIsDecodedBeforeTheCheckAndQueriesAreRefused) {
  std::ofstream(dir_ + "/root/mA.stl") << tetStl(1);
  std::ofstream(dir_ + "/root/m%41.stl") << tetStl(2);
  std::ofstream(dir_ + "/root/with space.stl") << tetStl(4);
  std::ofstream(dir_ + "/root/hash#1.stl") << tetStl(8);
  std::ofstream(dir_ + "/root/hash") << tetStl(16);
  std::ofstream(dir_ + "/root/100%.stl") << tetStl(32);
  MeshCache cache(roots_, 1000, resolver_);
  const auto size = [&](const std::string& name) -> double {
    auto r = cache.load("file://" + dir_ + "/root/" + name, core::Vec3(1, 1, 1));
    if (!r) return -1;
    return r->front().support(core::Vec3(1, 0.1, 0.1)).x();
  };
  EXPECT_EQ(size("mA.stl"), 1.0);
  EXPECT_EQ(size("m%41.stl"), 1.0);    // mA.stl, checked and read
  EXPECT_EQ(size("m%2541.stl"), 2.0);  // the file named m%41.stl
  EXPECT_EQ(size("with%20space.stl"), 4.0);
  EXPECT_EQ(size("with space.stl"), 4.0);  // curl refused it
  EXPECT_EQ(size("hash%231.stl"), 8.0);
  EXPECT_EQ(size("100%.stl"), 32.0);  // '%' without two hex digits stays
  EXPECT_EQ(resolveMeshUri("file://" + dir_ + "/root/hash#1.stl", roots_, resolver_).error(),
            "a URI with a query or fragment ('?' or '#') names no mesh file; percent-encode them "
            "in a file name (%3F, %23)");
  EXPECT_TRUE(contains(resolveMeshUri("package://pkg/p.stl?x=1", roots_, resolver_).error(),
                       "query or fragment"));
  EXPECT_TRUE(contains(
      resolveMeshUri("file://" + dir_ + "/root/%2E%2E/outside/secret.stl", roots_, resolver_)
          .error(),
      "outside mesh_roots"));
  EXPECT_TRUE(
      contains(resolveMeshUri("package://pkg/%2E%2E/outside/secret.stl", roots_, resolver_).error(),
               "outside"));
  EXPECT_EQ(resolveMeshUri("file://" + dir_ + "/root/mA.stl%00.x", roots_, resolver_).error(),
            "the URI's path holds a NUL (%00)");
}

// %XX is decoded at the very end of the path too ("t%41" is the file "tA"), as libcurl does; a
// '%' with one hex digit after it stays.
TEST_F(MeshUris, PercentEncodingAtTheEndOfThePath) {
  std::ofstream(dir_ + "/root/tA") << tetStl(1);
  std::ofstream(dir_ + "/root/t%4") << tetStl(1);
  auto a = resolveMeshUri("file://" + dir_ + "/root/t%41", roots_, resolver_);
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->substr(a->size() - 8), "/root/tA");
  auto b = resolveMeshUri("file://" + dir_ + "/root/t%4", roots_, resolver_);
  ASSERT_TRUE(b) << b.error();
  EXPECT_EQ(b->substr(b->size() - 9), "/root/t%4");
}

// mesh_roots "/" covers every file.
TEST_F(MeshUris, RootDirectoryCoversEveryFile) {
  auto a = resolveMeshUri("file://" + dir_ + "/outside/secret.stl", {"/"}, resolver_);
  ASSERT_TRUE(a) << a.error();
  EXPECT_EQ(a->substr(a->size() - 19), "/outside/secret.stl");
}

/// A COLLADA file of one tetrahedron with corners at `k` units, in `unit` (meter attribute;
/// none when empty).
std::string tetDae(int k, const std::string& unit) {
  const std::string n = std::to_string(k);
  return "<?xml version=\"1.0\"?>\n"
         "<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">"
         "<asset>" +
         (unit.empty() ? "" : "<unit name=\"u\" meter=\"" + unit + "\"/>") +
         "<up_axis>Z_UP</up_axis></asset><library_geometries><geometry id=\"g\"><mesh>"
         "<source id=\"p\"><float_array id=\"a\" count=\"12\">0 0 0 " +
         n + " 0 0 0 " + n + " 0 0 0 " + n +
         "</float_array><technique_common><accessor source=\"#a\" count=\"4\" stride=\"3\">"
         "<param name=\"X\" type=\"float\"/><param name=\"Y\" type=\"float\"/>"
         "<param name=\"Z\" type=\"float\"/></accessor></technique_common></source>"
         "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#p\"/></vertices>"
         "<triangles count=\"4\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>"
         "<p>0 2 1 0 3 2 0 1 3 1 2 3</p></triangles></mesh></geometry></library_geometries>"
         "<library_visual_scenes><visual_scene id=\"s\"><node id=\"n\"><instance_geometry "
         "url=\"#g\"/></node></visual_scene></library_visual_scenes>"
         "<scene><instance_visual_scene url=\"#s\"/></scene></COLLADA>\n";
}

// COLLADA's <unit meter>: assimp puts it in the root transform, which geometric_shapes drops; a
// mesh in centimetres was 100 times too large (a robot in collision for good). As rviz does, it
// is applied; a unit that is no length is refused.
TEST_F(MeshUris, ColladaUnitIsApplied) {
  std::ofstream(dir_ + "/root/cm.dae") << tetDae(10, "0.01");
  std::ofstream(dir_ + "/root/quarter.DAE") << tetDae(4, "0.25");
  std::ofstream(dir_ + "/root/none.dae") << tetDae(2, "");
  std::ofstream(dir_ + "/root/zero.dae") << tetDae(2, "0");
  std::ofstream(dir_ + "/root/word.dae") << tetDae(2, "inch");
  MeshCache cache(roots_, 1000, resolver_);
  const auto load = [&](const std::string& name, double scale) {
    return cache.load("file://" + dir_ + "/root/" + name, core::Vec3(scale, 1, 1));
  };
  auto cm = load("cm.dae", 1.0);
  ASSERT_TRUE(cm) << cm.error();
  EXPECT_NEAR(cm->front().support(core::Vec3(1, 0.1, 0.1)).x(), 0.1, 1e-15);
  auto quarter = load("quarter.DAE", -2.0);  // with the URDF's scale, mirrored
  ASSERT_TRUE(quarter) << quarter.error();
  EXPECT_EQ(quarter->front().support(core::Vec3(-1, 0.1, 0.1)), core::Vec3(-2, 0, 0));
  EXPECT_EQ(quarter->front().support(core::Vec3(0.1, 0.1, 1)), core::Vec3(0, 0, 1));
  auto none = load("none.dae", 1.0);
  ASSERT_TRUE(none) << none.error();
  EXPECT_EQ(none->front().support(core::Vec3(0.1, 1, 0.1)), core::Vec3(0, 2, 0));
  EXPECT_TRUE(contains(load("zero.dae", 1.0).error(),
                       "zero.dae: COLLADA <unit meter='0'> is not a number of metres > 0"))
      << load("zero.dae", 1.0).error();
  EXPECT_TRUE(contains(load("word.dae", 1.0).error(), "<unit meter='inch'>"));
}

// Vertices on no triangle (an OBJ's lines and points) are not the surface: an OBJ line 2 m away
// stretched the hull to it. In `pieces` mode the mesh could then never be split.
TEST_F(MeshUris, VerticesOnNoTriangleAreLeftOut) {
  std::ofstream(dir_ + "/root/line.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nv 3 0 0\n"
                                            "f 1 3 2\nf 1 4 3\nf 1 2 4\nf 2 3 4\nl 2 5\n";
  for (const auto mode : {MeshDecomposition::Hull, MeshDecomposition::Pieces}) {
    auto r = loadMeshParts(dir_ + "/root/line.obj", core::Vec3(1, 1, 1), 1000, mode);
    ASSERT_TRUE(r) << r.error();
    ASSERT_EQ(r->parts.size(), 1u);
    EXPECT_EQ(r->note, "");
    EXPECT_EQ(r->parts[0].support(core::Vec3(1, 0.1, 0.1)), core::Vec3(1, 0, 0));
  }
  std::ofstream(dir_ + "/root/points.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n";
  EXPECT_TRUE(contains(loadMeshParts(dir_ + "/root/points.obj", core::Vec3(1, 1, 1), 1000).error(),
                       "or one without triangles"))
      << loadMeshParts(dir_ + "/root/points.obj", core::Vec3(1, 1, 1), 1000).error();
}

// Bug: the cache kept every (mesh, scale) ever loaded: a stream of bodies with ever new scales
// grew it without bound. It now starts again empty past kMaxEntries; loads stay exact.
TEST_F(MeshUris, CacheIsBounded) {
  std::ofstream(dir_ + "/root/tet.stl") << "solid t\n"
                                           "facet normal 0 0 0\nouter loop\nvertex 0 0 0\n"
                                           "vertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n"
                                           "facet normal 0 0 0\nouter loop\nvertex 0 0 0\n"
                                           "vertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\n"
                                           "facet normal 0 0 0\nouter loop\nvertex 0 0 0\n"
                                           "vertex 0 0 1\nvertex 1 0 0\nendloop\nendfacet\n"
                                           "facet normal 0 0 0\nouter loop\nvertex 1 0 0\n"
                                           "vertex 0 0 1\nvertex 0 1 0\nendloop\nendfacet\n"
                                           "endsolid t\n";
  MeshCache cache(roots_, 1000, resolver_);
  const std::string uri = "file://" + dir_ + "/root/tet.stl";
  for (int i = 0; i < 300; ++i) {
    const double k = 1.0 + 0.125 * i;  // exact in binary
    auto r = cache.load(uri, core::Vec3(k, 2.0 * k, 4.0 * k));
    ASSERT_TRUE(r) << r.error();
    ASSERT_EQ(r->size(), 1u);
    EXPECT_EQ(r->front().support(core::Vec3(1, 0.1, 0.1)), core::Vec3(k, 0, 0));
    EXPECT_EQ(r->front().support(core::Vec3(0.1, 0.1, 1)), core::Vec3(0, 0, 4.0 * k));
    ASSERT_LE(cache.size(), MeshCache::kMaxEntries);
  }
  EXPECT_EQ(cache.size(), 300 - MeshCache::kMaxEntries);
}
