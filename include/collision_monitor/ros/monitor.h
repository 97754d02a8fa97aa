/// \file
/// The collision monitor's ROS wiring: parameters, the URDF/SRDF and `~bodies` at start-up,
/// topic and TF inputs, the check loop, outputs, services and diagnostics, around one
/// world::WorldModel. The nodelet (and through it the node executable) owns one Monitor.
///
/// Threads: callbacks (subscriptions, services, dynamic_reconfigure) run on callback queues and
/// threads of the monitor's own, not the caller's (a nodelet manager's workers: a callback that
/// waits for a check of seconds held one, and with a few such every other nodelet in the manager
/// stopped): pose input on one queue, `~bodies` on a second, `~get_distance`, `~list_bodies` and
/// ~set_parameters (which wait for a check in progress) on a third, `~check_collision` (which
/// may also wait for TF) on a fourth; the check loop runs on its own thread, woken at
/// `rate` Hz and promptly after pose input and new TF data (coalescing bursts, at most one check
/// per `min_check_interval`). One mutex guards the world model; TF lookups, mesh loading and
/// publishing happen outside it. TF comes in on TfReceiver's own thread, a message at a time;
/// /diagnostics go out from a thread of their own. The Tunables change while it runs through
/// dynamic_reconfigure (cfg/Monitor.cfg), checked by the rules of start-up.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <collision_monitor/Body.h>
#include <collision_monitor/BodyPoses.h>
#include <collision_monitor/CheckCollision.h>
#include <collision_monitor/GetDistance.h>
#include <collision_monitor/ListBodies.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/PoseStamped.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <boost/thread/recursive_mutex.hpp>

#include "collision_monitor/ros/conversions.h"
#include "collision_monitor/ros/markers.h"
#include "collision_monitor/ros/mesh_loader.h"
#include "collision_monitor/ros/robot_model.h"
#include "collision_monitor/ros/tf_receiver.h"
#include "collision_monitor/ros/tunables.h"
#include "collision_monitor/ros/wire_check.h"
#include "collision_monitor/world/world_model.h"

namespace dynamic_reconfigure {
template <class ConfigType>
class Server;
}  // namespace dynamic_reconfigure

namespace collision_monitor {
class MonitorConfig;  // generated from cfg/Monitor.cfg

namespace ros_layer {

/// Default of ~max_unknown_pairs: how many UNKNOWN pairs ~state lists (stale_bodies is complete).
constexpr std::size_t kDefaultMaxUnknownPairs = 1000;

class Monitor {
 public:
  /// `nh`: namespace of the node (robot_description, per-body pose topics resolve here);
  /// `pnh`: private namespace (parameters, ~topics, ~services). `name` for diagnostics.
  Monitor(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name);
  ~Monitor();
  Monitor(const Monitor&) = delete;
  Monitor& operator=(const Monitor&) = delete;

 private:
  /// The callbacks' queue and threads (see the file comment). First of the members: destroyed
  /// after everything that subscribes or advertises on it (the dynamic_reconfigure server too).
  ros::CallbackQueue callback_queue_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  /// ~bodies alone, on one thread: its callback waits for a check in progress, and while it did
  /// on callback_queue_, the other threads took the subscription's next message again and again
  /// without sleeping (roscpp's "try again"), half a core taken from the check.
  ros::CallbackQueue bodies_queue_;
  std::unique_ptr<ros::AsyncSpinner> bodies_spinner_;
  /// The services and dynamic_reconfigure's ~set_parameters, which wait for a check in progress,
  /// on threads of their own: on callback_queue_, as many waiting calls as it has threads took
  /// them all, and pose messages waited behind them until roscpp dropped them (a TSan stress
  /// run: 105 of 12,492 pose-topic messages taken in over 65 s of such calls).
  ros::CallbackQueue services_queue_;
  std::unique_ptr<ros::AsyncSpinner> services_spinner_;
  /// ~check_collision on threads of its own: a call whose body is stamped ahead of TF waits up
  /// to 50 ms for it (toFixed()), and on services_queue_ as many such calls as threads held
  /// ~get_distance and ~list_bodies back (12 clients stamping "now + 1 s": 307 ms a call of
  /// theirs; faults.test test_2b).
  ros::CallbackQueue what_if_queue_;
  std::unique_ptr<ros::AsyncSpinner> what_if_spinner_;

