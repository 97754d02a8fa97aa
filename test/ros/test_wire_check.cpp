// Plain gtests (no master) of the hostile-input defences of the ROS layer:
// - the layout walkers behind Checked<M> (wire_check.h): valid messages of every shape type pass
//   and round-trip, every truncated prefix is refused, a tiny message claiming 2^31 entries is
//   refused without allocating (measured with a counting global operator new);
// - the length limits and bounded quoting of input strings in error messages (conversions.h).
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <ros/serialization.h>

#include "collision_monitor/ros/conversions.h"
#include "collision_monitor/ros/mesh_loader.h"
#include "collision_monitor/ros/wire_check.h"

// ---------------------------------------------------------------------------------------------
// Allocation accounting: the largest single allocation while `g_track` is set.

namespace {
std::atomic<bool> g_track{false};
std::atomic<std::size_t> g_largest{0};
std::atomic<std::size_t> g_total{0};

void note(std::size_t n) {
  if (!g_track.load(std::memory_order_relaxed)) return;
  g_total += n;
  std::size_t prev = g_largest.load();
  while (n > prev && !g_largest.compare_exchange_weak(prev, n)) {
  }
}

void* allocate(std::size_t n) {
  note(n);
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}

/// Largest allocation and total bytes allocated while `f` runs.
template <class F>
std::pair<std::size_t, std::size_t> allocations(F&& f) {
  g_largest = 0;
  g_total = 0;
  g_track = true;
  f();
  g_track = false;
  return {g_largest.load(), g_total.load()};
}
}  // namespace

void* operator new(std::size_t n) {
  return allocate(n);
}
void* operator new[](std::size_t n) {
  return allocate(n);
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}

using namespace collision_monitor;
using namespace collision_monitor::ros_layer;

