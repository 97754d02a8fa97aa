/// \file
/// Load driver of the soak test (test/robustness/soak.test, scripts/soak.sh; issue #5).
///
/// Declares ~bodies (default 1,000) pose-topic bodies on <monitor>/bodies, plus ~tf_bodies bodies
/// attached to their own TF frames and ~tf_pairs static partners (attached to the fixed frame),
/// then drives the monitor for ~warmup + ~duration + ~quiet seconds:
///   - one <monitor>/body_poses message with every pose-topic body at ~pose_rate Hz (200), fresh
///     stamps, every background body moving by ~jitter (2 mm) so that the whole world changes;
///   - one /tf message with every TF body at ~tf_rate Hz (1 kHz);
///   - ~get_distance, ~check_collision and ~list_bodies called in three threads in parallel;
///   - a schedule: ~pose_pairs pose-topic pairs and ~tf_pairs TF pairs (spheres of 10 cm radius)
///     are toggled between 1 cm penetration and a 20 cm gap, pair i every 0.3 + 0.03 i s, during
///     the ~duration phase only (before: apart; the ~quiet phase keeps the last state).
///
/// It checks, online and at the end:
///   - every ~state message against the schedule: a pair overlapping in every pose the node could
///     have used (stamps from the state's stamp, the oldest pose used, to the receipt time) must
///     be COLLISION (or UNKNOWN, never CLEAR or WARNING); a pair apart in all of them must not be
///     COLLISION;
///   - every ~events message of a scheduled pair against the schedule at the event's stamp (the
///     stamp of the pair's poses): each toggle gets exactly one COLLISION_BEGIN / COLLISION_END,
///     none of the wrong kind, none for other pairs (events stamped before every body had its first
///     pose are the set-up's UNKNOWN intervals, counted apart); event latency = receipt time -
///     stamp of the first message that carried the toggle;
///   - the service answers: distances of scheduled pairs are -0.01 or 0.2, a hypothetical sphere
///     placed on a background body collides with it, list_bodies lists every body.
///
/// Progress and results: latched std_msgs/String on ~result, one JSON object with "phase"
/// (setup, warmup, run, quiet, done, failed) and, when done, every figure. The rostest
/// (test_soak.py) samples the node's memory and /diagnostics around it and asserts.
///
/// Parameters (private): monitor (node name, "collision_monitor"), frame ("world"), bodies (1000),
/// pose_pairs (16), tf_bodies (8), tf_pairs (4), pose_rate (200), tf_rate (1000), warmup (8 s),
/// duration (30 s), quiet (2 s), service_period (0.01 s, get_distance and check_collision),
/// list_period (0.1 s), jitter (0.002 m), setup_timeout (60 s).

#include <ros/ros.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "collision_monitor/Body.h"
#include "collision_monitor/BodyPoses.h"
#include "collision_monitor/CheckCollision.h"
#include "collision_monitor/CollisionEvent.h"
#include "collision_monitor/CollisionState.h"
#include "collision_monitor/GetDistance.h"
#include "collision_monitor/ListBodies.h"
#include "collision_monitor/PairState.h"
#include "collision_monitor/Shape.h"

namespace {

using Clock = std::chrono::steady_clock;
using collision_monitor::Body;
using collision_monitor::BodyPoses;
using collision_monitor::CollisionEvent;
using collision_monitor::CollisionState;
using collision_monitor::PairState;
using collision_monitor::Shape;

constexpr double kRadius = 0.1;       ///< scheduled pairs: spheres
constexpr double kOverlapX = 0.19;    ///< centre distance: 1 cm penetration
constexpr double kApartX = 0.40;      ///< centre distance: 20 cm gap
constexpr double kPairSpacing = 1.5;  ///< between scheduled pairs along x
constexpr double kCell = 0.6;         ///< background grid
constexpr double kStampTol = 1e-6;    ///< stamps go through double seconds in the node

geometry_msgs::Pose poseAt(double x, double y, double z, double yaw = 0.0) {
  geometry_msgs::Pose p;
  p.position.x = x;
  p.position.y = y;
  p.position.z = z;
  p.orientation.z = std::sin(yaw / 2);
  p.orientation.w = std::cos(yaw / 2);
  return p;
}

Shape sphere(double r, const geometry_msgs::Pose& at = poseAt(0, 0, 0)) {
  Shape s;
  s.type = Shape::SPHERE;
  s.dimensions = {r};
  s.pose = at;
  return s;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t i = std::min(
      v.size() - 1, static_cast<std::size_t>(std::max(1.0, std::ceil(p / 100.0 * v.size()))) - 1);
  return v[i];
}

/// A tiny JSON object writer (numbers, strings, booleans).
class Json {
 public:
  Json& num(const std::string& k, double v) {
    key(k);
    if (std::isfinite(v)) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.9g", v);
      os_ << buf;
    } else {
      os_ << "null";
    }
    return *this;
  }
  Json& integer(const std::string& k, long long v) {
    key(k);
    os_ << v;
    return *this;
  }
  Json& str(const std::string& k, const std::string& v) {
    key(k);
    os_ << '"';
    for (char c : v) {
      if (c == '"' || c == '\\') {
        os_ << '\\' << c;
      } else if (static_cast<unsigned char>(c) < 0x20) {
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", c);
        os_ << buf;
      } else {
        os_ << c;
      }
    }
    os_ << '"';
    return *this;
  }
  Json& boolean(const std::string& k, bool v) {
    key(k);
    os_ << (v ? "true" : "false");
    return *this;
  }
  /// p50 / p99 / max (and count) of `samples` scaled by `scale`, as <prefix>_p50 ...
  Json& dist(const std::string& prefix, const std::vector<double>& samples, double scale) {
    integer(prefix + "_n", static_cast<long long>(samples.size()));
    num(prefix + "_p50", percentile(samples, 50) * scale);
    num(prefix + "_p99", percentile(samples, 99) * scale);
    num(prefix + "_max",
        samples.empty() ? std::nan("") : *std::max_element(samples.begin(), samples.end()) * scale);
    return *this;
  }
  std::string text() const { return "{" + os_.str() + "}"; }