  struct Tracked {
    std::string frame;  ///< TF frame (PoseSource::Tf) or empty
    bool from_tf = false;
    world::BodyOrigin origin = world::BodyOrigin::Topic;
    std::string pose_topic;  ///< subscribed for its poses (resolved, not remapped), or empty
    ros::Time came;  ///< when added or replaced: unposed, it takes no TF catch-up from before
  };

  // start-up
  void readParameters();
  /// Private parameter `key` as a T, else `fallback`; a value of another type is recorded in
  /// param_errors_ ("not <type>; default used"), not ignored.
  template <class T>
  T typedParam(const std::string& key, T fallback, const char* type);
  void loadRobot();
  /// The robot's links' TF frames' prefix: robot_state_publisher's `tf_prefix`, searched upward
  /// from the private namespace as it searches; "" when none (or not a string: param_errors_).
  std::string robotTfPrefix();
  void loadParameterBodies();
  void setupDiagnostics();
  /// ~diagnostic_period, which diagnostic_updater reads itself at every report: a number
  /// ros::Duration cannot hold (non-finite, beyond kMaxDiagnosticPeriod) made it throw (at
  /// start-up the nodelet failed to load; later the diagnostics thread ended the process). Such
  /// a value is reported (a parameter error at start-up, a rejected input later) and replaced
  /// on the parameter server by the default, 1 s. Returns the text reported, empty when valid.
  std::string checkDiagnosticPeriod();
  /// Puts `t` (valid) in force: world settings, marker options, loop rates, check triggers.
  void applyTunables(const Tunables& t);
  /// dynamic_reconfigure: a change is checked by the start-up rules; an invalid value is refused
  /// (logged, counted as a rejected input) and `config` is set to the values in force, which the
  /// server then publishes and answers with.
  void onReconfigure(collision_monitor::MonitorConfig& config, std::uint32_t level);

