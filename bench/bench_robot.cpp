/// \file
/// Robot self-collision benchmark: the real robots of example-robot-data loaded the node's way
/// (the URDF through bodiesFromUrdf, meshes through MeshCache, the SRDF through
/// collisionsFromSrdf, adjacent links disabled), every link posed by forward kinematics (urdfdom's
/// joints) along a smooth joint trajectory, then one WorldModel::check per cycle with the node's
/// default settings (warning 0.05 m, contact 0, hysteresis 5 mm, exact min_distance, GJK): what a
/// monitor of that robot pays per cycle beyond TF.
///
/// Robots (fixed trajectory, every joint moving; 4 ms per cycle):
///   panda        panda_collision.urdf + panda.srdf: 11 bodies of spheres and cylinders
///   pr2_hull     pr2.urdf + pr2.srdf: 32 bodies, every STL mesh its convex hull
///   pr2_pieces   the same with mesh_decomposition "pieces" (one hull per closed piece)
/// Every joint with limits sweeps 80 % of its range (sinusoids of 0.05 to 0.25 Hz); a continuous
/// joint turns +-pi. Mimic joints are driven as their own joints.
///
/// Benchmarks, one cycle (setPose of every link + check) per iteration:
///   BM_Robot/ours/<robot>         the check with the node's defaults (GJK, exact min_distance:
///                                 the minimum over every enabled pair, however far)
///   BM_Robot/ours_reach/<robot>   min_distance only within reach (exact_min_distance false):
///                                 the pairs within warning + hysteresis, as FCL's row
///   BM_Robot/ours_twists/<robot>  the node's defaults with estimate_twists: every link moves as
///                                 its last two poses say, so each listed pair's time to
///                                 collision is followed (conservative advancement)
///   BM_Robot/libccd/<robot>       the node's defaults on the libccd backend
///   BM_Robot/fcl/<robot>          a MoveIt-style FCL 0.7 pipeline on the same parts (FCL's
///                                 Sphere, Box, Cylinder, and Convex with our hulls' triangles):
///                                 setTransform + computeAABB of every part,
///                                 DynamicAABBTreeCollisionManager update(), then its
///                                 self-distance() with a callback that prunes the traversal at
///                                 warning + hysteresis, skips pairs of one body and disabled pairs
///                                 (a precomputed table; MoveIt looks them up by name), skips AABBs
///                                 that far apart and runs fcl::distance (libccd GJK/EPA, signed,
///                                 nearest points) on the rest, keeping the per-body-pair minimum
///   BM_Markers/locked/<robot>     the node's marker build after each check of the ours row
///                                 (rviz listening; timed alone, manual time): links frame-locked
///                                 to their TF frames, the node's default
///   BM_Markers/unlocked/<robot>   the same with marker_frame_locked false (every moved link sent
///                                 at its new pose)
/// Counters per cycle: bodies, enabled (checked) body pairs, broad-phase pairs, narrow-phase pair
/// checks, pairs listed (WARNING or COLLISION); markers sent (BM_Markers).
///
/// Correctness (outside the timed loops, every run unless --cm_no_check), of the ours row (the
/// node's defaults; the other rows are timed only): 800 cycles of each robot (the first 400 in a
/// row, then every 25th of a 40 s sweep), every enabled pair against a brute force over all its
/// part pairs (core::signedDistance from cold: no broad phase, no cache, no ordering bound; it
/// checks the world model, the core has its own oracles): a pair below warning distance must be
/// listed, one beyond warning + hysteresis must not, a listed pair's distance must match to
/// 1e-9 m, min_distance too; a disabled pair (by the SRDF's rules, evaluated here on their own:
/// Robot::neverChecked) is never listed. A failure prints CORRECTNESS
/// FAILED, sets the JSON context cm_correctness and the exit status 1.
///
/// Extra flags (before Google Benchmark's own):
///   --cm_robot_data=DIR  folder holding example-robot-data (default $CM_ROBOT_DATA, else the
///                        configure-time ../shared/data)
///   --cm_no_check        skip the correctness pass
/// Reproduce: see docs/benchmarks.md ("Robot self-collision cycle").

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include "collision_monitor/core/convex_hull.h"
#include "collision_monitor/core/query.h"
#include "collision_monitor/ros/markers.h"
#include "collision_monitor/ros/mesh_loader.h"
#include "collision_monitor/ros/robot_model.h"
#include "collision_monitor/world/world_model.h"