 private:
  void key(const std::string& k) {
    if (!first_) os_ << ", ";
    first_ = false;
    os_ << '"' << k << "\": ";
  }
  std::ostringstream os_;
  bool first_ = true;
};

/// One scheduled pair: a mover toggled between overlap and apart next to a partner.
struct Pair {
  std::string mover, partner;
  bool tf = false;        ///< mover attached to a TF frame (partner static) or pose-topic (both)
  double hold = 0.3;      ///< s between toggles
  double phase = 0.0;     ///< s
  double px = 0, py = 0;  ///< partner position
  struct Toggle {
    double stamp;  ///< stamp of the first message that carried the new state
    bool on;
  };
  std::vector<Toggle> toggles;  ///< alternating on / off, first on (guarded by Driver::mutex)
  bool on = false;              ///< current state (publisher thread)
  struct Ev {
    double recv, stamp;
    std::uint8_t type;
  };
  std::vector<Ev> events;  ///< guarded by Driver::mutex

  /// State of the schedule at `t` (ROS time) given by the toggles (mutex held).
  bool stateAt(double t, std::size_t* index = nullptr) const {
    auto it = std::upper_bound(toggles.begin(), toggles.end(), t,
                               [](double s, const Toggle& x) { return s < x.stamp; });
    if (index) *index = static_cast<std::size_t>(it - toggles.begin());  // toggles <= t
    return it == toggles.begin() ? false : std::prev(it)->on;
  }
};

struct ServiceStats {
  std::size_t calls = 0, ok = 0, refused = 0, wrong = 0, failed = 0;
  std::vector<double> latency;  ///< s
  std::string last_problem;
};

class Driver {
 public:
  Driver() : pnh_("~") {
    monitor_ = pnh_.param<std::string>("monitor", "collision_monitor");
    frame_ = pnh_.param<std::string>("frame", "world");
    n_bodies_ = std::max(4, pnh_.param("bodies", 1000));
    pose_pairs_ = std::clamp(pnh_.param("pose_pairs", 16), 1, n_bodies_ / 2 - 1);
    tf_bodies_ = std::max(0, pnh_.param("tf_bodies", 8));
    tf_pairs_ = std::clamp(pnh_.param("tf_pairs", 4), 0, tf_bodies_);
    pose_rate_ = pnh_.param("pose_rate", 200.0);
    tf_rate_ = pnh_.param("tf_rate", 1000.0);
    warmup_ = pnh_.param("warmup", 8.0);
    duration_ = pnh_.param("duration", 30.0);
    quiet_ = pnh_.param("quiet", 2.0);
    service_period_ = pnh_.param("service_period", 0.01);
    list_period_ = pnh_.param("list_period", 0.1);
    jitter_ = pnh_.param("jitter", 0.002);
    setup_timeout_ = pnh_.param("setup_timeout", 60.0);
    result_pub_ = pnh_.advertise<std_msgs::String>("result", 1, true);
    buildScene();
  }

  int run();

 private:
  void buildScene();
  void report(const std::string& phase, const std::string& extra = "");
  bool declareBodies();
  /// Waits until the monitor lists every body with a pose (the streams are running).
  bool waitFresh();
  void posesThread();
  void tfThread();
  void distanceThread();
  void checkThread();
  void listThread();
  void onEvent(const CollisionEvent::ConstPtr& msg);
  void onState(const CollisionState::ConstPtr& msg);
  /// Updates the schedule of `pair` for a message stamped `t`; records a toggle (mutex held).
  void schedule(Pair* pair, double t);
  std::string evaluate();
  static std::string key(const std::string& a, const std::string& b) {
    return a < b ? a + '\n' + b : b + '\n' + a;
  }
  /// Sleeps until `next` (+= period); counts whole periods skipped when behind.
  static void pace(Clock::time_point* next, Clock::duration period, std::size_t* skipped);

  ros::NodeHandle nh_, pnh_;
  std::string monitor_, frame_;
  int n_bodies_ = 1000, pose_pairs_ = 16, tf_bodies_ = 8, tf_pairs_ = 4;
  double pose_rate_ = 200, tf_rate_ = 1000, warmup_ = 8, duration_ = 30, quiet_ = 2;
  double service_period_ = 0.01, list_period_ = 0.1, jitter_ = 0.002, setup_timeout_ = 60;
  ros::Publisher result_pub_;

