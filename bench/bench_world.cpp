/// \file
/// Node-level benchmark: one world update + check cycle of the monitor (world::WorldModel:
/// setPose for what moved, then check(now)) against the same scene through FCL 0.7's
/// DynamicAABBTreeCollisionManager (a MoveIt-style pipeline: setTransform + computeAABB of the
/// moved objects, update the manager, then a self-distance traversal whose callback computes
/// fcl::distance with signed distance for every pair of objects within reach).
///
/// Scene (fixed seeds, identical for both pipelines): the Franka Panda's links 1..7 (the
/// capsules of panda_collision.urdf: each <cylinder> with its two end <sphere>s is exactly one
/// capsule; links 5 and 7 have two), driven by forward kinematics along a smooth joint-space
/// trajectory (the tip moves ~1 m/s, ~4 mm per cycle of 4 ms); the links form one group (no
/// self-collision checks, as adjacent-link ACM entries would). n obstacles (spheres, boxes,
/// 16-point convex hulls, 3 to 10 cm bounding radius) sit on a jittered 0.3 m grid at constant
/// density, in the cells nearest to the shoulder outside a 0.75 m free sphere (70 % of the
/// cells used), so the arm reaches into the obstacle shell at every n and larger n adds
/// obstacles further out. At rest neighbouring obstacles are >= 2.4 cm apart; each oscillates
/// (+-2 cm, +-10 degrees) around its home, so obstacle pairs enter and leave warning distance
/// (and, rarely, contact).
///
/// Benchmarks, one cycle per iteration (median time per cycle):
///   BM_Cycle/<lib>/n<N>      arm moves every cycle, 10 % of the obstacles move per cycle
///                            (obstacle i moves when (cycle + i) % 10 == 0);
///   BM_CycleAll/<lib>/n<N>   arm and every obstacle move every cycle;
///   BM_Cycle/ours_aligned/n<N>  BM_Cycle with align_poses (the node's default): each arm-obstacle
///                            pair at the obstacle's older stamp, the arm taken back along its
///                            poses (the other rows check each body at its latest pose, as FCL);
///   BM_TimeToCollision/ours/<motion>  one pair in warning reach (a 0.4 x 0.3 x 0.2 m box on a
///                            2 m lever, a cylinder 2 m away), posed anew and checked each
///                            iteration: the cost of time_to_collision (conservative advancement)
///                            with no twist, one translating towards the cylinder, one spinning
///                            towards it cylinder (contact after 1.39 s) and away (round
///                            again, 4.54 s);
/// lib: ours (WorldModel, default Settings: warning 0.05 m, contact 0, hysteresis 5 mm, GJK),
/// fcl (DynamicAABBTreeCollisionManager<double>; update(moved) resp. update() for all moving;
/// distance() with a callback that keeps the traversal's pruning distance at warning +
/// hysteresis, skips pairs of one body or of the arm group, checks the objects' AABB distance
/// and runs fcl::distance (libccd GJK/EPA, enable_signed_distance, nearest points) on the rest,
/// keeping the per-body-pair minimum).
/// N = 10, 100, 1000, 10000 obstacles (plus the 7 links). Counters per cycle: broad-phase pairs,
/// narrow-phase pair checks, pairs within warning distance.
///
/// Correctness (outside the timed loops, every run unless --cm_no_check): for each N, fresh
/// instances of both pipelines run 40 cycles of each variant from the same start; every cycle
/// the set of body pairs with signed distance < warning_distance must be identical (pairs
/// within kBand of the threshold by either library are counted but not failed), and the
/// distances of pairs both report are compared. A failure prints CORRECTNESS FAILED, sets the
/// JSON context cm_correctness and the exit status 1.
///
/// Extra flags (before Google Benchmark's own):
///   --cm_sizes=10,1000   only these obstacle counts
///   --cm_no_check        skip the correctness pass
/// Reproduce: see docs/benchmarks.md ("World cycle and latency").

#include <benchmark/benchmark.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "collision_monitor/core/convex_hull.h"
#include "collision_monitor/core/convex_shape.h"
#include "collision_monitor/core/math.h"
#include "collision_monitor/world/world_model.h"

#ifdef CM_BENCH_HAVE_FCL
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/capsule.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/distance.h>

#include "fcl_common.h"
#endif