#ifdef CM_BENCH_HAVE_FCL
#include <fcl/broadphase/broadphase_dynamic_AABB_tree.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/convex.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/narrowphase/collision_object.h>
#include <fcl/narrowphase/distance.h>

#include "fcl_common.h"
#endif

namespace cm_bench_robot {
namespace {

namespace core = collision_monitor::core;
namespace world = collision_monitor::world;
namespace rl = collision_monitor::ros_layer;
using core::Transform3;
using core::Vec3;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDt = 0.004;        ///< s per cycle (250 Hz)
constexpr int kCheckCycles = 400;    ///< 1.6 s of motion, from t = 0
constexpr int kCheckStride = 25;     ///< and 400 more cycles, one every 0.1 s of a 40 s sweep
constexpr double kTolerance = 1e-9;  ///< m, listed distance vs the brute force
constexpr int kRing = 2500;          ///< cycles of poses computed before timing (10 s)

std::string robotData = CM_BENCH_ROBOT_DATA;

std::string readFile(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot read " + path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

Transform3 fromUrdf(const urdf::Pose& p) {
  Transform3 T;
  const urdf::Rotation& q = p.rotation;
  T.R = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
  T.t = Vec3(p.position.x, p.position.y, p.position.z);
  return T;
}

double timeOf(std::int64_t cycle) {
  return static_cast<double>(cycle) * kDt;
}

/// One robot: its bodies (the node's), which pairs are enabled, and forward kinematics.
struct Robot {
  std::string name;
  std::vector<world::BodySpec> bodies;
  /// A moving joint: its link's parent link (index into `links`) and motion.
  struct Joint {
    int parent = -1;
    Transform3 origin;  ///< parent link -> joint frame
    int type = urdf::Joint::FIXED;
    Vec3 axis = Vec3::UnitX();
    double lo = 0.0, hi = 0.0, freq = 0.0, phase = 0.0;
  };
  std::vector<std::string> links;  ///< parents before children
  std::vector<Joint> joint_of;     ///< by link: the joint that moves it (root: none)
  std::vector<int> body_link;      ///< by body: its link
  std::vector<std::pair<std::string, std::string>> disabled, enabled;
  std::vector<std::string> default_off;
  std::size_t enabled_pairs = 0;
  std::vector<char> never;  ///< by body index (i * bodies + j): neverChecked()
  std::size_t parts = 0;

  /// The URDF to bodies as the node loads it at start-up: a fresh mesh cache (every mesh read,
  /// parsed by assimp and hulled).
  rl::Expected<rl::RobotBodies> load() const {
    rl::MeshCache cache(
        {}, world::Settings().max_vertices_per_part,
        [](const std::string& pkg) {
          return pkg == "example-robot-data" ? robotData + "/example-robot-data" : std::string();
        },
        mode, world::Settings().max_parts_per_body);
    const rl::MeshLoader loader = [&cache](const std::string& uri, const Vec3& scale) {
      return cache.load(uri, scale);
    };
    return rl::bodiesFromUrdf(urdf_xml, 0.0, rl::Limits(), loader);
  }

  std::string urdf_xml;
  rl::MeshDecomposition mode;

  Robot(std::string robot_name, const std::string& urdf_path, const std::string& srdf_path,
        rl::MeshDecomposition decomposition)
      : name(std::move(robot_name)), urdf_xml(readFile(urdf_path)), mode(decomposition) {
    auto robot = load();
    if (!robot) throw std::runtime_error(urdf_path + ": " + robot.error());
    if (!robot->errors.empty()) throw std::runtime_error(urdf_path + ": " + robot->errors[0]);
    bodies = robot->bodies;
    disabled = robot->adjacent;
    auto rules_xml = rl::collisionsFromSrdf(readFile(srdf_path));
    if (!rules_xml) throw std::runtime_error(srdf_path + ": " + rules_xml.error());
    disabled.insert(disabled.end(), rules_xml->disabled.begin(), rules_xml->disabled.end());
    enabled = rules_xml->enabled;
    default_off = rules_xml->default_off;
    for (const auto& b : bodies)
      parts += b.parts.size();
    const std::size_t nb = bodies.size();
    never.assign(nb * nb, 1);
    for (std::size_t i = 0; i < nb; ++i) {
      for (std::size_t j = 0; j < nb; ++j) {
        if (i != j) never[i * nb + j] = neverChecked(bodies[i].id, bodies[j].id);
      }
    }
    for (std::size_t i = 0; i < nb; ++i)
      for (std::size_t j = i + 1; j < nb; ++j)
        enabled_pairs += never[i * nb + j] ? 0 : 1;

    // Kinematics: links in breadth-first order from the root, each with its parent joint.
    const urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
    if (!model) throw std::runtime_error(urdf_path + ": urdfdom cannot parse it");
    std::map<std::string, int> index;
    links.push_back(model->getRoot()->name);
    joint_of.emplace_back();
    index[links[0]] = 0;
    for (std::size_t k = 0; k < links.size(); ++k) {
      const urdf::LinkConstSharedPtr link = model->getLink(links[k]);
      for (const urdf::JointSharedPtr& j : link->child_joints) {
        Joint J;
        J.parent = static_cast<int>(k);
        J.origin = fromUrdf(j->parent_to_joint_origin_transform);
        J.type = j->type;
        J.axis = Vec3(j->axis.x, j->axis.y, j->axis.z);
        if (J.axis.norm() > 0.0) J.axis.normalize();
        if (j->limits && j->type != urdf::Joint::CONTINUOUS) {
          J.lo = j->limits->lower;
          J.hi = j->limits->upper;
        } else {
          J.lo = -kPi;
          J.hi = kPi;
        }
        // Fixed per joint (its order in the tree): 0.05 to 0.25 Hz, phases spread.
        const double s = static_cast<double>(joint_of.size());
        J.freq = 0.05 + 0.2 * std::fmod(s * 0.618033988749895, 1.0);
        J.phase = 2.0 * kPi * std::fmod(s * 0.414213562373095, 1.0);
        index[j->child_link_name] = static_cast<int>(links.size());
        links.push_back(j->child_link_name);
        joint_of.push_back(J);
      }
    }
    for (const auto& b : bodies)
      body_link.push_back(index.at(b.id));
    ring.resize(kRing);
    for (int c = 0; c < kRing; ++c)
      fk(timeOf(c), &ring[static_cast<std::size_t>(c)]);
  }

  /// MoveIt's rule, on its own: explicitly disabled (adjacent, <disable_collisions>) wins, then
  /// <enable_collisions>, then <disable_default_collisions> of either link.
  bool neverChecked(const std::string& a, const std::string& b) const {
    const auto named = [&](const std::vector<std::pair<std::string, std::string>>& pairs) {
      for (const auto& [x, y] : pairs)
        if ((x == a && y == b) || (x == b && y == a)) return true;
      return false;
    };
    if (named(disabled)) return true;
    if (named(enabled)) return false;
    return std::count(default_off.begin(), default_off.end(), a) +
               std::count(default_off.begin(), default_off.end(), b) >
           0;
  }

  /// The disabled, default-off and enabled pairs, as the node gives them to its world.
  void applyRules(world::WorldModel& w) const {
    for (const auto& [a, b] : disabled)
      w.disablePair(a, b);
    for (const std::string& l : default_off)
      w.disableByDefault(l);
    for (const auto& [a, b] : enabled)
      w.enablePair(a, b);
  }

  /// Body poses at cycle c, computed before timing (the node gets them from TF): `wrap`, as the
  /// timed loops do, goes round the first kRing cycles again (a jump back every 10 s of motion;
  /// the stamps still advance); else cycles beyond them are computed.
  void posesAt(std::int64_t c, bool wrap, std::vector<Transform3>* out) const {
    if (wrap || c < kRing) {
      *out = ring[static_cast<std::size_t>(c % kRing)];
    } else {
      fk(timeOf(c), out);
    }
  }
  std::vector<std::vector<Transform3>> ring;

  /// Body poses (body = link frame -> root link) at time t.
  void fk(double t, std::vector<Transform3>* out) const {
    std::vector<Transform3> T(links.size());
    for (std::size_t k = 1; k < links.size(); ++k) {
      const Joint& J = joint_of[k];
      Transform3 motion;
      const double mid = 0.5 * (J.lo + J.hi), amp = 0.4 * (J.hi - J.lo);
      const double q = mid + amp * std::sin(2.0 * kPi * J.freq * t + J.phase);
      if (J.type == urdf::Joint::REVOLUTE || J.type == urdf::Joint::CONTINUOUS) {
        motion.R = Eigen::AngleAxisd(q, J.axis).toRotationMatrix();
      } else if (J.type == urdf::Joint::PRISMATIC) {
        motion.t = q * J.axis;
      }
      T[k] = T[J.parent] * J.origin * motion;
    }
    out->resize(body_link.size());
    for (std::size_t b = 0; b < body_link.size(); ++b)
      (*out)[b] = T[body_link[b]];
  }
};

/// The monitor's world of one robot, cycled along the trajectory.
class Monitor {
 public:
  Monitor(const Robot& robot, const world::Settings& settings) : robot_(robot), world_(settings) {
    for (const auto& b : robot.bodies) {
      const std::string why = world_.addBody(b);
      if (!why.empty()) throw std::runtime_error(why);
    }
    robot.applyRules(world_);
  }

  const world::CycleResult& cycle(std::int64_t c) {
    const double t = timeOf(c);
    robot_.posesAt(c, wrap, &poses_);
    for (std::size_t b = 0; b < poses_.size(); ++b)
      world_.setPose(robot_.bodies[b].id, poses_[b], t);
    last_ = world_.check(t);
    return last_;
  }

  const std::vector<Transform3>& poses() const { return poses_; }
  const world::WorldModel& world() const { return world_; }
  std::int64_t next = 0;
  bool wrap = false;  ///< see Robot::posesAt

 private:
  const Robot& robot_;
  world::WorldModel world_;
  std::vector<Transform3> poses_;
  world::CycleResult last_;
};

#ifdef CM_BENCH_HAVE_FCL
using cm_bench_fcl::toFcl;

/// FCL's geometry of a shape's core about its offset() (the caller places it there), or null for
/// a shape FCL has no counterpart of here.
std::shared_ptr<fcl::CollisionGeometryd> fclGeometry(const core::ConvexShape& shape) {
  const double r = shape.radius();
  const auto& c = shape.core();
  if (const auto* p = std::get_if<core::PointShape<3>>(&c)) {
    if (p->p.norm() == 0.0) return std::make_shared<fcl::Sphered>(r);
  } else if (r == 0.0) {
    if (const auto* b = std::get_if<core::BoxShape<3>>(&c)) {
      return std::make_shared<fcl::Boxd>(2.0 * b->half);
    } else if (const auto* y = std::get_if<core::CylinderShape>(&c)) {
      return std::make_shared<fcl::Cylinderd>(y->radius, 2.0 * y->half_height);
    } else if (const auto* h = std::get_if<std::shared_ptr<const core::Polytope<3>>>(&c)) {
      return std::make_shared<fcl::Convexd>(toFcl(**h, core::hullTriangles(**h)));
    }
  }
  return nullptr;
}

/// The MoveIt-style FCL pipeline of one robot (see the file comment).
class FclMonitor {
 public:
  explicit FclMonitor(const Robot& robot) : robot_(robot) {
    const world::Settings s;
    data_.reach = std::max(s.warning_distance, s.contact_distance) + s.hysteresis;
    const std::size_t nb = robot.bodies.size();
    data_.allowed.assign(nb * nb, 0);
    data_.nb = nb;
    for (std::size_t i = 0; i < nb * nb; ++i)
      data_.allowed[i] = !robot.never[i];
    for (std::size_t b = 0; b < nb; ++b) {
      for (const world::Part& p : robot.bodies[b].parts) {
        auto g = fclGeometry(p.shape);
        if (!g) throw std::runtime_error("no FCL shape for " + p.shape.describe());
        Transform3 at = p.pose;
        at.t += p.pose.R * p.shape.offset();
        parts_.push_back({static_cast<int>(b), at});
        objects_.push_back(std::make_unique<fcl::CollisionObjectd>(g));
        objects_.back()->setUserData(reinterpret_cast<void*>(static_cast<std::intptr_t>(b)));
      }
    }
    place(0);
    std::vector<fcl::CollisionObjectd*> all;
    for (auto& o : objects_)
      all.push_back(o.get());
    manager_.registerObjects(all);
    manager_.setup();
  }

  /// One cycle; the per-body-pair minima below reach in `found()`.
  void cycle(std::int64_t c) {
    place(c);
    manager_.update();
    data_.found.clear();
    data_.narrow_calls = 0;
    manager_.distance(&data_, &FclMonitor::callback);
  }

  const std::map<std::pair<int, int>, double>& found() const { return data_.found; }
  std::size_t narrowCalls() const { return data_.narrow_calls; }
  std::int64_t next = 0;

 private:
  struct Data {
    double reach = 0.055;
    std::size_t nb = 0;
    std::vector<char> allowed;  ///< nb x nb
    std::map<std::pair<int, int>, double> found;
    std::size_t narrow_calls = 0;
  };

  static int bodyOf(const fcl::CollisionObjectd* o) {
    return static_cast<int>(reinterpret_cast<std::intptr_t>(o->getUserData()));
  }

  static bool callback(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* cdata,
                       double& dist) {
    Data& d = *static_cast<Data*>(cdata);
    dist = d.reach;  // prune the traversal at the reach, never stop early
    const int b1 = bodyOf(o1);
    const int b2 = bodyOf(o2);
    if (!d.allowed[static_cast<std::size_t>(b1) * d.nb + static_cast<std::size_t>(b2)]) {
      return false;
    }
    if (o1->getAABB().distance(o2->getAABB()) > d.reach) return false;
    fcl::DistanceRequestd request(true /*nearest points*/, true /*signed distance*/);
    fcl::DistanceResultd result;
    ++d.narrow_calls;
    fcl::distance(o1, o2, request, result);
    if (result.min_distance <= d.reach) {
      auto [it, added] = d.found.emplace(std::minmax(b1, b2), result.min_distance);
      if (!added) it->second = std::min(it->second, result.min_distance);
    }
    return false;
  }

  void place(std::int64_t c) {
    robot_.posesAt(c, true, &poses_);
    for (std::size_t k = 0; k < objects_.size(); ++k) {
      objects_[k]->setTransform(toFcl(poses_[parts_[k].body] * parts_[k].pose));
      objects_[k]->computeAABB();
    }
  }

  struct PartRef {
    int body;
    Transform3 pose;  ///< FCL object -> body
  };
  const Robot& robot_;
  std::vector<PartRef> parts_;
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> objects_;
  std::vector<Transform3> poses_;
  fcl::DynamicAABBTreeCollisionManagerd manager_;
  Data data_;
};

void fclCycle(benchmark::State& state, const Robot* robot) {
  FclMonitor m(*robot);
  m.cycle(m.next++);
  double checked = 0, listed = 0;
  for (auto _ : state) {
    m.cycle(m.next++);
    checked += static_cast<double>(m.narrowCalls());
    listed += static_cast<double>(m.found().size());
  }
  state.counters["bodies"] = static_cast<double>(robot->bodies.size());
  state.counters["parts"] = static_cast<double>(robot->parts);
  state.counters["narrow_pairs"] = benchmark::Counter(checked, benchmark::Counter::kAvgIterations);
  state.counters["reach_pairs"] = benchmark::Counter(listed, benchmark::Counter::kAvgIterations);
}
#endif

/// Signed distance of two bodies by brute force: every part pair from cold.
double bruteDistance(const world::BodySpec& a, const Transform3& pa, const world::BodySpec& b,
                     const Transform3& pb) {
  double best = std::numeric_limits<double>::infinity();
  for (const world::Part& x : a.parts)
    for (const world::Part& y : b.parts)
      best =
          std::min(best, core::signedDistance(x.shape, pa * x.pose, y.shape, pb * y.pose).distance);
  return best;
}

bool checkRobot(const Robot& robot, std::string* summary) {
  const world::Settings s;  // the node's defaults
  Monitor m(robot, s);
  std::size_t failures = 0, listed = 0, below = 0, in_band = 0, cycles = 0;
  double worst = 0.0;
  std::string first;
  const auto fail = [&](const std::string& what) {
    if (failures++ == 0) first = what;
  };
  const std::size_t nb = robot.bodies.size();
  for (int k = 0; k < 2 * kCheckCycles; ++k) {
    // The first 400 cycles in a row (warm starts, hysteresis), then every 25th of the sweep.
    const std::int64_t c = k < kCheckCycles ? k : kCheckCycles + (k - kCheckCycles) * kCheckStride;
    const world::CycleResult& r = m.cycle(c);
    ++cycles;
    std::map<std::pair<std::string, std::string>, double> got;
    for (const world::PairResult& p : r.pairs) {
      if (p.status == world::PairStatus::Unknown) fail("cycle " + std::to_string(c) + ": UNKNOWN");
      got[std::minmax(p.body_a, p.body_b)] = p.distance;
    }
    listed += got.size();
    double min_d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < nb; ++i) {
      for (std::size_t j = i + 1; j < nb; ++j) {
        const std::string& a = robot.bodies[i].id;
        const std::string& b = robot.bodies[j].id;
        auto it = got.find(std::minmax(a, b));
        const std::string pair = "cycle " + std::to_string(c) + " " + a + "-" + b;
        if (robot.never[i * nb + j]) {
          if (it != got.end()) fail(pair + ": disabled but listed");
          continue;
        }
        const double d =
            bruteDistance(robot.bodies[i], m.poses()[i], robot.bodies[j], m.poses()[j]);
        min_d = std::min(min_d, d);
        if (d < s.warning_distance) ++below;
        if (it == got.end()) {
          if (d < s.warning_distance) fail(pair + ": " + std::to_string(d) + " m not listed");
          continue;
        }
        if (d > s.warning_distance + s.hysteresis) {
          fail(pair + ": listed at " + std::to_string(d) + " m");
        } else if (d > s.warning_distance) {
          ++in_band;
        }
        worst = std::max(worst, std::abs(it->second - d));
        if (!(std::abs(it->second - d) <= kTolerance)) {
          fail(pair + ": listed " + std::to_string(it->second) + " m, brute force " +
               std::to_string(d));
        }
      }
    }
    if (!(std::abs(r.min_distance - min_d) <= kTolerance) &&
        !(std::isinf(min_d) && std::isinf(r.min_distance))) {
      fail("cycle " + std::to_string(c) + ": min_distance " + std::to_string(r.min_distance) +
           ", brute force " + std::to_string(min_d));
    }
  }
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%zu cycles, %zu bodies of %zu parts, %zu enabled pairs, %zu pair-cycles below "
                "warning, %zu listed (%zu in the hysteresis band), max |listed - brute| %.3g m, "
                "%zu failures",
                cycles, nb, robot.parts, robot.enabled_pairs, below, listed, in_band, worst,
                failures);
  *summary = buf + (failures ? "; first: " + first : std::string());
  return failures == 0;
}

void robotCycle(benchmark::State& state, const Robot* robot, const world::Settings& settings) {
  Monitor m(*robot, settings);
  m.wrap = true;
  m.cycle(m.next++);
  double broad = 0, checked = 0, listed = 0;
  for (auto _ : state) {
    const world::CycleResult& r = m.cycle(m.next++);
    benchmark::DoNotOptimize(&r);
    broad += static_cast<double>(r.num_broad_phase_pairs);
    checked += static_cast<double>(r.num_pairs_checked);
    listed += static_cast<double>(r.pairs.size());
  }
  state.counters["bodies"] = static_cast<double>(robot->bodies.size());
  state.counters["parts"] = static_cast<double>(robot->parts);
  state.counters["enabled_pairs"] = static_cast<double>(robot->enabled_pairs);
  state.counters["broad_pairs"] = benchmark::Counter(broad, benchmark::Counter::kAvgIterations);
  state.counters["narrow_pairs"] = benchmark::Counter(checked, benchmark::Counter::kAvgIterations);
  state.counters["listed_pairs"] = benchmark::Counter(listed, benchmark::Counter::kAvgIterations);
}

/// The node's marker build after a check (MarkerBuilder::build() with the node's options but no
/// rate limit, the cycles 4 ms apart in its clock as in the trajectory): what a cycle holds the
/// world lock for beyond the check while rviz listens (Monitor::runCycle() builds them there).
/// Only the build is timed, not the check. `frame_locked`: the node's default, links drawn in
/// their TF frames and sent again only to refresh them; false: every moved link at its new pose
/// each cycle.
void markerBuild(benchmark::State& state, const Robot* robot, bool frame_locked) {
  Monitor m(*robot, world::Settings());
  m.wrap = true;
  rl::MarkerOptions options;
  options.max_rate = 0.0;
  options.frame_locked = frame_locked;
  rl::MarkerBuilder builder(options);
  double now = 0.0;
  benchmark::DoNotOptimize(builder.build(m.world(), m.cycle(m.next++), "base", now));  // every one
  double markers = 0;
  for (auto _ : state) {
    const world::CycleResult& r = m.cycle(m.next++);
    now += kDt;
    const auto start = std::chrono::steady_clock::now();
    const visualization_msgs::MarkerArray array = builder.build(m.world(), r, "base", now);
    state.SetIterationTime(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    markers += static_cast<double>(array.markers.size());
  }
  state.counters["markers"] = benchmark::Counter(markers, benchmark::Counter::kAvgIterations);
}

}  // namespace
}  // namespace cm_bench_robot