  // the scene
  std::vector<Body> bodies_;                                 ///< every body to declare
  std::vector<Pair> pairs_;                                  ///< pose pairs first, then TF pairs
  std::unordered_map<std::string, std::size_t> pair_index_;  ///< key(a, b) -> pairs_ index
  std::unordered_set<std::string> scheduled_ids_;
  std::vector<geometry_msgs::Pose> bg_nominal_;  ///< background bodies' nominal poses
  std::vector<std::string> bg_ids_;

  // timeline (ROS time, s); t_run_ / t_quiet_ set before the phases start
  std::atomic<double> t_run_{1e300}, t_quiet_{1e300};
  std::atomic<bool> stop_{false};

  mutable std::mutex mutex_;  ///< guards the pairs' toggles and events and what follows
  std::size_t poses_sent_ = 0, poses_sent_run_ = 0, poses_skipped_ = 0;
  std::size_t tf_sent_ = 0, tf_sent_run_ = 0, tf_skipped_ = 0;
  double poses_elapsed_ = 0, tf_elapsed_ = 0;
  std::size_t states_ = 0, states_run_ = 0, states_stale_ = 0;
  std::size_t not_collision_while_overlapping_ = 0, collision_while_apart_ = 0;
  std::size_t pair_checks_overlapping_ = 0, pair_checks_apart_ = 0;
  std::string first_violation_;
  std::vector<double> compute_time_, state_age_;
  std::size_t events_total_ = 0, events_other_pairs_ = 0;
  /// Events stamped before every body had its first pose (t_fresh_): the UNKNOWN intervals of
  /// the set-up (pairs of bodies without a pose yet), not part of the load test.
  std::size_t events_setup_ = 0;
  double t_fresh_ = std::numeric_limits<double>::infinity();
  std::string first_other_event_;
  ServiceStats distance_stats_, check_stats_, list_stats_;
  std::size_t list_min_ = 0;
};

void Driver::buildScene() {
  auto add = [this](const std::string& id, const std::string& frame, bool from_topic,
                    std::vector<Shape> parts) {
    Body b;
    b.header.frame_id = frame;
    b.id = id;
    b.operation = Body::ADD;
    b.pose_from_topic = from_topic;
    b.parts = std::move(parts);
    bodies_.push_back(std::move(b));
  };
  char id[32];
  for (int i = 0; i < pose_pairs_; ++i) {
    Pair p;
    std::snprintf(id, sizeof id, "soak_pm_%02d", i);
    p.mover = id;
    std::snprintf(id, sizeof id, "soak_pp_%02d", i);
    p.partner = id;
    p.px = kPairSpacing * i;
    p.py = -2.0;
    add(p.mover, frame_, true, {sphere(kRadius)});
    add(p.partner, frame_, true, {sphere(kRadius)});
    pairs_.push_back(std::move(p));
  }
  for (int j = 0; j < tf_bodies_; ++j) {
    std::snprintf(id, sizeof id, "soak_tf_%02d", j);
    add(id, id, false, {sphere(kRadius)});  // body id = its frame
    if (j < tf_pairs_) {
      Pair p;
      p.mover = id;
      p.tf = true;
      std::snprintf(id, sizeof id, "soak_tp_%02d", j);
      p.partner = id;
      p.px = kPairSpacing * j;
      p.py = -4.0;
      // Attached to the fixed frame (static: stamp 0), its sphere placed by the part's pose.
      add(p.partner, frame_, false, {sphere(kRadius, poseAt(p.px, p.py, 0.0))});
      pairs_.push_back(std::move(p));
    }
  }
  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    pairs_[i].hold = 0.3 + 0.03 * static_cast<double>(i);
    pairs_[i].phase = 0.011 * static_cast<double>(i);
    pair_index_[key(pairs_[i].mover, pairs_[i].partner)] = i;
    scheduled_ids_.insert(pairs_[i].mover);
    scheduled_ids_.insert(pairs_[i].partner);
  }
  // Background: a grid of spheres, boxes, capsules and hulls, 0.6 m apart (never near each other).
  const int n_bg = n_bodies_ - 2 * pose_pairs_;
  const int side = static_cast<int>(std::ceil(std::cbrt(static_cast<double>(n_bg))));
  for (int k = 0; k < n_bg; ++k) {
    std::snprintf(id, sizeof id, "soak_bg_%04d", k);
    Shape s;
    s.pose.orientation.w = 1.0;
    switch (k % 4) {
      case 0:
        s = sphere(0.1);
        break;
      case 1:
        s.type = Shape::BOX;
        s.dimensions = {0.15, 0.12, 0.1};
        break;
      case 2:
        s.type = Shape::CAPSULE;
        s.dimensions = {0.1, 0.05};
        break;
      default:
        s.type = Shape::CONVEX;
        for (int v = 0; v < 8; ++v) {
          geometry_msgs::Point pt;
          pt.x = ((v & 1) ? 0.07 : -0.07) + 0.01 * std::sin(k + v);
          pt.y = ((v & 2) ? 0.07 : -0.07) + 0.01 * std::cos(k * 3 + v);
          pt.z = ((v & 4) ? 0.07 : -0.07) + 0.01 * std::sin(k * 7 + v);
          s.vertices.push_back(pt);
        }
        break;
    }
    add(id, frame_, true, {s});
    bg_ids_.push_back(id);
    bg_nominal_.push_back(
        poseAt(kCell * (k % side), 2.0 + kCell * ((k / side) % side), kCell * (k / side / side)));
  }
}