namespace {

using Bytes = std::vector<std::uint8_t>;

template <class M>
Bytes serialize(const M& m) {
  Bytes out(ros::serialization::serializationLength(m));
  ros::serialization::OStream s(out.data(), static_cast<std::uint32_t>(out.size()));
  ros::serialization::serialize(s, m);
  return out;
}

/// Deserializes `bytes` (any prefix length) as Checked<M>; must never throw.
template <class M>
Checked<M> readChecked(const Bytes& bytes, std::size_t size) {
  Checked<M> m;
  ros::serialization::IStream s(const_cast<std::uint8_t*>(bytes.data()),
                                static_cast<std::uint32_t>(size));
  ros::serialization::deserialize(s, m);
  return m;
}

geometry_msgs::Point point(double x, double y, double z) {
  geometry_msgs::Point p;
  p.x = x;
  p.y = y;
  p.z = z;
  return p;
}

collision_monitor::Shape shape(std::uint8_t type, std::vector<double> dims) {
  collision_monitor::Shape s;
  s.type = type;
  s.dimensions = std::move(dims);
  s.pose.orientation.w = 1.0;
  s.pose.position.x = 0.25;
  return s;
}

/// A Body with one part of every shape type and every field set.
collision_monitor::Body everyShape() {
  collision_monitor::Body b;
  b.header.seq = 7;
  b.header.stamp = ros::Time(12, 34);
  b.header.frame_id = "frame_a";
  b.id = "every_shape";
  b.group = "tools";
  b.padding = 0.01;
  b.pose_from_topic = true;
  b.pose_topic = "/tracker/pose";
  using S = collision_monitor::Shape;
  b.parts = {shape(S::SPHERE, {0.1}),        shape(S::BOX, {0.1, 0.2, 0.3}),
             shape(S::CYLINDER, {0.4, 0.1}), shape(S::CONE, {0.4, 0.1}),
             shape(S::CAPSULE, {0.3, 0.05}), shape(S::ELLIPSOID, {0.1, 0.2, 0.3}),
             shape(S::CONVEX, {}),           shape(S::MESH, {})};
  b.parts[6].vertices = {point(0, 0, 0), point(1, 0, 0), point(0, 1, 0), point(0, 0, 1)};
  b.parts[6].scale.x = b.parts[6].scale.y = b.parts[6].scale.z = 2.0;
  b.parts[7].resource = "package://collision_monitor/meshes/part.stl";
  return b;
}

collision_monitor::BodyPoses somePoses(bool twists) {
  collision_monitor::BodyPoses m;
  m.header.frame_id = "world";
  m.ids = {"a", "bb", "", "dddd"};
  m.poses.resize(4);
  for (std::size_t i = 0; i < 4; ++i) {
    m.poses[i].position.x = static_cast<double>(i);
    m.poses[i].orientation.w = 1.0;
  }
  if (twists) {
    m.twists.resize(4);
    m.twists[1].linear.x = 0.5;
  }
  return m;
}

collision_monitor::CheckCollisionRequest someRequest() {
  collision_monitor::CheckCollisionRequest r;
  r.body = everyShape();
  r.pose.orientation.w = 1.0;
  r.margin = 0.2;
  return r;
}

/// A Body "raw" in "world" of one sphere (radius 0.1): the smallest layout the tests corrupt.
collision_monitor::Body oneSphereBody() {
  collision_monitor::Body b;
  b.header.frame_id = "world";
  b.id = "raw";
  b.parts = {shape(collision_monitor::Shape::SPHERE, {0.1})};
  return b;
}

/// Offset of parts[0].dimensions' length prefix in a serialized Body (header, id, operation,
/// group and the parts count before it, then the part's type byte).
std::size_t dimensionsPrefixOffset(const collision_monitor::Body& b) {
  return 12 + 4 + b.header.frame_id.size() + 4 + b.id.size() + 1 + 4 + b.group.size() + 4 + 1;
}

void putU32(Bytes* bytes, std::size_t offset, std::uint32_t v) {
  std::memcpy(bytes->data() + offset, &v, 4);
}

template <class M>
void expectRoundTrip(const M& msg, bool (*check)(const std::uint8_t*, std::size_t, std::string*)) {
  const Bytes bytes = serialize(msg);
  std::string why;
  EXPECT_TRUE(check(bytes.data(), bytes.size(), &why)) << why;
  const Checked<M> back = readChecked<M>(bytes, bytes.size());
  EXPECT_TRUE(back.refused.empty()) << back.refused;
  EXPECT_EQ(back.wire_size, bytes.size());
  EXPECT_EQ(serialize(static_cast<const M&>(back)), bytes);
  // Trailing bytes are ignored, as roscpp does.
  Bytes longer = bytes;
  longer.insert(longer.end(), {1, 2, 3});
  EXPECT_TRUE(check(longer.data(), longer.size(), &why)) << why;
}

template <class M>
void expectEveryPrefixRefused(const M& msg,
                              bool (*check)(const std::uint8_t*, std::size_t, std::string*)) {
  const Bytes bytes = serialize(msg);
  ASSERT_GT(bytes.size(), 0u);
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    std::string why;
    EXPECT_FALSE(check(bytes.data(), n, &why)) << "prefix of " << n << " bytes accepted";
    EXPECT_NE(why.find("malformed message (" + std::to_string(n) + " bytes)"), std::string::npos)
        << why;
    Checked<M> m;
    EXPECT_NO_THROW(m = readChecked<M>(bytes, n));
    EXPECT_FALSE(m.refused.empty());
  }
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Layout walkers

TEST(WireCheck, ValidMessagesPassAndRoundTrip) {
  expectRoundTrip(everyShape(), &checkBodyLayout);
  expectRoundTrip(collision_monitor::Body(), &checkBodyLayout);  // every array empty
  for (std::uint8_t type = 0; type <= 9; ++type) {  // one part of each type, unknown ones too
    collision_monitor::Body b = everyShape();
    b.parts = {shape(type, {1.0, 2.0})};
    expectRoundTrip(b, &checkBodyLayout);
  }
  expectRoundTrip(somePoses(false), &checkBodyPosesLayout);
  expectRoundTrip(somePoses(true), &checkBodyPosesLayout);
  expectRoundTrip(collision_monitor::BodyPoses(), &checkBodyPosesLayout);
  expectRoundTrip(someRequest(), &checkCheckCollisionRequestLayout);
}

TEST(WireCheck, EveryTruncatedPrefixIsRefused) {
  expectEveryPrefixRefused(everyShape(), &checkBodyLayout);
  expectEveryPrefixRefused(somePoses(true), &checkBodyPosesLayout);
  expectEveryPrefixRefused(someRequest(), &checkCheckCollisionRequestLayout);
}

TEST(WireCheck, HugeClaimsAreRefusedWithoutAllocating) {
  const collision_monitor::Body b = oneSphereBody();
  const Bytes good = serialize(b);
  const std::size_t dims = dimensionsPrefixOffset(b);
  ASSERT_EQ(good[dims - 1], collision_monitor::Shape::SPHERE);
  std::uint32_t one = 0;
  std::memcpy(&one, good.data() + dims, 4);
  ASSERT_EQ(one, 1u);

  for (std::uint32_t claim : {2u, 1u << 25, 0x7FFFFFFFu, 0x80000000u, 0xFFFFFFFFu}) {
    Bytes bad = good;
    putU32(&bad, dims, claim);
    std::string why;
    EXPECT_FALSE(checkBodyLayout(bad.data(), bad.size(), &why));
    if (claim > 2) {  // 2 fits the bytes left: the walk fails further on, at the end
      EXPECT_TRUE(contains(why, "parts[0].dimensions claims " + std::to_string(claim))) << why;
    }
    Checked<collision_monitor::Body> m;
    const auto [largest, total] =
        allocations([&] { m = readChecked<collision_monitor::Body>(bad, bad.size()); });
    EXPECT_FALSE(m.refused.empty());
    EXPECT_TRUE(m.parts.empty());
    EXPECT_LT(largest, 4096u) << "claim " << claim;
    EXPECT_LT(total, 16384u) << "claim " << claim;
  }

  // The parts count, and claims inside BodyPoses and the service request.
  {
    Bytes bad = good;
    putU32(&bad, dims - 5, 0xFFFFFFFFu);
    std::string why;
    EXPECT_FALSE(checkBodyLayout(bad.data(), bad.size(), &why));
    EXPECT_TRUE(contains(why, "parts claims 4294967295 entries")) << why;
  }
  {
    const Bytes poses = serialize(somePoses(true));
    const std::size_t ids = 12 + 4 + 5;  // header with "world"
    for (std::size_t offset : {ids, ids + 4 + (4 + 1) + (4 + 2) + 4 + (4 + 4)}) {  // ids, poses
      Bytes bad = poses;
      putU32(&bad, offset, 0x7FFFFFFFu);
      Checked<collision_monitor::BodyPoses> m;
      const auto [largest, total] =
          allocations([&] { m = readChecked<collision_monitor::BodyPoses>(bad, bad.size()); });
      EXPECT_TRUE(contains(m.refused, "claims 2147483647 entries")) << m.refused;
      EXPECT_LT(largest, 4096u);
      (void)total;
    }
  }
  {
    collision_monitor::CheckCollisionRequest r;
    r.body = b;
    Bytes bad = serialize(r);
    putU32(&bad, dims, 0x80000000u);
    Checked<collision_monitor::CheckCollisionRequest> m;
    const auto [largest, total] = allocations(
        [&] { m = readChecked<collision_monitor::CheckCollisionRequest>(bad, bad.size()); });
    EXPECT_TRUE(contains(m.refused, "body.parts[0].dimensions claims 2147483648")) << m.refused;
    EXPECT_LT(largest, 4096u);
    (void)total;
  }
}

// A parts count is checked against the smallest Shape (wire::kShape, 93 bytes) before any part
// is walked: two parts need at least 186 bytes, and a body of one sphere has 114 after the count.
TEST(WireCheck, PartsClaimIsCheckedAgainstTheSmallestShape) {
  const collision_monitor::Body b = oneSphereBody();
  Bytes bad = serialize(b);
  putU32(&bad, dimensionsPrefixOffset(b) - 5, 2);
  std::string why;
  EXPECT_FALSE(checkBodyLayout(bad.data(), bad.size(), &why));
  EXPECT_TRUE(contains(why, "parts claims 2 entries (at least 186 bytes), 114 bytes left")) << why;
}

TEST(WireCheck, PlainRoscppAllocatesWhatTheMessageClaims) {
  // The bug Checked<M> exists for (and proof that the allocation counter sees it): plain
  // deserialization of a 2^20-dimension claim allocates 8 MB before it finds the stream short.
  const collision_monitor::Body b = oneSphereBody();
  Bytes bad = serialize(b);
  putU32(&bad, dimensionsPrefixOffset(b), 1u << 20);
  collision_monitor::Body plain;
  const auto [largest, total] = allocations([&] {
    ros::serialization::IStream s(bad.data(), static_cast<std::uint32_t>(bad.size()));
    EXPECT_THROW(ros::serialization::deserialize(s, plain),
                 ros::serialization::StreamOverrunException);
  });
  EXPECT_GE(largest, 8u << 20);
  (void)total;
}

TEST(WireCheck, MutatedMessagesNeverOverrunOnceAccepted) {
  // Random byte flips of valid messages: whenever the walker accepts, roscpp's own
  // deserialization must succeed (the walker is at least as strict as the reader).
  std::mt19937 rng(0x5eed);
  const Bytes base = serialize(everyShape());
  const Bytes base_poses = serialize(somePoses(true));
  std::size_t accepted = 0;
  for (int i = 0; i < 4000; ++i) {
    const bool poses = i % 2 == 1;
    Bytes bytes = poses ? base_poses : base;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f)
      bytes[rng() % bytes.size()] = static_cast<std::uint8_t>(rng() % 4 == 0 ? 0xFF : rng());
    const std::size_t size = rng() % 8 == 0 ? rng() % bytes.size() : bytes.size();
    std::string why;
    const bool ok = poses ? checkBodyPosesLayout(bytes.data(), size, &why)
                          : checkBodyLayout(bytes.data(), size, &why);
    if (!ok) continue;
    ++accepted;
    ros::serialization::IStream s(bytes.data(), static_cast<std::uint32_t>(size));
    if (poses) {
      collision_monitor::BodyPoses m;
      EXPECT_NO_THROW(ros::serialization::deserialize(s, m));
    } else {
      collision_monitor::Body m;
      EXPECT_NO_THROW(ros::serialization::deserialize(s, m));
    }
  }
  EXPECT_GT(accepted, 100u);
}