  // inputs
  // ~bodies, ~body_poses and ~check_collision deserialize through Checked<M> (wire_check.h): a
  // malformed message arrives with `refused` set and nothing deserialized.
  void onBody(const ros::MessageEvent<const Checked<collision_monitor::Body>>& event);
  void onBodyPoses(const ros::MessageEvent<const Checked<collision_monitor::BodyPoses>>& event);
  /// A pose of body `id` from `topic`, the one subscribed for it when the message came.
  void onPoseStamped(const std::string& id, const std::string& topic,
                     const geometry_msgs::PoseStamped::ConstPtr& msg);
  /// Adds (or replaces) a validated body and (re)subscribes its pose topic. Empty on success.
  std::string addBody(world::BodySpec spec);
  /// Removes a body added on ~bodies: true when it is gone (an unknown id is: nothing to do);
  /// false with `why` for a body declared by the URDF or the parameters.
  bool removeBody(const std::string& id, std::string* why);
  /// The absolute name of a body's pose_topic: a relative name in the node's namespace, `~name`
  /// in its private namespace (as roscpp resolves `~` elsewhere), not remapped (subscribe()
  /// remaps the name it is given). Throws ros::Exception on a name roscpp refuses.
  std::string resolvePoseTopic(const std::string& topic) const;
  /// The parameter key of robot parameter `name`: its remapped name when remapped, else
  /// `fallback`, else the key found searching upward from the node's namespace.
  std::string robotParamKey(const std::string& name, const std::string& fallback) const;
  void updatePoseSubscription(const std::string& id, const std::string& topic);
  /// header frame -> fixed frame at `stamp` (latest when zero); nullopt with `why`. `used`: the
  /// time of the transform taken (zero for the fixed frame and static chains).
  std::optional<core::Transform3> toFixed(const std::string& frame, const ros::Time& stamp,
                                          std::string* why, ros::Time* used = nullptr) const;
  /// Pose messages that came while the world was locked (a check in progress), in the order they
  /// came. `pose_topic`: the topic of a body's own `pose_topic` subscription, for those.
  struct PendingPoses {
    std::vector<PoseUpdate> updates;
    ros::Time stamp;
    ros::Time arrived;  ///< ROS time when the message came
    std::string source;
    std::optional<std::string> pose_topic;
  };
  /// Applies the poses now if the world is free; while it is locked (a check in progress) they
  /// wait in `pending_poses_` and the callback returns, so that no spinner thread waits for a
  /// check (roscpp's other threads then spun on the subscription's next message, "try again":
  /// half a core taken from the check). `pose_topic`: the updates apply only while the body still
  /// follows that topic (a message in flight on the subscription a replacement shut down is
  /// dropped).
  void applyPoses(std::vector<PoseUpdate> updates, const ros::Time& stamp,
                  const std::string& source, const std::string* pose_topic = nullptr);
  /// Under world_mutex_: applies one message's poses (or refuses them). True when some update
  /// was for a body posed this way (unknown, TF-attached and superseded ones are not).
  bool applyPosesLocked(const PendingPoses& p);
  /// Under world_mutex_: applies the messages that waited for it, in the order they came.
  void applyPendingPoses();
  /// world_mutex_, locked, with the poses that waited for it applied first. The check, the
  /// services and body changes take it this way, so that none of them sees the world without
  /// those poses (the check's TF lookup of tracked_ and a time jump's clearPoses() need not).
  std::unique_lock<std::mutex> lockWorld();

  // services
  bool getDistance(collision_monitor::GetDistance::Request& req,
                   collision_monitor::GetDistance::Response& res);
  bool checkCollision(Checked<collision_monitor::CheckCollision::Request>& req,
                      collision_monitor::CheckCollision::Response& res);
  bool listBodies(collision_monitor::ListBodies::Request& req,
                  collision_monitor::ListBodies::Response& res);
  /// Why a pair is never checked (adjacent links, SRDF, disabled_pairs, same group), or empty.
  std::string whyNeverChecked(const std::string& a, const std::string& b) const;

  // the check loop
  void loopThread();
  void runCycle();
  void trigger();
  /// Sends /diagnostics every diagnostic_period, also while a check runs (a long check delayed
  /// them when the loop sent them after each check: 5.4 s behind a 2.4 s check).
  void diagnosticsThread();