void Driver::report(const std::string& phase, const std::string& extra) {
  std_msgs::String m;
  m.data = "{\"phase\": \"" + phase + "\"" + (extra.empty() ? "" : ", " + extra) + "}";
  result_pub_.publish(m);
  ROS_INFO_STREAM("soak_driver: phase " << phase);
}

bool Driver::declareBodies() {
  ros::Publisher pub = nh_.advertise<Body>(monitor_ + "/bodies", bodies_.size() + 10);
  ros::ServiceClient list =
      nh_.serviceClient<collision_monitor::ListBodies>(monitor_ + "/list_bodies");
  const auto deadline = Clock::now() + std::chrono::duration<double>(setup_timeout_);
  while (ros::ok() && pub.getNumSubscribers() == 0) {
    if (Clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (!list.waitForExistence(ros::Duration(std::max(1.0, setup_timeout_)))) return false;
  std::unordered_set<std::string> missing;
  for (const auto& b : bodies_)
    missing.insert(b.id);
  // The node's ~bodies queue holds 1,000 messages: send, then re-send what is not listed yet.
  auto last_send = Clock::now() - std::chrono::seconds(10);
  while (ros::ok() && Clock::now() < deadline) {
    if (Clock::now() - last_send > std::chrono::seconds(3)) {
      for (const auto& b : bodies_) {
        if (missing.count(b.id)) pub.publish(b);
      }
      last_send = Clock::now();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    collision_monitor::ListBodies srv;
    if (!list.call(srv)) continue;
    for (const auto& id : srv.response.ids)
      missing.erase(id);
    if (missing.empty()) return true;
  }
  ROS_ERROR_STREAM("soak_driver: " << missing.size() << " bodies not listed by the monitor");
  return false;
}

bool Driver::waitFresh() {
  ros::ServiceClient list =
      nh_.serviceClient<collision_monitor::ListBodies>(monitor_ + "/list_bodies");
  const auto deadline = Clock::now() + std::chrono::duration<double>(setup_timeout_);
  while (ros::ok() && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    collision_monitor::ListBodies srv;
    if (!list.call(srv)) continue;
    if (srv.response.ids.size() == bodies_.size() &&
        std::none_of(srv.response.stale.begin(), srv.response.stale.end(),
                     [](bool stale) { return stale; })) {
      return true;
    }
  }
  return false;
}

void Driver::pace(Clock::time_point* next, Clock::duration period, std::size_t* skipped) {
  *next += period;
  const auto now = Clock::now();
  if (now > *next + period) {
    const auto behind = (now - *next) / period;
    *skipped += static_cast<std::size_t>(behind);
    *next += behind * period;
  }
  std::this_thread::sleep_until(*next);
}

void Driver::schedule(Pair* pair, double t) {
  if (t < t_run_ || t >= t_quiet_) return;  // before: apart; quiet: frozen
  const bool on = static_cast<long long>(std::floor((t - t_run_ + pair->phase) / pair->hold)) % 2;
  if (on != pair->on) {
    pair->on = on;
    pair->toggles.push_back({t, on});
  }
}

void Driver::posesThread() {
  ros::Publisher pub = nh_.advertise<BodyPoses>(monitor_ + "/body_poses", 100);
  BodyPoses msg;
  msg.header.frame_id = frame_;
  for (const auto& p : pairs_) {
    if (p.tf) continue;
    msg.ids.push_back(p.mover);
    msg.poses.push_back(poseAt(p.px + kApartX, p.py, 0.0));
    msg.ids.push_back(p.partner);
    msg.poses.push_back(poseAt(p.px, p.py, 0.0));
  }
  const std::size_t first_bg = msg.ids.size();
  for (std::size_t k = 0; k < bg_ids_.size(); ++k) {
    msg.ids.push_back(bg_ids_[k]);
    msg.poses.push_back(bg_nominal_[k]);
  }
  while (!stop_ && ros::ok() && pub.getNumSubscribers() == 0)  // nothing sent into the void
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / pose_rate_));
  const auto start = Clock::now();
  auto next = start;
  std::size_t sent = 0, skipped = 0;
  while (!stop_ && ros::ok()) {
    const ros::Time stamp = ros::Time::now();
    const double t = stamp.toSec();
    msg.header.stamp = stamp;
    for (std::size_t k = 0; k < bg_ids_.size(); ++k) {
      const double w = 2 * M_PI * 0.5 * t + static_cast<double>(k);
      const auto& n = bg_nominal_[k].position;
      msg.poses[first_bg + k] = poseAt(n.x + jitter_ * std::sin(w), n.y + jitter_ * std::cos(w),
                                       n.z + jitter_ * std::sin(1.3 * w), 0.05 * std::sin(w));
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);  // toggles recorded before the message leaves
      std::size_t slot = 0;
      for (auto& p : pairs_) {
        if (p.tf) continue;
        schedule(&p, t);
        msg.poses[slot].position.x = p.px + (p.on ? kOverlapX : kApartX);
        slot += 2;
      }
    }
    pub.publish(msg);
    ++sent;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      poses_sent_ = sent;
      if (t >= t_run_ && t < t_quiet_) ++poses_sent_run_;
      poses_skipped_ = skipped;
      poses_elapsed_ = std::chrono::duration<double>(Clock::now() - start).count();
    }
    pace(&next, period, &skipped);
  }
}