// ---------------------------------------------------------------------------------------------
// Length limits and bounded quoting

TEST(InputStrings, QuotedIsBoundedAndOneLine) {
  EXPECT_EQ(quoteInput("abc"), "'abc'");
  EXPECT_EQ(quoteInput(""), "''");
  EXPECT_EQ(quoteInput("a\nb\x01"), "'a\\x0ab\\x01'");
  const std::string huge(100 << 20, 'x');
  const std::string q = quoteInput(huge);
  EXPECT_LT(q.size(), kQuoteLength + 40);
  EXPECT_TRUE(contains(q, "...' (104857600 bytes)")) << q;
  EXPECT_EQ(quoteInput(std::string(kQuoteLength, 'y')), "'" + std::string(kQuoteLength, 'y') + "'");
  EXPECT_TRUE(checkLength("abc", 3, "id").empty());
  const std::string err = checkLength(huge, kMaxNameLength, "body id");
  EXPECT_TRUE(contains(err, "body id is 104857600 bytes, longer than the limit of 256")) << err;
  EXPECT_LT(err.size(), 400u);
}

TEST(InputStrings, BodyNamesAreLimited) {
  const MeshLoader no_meshes;
  Limits limits;
  auto make = [] {
    collision_monitor::Body b;
    b.id = "b";
    b.header.frame_id = "world";
    b.parts = {shape(collision_monitor::Shape::SPHERE, {0.1})};
    return b;
  };
  const std::string at_limit(kMaxNameLength, 'n');
  const std::string over(kMaxNameLength + 1, 'n');
  const std::string mb(1 << 20, 'n');
  for (int field = 0; field < 4; ++field) {
    auto set = [field](collision_monitor::Body* b, const std::string& v) {
      (field == 0   ? b->id
       : field == 1 ? b->header.frame_id
       : field == 2 ? b->group
                    : b->pose_topic) = v;
    };
    collision_monitor::Body ok = make();
    set(&ok, at_limit);
    EXPECT_TRUE(bodyFromMsg(ok, world::BodyOrigin::Topic, limits, no_meshes).ok()) << field;
    for (const std::string* v : {&over, &mb}) {
      collision_monitor::Body bad = make();
      set(&bad, *v);
      auto r = bodyFromMsg(bad, world::BodyOrigin::Topic, limits, no_meshes);
      ASSERT_FALSE(r.ok()) << field;
      EXPECT_TRUE(contains(r.error(), "longer than the limit of 256")) << r.error();
      EXPECT_LT(r.error().size(), 400u);
    }
  }
}