int main(int argc, char** argv) {
  using namespace cm_bench_robot;
  bool check = true;
  if (const char* env = std::getenv("CM_ROBOT_DATA"); env && *env) robotData = env;
  std::vector<char*> rest;
  for (int i = 0; i < argc; ++i) {
    if (std::strncmp(argv[i], "--cm_robot_data=", 16) == 0) {
      robotData = argv[i] + 16;
    } else if (std::strcmp(argv[i], "--cm_no_check") == 0) {
      check = false;
    } else {
      rest.push_back(argv[i]);
    }
  }
  int rest_argc = static_cast<int>(rest.size());
  benchmark::Initialize(&rest_argc, rest.data());
  if (benchmark::ReportUnrecognizedArguments(rest_argc, rest.data())) return 2;

  const std::string dir = robotData + "/example-robot-data/robots/";
  std::vector<std::unique_ptr<Robot>> robots;
  try {
    robots.push_back(std::make_unique<Robot>(
        "panda", dir + "panda_description/urdf/panda_collision.urdf",
        dir + "panda_description/srdf/panda.srdf", rl::MeshDecomposition::Hull));
    for (auto mode : {rl::MeshDecomposition::Hull, rl::MeshDecomposition::Pieces}) {
      robots.push_back(std::make_unique<Robot>(std::string("pr2_") + rl::toString(mode),
                                               dir + "pr2_description/urdf/pr2.urdf",
                                               dir + "pr2_description/srdf/pr2.srdf", mode));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_robot: %s (--cm_robot_data or CM_ROBOT_DATA)\n", e.what());
    return 2;
  }

  bool all_ok = true;
  world::Settings reach;
  reach.exact_min_distance = false;
  world::Settings libccd;
  libccd.backend = core::BackendType::Libccd;
  world::Settings twists;
  twists.estimate_twists = true;
  const std::pair<const char*, world::Settings> variants[] = {{"ours", world::Settings()},
                                                              {"ours_reach", reach},
                                                              {"ours_twists", twists},
                                                              {"libccd", libccd}};
  for (const auto& r : robots) {
    if (!check) break;
    std::string summary;
    const bool ok = checkRobot(*r, &summary);
    all_ok = all_ok && ok;
    std::printf("check %s: %s%s\n", r->name.c_str(), summary.c_str(), ok ? "" : "  <-- FAILED");
    benchmark::AddCustomContext("cm_check_" + r->name, summary);
  }
  std::fflush(stdout);
  benchmark::AddCustomContext("cm_correctness", check ? (all_ok ? "OK" : "FAILED") : "not checked");
  if (!all_ok) std::fprintf(stderr, "CORRECTNESS FAILED (see the check lines above)\n");

  for (const auto& r : robots) {
    const Robot* rp = r.get();
    benchmark::RegisterBenchmark(("BM_LoadUrdf/ours/" + rp->name).c_str(),
                                 [rp](benchmark::State& state) {
                                   for (auto _ : state) {
                                     auto robot = rp->load();
                                     if (!robot) state.SkipWithError(robot.error().c_str());
                                     benchmark::DoNotOptimize(robot);
                                   }
                                 })
        ->Unit(benchmark::kMillisecond);
  }
  for (const auto& [lib, settings] : variants) {
    for (const auto& r : robots) {
      const Robot* rp = r.get();
      const world::Settings st = settings;
      benchmark::RegisterBenchmark(("BM_Robot/" + std::string(lib) + "/" + rp->name).c_str(),
                                   [rp, st](benchmark::State& state) { robotCycle(state, rp, st); })
          ->Unit(benchmark::kMicrosecond);
    }
  }
  for (const auto& r : robots) {
    const Robot* rp = r.get();
    for (const bool locked : {true, false}) {
      benchmark::RegisterBenchmark(
          ("BM_Markers/" + std::string(locked ? "locked" : "unlocked") + "/" + rp->name).c_str(),
          [rp, locked](benchmark::State& st) { markerBuild(st, rp, locked); })
          ->UseManualTime()
          ->Unit(benchmark::kMicrosecond);
    }
  }
#ifdef CM_BENCH_HAVE_FCL
  for (const auto& r : robots) {
    const Robot* rp = r.get();
    benchmark::RegisterBenchmark(("BM_Robot/fcl/" + rp->name).c_str(), [rp](benchmark::State& st) {
      fclCycle(st, rp);
    })->Unit(benchmark::kMicrosecond);
  }
#endif
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return all_ok ? 0 : 1;
}