void Driver::tfThread() {
  if (tf_bodies_ == 0) return;
  // What tf2_ros::TransformBroadcaster does, with a publisher whose subscribers can be counted.
  ros::Publisher pub = nh_.advertise<tf2_msgs::TFMessage>("/tf", 100);
  tf2_msgs::TFMessage msg;
  auto& tfs = msg.transforms;
  tfs.resize(tf_bodies_);
  char id[32];
  for (int j = 0; j < tf_bodies_; ++j) {
    std::snprintf(id, sizeof id, "soak_tf_%02d", j);
    tfs[j].header.frame_id = frame_;
    tfs[j].child_frame_id = id;
    tfs[j].transform.translation.x = kPairSpacing * j + kApartX;
    tfs[j].transform.translation.y = -4.0;
    tfs[j].transform.rotation.w = 1.0;
  }
  while (!stop_ && ros::ok() && pub.getNumSubscribers() == 0)  // nothing sent into the void
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / tf_rate_));
  const auto start = Clock::now();
  auto next = start;
  std::size_t sent = 0, skipped = 0;
  const std::size_t first_tf_pair = static_cast<std::size_t>(pose_pairs_);
  while (!stop_ && ros::ok()) {
    const ros::Time stamp = ros::Time::now();
    const double t = stamp.toSec();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (int j = 0; j < tf_bodies_; ++j) {
        tfs[j].header.stamp = stamp;
        if (j < tf_pairs_) {
          Pair& p = pairs_[first_tf_pair + j];
          schedule(&p, t);
          tfs[j].transform.translation.x = p.px + (p.on ? kOverlapX : kApartX);
        } else {  // free TF bodies wander by the jitter
          tfs[j].transform.translation.x = kPairSpacing * j + jitter_ * std::sin(2 * M_PI * t + j);
        }
      }
    }
    pub.publish(msg);
    ++sent;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      tf_sent_ = sent;
      if (t >= t_run_ && t < t_quiet_) ++tf_sent_run_;
      tf_skipped_ = skipped;
      tf_elapsed_ = std::chrono::duration<double>(Clock::now() - start).count();
    }
    pace(&next, period, &skipped);
  }
}

/// Calls `call` every `period` s until stop, timing it; `call` returns "" when the answer is
/// right, "refused: ..." when success was false, or another text when the answer is wrong.
template <class Srv>
void serviceLoop(ros::NodeHandle& nh, const std::string& name, double period,
                 const std::atomic<bool>& stop, std::mutex& mutex, ServiceStats* stats,
                 const std::function<void(Srv*, std::size_t)>& fill,
                 const std::function<std::string(const Srv&, std::size_t)>& judge) {
  ros::ServiceClient client = nh.serviceClient<Srv>(name, true);
  const auto dt =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(period));
  auto next = Clock::now();
  for (std::size_t k = 0; !stop && ros::ok(); ++k) {
    if (!client.isValid()) client = nh.serviceClient<Srv>(name, true);
    Srv srv;
    fill(&srv, k);
    const auto t0 = Clock::now();
    const bool ok = client.call(srv);
    const double latency = std::chrono::duration<double>(Clock::now() - t0).count();
    {
      std::lock_guard<std::mutex> lock(mutex);
      ++stats->calls;
      if (!ok) {
        ++stats->failed;
        stats->last_problem = "call failed (transport)";
      } else {
        stats->latency.push_back(latency);
        const std::string why = judge(srv, k);
        if (why.empty()) {
          ++stats->ok;
        } else if (why.rfind("refused", 0) == 0) {
          ++stats->refused;
          stats->last_problem = why;
        } else {
          ++stats->wrong;
          stats->last_problem = why;
        }
      }
    }
    if (!ok) client = nh.serviceClient<Srv>(name, true);
    next += dt;
    const auto now = Clock::now();
    if (now > next + dt) next = now;  // behind: no catching up in a burst
    std::this_thread::sleep_until(next);
  }
}

