/// \file
/// End-to-end latency probe for collision_monitor_node over loopback (bench/latency.launch,
/// scripts/bench_latency.sh).
///
/// Publishes ~n bodies on <monitor>/bodies (all pose_from_topic) and poses them with one
/// <monitor>/body_poses message (stamp 0: static). Two of them, "mover" and "target" (spheres of
/// 5 cm radius), sit apart from the n - 2 others (spheres, boxes and convex hulls on a 0.3 m grid,
/// as in bench_world.cpp). Then, ~transitions times, the probe moves "mover" alternately into
/// contact with "target" (1 cm penetration) and out of reach (20 cm gap) with a BodyPoses message
/// holding only the mover, stamped with the current ROS time, and waits for the matching
/// <monitor>/events message: COLLISION_BEGIN resp. COLLISION_END of the pair, recognised by its
/// header.stamp (the node stamps events with the pose stamp the verdict came from). Latency = wall
/// time (steady clock) from just before publish() to the event callback. A random pause of
/// ~gap_min..~gap_max s follows each transition, so that transitions do not lock onto the
/// node's heartbeat.
///
/// Prints p50 / p90 / p99 / max / mean in ms and writes one line per transition to ~output (CSV)
/// when given. Exit status 0 when every transition got its event, 1 otherwise.
///
/// Parameters (private): n (1000), transitions (1000), gap_min (0.005), gap_max (0.015),
/// timeout (1.0 s per transition), monitor (node name, "collision_monitor"), frame ("world"),
/// output (""), seed (1).

#include <ros/ros.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "collision_monitor/Body.h"
#include "collision_monitor/BodyPoses.h"
#include "collision_monitor/CollisionEvent.h"
#include "collision_monitor/CollisionState.h"
#include "collision_monitor/Shape.h"

namespace {

using Clock = std::chrono::steady_clock;
using collision_monitor::Body;
using collision_monitor::BodyPoses;
using collision_monitor::CollisionEvent;
using collision_monitor::CollisionState;
using collision_monitor::Shape;

geometry_msgs::Pose poseAt(double x, double y, double z) {
  geometry_msgs::Pose p;
  p.position.x = x;
  p.position.y = y;
  p.position.z = z;
  p.orientation.w = 1.0;
  return p;
}

Shape sphere(double r) {
  Shape s;
  s.type = Shape::SPHERE;
  s.dimensions = {r};
  s.pose.orientation.w = 1.0;
  return s;
}

struct Probe {
  std::mutex mutex;
  std::condition_variable cv;
  // The transition being waited for.
  bool waiting = false;
  double want_stamp = 0.0;
  std::uint8_t want_type = 0;
  bool got = false;
  Clock::time_point got_at;
  int unexpected = 0;
  // Last state.
  std::uint32_t num_bodies = 0;
  std::size_t num_stale = 0;
  std::size_t states = 0;
  double compute_sum = 0.0;
  double compute_max = 0.0;

  void onEvent(const CollisionEvent::ConstPtr& msg) {
    const Clock::time_point now = Clock::now();
    std::lock_guard<std::mutex> lock(mutex);
    const bool ours = (msg->pair.body_a == "mover" && msg->pair.body_b == "target") ||
                      (msg->pair.body_a == "target" && msg->pair.body_b == "mover");
    if (waiting && !got && ours && msg->type == want_type &&
        std::abs(msg->header.stamp.toSec() - want_stamp) < 1e-5) {
      got = true;
      got_at = now;
      cv.notify_all();
    } else {
      ++unexpected;
    }
  }