namespace cm_bench_world {
namespace {

namespace core = collision_monitor::core;
namespace world = collision_monitor::world;
using core::Transform3;
using core::Vec3;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDt = 0.004;        ///< s per cycle (250 Hz)
constexpr double kCell = 0.3;        ///< m, obstacle grid
constexpr double kFreeRadius = 0.6;  ///< m, no obstacle centre this close to the shoulder
constexpr double kOccupancy = 0.7;   ///< share of the grid cells used
constexpr int kRing = 32;            ///< poses per obstacle oscillation
constexpr int kArmLinks = 7;
constexpr int kCheckCycles = 2500;      ///< 10 s of motion (n <= 1000)
constexpr int kCheckCyclesLarge = 250;  ///< n = 10000 (FCL needs ~30 ms per cycle there)
/// Pairs whose distance is within this of warning_distance (by the library that reports them)
/// may legitimately fall on either side (FCL's GJK stops at 1e-6 m progress per iteration).
constexpr double kBand = 1e-3;

// ---- scene ------------------------------------------------------------------------------------

enum class Kind { Sphere, Box, Hull, Capsule };

struct PartDesc {
  Kind kind = Kind::Sphere;
  double radius = 0.0;        ///< sphere, capsule
  double length = 0.0;        ///< capsule segment length (z)
  Vec3 sides = Vec3::Zero();  ///< box
  std::shared_ptr<const core::Polytope<3>> hull;
  std::vector<std::array<int, 3>> triangles;
  Transform3 pose = Transform3::Identity();  ///< part -> body
  core::ConvexShape shape = core::ConvexShape::sphere(0.0);
};

struct BodyDesc {
  std::string id;
  std::string group;
  std::vector<PartDesc> parts;
};

Transform3 rpyXyz(double r, double p, double y, const Vec3& t) {
  Transform3 T;
  T.R = (Eigen::AngleAxisd(y, Vec3::UnitZ()) * Eigen::AngleAxisd(p, Vec3::UnitY()) *
         Eigen::AngleAxisd(r, Vec3::UnitX()))
            .toRotationMatrix();
  T.t = t;
  return T;
}

PartDesc capsule(double length, double radius, const Transform3& pose) {
  PartDesc p;
  p.kind = Kind::Capsule;
  p.length = length;
  p.radius = radius;
  p.pose = pose;
  p.shape = core::ConvexShape::capsule(length, radius);
  return p;
}

/// Franka Panda links 1..7 (panda_collision.urdf) and its joint origins.
struct Panda {
  std::vector<Transform3> joint_origin;  ///< parent link -> joint frame (before the rotation)
  std::vector<BodyDesc> links;

  Panda() {
    const double h = kPi / 2;
    joint_origin = {rpyXyz(0, 0, 0, Vec3(0, 0, 0.333)),        rpyXyz(-h, 0, 0, Vec3(0, 0, 0)),
                    rpyXyz(h, 0, 0, Vec3(0, -0.316, 0)),       rpyXyz(h, 0, 0, Vec3(0.0825, 0, 0)),
                    rpyXyz(-h, 0, 0, Vec3(-0.0825, 0.384, 0)), rpyXyz(h, 0, 0, Vec3(0, 0, 0)),
                    rpyXyz(h, 0, 0, Vec3(0.088, 0, 0))};
    const auto at = [](double x, double y, double z) { return rpyXyz(0, 0, 0, Vec3(x, y, z)); };
    std::vector<std::vector<PartDesc>> parts = {
        {capsule(0.283, 0.09, at(0, 0, -0.1915))},
        {capsule(0.12, 0.09, at(0, 0, 0))},
        {capsule(0.15, 0.09, at(0, 0, -0.145))},
        {capsule(0.12, 0.09, at(0, 0, 0))},
        {capsule(0.1, 0.09, at(0, 0, -0.26)),
         capsule(0.14, 0.055, rpyXyz(0, 0, 0.08, Vec3(0, 0.08, -0.13)))},
        {capsule(0.08, 0.08, at(0, 0, -0.03))},
        {capsule(0.14, 0.07, at(0, 0, 0.01)),
         capsule(0.01, 0.045, rpyXyz(1.57, 0, -0.785, Vec3(0.04, 0.04, 0.09)))}};
    for (int i = 0; i < kArmLinks; ++i) {
      BodyDesc b;
      b.id = "panda_link" + std::to_string(i + 1);
      b.group = "arm";
      b.parts = parts[i];
      links.push_back(std::move(b));
    }
  }

  /// Joint angles at time t (s): a smooth sweep inside the joint limits.
  static void joints(double t, double q[kArmLinks]) {
    q[0] = 1.5 * std::sin(0.8 * t);
    q[1] = 0.3 + 0.6 * std::sin(0.6 * t + 1.0);
    q[2] = 0.5 * std::sin(0.9 * t);
    q[3] = -1.6 + 0.8 * std::sin(0.7 * t + 0.5);
    q[4] = 0.8 * std::sin(1.1 * t);
    q[5] = 1.6 + 0.8 * std::sin(0.9 * t + 2.0);
    q[6] = 0.8 * std::sin(1.3 * t);
  }

  /// Link poses (link frame -> world; the base link0 frame is the world) at time t.
  void fk(double t, Transform3 out[kArmLinks]) const {
    double q[kArmLinks];
    joints(t, q);
    Transform3 T = Transform3::Identity();
    for (int i = 0; i < kArmLinks; ++i) {
      Transform3 J;
      J.R = Eigen::AngleAxisd(q[i], Vec3::UnitZ()).toRotationMatrix();
      T = T * joint_origin[i] * J;
      out[i] = T;
    }
  }
};

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : gen_(seed) {}
  double uniform(double lo, double hi) {
    return std::uniform_real_distribution<double>(lo, hi)(gen_);
  }
  Vec3 unitVector() {
    std::normal_distribution<double> n(0.0, 1.0);
    Vec3 v(n(gen_), n(gen_), n(gen_));
    return v.normalized();
  }
  std::mt19937_64& gen() { return gen_; }

 private:
  std::mt19937_64 gen_;
};

/// The arm plus n obstacles with their pose rings. Body index: 0..6 links, 7.. obstacles.
struct Scene {
  int n = 0;
  Panda panda;
  std::vector<BodyDesc> bodies;
  std::vector<Transform3> ring;  ///< obstacle i, step k: ring[i * kRing + k]