void Driver::distanceThread() {
  using collision_monitor::GetDistance;
  const std::size_t n = static_cast<std::size_t>(pose_pairs_);
  serviceLoop<GetDistance>(
      nh_, monitor_ + "/get_distance", service_period_, stop_, mutex_, &distance_stats_,
      [&](GetDistance* srv, std::size_t k) {
        srv->request.body_a = pairs_[k % n].mover;
        srv->request.body_b = pairs_[k % n].partner;
      },
      [&](const GetDistance& srv, std::size_t /*k*/) -> std::string {
        if (!srv.response.success) return "refused: " + srv.response.message;
        const double d = srv.response.result.distance;
        const double overlap = kOverlapX - 2 * kRadius, apart = kApartX - 2 * kRadius;
        if (std::abs(d - overlap) < 1e-6 || std::abs(d - apart) < 1e-6) return {};
        return "get_distance " + srv.request.body_a + " " + srv.request.body_b + " = " +
               std::to_string(d) + " (want " + std::to_string(overlap) + " or " +
               std::to_string(apart) + ")";
      });
}

void Driver::checkThread() {
  using collision_monitor::CheckCollision;
  serviceLoop<CheckCollision>(
      nh_, monitor_ + "/check_collision", service_period_, stop_, mutex_, &check_stats_,
      [&](CheckCollision* srv, std::size_t k) {
        const std::size_t b = (k * 37) % bg_ids_.size();
        srv->request.body.id = "soak_probe";
        srv->request.body.header.frame_id = frame_;
        srv->request.body.parts = {sphere(0.05)};
        srv->request.pose = bg_nominal_[b];
        srv->request.margin = 0.0;
      },
      [&](const CheckCollision& srv, std::size_t k) -> std::string {
        if (!srv.response.success) return "refused: " + srv.response.message;
        const std::string& want = bg_ids_[(k * 37) % bg_ids_.size()];
        bool found = false;
        for (const auto& p : srv.response.pairs)
          found = found || p.body_a == want || p.body_b == want;
        if (srv.response.in_collision && found) return {};
        return "check_collision on " + want + ": in_collision " +
               std::to_string(srv.response.in_collision) + ", " +
               std::to_string(srv.response.pairs.size()) + " pairs, " + want +
               (found ? " listed" : " not listed");
      });
}

void Driver::listThread() {
  using collision_monitor::ListBodies;
  serviceLoop<ListBodies>(
      nh_, monitor_ + "/list_bodies", list_period_, stop_, mutex_, &list_stats_,
      [](ListBodies*, std::size_t) {},
      [&](const ListBodies& srv, std::size_t) -> std::string {
        // mutex_ is held by serviceLoop while judging.
        list_min_ = std::min(list_min_, srv.response.ids.size());
        if (srv.response.ids.size() == bodies_.size()) return {};
        return "list_bodies: " + std::to_string(srv.response.ids.size()) + " bodies, want " +
               std::to_string(bodies_.size());
      });
}

void Driver::onEvent(const CollisionEvent::ConstPtr& msg) {
  const double recv = ros::Time::now().toSec();
  std::lock_guard<std::mutex> lock(mutex_);
  ++events_total_;
  if (msg->header.stamp.toSec() < t_fresh_) {
    ++events_setup_;
    return;
  }
  auto it = pair_index_.find(key(msg->pair.body_a, msg->pair.body_b));
  if (it == pair_index_.end()) {
    ++events_other_pairs_;
    if (first_other_event_.empty()) {
      first_other_event_ = "event " + std::to_string(msg->type) + " for " + msg->pair.body_a +
                           " / " + msg->pair.body_b + " (distance " +
                           std::to_string(msg->pair.distance) + ")";
    }
    return;
  }
  pairs_[it->second].events.push_back({recv, msg->header.stamp.toSec(), msg->type});
}

void Driver::onState(const CollisionState::ConstPtr& msg) {
  const double recv = ros::Time::now().toSec();
  const double stamp = msg->header.stamp.toSec();
  std::vector<int> status(pairs_.size(), PairState::CLEAR);
  for (const auto& p : msg->pairs) {
    auto it = pair_index_.find(key(p.body_a, p.body_b));
    if (it != pair_index_.end()) status[it->second] = p.status;
  }
  std::unordered_set<std::string> stale;
  for (const auto& id : msg->stale_bodies) {
    if (scheduled_ids_.count(id)) stale.insert(id);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  ++states_;
  if (stamp < t_run_ || stamp >= t_quiet_ + quiet_) return;
  ++states_run_;
  compute_time_.push_back(msg->compute_time);
  state_age_.push_back(recv - stamp);
  if (!msg->stale_bodies.empty()) ++states_stale_;
  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    const Pair& p = pairs_[i];
    if (stale.count(p.mover) || stale.count(p.partner)) continue;  // UNKNOWN: never CLEAR
    // The poses the node used for this pair are stamped in [stamp, recv].
    std::size_t from = 0, to = 0;
    const bool on = p.stateAt(stamp - kStampTol, &from);
    p.stateAt(recv, &to);
    if (from != to) continue;  // toggled within the window: either verdict may be right
    if (on) {
      ++pair_checks_overlapping_;
      if (status[i] != PairState::COLLISION && status[i] != PairState::UNKNOWN) {
        ++not_collision_while_overlapping_;
        if (first_violation_.empty()) {
          first_violation_ = "~state stamp " + std::to_string(stamp) + ": " + p.mover + " / " +
                             p.partner + " overlapping, reported status " +
                             std::to_string(status[i]);
        }
      }
    } else {
      ++pair_checks_apart_;
      if (status[i] == PairState::COLLISION) {
        ++collision_while_apart_;
        if (first_violation_.empty()) {
          first_violation_ = "~state stamp " + std::to_string(stamp) + ": " + p.mover + " / " +
                             p.partner + " apart, reported COLLISION";
        }
      }
    }
  }
}