  // bookkeeping
  /// A refused input: counted for /diagnostics and logged, throttled per `key` (the source) and
  /// to kRejectLogBudget lines per second in all. `what` is capped at kMaxRejectionText bytes.
  void reject(const std::string& key, const std::string& what);
  void rejectAtStartup(const std::string& what);
  /// Logs the count of rejections left out by the budget once its second has passed: they were
  /// counted only in the next line logged, and with no rejection after them in none.
  void logUnlogged();
  /// Counts a rejection; returns `what` capped at kMaxRejectionText bytes.
  std::string count(const std::string& what);
  static constexpr double kRejectLogPeriod = 1.0;  ///< s between two logs of one source
  static constexpr std::size_t kRejectLogBudget =
      20;  ///< rejection log lines per second, all sources
  static constexpr std::size_t kMaxRejectionText = 1024;  ///< bytes of a rejection message
  static constexpr std::uint32_t kEventsQueue = 10000;    ///< ~events messages per subscriber
  /// Pose updates kept while a check holds the world (a message counts at least 1): 100 full
  /// ~body_poses queues of 1,000 ids, about 20 MB.
  static constexpr std::size_t kMaxPendingPoseUpdates = 100000;
  std::map<std::string, ros::WallTime> last_logged_;  ///< guarded by stats_mutex_
  ros::WallTime log_window_start_;                    ///< guarded by stats_mutex_
  std::size_t logged_in_window_ = 0;                  ///< guarded by stats_mutex_
  std::size_t not_logged_ = 0;   ///< rejections over the budget since the last line (stats_mutex_)
  std::string last_not_logged_;  ///< the last of them (stats_mutex_)
  void disablePair(const std::string& a, const std::string& b, const std::string& reason);
  world::Settings settings_;  ///< guarded by world_mutex_ once the world model exists
  Limits limits_;
  std::string fixed_frame_;
  /// The values in force: set at start-up, then only by onReconfigure (serialised by the
  /// dynamic_reconfigure server). The threads read the copies below.
  Tunables tunables_;
  boost::recursive_mutex reconfigure_mutex_;  ///< the server's (updateConfig() warns without)
  std::unique_ptr<dynamic_reconfigure::Server<collision_monitor::MonitorConfig>> reconfigure_;
  std::atomic<double> rate_{50.0};
  std::atomic<double> min_check_interval_{0.002};
  std::atomic<bool> check_on_pose_{true};
  std::atomic<bool> check_on_tf_{true};
  std::atomic<bool> publish_markers_{true};
  bool markers_published_ = false;  ///< loop thread: arrays went out since the last clear
  double robot_padding_ = 0.0;
  /// ~body_poses entries for ids this monitor does not track are dropped without a word (a pose
  /// stream shared by monitors that each watch some of its ids); start-up only.
  bool ignore_unknown_pose_ids_ = false;
  LinkSettings robot_links_;  ///< robot_link_padding, robot_link_groups
  std::string robot_description_param_ = "robot_description";
  MeshDecomposition mesh_decomposition_ = MeshDecomposition::Hull;  ///< start-up only
  std::vector<std::string> param_errors_;  ///< invalid parameters (fell back to defaults)
  /// Private parameters the node does not read, each with the one meant when it is near one
  /// (findUnknownParameters; logged at start-up, a /diagnostics value).
  std::vector<std::string> unknown_params_;
  /// The names under the node's private namespace on the parameter server that are none of its
  /// parameters (a typo: `disabled_pair` was ignored without a word).
  void findUnknownParameters();
  /// Robot geometry left out at start-up (the URDF, a link, a <collision> element): not watched
  /// for as long as the node runs, so /diagnostics says so in every report (ERROR).
  std::vector<std::string> robot_errors_;
  /// Bodies of the ~bodies parameter refused at start-up: as robot_errors_.
  std::vector<std::string> body_errors_;

  ros::NodeHandle nh_;           ///< on callback_queue_
  ros::NodeHandle pnh_;          ///< on callback_queue_
  ros::NodeHandle srv_pnh_;      ///< pnh_ on services_queue_
  ros::NodeHandle what_if_pnh_;  ///< pnh_ on what_if_queue_
  std::string name_;

  std::shared_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<TfReceiver> tf_receiver_;  ///< fills tf_buffer_ a message at a time
  std::unique_ptr<MeshCache> mesh_cache_;
  MeshLoader mesh_loader_;