  int size() const { return static_cast<int>(bodies.size()); }

  explicit Scene(int num_obstacles) : n(num_obstacles) {
    bodies = panda.links;
    Rng rng(20261122);
    // Grid cells outside the free sphere, nearest first (ties broken by the cell index).
    const Vec3 shoulder(0, 0, 0.333);
    const int want_cells = static_cast<int>(std::ceil(n / kOccupancy)) + 1;
    int k = 1;
    std::vector<std::pair<double, Vec3>> cells;
    for (;; ++k) {
      cells.clear();
      for (int x = -k; x <= k; ++x)
        for (int y = -k; y <= k; ++y)
          for (int z = -k; z <= k; ++z) {
            const Vec3 c = shoulder + kCell * Vec3(x, y, z);
            const double d = (c - shoulder).norm();
            if (d >= kFreeRadius) cells.emplace_back(d, c);
          }
      // Every cell within radius k * kCell is in the cube: enough once those suffice.
      const double r = k * kCell;
      const auto inside =
          std::count_if(cells.begin(), cells.end(),
                        [r](const std::pair<double, Vec3>& c) { return c.first <= r; });
      if (inside >= want_cells) break;
    }
    std::stable_sort(cells.begin(), cells.end(),
                     [](const std::pair<double, Vec3>& a, const std::pair<double, Vec3>& b) {
                       return a.first < b.first;
                     });
    cells.resize(want_cells);
    std::shuffle(cells.begin(), cells.end(), rng.gen());
    cells.resize(n);

    ring.resize(static_cast<std::size_t>(n) * kRing);
    for (int i = 0; i < n; ++i) {
      BodyDesc b;
      char id[16];
      std::snprintf(id, sizeof id, "o%05d", i);
      b.id = id;
      PartDesc p;
      double bound = 0.0;
      switch (i % 3) {
        case 0:
          p.kind = Kind::Sphere;
          p.radius = rng.uniform(0.03, 0.09);
          p.shape = core::ConvexShape::sphere(p.radius);
          bound = p.radius;
          break;
        case 1:
          p.kind = Kind::Box;
          p.sides =
              Vec3(rng.uniform(0.04, 0.115), rng.uniform(0.04, 0.115), rng.uniform(0.04, 0.115));
          p.shape = core::ConvexShape::box(p.sides);
          bound = 0.5 * p.sides.norm();
          break;
        default: {
          p.kind = Kind::Hull;
          const Vec3 semi(rng.uniform(0.03, 0.09), rng.uniform(0.03, 0.09),
                          rng.uniform(0.03, 0.09));
          std::vector<Vec3> pts;
          for (int v = 0; v < 16; ++v)
            pts.push_back(semi.cwiseProduct(rng.unitVector()));
          p.hull = core::buildConvexHull(pts);
          p.triangles = core::hullTriangles(*p.hull);
          p.shape = core::ConvexShape::polytope(p.hull);
          for (const Vec3& v : p.hull->vertices())
            bound = std::max(bound, v.norm());
          break;
        }
      }
      b.parts.push_back(std::move(p));
      bodies.push_back(std::move(b));
      // Home: the cell centre plus a jitter that keeps >= 2 * 0.5 cm between neighbours at rest.
      const double jitter = std::max(0.0, 0.5 * kCell - bound - 0.005);
      Transform3 home;
      home.t = cells[i].second + Vec3(rng.uniform(-jitter, jitter), rng.uniform(-jitter, jitter),
                                      rng.uniform(-jitter, jitter));
      home.R = Eigen::AngleAxisd(rng.uniform(0, kPi), rng.unitVector()).toRotationMatrix();
      const Vec3 dir = rng.unitVector();
      const Vec3 axis = rng.unitVector();
      const double amp = rng.uniform(0.005, 0.02);
      const double phase = rng.uniform(0, 2 * kPi);
      for (int s = 0; s < kRing; ++s) {
        const double w = std::sin(2 * kPi * s / kRing + phase);
        Transform3 T;
        T.R = Eigen::AngleAxisd(0.17 * w, axis).toRotationMatrix() * home.R;
        T.t = home.t + amp * w * dir;
        ring[static_cast<std::size_t>(i) * kRing + s] = T;
      }
    }
  }

  static double time(std::int64_t cycle) { return 1.0 + kDt * static_cast<double>(cycle); }

  /// Pose of obstacle o (0-based) at `cycle`.
  const Transform3& obstaclePose(int o, std::int64_t cycle, bool all) const {
    const std::int64_t step = all ? cycle : (cycle + o) / 10;
    return ring[static_cast<std::size_t>(o) * kRing + static_cast<std::size_t>(step % kRing)];
  }

  /// Pose of body b at `cycle` (what both pipelines hold after that cycle).
  Transform3 bodyPose(int b, std::int64_t cycle, bool all) const {
    if (b >= kArmLinks) return obstaclePose(b - kArmLinks, cycle, all);
    Transform3 links[kArmLinks];
    panda.fk(time(cycle), links);
    return links[b];
  }