std::string Driver::evaluate() {
  std::lock_guard<std::mutex> lock(mutex_);
  Json j;
  std::size_t toggles = 0, matched = 0, missed = 0, excused_missed = 0, wrong = 0, duplicate = 0,
              excused = 0, unknown_events = 0, warning_events = 0;
  std::vector<double> latency, latency_pose, latency_tf, lag;
  std::string first_problem;
  for (const Pair& p : pairs_) {
    std::vector<bool> got(p.toggles.size(), false);
    std::vector<std::pair<double, double>> unknown;  // UNKNOWN intervals (stamps)
    double unknown_since = -1;
    for (std::size_t e = 0; e < p.events.size(); ++e) {
      const auto& ev = p.events[e];
      const auto type = ev.type;
      if (type == CollisionEvent::UNKNOWN_BEGIN) {
        ++unknown_events;
        unknown_since = ev.stamp;
        continue;
      }
      if (type == CollisionEvent::UNKNOWN_END) {
        ++unknown_events;
        unknown.emplace_back(unknown_since < 0 ? ev.stamp : unknown_since, ev.stamp);
        unknown_since = -1;
        continue;
      }
      if (type == CollisionEvent::WARNING_BEGIN || type == CollisionEvent::WARNING_END) {
        ++warning_events;  // the schedule jumps between -1 cm and 20 cm: never WARNING
        if (first_problem.empty()) first_problem = "WARNING event for " + p.mover;
        continue;
      }
      const bool want_on = type == CollisionEvent::COLLISION_BEGIN;
      // An END right before UNKNOWN_BEGIN, a BEGIN right after UNKNOWN_END: part of a stale spell.
      const bool next_unknown =
          e + 1 < p.events.size() && p.events[e + 1].type == CollisionEvent::UNKNOWN_BEGIN;
      const bool prev_unknown = e > 0 && p.events[e - 1].type == CollisionEvent::UNKNOWN_END;
      std::size_t k = 0;
      const bool on = p.stateAt(ev.stamp + kStampTol, &k);  // k toggles at or before the stamp
      if (on != want_on) {
        if ((!want_on && next_unknown) || (want_on && prev_unknown)) {
          ++excused;
        } else {
          ++wrong;
          if (first_problem.empty()) {
            first_problem = "event " + std::to_string(type) + " for " + p.mover + " at stamp " +
                            std::to_string(ev.stamp) + " while the schedule says " +
                            (on ? "overlapping" : "apart");
          }
        }
        continue;
      }
      if (k == 0 || got[k - 1]) {
        if (prev_unknown) {
          ++excused;
        } else {
          ++duplicate;
          if (first_problem.empty()) first_problem = "duplicate event for " + p.mover;
        }
        continue;
      }
      got[k - 1] = true;
      const auto& tg = p.toggles[k - 1];
      latency.push_back(ev.recv - tg.stamp);
      (p.tf ? latency_tf : latency_pose).push_back(ev.recv - tg.stamp);
      lag.push_back(ev.stamp - tg.stamp);
    }
    if (unknown_since >= 0) unknown.emplace_back(unknown_since, 1e300);
    for (std::size_t k = 0; k < p.toggles.size(); ++k) {
      ++toggles;
      if (got[k]) {
        ++matched;
        continue;
      }
      const double a = p.toggles[k].stamp,
                   b = k + 1 < p.toggles.size() ? p.toggles[k + 1].stamp : 1e300;
      bool during_unknown = false;
      for (const auto& [u0, u1] : unknown)
        during_unknown = during_unknown || (u0 < b && u1 > a);
      if (during_unknown) {
        ++excused_missed;
      } else {
        ++missed;
        if (first_problem.empty()) {
          first_problem = "no event for the toggle of " + p.mover + " to " +
                          (p.toggles[k].on ? "overlapping" : "apart") + " at stamp " +
                          std::to_string(a);
        }
      }
    }
  }
  const double run = duration_;
  j.integer("bodies", static_cast<long long>(bodies_.size()))
      .integer("pose_bodies", n_bodies_)
      .integer("tf_bodies", tf_bodies_)
      .integer("scheduled_pairs", static_cast<long long>(pairs_.size()))
      .num("pose_rate", pose_rate_)
      .num("tf_rate", tf_rate_)
      .num("warmup", warmup_)
      .num("duration", duration_)
      .num("quiet", quiet_)
      .integer("poses_sent", static_cast<long long>(poses_sent_))
      .integer("poses_sent_run", static_cast<long long>(poses_sent_run_))
      .integer("poses_skipped", static_cast<long long>(poses_skipped_))
      .num("poses_rate_achieved", poses_elapsed_ > 0 ? poses_sent_ / poses_elapsed_ : 0)
      .num("poses_rate_run", poses_sent_run_ / run)
      .integer("tf_sent", static_cast<long long>(tf_sent_))
      .integer("tf_sent_run", static_cast<long long>(tf_sent_run_))
      .integer("tf_skipped", static_cast<long long>(tf_skipped_))
      .num("tf_rate_achieved", tf_elapsed_ > 0 ? tf_sent_ / tf_elapsed_ : 0)
      .num("tf_rate_run", tf_sent_run_ / run)
      .integer("states", static_cast<long long>(states_))
      .integer("states_run", static_cast<long long>(states_run_))
      .integer("states_with_stale", static_cast<long long>(states_stale_))
      .dist("compute_time_ms", compute_time_, 1e3)
      .dist("state_age_ms", state_age_, 1e3)
      .integer("pair_checks_overlapping", static_cast<long long>(pair_checks_overlapping_))
      .integer("pair_checks_apart", static_cast<long long>(pair_checks_apart_))
      .integer("not_collision_while_overlapping",
               static_cast<long long>(not_collision_while_overlapping_))
      .integer("collision_while_apart", static_cast<long long>(collision_while_apart_))
      .str("first_state_violation", first_violation_)
      .integer("toggles", static_cast<long long>(toggles))
      .integer("toggles_reported", static_cast<long long>(matched))
      .integer("toggles_missed", static_cast<long long>(missed))
      .integer("toggles_missed_while_unknown", static_cast<long long>(excused_missed))
      .integer("events_wrong", static_cast<long long>(wrong))
      .integer("events_duplicate", static_cast<long long>(duplicate))
      .integer("events_excused_unknown", static_cast<long long>(excused))
      .integer("events_unknown", static_cast<long long>(unknown_events))
      .integer("events_warning", static_cast<long long>(warning_events))
      .integer("events_total", static_cast<long long>(events_total_))
      .integer("events_other_pairs", static_cast<long long>(events_other_pairs_))
      .integer("events_setup", static_cast<long long>(events_setup_))
      .str("first_other_event", first_other_event_)
      .str("first_event_problem", first_problem)
      .dist("event_latency_ms", latency, 1e3)
      .dist("event_latency_pose_ms", latency_pose, 1e3)
      .dist("event_latency_tf_ms", latency_tf, 1e3)
      .dist("event_lag_ms", lag, 1e3);
  const std::pair<const char*, const ServiceStats*> services[] = {
      {"get_distance", &distance_stats_},
      {"check_collision", &check_stats_},
      {"list_bodies", &list_stats_}};
  for (const auto& [name, s] : services) {
    const std::string n = name;
    j.integer(n + "_calls", static_cast<long long>(s->calls))
        .integer(n + "_ok", static_cast<long long>(s->ok))
        .integer(n + "_refused", static_cast<long long>(s->refused))
        .integer(n + "_wrong", static_cast<long long>(s->wrong))
        .integer(n + "_failed", static_cast<long long>(s->failed))
        .str(n + "_last_problem", s->last_problem)
        .dist(n + "_ms", s->latency, 1e3);
  }
  j.integer("list_bodies_min", static_cast<long long>(list_min_));
  return j.text();
}