TEST(InputStrings, MeshResourceIsLimitedAndNotEchoed) {
  Limits limits;
  int calls = 0;
  const MeshLoader refuse =
      [&calls](const std::string&, const core::Vec3&) -> Expected<std::vector<core::ConvexShape>> {
    ++calls;
    return Error{"outside mesh_roots"};
  };
  collision_monitor::Shape s = shape(collision_monitor::Shape::MESH, {});
  s.resource = "file:///" + std::string(100 << 20, '.');
  auto r = shapesFromMsg(s, limits, refuse);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(calls, 0);  // refused before the loader runs
  EXPECT_TRUE(
      contains(r.error(), "mesh resource is 104857608 bytes, longer than the limit of 4096"))
      << r.error().substr(0, 300);
  EXPECT_LT(r.error().size(), 400u);
  s.resource = "file:///" + std::string(kMaxResourceLength - 8, 'a');
  r = shapesFromMsg(s, limits, refuse);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(calls, 1);
  EXPECT_LT(r.error().size(), 400u) << r.error();
  EXPECT_TRUE(contains(r.error(), "outside mesh_roots"));
}

TEST(InputStrings, BodyPosesNamesAreLimited) {
  collision_monitor::BodyPoses m = somePoses(false);
  m.ids[2] = "c";
  ASSERT_TRUE(posesFromMsg(m).ok()) << posesFromMsg(m).error();
  m.ids[1] = std::string(1 << 20, 'i');
  auto r = posesFromMsg(m);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error(), "ids[1] is 1048576 bytes")) << r.error().substr(0, 300);
  EXPECT_LT(r.error().size(), 400u);
  m = somePoses(false);
  m.ids[2] = "c";
  m.ids[3] = "a";  // repeated: quoted
  EXPECT_TRUE(contains(posesFromMsg(m).error(), "id 'a' appears twice"));
  m.ids[3] = "d";
  m.header.frame_id = std::string(kMaxNameLength + 1, 'f');
  r = posesFromMsg(m);
  ASSERT_FALSE(r.ok());
  EXPECT_TRUE(contains(r.error(), "header.frame_id is 257 bytes")) << r.error();
}

TEST(InputStrings, MeshVertexCountIsCheckedBeforeHulling) {
  const std::string path = std::string(CM_SOURCE_DIR) + "/meshes/gripper.stl";
  auto hull = loadMeshParts(path, core::Vec3(1, 1, 1), 100000);
  ASSERT_TRUE(hull.ok()) << hull.error();
  auto r = loadMeshParts(path, core::Vec3(1, 1, 1), 3);
  ASSERT_FALSE(r.ok());
  // The mesh's own count, not its hull's: refused before hulling.
  EXPECT_TRUE(contains(r.error(), "vertices, more than max_vertices_per_part 3")) << r.error();
  EXPECT_FALSE(contains(r.error(), "convex hull")) << r.error();
}