  /// Calls f(body, pose) for every body that moves at `cycle` (every body at cycle 0).
  template <class F>
  void forEachMoved(std::int64_t cycle, bool all, F&& f) const {
    Transform3 links[kArmLinks];
    panda.fk(time(cycle), links);
    for (int l = 0; l < kArmLinks; ++l)
      f(l, links[l]);
    if (all || cycle == 0) {
      for (int o = 0; o < n; ++o)
        f(kArmLinks + o, obstaclePose(o, cycle, all));
      return;
    }
    for (int o = static_cast<int>((10 - cycle % 10) % 10); o < n; o += 10)
      f(kArmLinks + o, obstaclePose(o, cycle, all));
  }
};

std::uint64_t pairKey(int a, int b) {
  if (a > b) std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | static_cast<std::uint32_t>(b);
}

/// Body pair -> signed distance, for the pairs below a threshold.
using PairMap = std::map<std::uint64_t, double>;

// ---- ours -------------------------------------------------------------------------------------

class Ours {
 public:
  Ours(const Scene& scene, bool all, bool aligned = false)
      : scene_(scene), all_(all), world_(settings(aligned)) {
    for (int b = 0; b < scene.size(); ++b) {
      const BodyDesc& d = scene.bodies[b];
      world::BodySpec s;
      s.id = d.id;
      s.group = d.group;
      s.pose_source = world::PoseSource::Topic;
      s.origin = world::BodyOrigin::Topic;
      for (const PartDesc& p : d.parts)
        s.parts.push_back(world::Part{p.shape, p.pose});
      const std::string why = world_.addBody(std::move(s));
      if (!why.empty()) throw std::runtime_error(why);
      index_.emplace(d.id, b);
    }
    cycle(0);
  }

  /// `aligned`: align_poses as the node's default. Off, each body is checked at its latest pose,
  /// as the FCL pipeline places it: an obstacle posed every tenth cycle keeps its older stamp,
  /// and aligned, the arm would be taken back to it.
  static world::Settings settings(bool aligned = false) {
    world::Settings s;  // warning 0.05, contact 0, hysteresis 0.005, GJK
    s.max_bodies = 100000;
    // The FCL pipeline answers the pairs within reach only: the same work (min_distance beyond
    // reach costs 2.4 us per cycle at n = 10, docs/benchmarks.md, thirteenth session).
    s.exact_min_distance = false;
    s.align_poses = aligned;
    return s;
  }

  const world::CycleResult& cycle(std::int64_t c) {
    const double t = Scene::time(c);
    scene_.forEachMoved(
        c, all_, [&](int b, const Transform3& T) { world_.setPose(scene_.bodies[b].id, T, t); });
    last_ = world_.check(t);
    return last_;
  }

  /// Pairs of the last cycle with distance < threshold.
  PairMap pairsBelow(double threshold) const {
    PairMap out;
    for (const world::PairResult& r : last_.pairs) {
      if (r.status == world::PairStatus::Unknown || !(r.distance < threshold)) continue;
      out[pairKey(index_.at(r.body_a), index_.at(r.body_b))] = r.distance;
    }
    return out;
  }

  /// Signed distance of two bodies now (WorldModel::distance), +inf when it has none.
  double distance(int a, int b, std::int64_t c) const {
    std::string why;
    const auto r = world_.distance(scene_.bodies[a].id, scene_.bodies[b].id, Scene::time(c), &why);
    return r ? r->distance : std::numeric_limits<double>::infinity();
  }

  std::int64_t next = 1;

 private:
  const Scene& scene_;
  bool all_;
  world::WorldModel world_;
  std::unordered_map<std::string, int> index_;
  world::CycleResult last_;
};

// ---- FCL --------------------------------------------------------------------------------------

#ifdef CM_BENCH_HAVE_FCL
using cm_bench_fcl::toFcl;

std::shared_ptr<fcl::CollisionGeometryd> fclGeometry(const PartDesc& p) {
  switch (p.kind) {
    case Kind::Sphere:
      return std::make_shared<fcl::Sphered>(p.radius);
    case Kind::Box:
      return std::make_shared<fcl::Boxd>(p.sides.x(), p.sides.y(), p.sides.z());
    case Kind::Capsule:
      return std::make_shared<fcl::Capsuled>(p.radius, p.length);
    case Kind::Hull:
      return std::make_shared<fcl::Convexd>(toFcl(*p.hull, p.triangles));
  }
  return nullptr;
}

class Fcl {
 public:
  Fcl(const Scene& scene, bool all) : scene_(scene), all_(all) {
    const world::Settings s = Ours::settings();
    data_.warning = s.warning_distance;
    data_.reach = std::max(s.warning_distance, s.contact_distance) + s.hysteresis;
    for (int b = 0; b < scene.size(); ++b) {
      first_object_.push_back(static_cast<int>(objects_.size()));
      for (const PartDesc& p : scene.bodies[b].parts) {
        auto o = std::make_unique<fcl::CollisionObjectd>(fclGeometry(p));
        o->setUserData(reinterpret_cast<void*>(static_cast<std::intptr_t>(b)));
        objects_.push_back(std::move(o));
      }
    }
    first_object_.push_back(static_cast<int>(objects_.size()));
    place(0);
    std::vector<fcl::CollisionObjectd*> all_objects;
    for (auto& o : objects_)
      all_objects.push_back(o.get());
    manager_.registerObjects(all_objects);
    manager_.setup();
    query();
  }

  void cycle(std::int64_t c) {
    place(c);
    if (all_) {
      manager_.update();
    } else {
      manager_.update(moved_);
    }
    query();
  }