int Driver::run() {
  report("setup");
  ros::AsyncSpinner spinner(2);
  spinner.start();
  if (!declareBodies()) {
    report("failed", "\"why\": \"the monitor did not list every body within setup_timeout\"");
    ros::waitForShutdown();
    return 1;
  }
  list_min_ = bodies_.size();
  const auto hints = ros::TransportHints().tcpNoDelay();
  ros::Subscriber events_sub =
      nh_.subscribe(monitor_ + "/events", 10000, &Driver::onEvent, this, hints);
  ros::Subscriber state_sub =
      nh_.subscribe(monitor_ + "/state", 1000, &Driver::onState, this, hints);

  std::vector<std::thread> threads;
  threads.emplace_back([this] { posesThread(); });
  threads.emplace_back([this] { tfThread(); });
  if (!waitFresh()) {
    stop_ = true;
    for (auto& t : threads)
      t.join();
    report("failed", "\"why\": \"bodies still stale after setup_timeout\"");
    ros::waitForShutdown();
    return 1;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    t_fresh_ = ros::Time::now().toSec();
  }
  threads.emplace_back([this] { distanceThread(); });
  threads.emplace_back([this] { checkThread(); });
  threads.emplace_back([this] { listThread(); });
  report("warmup");
  auto sleep = [](double s) {
    const auto until = Clock::now() + std::chrono::duration<double>(s);
    while (ros::ok() && Clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
  };
  sleep(warmup_);
  const double t0 = ros::Time::now().toSec();
  t_quiet_ = t0 + duration_;
  t_run_ = t0;
  report("run");
  sleep(duration_);
  report("quiet");
  sleep(quiet_);
  // Late events and states (the publishers stop after the quiet phase).
  stop_ = true;
  for (auto& t : threads)
    t.join();
  sleep(0.5);
  events_sub.shutdown();
  state_sub.shutdown();
  if (!ros::ok()) return 1;
  const std::string figures = evaluate();
  report("done", "\"figures\": " + figures);
  ROS_INFO_STREAM("soak_driver: " << figures);
  ros::waitForShutdown();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "soak_driver");
  Driver driver;
  return driver.run();
}