  mutable std::mutex world_mutex_;  ///< guards world_, tracked_
  std::unique_ptr<world::WorldModel> world_;
  std::map<std::string, Tracked> tracked_;
  std::map<std::pair<std::string, std::string>, std::string> disabled_reasons_;  // sorted pairs
  std::set<std::string> default_off_;  // SRDF <disable_default_collisions> links
  /// runCycle(): per attached frame, the stamp of its latest transform and the ROS time it was
  /// first seen (a frame stamped ahead of ROS time ages from then). Loop thread only.
  struct TfSeen {
    ros::Time stamp;
    ros::Time at;
  };
  std::map<std::string, TfSeen> tf_seen_;
  /// runCycle(): per attached frame that cannot be looked up, since when (steady clock), and
  /// whether its WARN went out (kUnresolvedWarnAfter). Loop thread only.
  struct Unresolved {
    std::chrono::steady_clock::time_point since;
    bool warned = false;
  };
  std::map<std::string, Unresolved> unresolved_;
  /// A frame unresolved this long (s) is logged (WARN, once, with the reason; INFO when it
  /// resolves): a typo in a frame name said nothing but /diagnostics. Long enough for the TF of
  /// a robot that starts with the monitor.
  static constexpr double kUnresolvedWarnAfter = 5.0;
  /// logUnresolved(): frames named in one line at most.
  static constexpr std::size_t kUnresolvedNamed = 5;
  /// runCycle(): logs the frames unresolved for kUnresolvedWarnAfter, and those that resolved
  /// after such a line; `unresolved_why` this cycle's failed lookups, `looked_up` every frame.
  void logUnresolved(const std::map<std::string, std::string>& unresolved_why,
                     const std::set<std::string>& looked_up,
                     std::chrono::steady_clock::time_point now);
  bool clock_started_ = false;  ///< runCycle() has seen a ROS time other than 0. Loop thread only.
  // Pose input vs. checks (guarded by world_mutex_): messages that set at least one pose, and
  // checks that saw at least one such message since the previous check. The difference is the
  // number of pose messages superseded before a check used them (coalesced), on /diagnostics.
  std::size_t pose_msgs_applied_ = 0, checks_with_new_poses_ = 0;
  bool new_poses_ = false;
  /// applyPoses(): messages waiting for the world lock, their updates counted (bounded by
  /// kMaxPendingPoseUpdates: the oldest are dropped, as roscpp drops the oldest beyond a
  /// subscription's queue), and the totals deferred and dropped (diagnostics).
  std::mutex pending_mutex_;
  std::deque<PendingPoses> pending_poses_;
  std::size_t pending_updates_ = 0, poses_deferred_ = 0, poses_dropped_ = 0;

  std::mutex subs_mutex_;
  /// toFixed(): per frame, the latest TF time when a wait for it last failed (no new wait
  /// until its TF moves).
  mutable std::mutex tf_wait_mutex_;
  mutable std::map<std::string, ros::Time> failed_waits_;
  mutable std::atomic<std::size_t> tf_waits_{0};  ///< waits made (diagnostics)
  std::map<std::string, std::pair<std::string, ros::Subscriber>> pose_subs_;  // id -> topic, sub

  ros::Publisher events_pub_, state_pub_, markers_pub_;
  ros::Subscriber bodies_sub_, poses_sub_;
  ros::ServiceServer distance_srv_, check_srv_, list_srv_;
  MarkerBuilder marker_builder_;
  std::atomic<bool> markers_subscribed_{false};  ///< ~markers got a subscriber since last build
  std::uint32_t marker_subscribers_ = 0;         ///< ~markers' subscribers at the last check (loop)