  /// Per body pair (minimum over their parts) of the last cycle, distance < threshold.
  PairMap pairsBelow(double threshold) const {
    PairMap out;
    for (const auto& [key, d] : data_.found) {
      auto it = out.find(key);
      if (it == out.end()) {
        out.emplace(key, d);
      } else {
        it->second = std::min(it->second, d);
      }
    }
    for (auto it = out.begin(); it != out.end();) {
      it = it->second < threshold ? std::next(it) : out.erase(it);
    }
    return out;
  }

  /// Diagnosis of a pair FCL did not report: for each part pair, the objects' AABB distance
  /// and a direct fcl::distance (signed), outside the manager.
  std::string explain(int a, int b) const {
    std::ostringstream os;
    for (int i = first_object_[a]; i < first_object_[a + 1]; ++i) {
      for (int j = first_object_[b]; j < first_object_[b + 1]; ++j) {
        const fcl::CollisionObjectd* o1 = objects_[i].get();
        const fcl::CollisionObjectd* o2 = objects_[j].get();
        fcl::DistanceRequestd request(true, true);
        fcl::DistanceResultd result;
        fcl::distance(o1, o2, request, result);
        fcl::DistanceResultd swapped;
        fcl::distance(o2, o1, request, swapped);
        os << " [parts " << i - first_object_[a] << "/" << j - first_object_[b] << ": aabb gap "
           << o1->getAABB().distance(o2->getAABB()) << ", fcl::distance " << result.min_distance
           << " (arguments swapped: " << swapped.min_distance << ")]";
      }
    }
    return os.str();
  }

  /// A referee for a body pair the pipelines disagree on: FCL's libccd GJK/EPA stops when an
  /// iteration improves by < 1e-6 m and can be centimetres off (docs/benchmarks.md); each
  /// estimate of a separated pair is the distance of two points on the shapes, i.e. an upper
  /// bound. So: min over the part pairs of the best of libccd (both argument orders) and FCL's
  /// own GJK (GST_INDEP).
  double referee(int a, int b) const {
    double best = std::numeric_limits<double>::infinity();
    for (int i = first_object_[a]; i < first_object_[a + 1]; ++i) {
      for (int j = first_object_[b]; j < first_object_[b + 1]; ++j) {
        const fcl::CollisionObjectd* o1 = objects_[i].get();
        const fcl::CollisionObjectd* o2 = objects_[j].get();
        fcl::DistanceRequestd ccd(true, true);
        // GST_INDEP only unsigned (its signed path asserts on penetration in FCL 0.7).
        fcl::DistanceRequestd indep(true, false, 0.0, 0.0, 1e-9, fcl::GST_INDEP);
        double d = std::numeric_limits<double>::infinity();
        for (int k = 0; k < 3; ++k) {
          fcl::DistanceResultd r;
          try {
            if (k == 0) fcl::distance(o1, o2, ccd, r);
            if (k == 1) fcl::distance(o2, o1, ccd, r);
            if (k == 2) fcl::distance(o1, o2, indep, r);
          } catch (const std::exception&) {
            continue;
          }
          if (k == 2 && !(r.min_distance > 0.0)) continue;  // unsigned: no depth
          d = std::min(d, r.min_distance);
        }
        best = std::min(best, d);
      }
    }
    return best;
  }

  std::size_t narrowCalls() const { return data_.narrow_calls; }
  std::size_t callbacks() const { return data_.callbacks; }
  std::size_t errors() const { return data_.errors; }
  std::int64_t next = 1;

 private:
  struct Data {
    double warning = 0.05;
    double reach = 0.055;
    std::vector<std::pair<std::uint64_t, double>> found;  ///< part pairs below reach
    std::size_t callbacks = 0;
    std::size_t narrow_calls = 0;
    std::size_t errors = 0;
  };

  static int bodyOf(const fcl::CollisionObjectd* o) {
    return static_cast<int>(reinterpret_cast<std::intptr_t>(o->getUserData()));
  }

  static bool callback(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* cdata,
                       double& dist) {
    Data& d = *static_cast<Data*>(cdata);
    dist = d.reach;  // prune the traversal at the reach, never stop early
    ++d.callbacks;
    const int b1 = bodyOf(o1);
    const int b2 = bodyOf(o2);
    if (b1 == b2 || (b1 < kArmLinks && b2 < kArmLinks)) return false;  // same body / arm group
    if (o1->getAABB().distance(o2->getAABB()) > d.reach) return false;
    fcl::DistanceRequestd request(true /*nearest points*/, true /*signed distance*/);
    fcl::DistanceResultd result;
    ++d.narrow_calls;
    try {
      fcl::distance(o1, o2, request, result);
    } catch (const std::exception&) {
      ++d.errors;
      return false;
    }
    if (result.min_distance <= d.reach) d.found.emplace_back(pairKey(b1, b2), result.min_distance);
    return false;
  }

  void place(std::int64_t c) {
    moved_.clear();
    scene_.forEachMoved(c, all_, [&](int b, const Transform3& T) {
      const BodyDesc& desc = scene_.bodies[b];
      for (int k = first_object_[b]; k < first_object_[b + 1]; ++k) {
        fcl::CollisionObjectd* o = objects_[k].get();
        o->setTransform(toFcl(T * desc.parts[k - first_object_[b]].pose));
        o->computeAABB();
        moved_.push_back(o);
      }
    });
  }