  void onState(const CollisionState::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex);
    num_bodies = msg->num_bodies;
    num_stale = msg->stale_bodies.size();
    ++states;
    compute_sum += msg->compute_time;
    compute_max = std::max(compute_max, msg->compute_time);
  }
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t i =
      std::min(v.size() - 1, static_cast<std::size_t>(std::ceil(p / 100.0 * v.size())) - 1);
  return v[i];
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "latency_probe");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  const int n = std::max(2, pnh.param("n", 1000));
  const int transitions = pnh.param("transitions", 1000);
  const double gap_min = pnh.param("gap_min", 0.005);
  const double gap_max = std::max(gap_min, pnh.param("gap_max", 0.015));
  const double timeout = pnh.param("timeout", 1.0);
  const std::string monitor = pnh.param<std::string>("monitor", "collision_monitor");
  const std::string frame = pnh.param<std::string>("frame", "world");
  const std::string output = pnh.param<std::string>("output", "");
  std::mt19937_64 rng(static_cast<std::uint64_t>(pnh.param("seed", 1)));

  Probe probe;
  ros::Publisher bodies_pub = nh.advertise<Body>(monitor + "/bodies", n + 10);
  ros::Publisher poses_pub = nh.advertise<BodyPoses>(monitor + "/body_poses", 100);
  ros::Subscriber events_sub = nh.subscribe(monitor + "/events", 1000, &Probe::onEvent, &probe,
                                            ros::TransportHints().tcpNoDelay());
  ros::Subscriber state_sub = nh.subscribe(monitor + "/state", 10, &Probe::onState, &probe,
                                           ros::TransportHints().tcpNoDelay());
  ros::AsyncSpinner spinner(1);
  spinner.start();

  // Wait for the monitor.
  const auto deadline = Clock::now() + std::chrono::seconds(60);
  while (ros::ok() && (bodies_pub.getNumSubscribers() == 0 || poses_pub.getNumSubscribers() == 0 ||
                       events_sub.getNumPublishers() == 0)) {
    if (Clock::now() > deadline) {
      ROS_ERROR("latency_probe: no monitor on %s after 60 s", monitor.c_str());
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }

  // The scene: mover and target at the origin region, the others on a grid further out.
  const double kCell = 0.3;
  const geometry_msgs::Pose target_pose = poseAt(0.0, 0.0, 0.0);
  const geometry_msgs::Pose in_pose = poseAt(0.09, 0.0, 0.0);   // 1 cm penetration
  const geometry_msgs::Pose out_pose = poseAt(0.30, 0.0, 0.0);  // 20 cm gap
  BodyPoses all_poses;
  all_poses.header.frame_id = frame;  // stamp 0: static poses
  std::vector<Body> bodies;
  {
    Body b;
    b.header.frame_id = frame;
    b.operation = Body::ADD;
    b.pose_from_topic = true;
    b.id = "target";
    b.parts = {sphere(0.05)};
    bodies.push_back(b);
    all_poses.ids.push_back(b.id);
    all_poses.poses.push_back(target_pose);
    b.id = "mover";
    bodies.push_back(b);
    all_poses.ids.push_back(b.id);
    all_poses.poses.push_back(out_pose);
  }
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const int side = static_cast<int>(std::ceil(std::cbrt(static_cast<double>(n)))) + 2;
  int made = 0;
  for (int x = 0; x < side && made < n - 2; ++x) {
    for (int y = 0; y < side && made < n - 2; ++y) {
      for (int z = 0; z < side && made < n - 2; ++z) {
        Body b;
        b.header.frame_id = frame;
        b.operation = Body::ADD;
        b.pose_from_topic = true;
        char id[16];
        std::snprintf(id, sizeof id, "o%05d", made);
        b.id = id;
        Shape s;
        s.pose.orientation.w = 1.0;
        switch (made % 3) {
          case 0:
            s = sphere(0.03 + 0.06 * u01(rng));
            break;
          case 1:
            s.type = Shape::BOX;
            s.dimensions = {0.04 + 0.07 * u01(rng), 0.04 + 0.07 * u01(rng), 0.04 + 0.07 * u01(rng)};
            break;
          default: {
            s.type = Shape::CONVEX;
            std::normal_distribution<double> g(0.0, 1.0);
            const double a = 0.03 + 0.06 * u01(rng), bb = 0.03 + 0.06 * u01(rng),
                         c = 0.03 + 0.06 * u01(rng);
            for (int v = 0; v < 16; ++v) {
              double vx = g(rng), vy = g(rng), vz = g(rng);
              const double norm = std::sqrt(vx * vx + vy * vy + vz * vz);
              geometry_msgs::Point p;
              p.x = a * vx / norm;
              p.y = bb * vy / norm;
              p.z = c * vz / norm;
              s.vertices.push_back(p);
            }
            break;
          }
        }
        b.parts = {s};
        bodies.push_back(b);
        all_poses.ids.push_back(b.id);
        // Grid starting 1 m away from the pair (x >= 1 m), 0.3 m spacing, small jitter.
        all_poses.poses.push_back(poseAt(1.0 + kCell * x + 0.05 * (u01(rng) - 0.5),
                                         kCell * (y - side / 2) + 0.05 * (u01(rng) - 0.5),
                                         kCell * (z - side / 2) + 0.05 * (u01(rng) - 0.5)));
        ++made;
      }
    }
  }
  for (const Body& b : bodies) {
    bodies_pub.publish(b);
  }
  // Wait until the monitor holds every body with a pose (re-send the poses now and then: the
  // bodies may still be on their way when the first poses arrive).
  const auto ready_deadline = Clock::now() + std::chrono::seconds(120);
  auto last_poses = Clock::now() - std::chrono::seconds(10);
  for (;;) {
    if (!ros::ok()) return 1;
    if (Clock::now() - last_poses > std::chrono::milliseconds(500)) {
      poses_pub.publish(all_poses);
      last_poses = Clock::now();
    }
    {
      std::lock_guard<std::mutex> lock(probe.mutex);
      if (probe.num_bodies == static_cast<std::uint32_t>(n) && probe.num_stale == 0) break;
    }
    if (Clock::now() > ready_deadline) {
      std::lock_guard<std::mutex> lock(probe.mutex);
      ROS_ERROR("latency_probe: monitor holds %u bodies (%zu stale), want %d fresh",
                probe.num_bodies, probe.num_stale, n);
      return 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  {
    std::lock_guard<std::mutex> lock(probe.mutex);
    probe.unexpected = 0;
    probe.states = 0;
    probe.compute_sum = 0.0;
    probe.compute_max = 0.0;
  }

  std::vector<double> lat_ms;
  std::vector<int> kinds;
  int timeouts = 0;
  std::uniform_real_distribution<double> gap(gap_min, gap_max);
  double last_stamp = 0.0;
  for (int k = 0; k < transitions && ros::ok(); ++k) {
    const bool into = k % 2 == 0;
    BodyPoses msg;
    msg.header.frame_id = frame;
    ros::Time stamp = ros::Time::now();
    if (stamp.toSec() <= last_stamp + 1e-4) stamp = ros::Time(last_stamp + 1e-4);
    last_stamp = stamp.toSec();
    msg.header.stamp = stamp;
    msg.ids = {"mover"};
    msg.poses = {into ? in_pose : out_pose};
    Clock::time_point t0;
    {
      std::lock_guard<std::mutex> lock(probe.mutex);
      probe.waiting = true;
      probe.got = false;
      probe.want_stamp = stamp.toSec();
      probe.want_type = into ? CollisionEvent::COLLISION_BEGIN : CollisionEvent::COLLISION_END;
      t0 = Clock::now();
    }
    poses_pub.publish(msg);
    std::unique_lock<std::mutex> lock(probe.mutex);
    const bool ok =
        probe.cv.wait_for(lock, std::chrono::duration<double>(timeout), [&] { return probe.got; });
    probe.waiting = false;
    if (ok) {
      lat_ms.push_back(1e3 * std::chrono::duration<double>(probe.got_at - t0).count());
      kinds.push_back(into ? 1 : 2);
    } else {
      ++timeouts;
      ROS_WARN("latency_probe: transition %d (%s) timed out", k, into ? "into contact" : "out");
    }
    lock.unlock();
    std::this_thread::sleep_for(std::chrono::duration<double>(gap(rng)));
  }

  double mean = 0.0;
  for (double v : lat_ms)
    mean += v;
  if (!lat_ms.empty()) mean /= static_cast<double>(lat_ms.size());
  int unexpected;
  std::size_t states;
  double compute_mean, compute_max;
  {
    std::lock_guard<std::mutex> lock(probe.mutex);
    unexpected = probe.unexpected;
    states = probe.states;
    compute_mean = states ? probe.compute_sum / static_cast<double>(states) : 0.0;
    compute_max = probe.compute_max;
  }
  std::printf(
      "latency n=%d: %zu transitions (%d timed out, %d unexpected events): p50 %.3f ms, p90 "
      "%.3f ms, p99 %.3f ms, max %.3f ms, mean %.3f ms; monitor check compute_time mean %.1f us, "
      "max %.1f us over %zu cycles\n",
      n, lat_ms.size(), timeouts, unexpected, percentile(lat_ms, 50), percentile(lat_ms, 90),
      percentile(lat_ms, 99),
      lat_ms.empty() ? 0.0 : *std::max_element(lat_ms.begin(), lat_ms.end()), mean,
      1e6 * compute_mean, 1e6 * compute_max, states);
  std::fflush(stdout);
  if (!output.empty()) {
    std::ofstream f(output);
    f << "# n=" << n << " transition,kind(1=COLLISION_BEGIN,2=COLLISION_END),latency_ms\n";
    for (std::size_t i = 0; i < lat_ms.size(); ++i)
      f << i << "," << kinds[i] << "," << lat_ms[i] << "\n";
  }
  spinner.stop();
  ros::shutdown();
  return timeouts == 0 && !lat_ms.empty() ? 0 : 1;
}