  // diagnostics (guarded by stats_mutex_)
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  mutable std::mutex stats_mutex_;
  struct Stats {
    std::size_t bodies_msgs = 0, poses_msgs = 0, pose_topic_msgs = 0, cycles = 0;
    std::size_t pose_msgs_applied = 0, checks_with_new_poses = 0;  // copies taken by each check
    std::size_t rejected = 0;
    std::size_t unknown_pose_ids_ignored = 0;  ///< with ignore_unknown_pose_ids
    std::size_t time_jumps_back = 0;  ///< ROS time more than kTimeJumpTolerance behind the last
    std::string last_rejection;
    double cycle_time_max = 0.0, cycle_time_sum = 0.0;
    std::size_t stale = 0, bodies = 0, pairs_checked = 0, pairs_checked_sum = 0;
    std::size_t pairs_caught_up_sum = 0;  ///< of pairs_checked_sum: catch-up checks
    std::vector<std::string> stale_ids;
    /// TF frames of bodies whose lookup failed in the last check: "'frame': why".
    std::vector<std::string> unresolved_frames;
  } stats_, stats_window_start_;
  /// Wall times of the last kJumpsWarn jumps back of ROS time (stats_mutex_): that many within
  /// kJumpsWindow s is a warning on /diagnostics (for kJumpsWindow s after the last).
  std::deque<ros::WallTime> recent_jumps_;
  static constexpr std::size_t kJumpsWarn = 3;
  static constexpr double kJumpsWindow = 5.0;
  ros::WallTime window_start_;
  /// The tunables in force, for /diagnostics (stats_mutex_; a copy, as tunables_ is written under
  /// the reconfigure server's mutex and the report must not wait for a check).
  Tunables reported_tunables_;

  // loop
  std::thread loop_thread_;
  std::mutex loop_mutex_;
  std::condition_variable loop_cv_;
  bool triggered_ = false;
  bool retimed_ = false;  ///< loop_mutex_: rate or min_check_interval changed
  bool stop_ = false;     ///< both threads stop (loop_mutex_)
  std::thread diagnostics_thread_;
  std::condition_variable diagnostics_cv_;  ///< with loop_mutex_
  bool force_diagnostics_ = false;          ///< loop_mutex_: send a report now (time jump)
  /// Start of the check in progress (steady clock ticks), 0 between checks.
  std::atomic<std::chrono::steady_clock::rep> check_started_{0};
  /// Start of the last check (steady clock ticks), 0 before the first.
  std::atomic<std::chrono::steady_clock::rep> last_check_started_{0};
  double last_now_ = 0.0;             ///< ROS time of the previous check (loop thread)
  LogThrottle cycle_error_log_{1.0};  ///< "check cycle failed" (loop thread)
  LogThrottle future_tf_log_{1.0};    ///< "TF stamped more than ... after the current ROS time"
  LogThrottle jump_log_{5.0};         ///< "time jumped backwards" (two /clock: 10 lines/s)
  std::size_t jumps_not_logged_ = 0;  ///< since the last such line (loop thread)
  ros::WallTime last_forced_report_;  ///< diagnostics forced by a jump (loop thread)
  double last_forced_time_ = 0.0;     ///< ROS time of that report (loop thread)
  /// ROS time going back by more than this (s) is a time jump (bag loop, simulation reset): every
  /// pose and the TF buffer are forgotten. Poses stamped more than this after ROS time are
  /// refused, and TF that far ahead leaves its frame unresolved.
  static constexpr double kTimeJumpTolerance = 1.0;
  /// runCycle(): TF lookups at the stamps between two checks of a frame (catch-up): at most
  /// kMaxTfStampsBetween a frame, and kMaxTfLookupsBetween a cycle shared by the frames looked up
  /// (those of TF bodies but the fixed frame) when there are more of them than
  /// kMaxTfStampsBetween, but at least one a frame.
  static constexpr std::size_t kMaxTfLookupsBetween = 1024;
  static constexpr std::size_t kMaxTfStampsBetween = 32;
  /// For this long (s, steady clock) after a backward jump, TF from the future (data from before
  /// the jump that arrived after the buffer was cleared) clears the TF buffer again.
  static constexpr int kTfClearWindow = 10;
  /// s: the longest wait of the check loop (1 / rate, min_check_interval), a year.
  static constexpr double kMaxLoopPeriod = 365.0 * 86400.0;
  /// s: the largest |~diagnostic_period| let through to diagnostic_updater (ros::Time + it must
  /// stay within 32 bits of seconds).
  static constexpr double kMaxDiagnosticPeriod = 1e6;
  std::chrono::steady_clock::time_point tf_clear_until_;  ///< loop thread
};

}  // namespace ros_layer
}  // namespace collision_monitor