  void query() {
    data_.found.clear();
    data_.callbacks = 0;
    data_.narrow_calls = 0;
    data_.errors = 0;
    manager_.distance(&data_, &Fcl::callback);
  }

  const Scene& scene_;
  bool all_;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects_;
  std::vector<int> first_object_;
  std::vector<fcl::CollisionObjectd*> moved_;
  fcl::DynamicAABBTreeCollisionManagerd manager_;
  Data data_;
};
#endif

// ---- correctness ------------------------------------------------------------------------------

/// Exact signed distance of two bodies when every part pair is sphere/sphere or capsule/sphere
/// (closed form: point-segment distance minus the radii); nullopt otherwise.
std::optional<double> exactDistance(const Scene& scene, int a, int b, std::int64_t c, bool all) {
  const Transform3 Ta = scene.bodyPose(a, c, all);
  const Transform3 Tb = scene.bodyPose(b, c, all);
  double best = std::numeric_limits<double>::infinity();
  const auto segment = [](const PartDesc& p, const Transform3& T, Vec3* p0, Vec3* p1) {
    const double h = p.kind == Kind::Capsule ? 0.5 * p.length : 0.0;
    *p0 = T * Vec3(0, 0, -h);
    *p1 = T * Vec3(0, 0, h);
  };
  for (const PartDesc& pa : scene.bodies[a].parts) {
    for (const PartDesc& pb : scene.bodies[b].parts) {
      const bool round_a = pa.kind == Kind::Sphere || pa.kind == Kind::Capsule;
      const bool round_b = pb.kind == Kind::Sphere || pb.kind == Kind::Capsule;
      if (!round_a || !round_b || (pa.kind == Kind::Capsule && pb.kind == Kind::Capsule)) {
        return std::nullopt;
      }
      const bool a_is_sphere = pa.kind == Kind::Sphere;
      const PartDesc& cap = a_is_sphere ? pb : pa;
      const PartDesc& sph = a_is_sphere ? pa : pb;
      Vec3 s0, s1, q, unused;
      segment(cap, (a_is_sphere ? Tb : Ta) * cap.pose, &s0, &s1);
      segment(sph, (a_is_sphere ? Ta : Tb) * sph.pose, &q, &unused);
      const Vec3 d = s1 - s0;
      const double len2 = d.squaredNorm();
      const double t = len2 > 0 ? std::clamp((q - s0).dot(d) / len2, 0.0, 1.0) : 0.0;
      best = std::min(best, (s0 + t * d - q).norm() - cap.radius - sph.radius);
    }
  }
  return best;
}

/// Runs both pipelines side by side and compares the pairs below warning_distance.
///
/// A pair only one pipeline reports below warning_distance (or whose two distances differ by
/// more than kRefereeDiff) is re-measured: exactly in closed form when every part pair is
/// sphere/sphere or capsule/sphere (exactDistance()), else by Fcl::referee(); ours by
/// WorldModel::distance() when ours did not list it. It counts as an FCL inaccuracy when ours
/// agrees with the referee within kRefereeDiff, within the band when either distance is within
/// kBand of the threshold, and as a mismatch otherwise.
bool checkScene(const Scene& scene, bool all, std::string* summary) {
#ifdef CM_BENCH_HAVE_FCL
  constexpr double kRefereeDiff = 1e-5;
  const double w = Ours::settings().warning_distance;
  Ours ours(scene, all);
  Fcl fcl(scene, all);
  std::size_t compared = 0, mismatches = 0, band = 0, penetrating = 0, fcl_errors = 0;
  std::size_t fcl_wrong_set = 0, fcl_off = 0;
  double max_raw_diff = 0.0, max_ref_diff = 0.0, worst_fcl = 0.0;
  std::set<std::uint64_t> pairs_seen;
  std::string first_bad, worst_fcl_pair, first_missed;
  const int cycles = scene.n <= 1000 ? kCheckCycles : kCheckCyclesLarge;
  for (int c = 0; c <= cycles; ++c) {
    if (c > 0) {
      ours.cycle(c);
      fcl.cycle(c);
    }
    const PairMap a = ours.pairsBelow(w + kBand);
    const PairMap b = fcl.pairsBelow(w + kBand);
    fcl_errors += fcl.errors();
    std::set<std::uint64_t> keys;
    for (const auto& kv : a)
      keys.insert(kv.first);
    for (const auto& kv : b)
      keys.insert(kv.first);
    for (std::uint64_t key : keys) {
      const int ka = static_cast<int>(key >> 32);
      const int kb = static_cast<int>(key & 0xffffffffu);
      const auto ia = a.find(key);
      const auto ib = b.find(key);
      const double inf = std::numeric_limits<double>::infinity();
      double da = ia != a.end() ? ia->second : inf;
      const double db = ib != b.end() ? ib->second : inf;
      if (!(da < w) && !(db < w)) continue;
      ++compared;
      pairs_seen.insert(key);
      if (std::min(da, db) < 0.0) ++penetrating;
      if (std::isfinite(da) && std::isfinite(db))
        max_raw_diff = std::max(max_raw_diff, std::abs(da - db));
      const bool same_side = (da < w) == (db < w);
      if (same_side && std::abs(da - db) <= kRefereeDiff) {
        max_ref_diff = std::max(max_ref_diff, std::abs(da - db));
        continue;
      }
      // Disagreement: referee.
      if (!std::isfinite(da)) da = ours.distance(ka, kb, c);
      const std::optional<double> exact = exactDistance(scene, ka, kb, c, all);
      const double ref = exact ? *exact : fcl.referee(ka, kb);
      if (std::abs(da - ref) <= kRefereeDiff) {
        max_ref_diff = std::max(max_ref_diff, std::abs(da - ref));
        if (!same_side) {
          ++fcl_wrong_set;
        } else {
          ++fcl_off;
        }
        if (std::isfinite(db) && std::abs(db - ref) > worst_fcl) {
          worst_fcl = std::abs(db - ref);
          std::ostringstream os;
          os << scene.bodies[ka].id << "/" << scene.bodies[kb].id << " cycle " << c << ": fcl "
             << db << " m, ours " << da << " m, referee " << ref << " m";
          worst_fcl_pair = os.str();
        }
        if (!std::isfinite(db) && first_missed.empty()) {
          std::ostringstream os;
          os << "; first pair FCL missed: " << scene.bodies[ka].id << "/" << scene.bodies[kb].id
             << " cycle " << c << ", ours " << da << " m, referee " << ref << " m;"
             << fcl.explain(ka, kb);
          first_missed = os.str();
        }
      } else if (std::abs(da - w) <= kBand || std::abs(db - w) <= kBand) {
        ++band;
      } else if (same_side) {
        // Both on the same side of the threshold, distances differ beyond the referee.
        max_ref_diff = std::max(max_ref_diff, std::abs(da - ref));
        ++mismatches;
        if (first_bad.empty()) {
          std::ostringstream os;
          os << "cycle " << c << ": " << scene.bodies[ka].id << "/" << scene.bodies[kb].id
             << " ours " << da << " m, fcl " << db << " m, referee " << ref << " m;"
             << fcl.explain(ka, kb);
          first_bad = os.str();
        }
      } else {
        ++mismatches;
        if (first_bad.empty()) {
          std::ostringstream os;
          os << "cycle " << c << ": " << scene.bodies[ka].id << "/" << scene.bodies[kb].id
             << " below warning only in " << (da < w ? "ours" : "fcl") << ": ours " << da
             << " m, fcl " << db << " m, referee " << ref << " m;" << fcl.explain(ka, kb);
          first_bad = os.str();
        }
      }
    }
  }
  std::ostringstream os;
  os << (all ? "all moving" : "10% moving") << ", " << cycles + 1 << " cycles: " << compared
     << " pair results below warning (" << pairs_seen.size() << " distinct pairs, " << penetrating
     << " penetrating): " << mismatches << " mismatches, " << band
     << " in the +-1 mm band; FCL missed or invented " << fcl_wrong_set
     << " and was > 1e-5 m off on " << fcl_off
     << " (ours confirmed by the referee; worst FCL error " << worst_fcl << " m"
     << (worst_fcl_pair.empty() ? "" : ": " + worst_fcl_pair) << "); max |ours - fcl| "
     << max_raw_diff << " m, max |ours - best FCL estimate| " << max_ref_diff
     << " m; fcl exceptions " << fcl_errors << first_missed;
  if (!first_bad.empty()) os << "; first mismatch: " << first_bad;
  *summary = os.str();
  return mismatches == 0 && compared > 0;
#else
  (void)scene;
  (void)all;
  *summary = "not checked (built without FCL)";
  return true;
#endif
}

// ---- benchmarks -------------------------------------------------------------------------------

/// Pipelines persist across the calls Google Benchmark makes (the scene keeps evolving).
template <class P>
P& pipeline(const Scene& scene, bool all) {
  static std::map<std::pair<const Scene*, bool>, std::unique_ptr<P>> cache;
  auto& p = cache[{&scene, all}];
  if (!p) p = std::make_unique<P>(scene, all);
  return *p;
}

/// Ours with align_poses (BM_Cycle/ours_aligned): the arm, posed every cycle, taken back to the
/// stamps of the obstacles posed every tenth.
struct OursAligned : Ours {
  OursAligned(const Scene& scene, bool all) : Ours(scene, all, true) {}
};

template <class P = Ours>
void oursCycle(benchmark::State& state, const Scene* scene, bool all) {
  P& p = pipeline<P>(*scene, all);
  double broad = 0, checked = 0, warn = 0;
  for (auto _ : state) {
    const world::CycleResult& r = p.cycle(p.next++);
    benchmark::DoNotOptimize(&r);
    broad += static_cast<double>(r.num_broad_phase_pairs);
    checked += static_cast<double>(r.num_pairs_checked);
    warn += static_cast<double>(r.pairs.size());
  }
  state.counters["broad_pairs"] = benchmark::Counter(broad, benchmark::Counter::kAvgIterations);
  state.counters["narrow_pairs"] = benchmark::Counter(checked, benchmark::Counter::kAvgIterations);
  state.counters["warn_pairs"] = benchmark::Counter(warn, benchmark::Counter::kAvgIterations);
  state.counters["n"] = scene->n;
}

#ifdef CM_BENCH_HAVE_FCL
void fclCycle(benchmark::State& state, const Scene* scene, bool all) {
  Fcl& p = pipeline<Fcl>(*scene, all);
  double broad = 0, checked = 0;
  for (auto _ : state) {
    p.cycle(p.next++);
    broad += static_cast<double>(p.callbacks());
    checked += static_cast<double>(p.narrowCalls());
  }
  state.counters["broad_pairs"] = benchmark::Counter(broad, benchmark::Counter::kAvgIterations);
  state.counters["narrow_pairs"] = benchmark::Counter(checked, benchmark::Counter::kAvgIterations);
  state.counters["n"] = scene->n;
}
#endif

void oursTimeToCollision(benchmark::State& state, int motion) {
  world::Settings settings;
  settings.warning_distance = 5.0;
  world::WorldModel w(settings);
  world::BodySpec arm;
  arm.id = "arm";
  Transform3 lever;
  lever.t = Vec3(2, 0, 0);
  arm.parts.push_back(world::Part{core::ConvexShape::box(Vec3(0.4, 0.3, 0.2)), lever});
  world::BodySpec other;
  other.id = "other";
  other.parts.push_back(world::Part{core::ConvexShape::cylinder(0.3, 0.2), Transform3()});
  if (!w.addBody(arm).empty() || !w.addBody(other).empty()) state.SkipWithError("addBody");
  world::Twist twist;
  if (motion == 1) twist.linear = Vec3(-0.5, 0.5, 0);
  if (motion == 2) twist.angular = Vec3(0, 0, 1);
  if (motion == 3) twist.angular = Vec3(0, 0, -1);
  Transform3 other_pose;
  other_pose.t = Vec3(0, 2, 0);
  double now = 1.0, ttc = 0.0;
  for (auto _ : state) {
    now += 1e-3;
    w.setPose("arm", Transform3(), now, motion ? std::optional<world::Twist>(twist) : std::nullopt);
    w.setPose("other", other_pose, now);
    const world::CycleResult& r = w.check(now);
    ttc = r.pairs.empty() ? -1.0 : r.pairs[0].time_to_collision;
    benchmark::DoNotOptimize(ttc);
  }
  state.counters["ttc"] = ttc;
}

std::vector<int> parseSizes(const std::string& s) {
  std::vector<int> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(std::stoi(item));
  return out;
}

}  // namespace
}  // namespace cm_bench_world

int main(int argc, char** argv) {
  using namespace cm_bench_world;
  std::vector<int> sizes = {10, 100, 1000, 10000};
  bool check = true;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strncmp(argv[i], "--cm_sizes=", 11) == 0) {
      sizes = parseSizes(argv[i] + 11);
    } else if (std::strcmp(argv[i], "--cm_no_check") == 0) {
      check = false;
    } else {
      rest.push_back(argv[i]);
    }
  }
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
  if (benchmark::ReportUnrecognizedArguments(rest_argc, rest.data())) return 2;
#ifdef CM_BENCH_HAVE_FCL
  benchmark::AddCustomContext("cm_libraries", "ours fcl");
#else
  benchmark::AddCustomContext("cm_libraries", "ours");
  std::fprintf(stderr, "bench_world: built without FCL, no fcl rows\n");
#endif

  std::vector<std::unique_ptr<Scene>> scenes;
  bool all_ok = true;
  for (int n : sizes) {
    scenes.push_back(std::make_unique<Scene>(n));
    if (!check) continue;
    for (bool all : {false, true}) {
      std::string summary;
      const bool ok = checkScene(*scenes.back(), all, &summary);
      all_ok = all_ok && ok;
      std::printf("check n%d: %s%s\n", n, summary.c_str(), ok ? "" : "  <-- FAILED");
      benchmark::AddCustomContext("cm_check_n" + std::to_string(n) + (all ? "_all" : ""), summary);
    }
  }
  std::fflush(stdout);
  benchmark::AddCustomContext("cm_correctness", check ? (all_ok ? "OK" : "FAILED") : "not checked");
  if (!all_ok) std::fprintf(stderr, "CORRECTNESS FAILED (see the check lines above)\n");

  for (bool all : {false, true}) {
    const std::string query = all ? "BM_CycleAll" : "BM_Cycle";
    for (const auto& s : scenes) {
      const Scene* sp = s.get();
      const std::string suffix = "/n" + std::to_string(sp->n);
      benchmark::RegisterBenchmark((query + "/ours" + suffix).c_str(), [sp,
                                                                        all](benchmark::State& st) {
        oursCycle(st, sp, all);
      })->Unit(benchmark::kMicrosecond);
      if (!all) {  // every body posed every cycle: nothing to align
        benchmark::RegisterBenchmark(
            (query + "/ours_aligned" + suffix).c_str(),
            [sp](benchmark::State& st) { oursCycle<OursAligned>(st, sp, false); })
            ->Unit(benchmark::kMicrosecond);
      }
#ifdef CM_BENCH_HAVE_FCL
      benchmark::RegisterBenchmark((query + "/fcl" + suffix).c_str(), [sp,
                                                                       all](benchmark::State& st) {
        fclCycle(st, sp, all);
      })->Unit(benchmark::kMicrosecond);
#endif
    }
  }
  const char* motions[] = {"none", "translating", "spinning_towards", "spinning_away"};
  for (int m = 0; m < 4; ++m) {
    benchmark::RegisterBenchmark((std::string("BM_TimeToCollision/ours/") + motions[m]).c_str(),
                                 [m](benchmark::State& st) { oursTimeToCollision(st, m); })
        ->Unit(benchmark::kMicrosecond);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return all_ok ? 0 : 1;
}
