#include "collision_monitor/ros/monitor.h"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <exception>
#include <limits>
#include <set>
#include <sstream>
#include <type_traits>

#include <collision_monitor/CollisionEvent.h>
#include <collision_monitor/CollisionState.h>
#include <collision_monitor/MonitorConfig.h>
#include <dynamic_reconfigure/server.h>
#include <ros/master.h>
#include <tf2/exceptions.h>
#include <visualization_msgs/MarkerArray.h>
#include <boost/function.hpp>

#include "collision_monitor/core/backend.h"
#include "collision_monitor/ros/params.h"
#include "collision_monitor/ros/robot_model.h"

#include "collision_monitor/ros/markers.h"

namespace collision_monitor {
namespace ros_layer {

namespace {

using core::Transform3;

std::pair<std::string, std::string> sortedPair(const std::string& a, const std::string& b) {
  return a < b ? std::make_pair(a, b) : std::make_pair(b, a);
}

Transform3 toTransform3(const geometry_msgs::Transform& t) {
  const Eigen::Quaterniond q(t.rotation.w, t.rotation.x, t.rotation.y, t.rotation.z);
  return core::makeTransform(q, core::Vec3(t.translation.x, t.translation.y, t.translation.z));
}

std::string joined(const std::vector<std::string>& items, std::size_t max_items = 10) {
  std::ostringstream os;
  for (std::size_t i = 0; i < items.size() && i < max_items; ++i)
    os << (i ? ", " : "") << items[i].substr(0, kMaxNameLength + 64);
  if (items.size() > max_items) os << ", ... (" << items.size() << " in all)";
  return os.str();
}

/// Throttling key of an input source named by (untrusted) `id`: bounded in length.
std::string sourceKey(const char* prefix, const std::string& id) {
  return prefix + id.substr(0, kMaxNameLength);
}

/// What typedParam() reports a parameter of this type should have been.
const char* typeName(double) {
  return "a number";
}
const char* typeName(bool) {
  return "a boolean";
}
const char* typeName(const std::string&) {
  return "a string";
}

/// A tunable's value in force on /diagnostics, as a launch file would give it.
void addValue(diagnostic_updater::DiagnosticStatusWrapper& s, const char* key, double v) {
  s.addf(key, "%.9g", v);
}
void addValue(diagnostic_updater::DiagnosticStatusWrapper& s, const char* key, bool v) {
  s.add(key, v ? "true" : "false");
}
void addValue(diagnostic_updater::DiagnosticStatusWrapper& s, const char* key,
              const std::string& v) {
  s.add(key, v);
}

collision_monitor::MonitorConfig toConfig(const Tunables& t) {
  auto c = collision_monitor::MonitorConfig::__getDefault__();
#define CM_TO_CONFIG(field) c.field = t.field;
  CM_TUNABLES(CM_TO_CONFIG)
#undef CM_TO_CONFIG
  return c;
}

Tunables fromConfig(const collision_monitor::MonitorConfig& c) {
  Tunables t;
#define CM_FROM_CONFIG(field) t.field = c.field;
  CM_TUNABLES(CM_FROM_CONFIG)
#undef CM_FROM_CONFIG
  return t;
}

/// `what` cut to `max_bytes` ("... (N bytes)" appended when cut).
std::string capped(const std::string& what, std::size_t max_bytes) {
  if (what.size() <= max_bytes) return what;
  return what.substr(0, max_bytes) + "... (" + std::to_string(what.size()) + " bytes)";
}

/// The time a timed pose holds for: its stamp; for stamp 0 (static) in a frame that TF moves,
/// the time of the transform it was resolved with, so that it ages with that transform instead
/// of holding in the fixed frame for ever wherever the frame goes.
ros::Time poseStamp(const ros::Time& stamp, const ros::Time& transform_used) {
  return stamp.isZero() ? transform_used : stamp;
}

/// The time a pose or transform came, for WorldModel::setPose: none before the clock starts.
std::optional<world::Stamp> arrivedAt(const ros::Time& t) {
  if (t.isZero()) return std::nullopt;
  return toStamp(t);
}

}  // namespace

Monitor::Monitor(const ros::NodeHandle& nh, const ros::NodeHandle& pnh, const std::string& name)
    : nh_(nh), pnh_(pnh), srv_pnh_(pnh), what_if_pnh_(pnh), name_(name) {
  nh_.setCallbackQueue(&callback_queue_);
  pnh_.setCallbackQueue(&callback_queue_);
  srv_pnh_.setCallbackQueue(&services_queue_);
  what_if_pnh_.setCallbackQueue(&what_if_queue_);
  readParameters();
  world_ = std::make_unique<world::WorldModel>(settings_);
  applyTunables(tunables_);
  mesh_cache_ = std::make_unique<MeshCache>(
      [this] {
        std::vector<std::string> roots;
        XmlRpc::XmlRpcValue v;
        if (pnh_.getParam("mesh_roots", v)) {
          auto r = stringsFromXmlRpc(v);
          if (r) {
            roots = *r;
            for (const std::string& root : roots) {
              // A typo, or a command line's _mesh_roots:=[a, b] (one string): every mesh from
              // there is refused later, each with its own error; said once here.
              struct stat st {};
              if (::stat(root.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
                ROS_WARN_STREAM(name_ << ": mesh_roots: " << quoteInput(root, 512)
                                      << " is not a directory");
              }
            }
          } else {
            param_errors_.push_back("mesh_roots: " + r.error());
          }
        }
        return roots;
      }(),
      limits_.max_vertices_per_part, rosPackagePath, mesh_decomposition_,
      limits_.max_parts_per_body, name_);
  mesh_loader_ = [cache = mesh_cache_.get()](const std::string& uri, const core::Vec3& scale) {
    return cache->load(uri, scale);
  };

  tf_buffer_ = std::make_shared<tf2_ros::Buffer>(ros::Duration(10.0));
  // TCP_NODELAY: TF comes as many small messages; with Nagle's algorithm they arrived in bursts
  // up to ~40 ms late (soak test: TF-pair event latency p50 21 ms, p99 47 ms; with it 2.2 / 5.9).
  // New TF data is pose input for every TF-attached body (robot links): with check_on_tf, check
  // promptly after each message, coalesced with other triggers by min_check_interval.
  tf_receiver_ = std::make_unique<TfReceiver>(*tf_buffer_, nh_, ros::TransportHints().tcpNoDelay(),
                                              name_, [this] {
                                                if (check_on_tf_) trigger();
                                              });

  loadRobot();
  loadParameterBodies();
  if (std::string e = checkDiagnosticPeriod(); !e.empty()) param_errors_.push_back(e);
  for (const auto& e : param_errors_)
    ROS_ERROR_STREAM(name_ << ": invalid parameter " << e);
  findUnknownParameters();
  if (!unknown_params_.empty()) {
    ROS_WARN_STREAM(name_ << ": " << unknown_params_.size() << " unknown private parameter"
                          << (unknown_params_.size() > 1 ? "s" : "")
                          << ", ignored: " << joined(unknown_params_));
  }

  // One check may send a transition per pair at once (a pile landing on a robot, TF stopping:
  // every pair UNKNOWN), back to back; roscpp drops the oldest beyond the queue of a subscriber
  // link, so it holds 10,000 (60 touching spheres: 1,158 BEGINs in one check, of which a
  // queue of 100 delivered 101 to 202).
  events_pub_ = pnh_.advertise<collision_monitor::CollisionEvent>("events", kEventsQueue);
  state_pub_ = pnh_.advertise<collision_monitor::CollisionState>("state", 10);
  // A new subscriber gets every body in the next array, not only as their refreshes come due:
  // noticed by its callback, or sooner by the count of subscribers (runCycle()); the callback
  // runs from the callback queue after the new link already receives arrays.
  markers_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>(
      "markers", 1, [this](const ros::SingleSubscriberPublisher&) { markers_subscribed_ = true; });
  const auto hints = ros::TransportHints().tcpNoDelay();
  // Checked<M>: every length prefix is checked against the message size before anything is
  // allocated (wire_check.h).
  ros::SubscribeOptions bodies_ops;
  bodies_ops
      .initByFullCallbackType<const ros::MessageEvent<const Checked<collision_monitor::Body>>&>(
          "bodies", 1000,
          [this](const ros::MessageEvent<const Checked<collision_monitor::Body>>& e) {
            onBody(e);
          });
  bodies_ops.transport_hints = hints;
  bodies_ops.callback_queue = &bodies_queue_;
  bodies_sub_ = pnh_.subscribe(bodies_ops);
  poses_sub_ = pnh_.subscribe("body_poses", 100, &Monitor::onBodyPoses, this, hints);
  setupDiagnostics();
  // ~set_parameters, ~parameter_descriptions, ~parameter_updates. The server reads the raw
  // parameters (and writes them back): it is then given the checked values in force, which
  // also go back to the parameter server, before the callback is set (which calls it once).
  reconfigure_ = std::make_unique<dynamic_reconfigure::Server<collision_monitor::MonitorConfig>>(
      reconfigure_mutex_, srv_pnh_);
  reconfigure_->updateConfig(toConfig(tunables_));
  reconfigure_->setCallback([this](collision_monitor::MonitorConfig& config, std::uint32_t level) {
    onReconfigure(config, level);
  });
  // Last: a client that waits for a service finds the checked values on the parameter server.
  distance_srv_ = srv_pnh_.advertiseService("get_distance", &Monitor::getDistance, this);
  check_srv_ = what_if_pnh_.advertiseService("check_collision", &Monitor::checkCollision, this);
  list_srv_ = srv_pnh_.advertiseService("list_bodies", &Monitor::listBodies, this);

  {
    // rate_, not tunables_.rate: ~set_parameters is served once the spinner below starts, and
    // onReconfigure() writes tunables_ under reconfigure_mutex_ only.
    std::lock_guard<std::mutex> lock(world_mutex_);
    ROS_INFO_STREAM(name_ << ": monitoring " << world_->size() << " bodies in frame '"
                          << fixed_frame_ << "' at " << rate_.load() << " Hz with backend "
                          << core::toString(settings_.backend) << ", meshes as "
                          << toString(mesh_decomposition_));
  }
  loop_thread_ = std::thread([this] { loopThread(); });
  diagnostics_thread_ = std::thread([this] { diagnosticsThread(); });
  // As many threads as a manager would give (at least 2, at most 8), for pose input and for the
  // services: several calls are answered at once (those that wait for a check, one after the
  // other).
  const unsigned threads = std::clamp(std::thread::hardware_concurrency(), 2u, 8u);
  spinner_ = std::make_unique<ros::AsyncSpinner>(threads, &callback_queue_);
  spinner_->start();
  bodies_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &bodies_queue_);
  bodies_spinner_->start();
  services_spinner_ = std::make_unique<ros::AsyncSpinner>(threads, &services_queue_);
  services_spinner_->start();
  what_if_spinner_ = std::make_unique<ros::AsyncSpinner>(threads, &what_if_queue_);
  what_if_spinner_->start();
}

Monitor::~Monitor() {
  // A check of seconds (bodies of 1,000 parts) stops now; first, since a ~set_parameters call in
  // progress waits for it, and stopping the services' threads below waits for that call.
  world_->abandonChecks();
  // The services' threads stop before the reconfigure server goes: its destructor frees the
  // callback and the config before it shuts its service, so a ~set_parameters call let in then
  // would run on freed memory (ThreadSanitizer saw it at unload). stop() waits for calls running.
  services_queue_.disable();
  if (services_spinner_) services_spinner_->stop();
  reconfigure_.reset();  // no change comes in while the rest stops
  {
    std::lock_guard<std::mutex> lock(loop_mutex_);
    stop_ = true;
  }
  loop_cv_.notify_all();
  diagnostics_cv_.notify_all();
  if (loop_thread_.joinable()) loop_thread_.join();
  if (diagnostics_thread_.joinable()) diagnostics_thread_.join();
  // No callback starts from here on; one in progress finishes (no check holds the world now).
  callback_queue_.disable();
  bodies_queue_.disable();
  what_if_queue_.disable();
  if (spinner_) spinner_->stop();
  if (bodies_spinner_) bodies_spinner_->stop();
  if (what_if_spinner_) what_if_spinner_->stop();
  tf_receiver_.reset();  // after the loop, which reads through it; its trigger()s are harmless
  bodies_sub_.shutdown();
  poses_sub_.shutdown();
  distance_srv_.shutdown();
  check_srv_.shutdown();
  list_srv_.shutdown();
  std::lock_guard<std::mutex> lock(subs_mutex_);
  for (auto& [id, sub] : pose_subs_)
    sub.second.shutdown();
}

// ---------------------------------------------------------------------------------------------
// start-up

template <class T>
T Monitor::typedParam(const std::string& key, T fallback, const char* type) {
  T v = fallback;
  if (pnh_.getParam(key, v)) return v;
  XmlRpc::XmlRpcValue raw;
  if (pnh_.getParam(key, raw)) {
    const std::string hint = std::is_same_v<T, double> ? numberWrittenAsText(raw) : "";
    param_errors_.push_back(key + ": not " + type + hint + "; default used");
  }
  return fallback;
}

namespace {

/// Levenshtein distance of `a` and `b`, at most `bound` + 1 (a "did you mean" needs no more).
std::size_t editDistance(const std::string& a, const std::string& b, std::size_t bound) {
  if (a.size() > b.size() + bound || b.size() > a.size() + bound) return bound + 1;
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j)
    row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return std::min(row[b.size()], bound + 1);
}

}  // namespace

void Monitor::findUnknownParameters() {
  // Every private parameter the node reads (docs/node.md, Parameters; bad_params.test test_09
  // holds this to the table there).
  static const std::set<std::string> known = [] {
    std::set<std::string> k = {"fixed_frame",
                               "robot_description_param",
                               "tf_prefix",
                               "robot_padding",
                               "robot_link_padding",
                               "robot_link_groups",
                               "disabled_pairs",
                               "max_bodies",
                               "max_vertices_per_part",
                               "max_parts_per_body",
                               "max_unknown_pairs",
                               "ignore_unknown_pose_ids",
                               "mesh_roots",
                               "mesh_decomposition",
                               "bodies",
                               "diagnostic_period"};
#define CM_NAME(field) k.insert(#field);
    CM_TUNABLES(CM_NAME)
#undef CM_NAME
    return k;
  }();
  std::vector<std::string> names;
  if (!ros::param::getParamNames(names)) return;
  const std::string prefix = pnh_.getNamespace() + "/";
  std::set<std::string> unknown;
  for (const std::string& n : names) {
    if (n.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string first = n.substr(prefix.size(), n.find('/', prefix.size()) - prefix.size());
    if (!known.count(first)) unknown.insert(first);
  }
  unknown_params_.clear();
  for (const std::string& u : unknown) {
    std::string meant;
    std::size_t best = 3;  // at most 2 edits apart
    for (const std::string& k : known) {
      const std::size_t d = editDistance(u, k, 2);
      if (d < best) {
        best = d;
        meant = k;
      }
    }
    unknown_params_.push_back(quoteInput(u) +
                              (meant.empty() ? "" : " (did you mean " + meant + "?)"));
  }
}

void Monitor::readParameters() {
  const world::Settings defaults;
  // The values that may change later (Tunables): of the right type, then checked by the rules
  // every change is checked by (validate()); an invalid one is reported and the default used.
  Tunables& t = tunables_;
  const Tunables d;
  // A value of another type (publish_markers: "no", backend: 7) is an error, not silence.
#define CM_READ(field) t.field = typedParam(#field, d.field, typeName(d.field));
  CM_TUNABLES(CM_READ)
#undef CM_READ
  // contact_distance alone above the default warning distance: the warning distance follows it,
  // to the value ~set_parameters would use (it was an ERROR for the whole run about a parameter
  // nobody set).
  if (!pnh_.hasParam("warning_distance") && raiseWarningToContact(&t)) {
    ROS_INFO_STREAM(name_ << ": warning_distance not set: " << t.contact_distance
                          << " m, the contact_distance given");
  }
  validate(&t, d, &param_errors_);

  ignore_unknown_pose_ids_ =
      typedParam("ignore_unknown_pose_ids", false, typeName(ignore_unknown_pose_ids_));
  robot_padding_ = typedParam("robot_padding", 0.0, "a number");
  checkNumber(
      "robot_padding", &robot_padding_, 0.0, [](double v) { return v >= 0.0; }, ">= 0",
      &param_errors_);
  const auto readLinkMap = [this](const char* param, auto parse, auto* values) {
    if (XmlRpc::XmlRpcValue v; pnh_.getParam(param, v)) {
      auto read = parse(v);
      *values = std::move(read.values);
      param_errors_.insert(param_errors_.end(), read.errors.begin(), read.errors.end());
    }
  };
  readLinkMap("robot_link_padding", linkPaddingFromXmlRpc, &robot_links_.padding);
  readLinkMap("robot_link_groups", linkGroupsFromXmlRpc, &robot_links_.group);
  robot_description_param_ =
      typedParam<std::string>("robot_description_param", "robot_description", "a string");
  if (std::string why; !ros::names::validate(robot_description_param_, why) ||
                       robot_description_param_.empty() || robot_description_param_[0] == '~') {
    // roscpp would throw on it (the nodelet failed to load without a word).
    param_errors_.push_back("robot_description_param = '" + robot_description_param_ +
                            "' (must be a ROS name, not private); using robot_description");
    robot_description_param_ = "robot_description";
  }
  const std::string decomposition =
      typedParam<std::string>("mesh_decomposition", toString(mesh_decomposition_), "a string");
  if (const auto mode = parseMeshDecomposition(decomposition)) {
    mesh_decomposition_ = *mode;
  } else {
    param_errors_.push_back("mesh_decomposition = " + quoteInput(decomposition) +
                            " (must be hull or pieces); using hull");
  }

  // A whole number: an int, or a double without a fraction (10000.0; `<param value="1e4"/>`),
  // read as a double (roscpp's getParam(double) takes both). roscpp's getParam(int) would round
  // 2.5 to 3 without a word.
  auto count = [this](const std::string& key, std::size_t fallback) -> std::size_t {
    const double v = typedParam(key, static_cast<double>(fallback), "an integer");
    if (!(v > 0.0 && v <= INT_MAX && v == std::floor(v))) {
      std::ostringstream out;
      out << key << " = " << v << " (must be a whole number > 0); using " << fallback;
      param_errors_.push_back(out.str());
      return fallback;
    }
    return static_cast<std::size_t>(v);
  };
  settings_.max_bodies = count("max_bodies", defaults.max_bodies);
  settings_.max_vertices_per_part = count("max_vertices_per_part", defaults.max_vertices_per_part);
  settings_.max_parts_per_body = count("max_parts_per_body", defaults.max_parts_per_body);
  // Pairs listed as UNKNOWN in ~state: bounded so that 1,000 bodies without poses (500k pairs)
  // cannot stall a cycle; stale_bodies stays complete, and any pair with a stale body is UNKNOWN.
  settings_.max_unknown_pairs = count("max_unknown_pairs", kDefaultMaxUnknownPairs);
  limits_.max_vertices_per_part = settings_.max_vertices_per_part;
  limits_.max_parts_per_body = settings_.max_parts_per_body;
  settings_ = worldSettings(tunables_, settings_);
}

void Monitor::applyTunables(const Tunables& t) {
  {
    std::lock_guard<std::mutex> lock(world_mutex_);
    settings_ = worldSettings(t, settings_);
    world_->setSettings(settings_);
    marker_builder_.setOptions(markerOptions(t));
  }
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    reported_tunables_ = t;
  }
  rate_ = t.rate;
  min_check_interval_ = t.min_check_interval;
  check_on_pose_ = t.check_on_pose;
  check_on_tf_ = t.check_on_tf;
  publish_markers_ = t.publish_markers;
  {
    // A check at once, by the new values (the next one a period of the new rate later), and a
    // wait for the minimum interval in progress starts again from the new one.
    std::lock_guard<std::mutex> lock(loop_mutex_);
    triggered_ = true;
    retimed_ = true;
  }
  loop_cv_.notify_one();
}

void Monitor::onReconfigure(collision_monitor::MonitorConfig& config, std::uint32_t) {
  Tunables t = fromConfig(config);
  // A change of contact_distance alone past the warning distance in force: the warning distance
  // follows, as at start-up (the request carries every value: it was refused as an ERROR about
  // a warning_distance nobody sent). The change's INFO line says so.
  if (t.warning_distance == tunables_.warning_distance) raiseWarningToContact(&t);
  std::vector<std::string> errors;
  validate(&t, tunables_, &errors);
  if (!errors.empty()) {
    std::string all;
    for (const auto& e : errors)
      all += (all.empty() ? "" : "; ") + e;
    reject("~set_parameters", "dynamic_reconfigure refused " + all);
  }
  config = toConfig(t);  // what the server publishes and answers with: the values in force
  const std::string changed = differences(tunables_, t);
  if (changed.empty()) return;
  ROS_INFO_STREAM(name_ << ": reconfigured: " << changed);
  tunables_ = t;
  applyTunables(t);
}

std::string Monitor::robotParamKey(const std::string& name, const std::string& fallback) const {
  // A remapped name as remapped: roscpp's searchParam honours only the command line's remappings,
  // not a nodelet's (which come resolved), so a nodelet would search past the remap.
  std::string remapped = nh_.resolveName(name, true);
  if (remapped != nh_.resolveName(name, false)) return remapped;
  if (!fallback.empty()) return fallback;
  std::string key;
  return nh_.searchParam(name, key) ? key : remapped;
}

std::string Monitor::robotTfPrefix() {
  // As robot_state_publisher finds its tf_prefix: searched upward from the private namespace.
  std::string key;
  if (!pnh_.searchParam("tf_prefix", key)) return "";
  std::string prefix;
  if (!pnh_.getParam(key, prefix)) {
    param_errors_.push_back("tf_prefix (" + key + "): not a string; the robot's links unprefixed");
    return "";
  }
  return prefix;
}

void Monitor::loadRobot() {
  std::string root_frame;
  // The URDF's parameter, searched upward from the node's namespace; the SRDF next to it (its
  // own upward search would take another robot's SRDF where this one has none).
  const std::string key = robotParamKey(robot_description_param_, "");
  std::set<std::string> links;  // the robot's bodies: links with collision geometry
  std::string urdf;
  if (!nh_.getParam(key, urdf) || urdf.empty()) {
    ROS_INFO_STREAM(name_ << ": no URDF on parameter '" << robot_description_param_
                          << "': no robot bodies");
    // A parameter named or remapped on purpose that holds no URDF is a mistake (a typo watched
    // nothing of the robot, /diagnostics saying OK); the default one missing is a monitor of
    // obstacles only.
    if (robot_description_param_ != "robot_description" ||
        nh_.resolveName(robot_description_param_, true) !=
            nh_.resolveName(robot_description_param_, false)) {
      param_errors_.push_back("robot_description_param: no URDF on parameter '" +
                              robot_description_param_ + "' (looked up as '" + key +
                              "'): no robot bodies");
    }
    const auto unused = [this](const char* param, bool given) {
      if (given) {
        param_errors_.push_back(std::string(param) + ": no URDF on parameter '" +
                                robot_description_param_ + "': no robot links");
      }
    };
    unused("robot_link_padding", !robot_links_.padding.empty());
    unused("robot_link_groups", !robot_links_.group.empty());
  } else {
    const std::string tf_prefix = robotTfPrefix();
    auto robot =
        bodiesFromUrdf(urdf, robot_padding_, limits_, mesh_loader_, robot_links_, tf_prefix);
    if (!robot) {
      robot_errors_.push_back("URDF '" + key + "': " + robot.error());
      rejectAtStartup(robot_errors_.back());
    } else {
      root_frame = prefixedFrame(tf_prefix, robot->root_link);
      param_errors_.insert(param_errors_.end(), robot->link_errors.begin(),
                           robot->link_errors.end());
      for (const auto& e : robot->errors) {
        robot_errors_.push_back("URDF link " + e);
        rejectAtStartup(robot_errors_.back());
      }
      for (const auto& [a, b] : robot->adjacent)
        disablePair(a, b, "adjacent links");
      std::set<std::string> added;
      for (auto& spec : robot->bodies) {
        const std::string id = spec.id;
        links.insert(id);
        const std::string err = addBody(std::move(spec));
        if (err.empty()) {
          added.insert(id);
        } else {
          robot_errors_.push_back("URDF link '" + id + "' refused: " + err);
          rejectAtStartup(robot_errors_.back());
        }
      }
      // Adjacent pairs of the links monitored (one whose every <collision> was left out is
      // not: "1 links ..., 1 adjacent pairs disabled").
      const auto adjacent = std::count_if(
          robot->adjacent.begin(), robot->adjacent.end(),
          [&added](const auto& p) { return added.count(p.first) && added.count(p.second); });
      ROS_INFO_STREAM(name_ << ": robot '" << robot->robot_name << "': " << added.size()
                            << " links with collision geometry, " << adjacent
                            << " adjacent pairs disabled"
                            << (tf_prefix.empty() ? std::string()
                                                  : ", TF frames " + prefixedFrame(tf_prefix, "*"))
                            << (robot_errors_.empty()
                                    ? std::string()
                                    : ", " + std::to_string(robot_errors_.size()) +
                                          " links or collision elements left out (errors above)"));
    }
    const std::string skey =
        robotParamKey(robot_description_param_ + "_semantic", key + "_semantic");
    std::string srdf;
    if (nh_.getParam(skey, srdf) && !srdf.empty()) {
      auto rules = collisionsFromSrdf(srdf);
      if (!rules) {
        rejectAtStartup("SRDF '" + skey + "': " + rules.error());
      } else {
        // Only rules on the robot's links, as srdfdom keeps only rules on URDF links: a body
        // from ~bodies whose id an SRDF names by mistake takes none of them.
        std::size_t others = 0, disabled = 0, off = 0, enabled = 0;
        const auto ours = [&](const std::string& a, const std::string& b) {
          const bool both = links.count(a) != 0 && links.count(b) != 0;
          others += both ? 0 : 1;
          return both;
        };
        for (const auto& [a, b] : rules->disabled) {
          if (!ours(a, b)) continue;
          disablePair(a, b, "SRDF <disable_collisions>");
          ++disabled;
        }
        {
          std::lock_guard<std::mutex> lock(world_mutex_);
          for (const std::string& link : rules->default_off) {
            if (!ours(link, link)) continue;
            world_->disableByDefault(link);
            default_off_.insert(link);
            ++off;
          }
          for (const auto& [a, b] : rules->enabled) {
            if (!ours(a, b)) continue;
            world_->enablePair(a, b);
            ++enabled;
          }
        }
        // srdfdom logs an error and goes on: the rules are taken by link name all the same.
        // Another robot's SRDF (one left on the parameter server by an earlier launch) applied
        // no rule with an INFO line only.
        if (robot && rules->robot_name != robot->robot_name) {
          ROS_WARN_STREAM(name_ << ": SRDF '" << skey << "' is of robot '" << rules->robot_name
                                << "', the URDF of robot '" << robot->robot_name
                                << "': its rules apply by link name");
        }
        if (rules->num_skipped != 0) {
          ROS_WARN_STREAM(name_ << ": SRDF '" << skey << "': " << rules->num_skipped
                                << " collision elements skipped, the first: "
                                << rules->first_skipped);
        }
        ROS_INFO_STREAM(name_ << ": SRDF: " << disabled << " pairs disabled, " << off
                              << " links disabled by default, " << enabled << " pairs enabled"
                              << (others ? ", " + std::to_string(others) +
                                               " rules on links without collision geometry "
                                               "or not in the URDF left out"
                                         : std::string()));
      }
    }
  }
  const std::string default_frame = root_frame.empty() ? "world" : root_frame;
  const std::string given = typedParam<std::string>("fixed_frame", default_frame, "a string");
  // tf2 frames have no leading '/': dropped, and only then is the name checked ("/" was taken as
  // the frame '' without a word, and no TF-attached body was ever posed).
  fixed_frame_ = given.substr(std::min(given.find_first_not_of('/'), given.size()));
  if (fixed_frame_.empty()) {
    param_errors_.push_back((given.empty()
                                 ? "fixed_frame is empty"
                                 : "fixed_frame '" + given + "' is empty without its leading '/'") +
                            "; using " + default_frame);
    fixed_frame_ = default_frame;
  }

  XmlRpc::XmlRpcValue pairs;
  if (pnh_.getParam("disabled_pairs", pairs)) {
    auto p = pairsFromXmlRpc(pairs);
    if (!p) {
      param_errors_.push_back("disabled_pairs: " + p.error());
    } else {
      for (const auto& [a, b] : *p)
        disablePair(a, b, "disabled_pairs parameter");
    }
  }
}

void Monitor::loadParameterBodies() {
  // ~bodies is a topic and a parameter: roscpp's getParam applies remappings, so remapping the
  // topic (~bodies:=/obstacles) read the parameter /obstacles (another monitor's bodies, or none
  // and no word). Asked of the master as it is named.
  XmlRpc::XmlRpcValue params, result, list;
  params[0] = ros::this_node::getName();
  params[1] = pnh_.resolveName("bodies", false);
  if (!ros::master::execute("getParam", params, result, list, false)) return;
  // Refused bodies are configured obstacles not watched: an ERROR in every report, as robot
  // geometry left out (one report's WARN, then "ok", the thirty-ninth session's audit).
  const auto leftOut = [this](const std::string& what) {
    body_errors_.push_back(what);
    rejectAtStartup(what);
  };
  if (list.getType() != XmlRpc::XmlRpcValue::TypeArray) {
    leftOut("parameter ~bodies: expected a list of bodies");
    return;
  }
  for (int i = 0; i < list.size(); ++i) {
    const std::string where = "parameter ~bodies[" + std::to_string(i) + "]";
    auto msg = bodyFromXmlRpc(list[i]);
    if (!msg) {
      leftOut(where + ": " + msg.error());
      continue;
    }
    try {
      auto spec = bodyFromMsg(*msg, world::BodyOrigin::Parameter, limits_, mesh_loader_);
      if (!spec) {
        leftOut(where + " body " + quoteInput(msg->id) + " refused: " + spec.error());
        continue;
      }
      const std::string err = addBody(std::move(spec).value());
      if (!err.empty()) leftOut(where + ": " + err);
    } catch (const std::exception& e) {  // as onBody(): one body, not the node
      leftOut(where + " body " + quoteInput(msg->id) + ": internal error: " + e.what());
    }
  }
}

void Monitor::disablePair(const std::string& a, const std::string& b, const std::string& reason) {
  std::lock_guard<std::mutex> lock(world_mutex_);
  world_->disablePair(a, b);
  disabled_reasons_.emplace(sortedPair(a, b), reason);  // the first reason wins
}

// ---------------------------------------------------------------------------------------------
// inputs

std::string Monitor::count(const std::string& what) {
  // Escaped whole: the world model's errors name bodies by their raw ids.
  std::string text = capped(escapeInput(what), kMaxRejectionText);
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++stats_.rejected;
  stats_.last_rejection = text;
  return text;
}

void Monitor::rejectAtStartup(const std::string& what) {
  ROS_ERROR_STREAM(name_ << ": " << count(what));
}

void Monitor::reject(const std::string& key, const std::string& what) {
  const std::string text = count(what);
  // Throttled per source (a body id, ~body_poses, a pose topic): one bad body cannot hide
  // another's message, and a stream of bad poses logs once per period. A storm of distinct
  // sources is bounded by the overall budget; the lines left out are counted in the next one.
  const ros::WallTime now = ros::WallTime::now();
  std::size_t skipped = 0;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (last_logged_.size() > 10000) last_logged_.clear();
    auto it = last_logged_.find(key);
    if (it != last_logged_.end() && (now - it->second).toSec() < kRejectLogPeriod) return;
    if ((now - log_window_start_).toSec() >= 1.0) {
      log_window_start_ = now;
      logged_in_window_ = 0;
    }
    if (logged_in_window_ >= kRejectLogBudget) {
      ++not_logged_;
      last_not_logged_ = text;
      return;
    }
    ++logged_in_window_;
    last_logged_[key] = now;
    skipped = not_logged_;
    not_logged_ = 0;
  }
  if (skipped > 0) {
    ROS_ERROR_STREAM(name_ << ": " << text << " (and " << skipped
                           << " other rejections not logged: over " << kRejectLogBudget
                           << " lines/s)");
  } else {
    ROS_ERROR_STREAM(name_ << ": " << text);
  }
}

void Monitor::logUnlogged() {
  std::size_t skipped = 0;
  std::string last;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    if (not_logged_ == 0 || (ros::WallTime::now() - log_window_start_).toSec() < 1.0) return;
    skipped = std::exchange(not_logged_, 0);
    last = std::move(last_not_logged_);
  }
  ROS_ERROR_STREAM(name_ << ": " << skipped << " rejections not logged: over " << kRejectLogBudget
                         << " lines/s (the last: " << last << ")");
}

std::string Monitor::resolvePoseTopic(const std::string& topic) const {
  if (topic.empty()) return topic;
  // Not remapped: subscribe() remaps the name it is given. Remapped here too, a swap of two
  // names (a:=b b:=a) was applied twice, and undid itself.
  // roscpp's NodeHandle methods refuse `~name`: it is the private namespace's `name`.
  if (topic[0] == '~')
    return pnh_.resolveName(topic.substr(topic.size() > 1 && topic[1] == '/' ? 2 : 1), false);
  return nh_.resolveName(topic, false);
}

std::string Monitor::addBody(world::BodySpec spec) {
  const std::string id = spec.id;
  std::string topic;
  try {
    // Resolved before anything changes: a name roscpp would refuse leaves the old body as it was.
    topic = resolvePoseTopic(spec.pose_topic);
  } catch (const ros::Exception& e) {
    return "pose_topic " + quoteInput(spec.pose_topic) + " cannot be resolved: " + e.what();
  }
  // Kept as the topic read (remapped): a replaced body keeps its pose while it comes from the
  // same topic (WorldModel::addBody), however it is spelled ('~x', '/node/x', or 'a' with a:=/x).
  if (!topic.empty()) spec.pose_topic = nh_.resolveName(topic);
  Tracked t;
  t.from_tf = spec.pose_source == world::PoseSource::Tf;
  t.frame = spec.frame;
  t.origin = spec.origin;
  t.pose_topic = topic;
  t.came = ros::Time::now();
  {
    const auto lock = lockWorld();
    std::string err = world_->addBody(std::move(spec));
    if (!err.empty()) return err;
    tracked_[id] = t;
  }
  updatePoseSubscription(id, topic);
  if (check_on_pose_) trigger();
  return {};
}

bool Monitor::removeBody(const std::string& id, std::string* why) {
  {
    const auto lock = lockWorld();
    auto it = tracked_.find(id);
    if (it == tracked_.end()) {
      // Nothing to do: a second REMOVE, or a latched one replayed to a restarted monitor.
      ROS_DEBUG_STREAM(name_ << ": ~bodies: REMOVE of " << quoteInput(id) << ": no such body");
      return true;
    }
    if (it->second.origin != world::BodyOrigin::Topic) {
      *why = std::string("declared by the ") + world::toString(it->second.origin) +
             "; only bodies added on ~bodies can be removed there";
      return false;
    }
    world_->removeBody(id);
    tracked_.erase(it);
  }
  updatePoseSubscription(id, "");
  if (check_on_pose_) trigger();
  return true;
}

void Monitor::updatePoseSubscription(const std::string& id, const std::string& topic) {
  std::lock_guard<std::mutex> lock(subs_mutex_);
  auto it = pose_subs_.find(id);
  if (it != pose_subs_.end()) {
    if (it->second.first == topic) return;  // same topic: keep the connection
    it->second.second.shutdown();
    pose_subs_.erase(it);
  }
  if (topic.empty()) return;
  boost::function<void(const geometry_msgs::PoseStamped::ConstPtr&)> cb =
      [this, id, topic](const geometry_msgs::PoseStamped::ConstPtr& msg) {
        onPoseStamped(id, topic, msg);
      };
  ros::Subscriber sub = nh_.subscribe<geometry_msgs::PoseStamped>(
      topic, 10, cb, ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  pose_subs_.emplace(id, std::make_pair(topic, sub));
}

std::optional<Transform3> Monitor::toFixed(const std::string& frame_in, const ros::Time& stamp,
                                           std::string* why, ros::Time* used) const {
  const std::string frame = tfFrameName(frame_in);
  if (used != nullptr) *used = ros::Time();
  if (frame == fixed_frame_) return Transform3::Identity();
  const auto taken = [used](const geometry_msgs::TransformStamped& tf) {
    if (used != nullptr) *used = tf.header.stamp;
    return toTransform3(tf.transform);
  };
  try {
    return taken(tf_buffer_->lookupTransform(fixed_frame_, frame, stamp, ros::Duration(0)));
  } catch (const tf2::ExtrapolationException&) {
    // The pose may have arrived before the matching TF: give TF a moment, 50 ms of wall time.
    // Not tf2's own timeout: it waits in ROS time, which under a paused /clock never passes, and
    // held this callback thread (and with two such poses every worker thread, services
    // included) until the clock ran again. Only while TF is behind the stamp and has moved since
    // the last wait for this frame that failed: a frame whose TF has stopped would otherwise
    // hold a worker thread 50 ms per message (a stream of them stalled services for seconds).
    ros::Time latest;  // of the chain; zero when there is none
    try {
      latest = tf_buffer_->lookupTransform(fixed_frame_, frame, ros::Time(0)).header.stamp;
    } catch (const tf2::TransformException&) {
    }
    bool wait = latest.isZero() || latest < stamp;
    if (wait) {
      std::lock_guard<std::mutex> lock(tf_wait_mutex_);
      auto it = failed_waits_.find(frame);
      wait = it == failed_waits_.end() || it->second != latest;
    }
    bool caught_up = false;
    if (wait) {
      ++tf_waits_;
      const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(0.05);
      while (!(caught_up = tf_buffer_->canTransform(fixed_frame_, frame, stamp)) &&
             ros::WallTime::now() < deadline && ros::ok()) {
        ros::WallDuration(0.002).sleep();
      }
      std::lock_guard<std::mutex> lock(tf_wait_mutex_);
      if (caught_up) {
        failed_waits_.erase(frame);
      } else {
        if (failed_waits_.size() >= 1000) failed_waits_.clear();  // frames are few; bound it
        failed_waits_[frame] = latest;
      }
    }
    try {
      return taken(tf_buffer_->lookupTransform(fixed_frame_, frame, stamp));
    } catch (const tf2::TransformException& e) {
      *why = e.what();
    }
  } catch (const tf2::TransformException& e) {
    *why = e.what();
  }
  return std::nullopt;
}

void Monitor::applyPoses(std::vector<PoseUpdate> updates, const ros::Time& stamp,
                         const std::string& source, const std::string* pose_topic) {
  PendingPoses p{std::move(updates), stamp, ros::Time::now(), source,
                 pose_topic ? std::optional<std::string>(*pose_topic) : std::nullopt};
  {
    std::unique_lock<std::mutex> world(world_mutex_, std::try_to_lock);
    if (world.owns_lock()) {
      applyPendingPoses();  // those that came first
      const bool ours = applyPosesLocked(p);
      world.unlock();
      if (ours && check_on_pose_) trigger();
      return;
    }
  }
  // A message counts at least one update against kMaxPendingPoseUpdates.
  const auto weight = [](const PendingPoses& q) {
    return std::max<std::size_t>(1, q.updates.size());
  };
  {
    std::lock_guard<std::mutex> lock(pending_mutex_);
    pending_updates_ += weight(p);
    pending_poses_.push_back(std::move(p));
    ++poses_deferred_;
    while (pending_updates_ > kMaxPendingPoseUpdates && pending_poses_.size() > 1) {
      pending_updates_ -= weight(pending_poses_.front());
      pending_poses_.pop_front();
      ++poses_dropped_;
    }
  }
  // The next check applies them (and sooner any service or ~bodies message, lockWorld()).
  if (check_on_pose_) trigger();
}

std::unique_lock<std::mutex> Monitor::lockWorld() {
  std::unique_lock<std::mutex> lock(world_mutex_);
  applyPendingPoses();
  return lock;
}

void Monitor::applyPendingPoses() {
  std::deque<PendingPoses> pending;
  {
    std::lock_guard<std::mutex> lock(pending_mutex_);
    pending.swap(pending_poses_);
    pending_updates_ = 0;
  }
  for (const PendingPoses& p : pending)
    applyPosesLocked(p);
}

bool Monitor::applyPosesLocked(const PendingPoses& p) {
  // A pose from the future of ROS time would count as fresh until the clock caught up with it:
  // data from before a time jump still in flight, ROS time 0 (simulated time before the first
  // /clock), or clocks out of sync. Read under the lock that runCycle clears the poses with.
  const ros::Time now_time = ros::Time::now();
  const double now = now_time.toSec();
  const double t = p.stamp.toSec();
  if (t > now + kTimeJumpTolerance) {
    std::ostringstream os;
    os.setf(std::ios::fixed);
    os.precision(3);
    os << p.source << " refused: stamped " << t << " s, " << t - now
       << " s after the current ROS time " << now
       << " (data from before a time jump, no /clock yet, or unsynchronised clocks)";
    reject(p.source, os.str());
    return false;
  }
  // Stamped ahead (within the tolerance, a publisher's clock ahead of ours): it ages from when
  // it came. By its own stamp it would stay fresh for as long as it is ahead after its publisher
  // stopped. (Not before the clock starts: 0 is no time. Not after now: it came before a jump
  // back.)
  const std::optional<world::Stamp> arrived = arrivedAt(std::min(p.arrived, now_time));
  std::vector<std::string> unknown, attached;
  std::size_t superseded = 0, ignored = 0;
  bool applied = false;
  for (const auto& u : p.updates) {
    auto it = tracked_.find(u.id);
    if (it == tracked_.end()) {
      // A pose topic names one body: an unknown id there is this monitor's own business.
      if (ignore_unknown_pose_ids_ && !p.pose_topic) {
        ++ignored;
      } else {
        unknown.push_back(u.id);
      }
    } else if (p.pose_topic && it->second.pose_topic != *p.pose_topic) {
      // Sent to the body this one replaced: it posed the new body with a pose nobody sent it
      // (stamped 0, for good), or was refused as for a TF body.
      ++superseded;
    } else if (it->second.from_tf) {
      attached.push_back(u.id + " (frame " + it->second.frame + ")");
    } else {
      applied = world_->setPose(u.id, u.pose, toStamp(p.stamp), u.twist, arrived) || applied;
    }
  }
  if (applied) {  // statistics: see pose_msgs_applied_
    ++pose_msgs_applied_;
    new_poses_ = true;
  }
  if (ignored != 0) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.unknown_pose_ids_ignored += ignored;
  }
  if (!unknown.empty() || !attached.empty()) {
    std::string what = p.source + ": poses ignored for";
    if (!unknown.empty()) what += " unknown bodies: " + joined(unknown);
    if (!attached.empty()) {
      what += std::string(unknown.empty() ? "" : ";") +
              " bodies attached to TF (not pose_from_topic): " + joined(attached);
    }
    reject(p.source, what);
  }
  return unknown.size() + attached.size() + superseded + ignored < p.updates.size();
}

void Monitor::onBody(const ros::MessageEvent<const Checked<collision_monitor::Body>>& event) {
  const auto& msg = event.getConstMessage();
  const std::string key = sourceKey("~bodies:", msg->id);
  try {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.bodies_msgs;
    }
    if (!msg->refused.empty()) {
      reject("~bodies (malformed)", "~bodies: message from " +
                                        quoteInput(event.getPublisherName()) +
                                        " refused: " + msg->refused);
      return;
    }
    const std::string id = quoteInput(msg->id);
    if (msg->operation == collision_monitor::Body::REMOVE) {
      std::string why;
      if (!removeBody(msg->id, &why)) reject(key, "~bodies: cannot remove " + id + ": " + why);
      return;
    }
    if (msg->operation != collision_monitor::Body::ADD) {
      reject(key, "~bodies: body " + id + ": unknown operation " + std::to_string(msg->operation));
      return;
    }
    auto spec = bodyFromMsg(*msg, world::BodyOrigin::Topic, limits_, mesh_loader_);
    if (!spec) {
      reject(key, "~bodies: body " + id + " refused: " + spec.error());
      return;
    }
    const std::string err = addBody(std::move(spec).value());
    if (!err.empty()) reject(key, "~bodies: " + err);  // the world's errors name the body
  } catch (const std::exception& e) {
    reject(key, "~bodies: body " + quoteInput(msg->id) + ": internal error: " + e.what());
  }
}

void Monitor::onBodyPoses(
    const ros::MessageEvent<const Checked<collision_monitor::BodyPoses>>& event) {
  const auto& msg = event.getConstMessage();
  try {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.poses_msgs;
    }
    if (!msg->refused.empty()) {
      reject("~body_poses", "~body_poses: message from " + quoteInput(event.getPublisherName()) +
                                " refused: " + msg->refused);
      return;
    }
    auto updates = posesFromMsg(*msg);
    if (!updates) {
      reject("~body_poses", "~body_poses refused: " + updates.error());
      return;
    }
    if (msg->header.frame_id.empty()) {
      reject("~body_poses", "~body_poses refused: header.frame_id is empty");
      return;
    }
    std::string why;
    ros::Time used;
    auto to_fixed = toFixed(msg->header.frame_id, msg->header.stamp, &why, &used);
    if (!to_fixed) {
      reject("~body_poses", "~body_poses refused: cannot resolve frame " +
                                quoteInput(msg->header.frame_id) + ": " + capped(why, 512));
      return;
    }
    for (auto& u : *updates)
      u = transformUpdate(u, *to_fixed);
    applyPoses(std::move(*updates), poseStamp(msg->header.stamp, used), "~body_poses");
  } catch (const std::exception& e) {
    reject("~body_poses", std::string("~body_poses: internal error: ") + e.what());
  }
}

void Monitor::onPoseStamped(const std::string& id, const std::string& topic,
                            const geometry_msgs::PoseStamped::ConstPtr& msg) {
  try {
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.pose_topic_msgs;
    }
    const std::string key = sourceKey("pose_topic:", id);
    const std::string source = "pose_topic of " + quoteInput(id);
    auto pose = toTransform(msg->pose, ZeroQuaternion::Refuse);
    if (!pose) {
      reject(key, source + " refused: " + pose.error());
      return;
    }
    if (msg->header.frame_id.empty()) {
      reject(key, source + " refused: header.frame_id is empty");
      return;
    }
    const std::string too_long =
        checkLength(msg->header.frame_id, kMaxNameLength, "header.frame_id");
    if (!too_long.empty()) {
      reject(key, source + " refused: " + too_long);
      return;
    }
    std::string why;
    ros::Time used;
    auto to_fixed = toFixed(msg->header.frame_id, msg->header.stamp, &why, &used);
    if (!to_fixed) {
      reject(key, source + " refused: cannot resolve frame " + quoteInput(msg->header.frame_id) +
                      ": " + capped(why, 512));
      return;
    }
    applyPoses({PoseUpdate{id, *to_fixed * *pose, std::nullopt}},
               poseStamp(msg->header.stamp, used), source, &topic);
  } catch (const std::exception& e) {
    reject(sourceKey("pose_topic:", id),
           "pose_topic of " + quoteInput(id) + ": internal error: " + e.what());
  }
}

// ---------------------------------------------------------------------------------------------
// services

std::string Monitor::whyNeverChecked(const std::string& a, const std::string& b) const {
  if (world_->isPairDisabled(a, b)) {
    auto it = disabled_reasons_.find(sortedPair(a, b));
    if (it != disabled_reasons_.end()) return "the pair is disabled (" + it->second + ")";
    const std::string& off = default_off_.count(a) != 0 ? a : b;
    return "the pair is disabled (SRDF <disable_default_collisions> of '" + off + "')";
  }
  const world::BodySpec* ba = world_->body(a);
  const world::BodySpec* bb = world_->body(b);
  if (ba && bb && !ba->group.empty() && ba->group == bb->group) {
    return "both bodies are in group '" + ba->group + "'";
  }
  return {};
}

bool Monitor::getDistance(collision_monitor::GetDistance::Request& req,
                          collision_monitor::GetDistance::Response& res) {
  // Until there is an answer, the result says UNKNOWN (a failed call read as CLEAR at distance 0
  // and time to collision 0 by a client that skipped `success`).
  res.success = false;
  res.result.body_a = req.body_a;
  res.result.body_b = req.body_b;
  res.result.status = collision_monitor::PairState::UNKNOWN;
  res.result.distance = std::numeric_limits<double>::infinity();
  res.result.time_to_collision = std::numeric_limits<double>::infinity();
  try {
    const world::Stamp now = toStamp(ros::Time::now());
    if (req.body_a.empty()) {
      res.message = "body_a is empty";
      return true;
    }
    std::optional<world::PairResult> result;
    world::Stamp stamp;  // the poses' time (zero: both static)
    std::string why;
    {
      const auto lock = lockWorld();
      if (!world_->hasBody(req.body_a)) {
        why = "unknown body " + quoteInput(req.body_a);
      } else if (req.body_b.empty()) {
        result = world_->nearest(req.body_a, now, &why, &stamp);
      } else if (!world_->hasBody(req.body_b)) {
        why = "unknown body " + quoteInput(req.body_b);
      } else if (req.body_a == req.body_b) {
        why = "body_a and body_b are the same body";
      } else {
        const std::string never = whyNeverChecked(req.body_a, req.body_b);
        if (!never.empty()) {
          why = quoteInput(req.body_a) + " and " + quoteInput(req.body_b) +
                " are never checked: " + never;
        } else {
          result = world_->distance(req.body_a, req.body_b, now, &why, &stamp);
        }
      }
    }
    if (!result) {
      res.message = why.empty() ? "no result" : why;
      return true;
    }
    Transform3 to_frame = Transform3::Identity();
    std::string note;
    const std::string frame = tfFrameName(req.frame_id);
    if (!req.frame_id.empty() && frame != fixed_frame_) {
      // The frame where it was when the poses were taken: a frame moving at 1 m/s puts the latest
      // TF 0.1 m from the points of poses 0.1 s old. The latest TF when the frame has none for
      // that time (its publisher lags the bodies' poses), said in the message.
      const ros::Time at = stamp.isStatic() ? ros::Time(0) : toRosTime(stamp);
      try {
        try {
          to_frame = toTransform3(tf_buffer_->lookupTransform(frame, fixed_frame_, at).transform);
        } catch (const tf2::ExtrapolationException& e) {
          if (at.isZero()) throw;
          to_frame = toTransform3(
              tf_buffer_->lookupTransform(frame, fixed_frame_, ros::Time(0)).transform);
          note = "expressed with the latest transform of " + quoteInput(req.frame_id) +
                 ", none at the poses' time: " + capped(e.what(), 512);
        }
      } catch (const tf2::TransformException& e) {
        res.message = "cannot express the result in frame " + quoteInput(req.frame_id) + ": " +
                      capped(e.what(), 512);
        return true;
      }
    }
    res.result = toMsg(*result, to_frame);
    res.success = true;
    res.message = req.body_b.empty() ? "nearest body: " + result->body_b : "";
    if (!note.empty()) res.message += (res.message.empty() ? "" : "; ") + note;
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("internal error: ") + e.what();
  }
  return true;
}

bool Monitor::checkCollision(Checked<collision_monitor::CheckCollision::Request>& req,
                             collision_monitor::CheckCollision::Response& res) {
  try {
    res.success = false;
    if (!req.refused.empty()) {
      res.message = "request refused: " + req.refused;
      reject("~check_collision (malformed)", "~check_collision: " + res.message);
      return true;
    }
    const world::Stamp now = toStamp(ros::Time::now());
    // An empty id is a label only ("check_collision" in the answer), never a tracked body's id.
    bool anonymous = false;
    const collision_monitor::Body body = hypotheticalBody(req.body, fixed_frame_, &anonymous);
    if (!std::isfinite(req.margin)) {
      res.message = "margin is not finite";
      return true;
    }
    auto spec = bodyFromMsg(body, world::BodyOrigin::Topic, limits_, mesh_loader_);
    if (!spec) {
      res.message = "body " + quoteInput(body.id) + " refused: " + spec.error();
      return true;
    }
    auto pose = toTransform(req.pose, ZeroQuaternion::Identity);
    if (!pose) {
      res.message = "pose refused: " + pose.error();
      return true;
    }
    std::string why;
    auto to_fixed = toFixed(body.header.frame_id, body.header.stamp, &why);
    if (!to_fixed) {
      res.message =
          "cannot resolve frame " + quoteInput(body.header.frame_id) + ": " + capped(why, 512);
      return true;
    }
    std::optional<std::vector<world::PairResult>> pairs;
    std::size_t unknown = 0;  // listed or not (max_unknown_pairs)
    std::string refused;  // the world's own rules: an id of white space only, the limits in force
    {
      const auto lock = lockWorld();
      pairs = world_->checkHypothetical(*spec, *to_fixed * *pose, req.margin, now, anonymous,
                                        &unknown, &refused);
    }
    if (!pairs) {
      res.message = escapeInput(refused);
      return true;
    }
    // Sorted by distance (then body), UNKNOWN last, by checkHypothetical; a pair's status is the
    // one a first check would give (COLLISION at or below contact_distance).
    res.in_collision = false;
    std::size_t listed = 0;
    for (const auto& p : *pairs) {
      if (p.status == world::PairStatus::Collision) res.in_collision = true;
      if (p.status == world::PairStatus::Unknown) ++listed;
      res.pairs.push_back(toMsg(p));
    }
    if (unknown > 0) {
      res.message = std::to_string(unknown) +
                    " bodies without a fresh pose (or whose check failed): their pairs are UNKNOWN";
      if (listed < unknown) {
        res.message += " (" + std::to_string(listed) + " listed, max_unknown_pairs)";
      }
    }
    res.success = true;
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("internal error: ") + e.what();
  }
  return true;
}

bool Monitor::listBodies(collision_monitor::ListBodies::Request& /*req*/,
                         collision_monitor::ListBodies::Response& res) {
  const world::Stamp now = toStamp(ros::Time::now());
  std::vector<world::BodyInfo> infos;
  {
    const auto lock = lockWorld();
    infos = world_->listBodies(now);
  }
  // By id (WorldModel::listBodies).
  for (const auto& b : infos) {
    res.ids.push_back(b.id);
    res.frames.push_back(b.frame);
    res.groups.push_back(b.group);
    res.stale.push_back(b.stale);
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// the check loop

void Monitor::trigger() {
  {
    std::lock_guard<std::mutex> lock(loop_mutex_);
    triggered_ = true;
  }
  loop_cv_.notify_one();
}

void Monitor::loopThread() {
  using Clock = std::chrono::steady_clock;
  // rate and min_check_interval may change (dynamic_reconfigure, which triggers a check). Capped
  // at a year: the steady clock's nanoseconds overflow past 292 years (rate 1e-12 Hz is valid).
  const auto seconds = [](double s) {
    return std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(std::min(s, kMaxLoopPeriod)));
  };
  auto next = Clock::now();
  // The first check runs at once: neither a period nor min_check_interval has to pass first (a
  // min_check_interval of 20 s given at start-up held the first ~state back for 20 s).
  auto last_start = Clock::now() - seconds(std::max(1.0 / rate_, min_check_interval_.load()));
  // "no check for ..." (/diagnostics) counts from here until a first check starts.
  last_check_started_ = Clock::now().time_since_epoch().count();
  std::unique_lock<std::mutex> lock(loop_mutex_);
  while (!stop_) {
    loop_cv_.wait_until(lock, next, [this] { return stop_ || triggered_; });
    if (stop_) break;
    // A burst of pose messages becomes one check: wait out the minimum interval, during which
    // further triggers merge into this one.
    // A new min_check_interval ends the wait and is waited out instead (a typo of 20 s, put
    // right at once, stopped the checks for the 20 s).
    for (auto earliest = last_start + seconds(min_check_interval_); Clock::now() < earliest;
         earliest = last_start + seconds(min_check_interval_)) {
      retimed_ = false;
      loop_cv_.wait_until(lock, earliest, [this] { return stop_ || retimed_; });
      if (stop_) break;
    }
    if (stop_) break;
    triggered_ = false;
    last_start = Clock::now();
    lock.unlock();
    check_started_ = Clock::now().time_since_epoch().count();
    last_check_started_ = check_started_.load();
    try {
      runCycle();
    } catch (const std::exception& e) {
      if (cycle_error_log_.ready()) ROS_ERROR_STREAM(name_ << ": check cycle failed: " << e.what());
    }
    check_started_ = 0;
    lock.lock();
    next = last_start + seconds(1.0 / rate_);
  }
}

void Monitor::logUnresolved(const std::map<std::string, std::string>& unresolved_why,
                            const std::set<std::string>& looked_up,
                            std::chrono::steady_clock::time_point now) {
  std::vector<std::string> warn, resolved;
  for (auto it = unresolved_.begin(); it != unresolved_.end();) {
    if (unresolved_why.count(it->first)) {
      ++it;
      continue;
    }
    // Resolved, or no longer looked up (its bodies removed): only the former is news.
    if (it->second.warned && looked_up.count(it->first)) resolved.push_back(quoteInput(it->first));
    it = unresolved_.erase(it);
  }
  for (const auto& [frame, why] : unresolved_why) {
    Unresolved& u = unresolved_.try_emplace(frame, Unresolved{now, false}).first->second;
    if (u.warned || std::chrono::duration<double>(now - u.since).count() < kUnresolvedWarnAfter)
      continue;
    u.warned = true;
    warn.push_back(quoteInput(frame) + ": " + why);
  }
  if (!warn.empty()) {
    ROS_WARN_STREAM(name_ << ": " << warn.size() << " TF frame" << (warn.size() > 1 ? "s" : "")
                          << " cannot be looked up in " << quoteInput(fixed_frame_) << " for "
                          << kUnresolvedWarnAfter << " s, the bodies on "
                          << (warn.size() > 1 ? "them" : "it")
                          << " are UNKNOWN: " << joined(warn, kUnresolvedNamed));
  }
  if (!resolved.empty()) {
    ROS_INFO_STREAM(name_ << ": TF frame" << (resolved.size() > 1 ? "s " : " ")
                          << joined(resolved, kUnresolvedNamed) << " resolved in "
                          << quoteInput(fixed_frame_));
  }
}

void Monitor::runCycle() {
  const ros::Time stamp_now = ros::Time::now();
  const double now = stamp_now.toSec();
  const auto steady_now = std::chrono::steady_clock::now();
  if (last_now_ > 0.0 && now + kTimeJumpTolerance < last_now_) {
    // Bag loop, simulation reset: poses and transforms from before the jump would look fresh
    // (stamped ahead of ROS time), and tf2 would refuse the new ones as older than its cache.
    if (jump_log_.ready()) {
      ROS_WARN_STREAM(name_ << ": time jumped backwards by " << last_now_ - now
                            << " s: forgetting every pose and the TF buffer"
                            << (jumps_not_logged_ ? " (and " + std::to_string(jumps_not_logged_) +
                                                        " more jumps back since the last such "
                                                        "line: is /clock published twice?)"
                                                  : std::string()));
      jumps_not_logged_ = 0;
    } else {
      ++jumps_not_logged_;
    }
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.time_jumps_back;
      recent_jumps_.push_back(ros::WallTime::now());
      if (recent_jumps_.size() > kJumpsWarn) recent_jumps_.pop_front();
    }
    tf_receiver_->clear();
    tf_seen_.clear();
    {
      std::lock_guard<std::mutex> lock(world_mutex_);
      world_->clearPoses();
    }
    tf_clear_until_ = steady_now + std::chrono::seconds(kTfClearWindow);
    // diagnostic_updater waits for the ROS time of its next report, now in the future: publish
    // now, which also schedules the next report from the new time. At most once a second (two
    // /clock publishers jump back at every other message).
    // Further back than the last forced report: that one's schedule is as far ahead again.
    const ros::WallTime wall = ros::WallTime::now();
    if (last_forced_report_.isZero() || (wall - last_forced_report_).toSec() >= 1.0 ||
        now < last_forced_time_) {
      last_forced_report_ = wall;
      last_forced_time_ = now;
      {
        std::lock_guard<std::mutex> lock(loop_mutex_);
        force_diagnostics_ = true;
      }
      diagnostics_cv_.notify_one();
    }
  }
  if (last_now_ > 0.0 && now < last_now_) {
    // Any jump back: a TF frame first seen after the new time ages from it, as timed poses do
    // (WorldModel::check). By its first sighting, still ahead, it stayed fresh for as long again
    // as the jump after its publisher stopped (a jump of up to 1 s forgets nothing).
    for (auto& [frame, seen] : tf_seen_)
      seen.at = std::min(seen.at, stamp_now);
  }
  last_now_ = now;
  // Simulated time not started yet. Once it has, checks go on at time 0 (a reset to 0, held):
  // the pairs of the poses just forgotten turn UNKNOWN now, not when the clock runs again.
  if (stamp_now.isZero() && !clock_started_) return;
  clock_started_ = true;

  // TF lookups outside the world lock: one per distinct frame, and with align_poses one per TF
  // stamp since the frame's last lookup (a check that TF outran: the world keeps poses from the
  // second such pose of a body on, WorldModel::keepsPoses()).
  std::vector<std::pair<std::string, std::string>> attached;  // id, frame
  bool catch_up = false;
  double pose_timeout = 0.0;
  {
    std::lock_guard<std::mutex> lock(world_mutex_);
    for (const auto& [id, t] : tracked_) {
      if (t.from_tf) attached.emplace_back(id, t.frame);
    }
    catch_up = world_->settings().align_poses;
    pose_timeout = world_->settings().pose_timeout;
  }
  struct FramePose {
    Transform3 pose;
    world::Stamp stamp;                   ///< the transform's
    std::optional<world::Stamp> arrived;  ///< when the check first saw that transform
  };
  std::map<std::string, std::optional<FramePose>> frames;
  // Per frame, its poses at the TF stamps between its last lookup and this one, in order.
  std::map<std::string, std::vector<FramePose>> frames_between;
  // The frames to look up, each once: bodies may share one, and those on the fixed frame need
  // none. They share the lookups between two checks (counted by TF bodies, 1,000 YAML bodies on
  // the fixed frame cut a TF dart's catch-up to one stamp a check: the thirty-eighth session's
  // audit).
  std::set<std::string> tf_frames;
  for (const auto& [id, frame] : attached) {
    if (frame == fixed_frame_) {
      frames[frame] = FramePose{Transform3::Identity(), world::Stamp(), std::nullopt};  // static
    } else {
      tf_frames.insert(frame);
    }
  }
  const std::size_t between_most = std::clamp<std::size_t>(
      kMaxTfLookupsBetween / std::max<std::size_t>(1, tf_frames.size()), 1, kMaxTfStampsBetween);
  std::vector<std::string> future_frames;
  // Why a frame's lookup failed, for the queries' messages and /diagnostics ("has no pose yet"
  // said nothing of the frame: a typo in a frame name, a fixed frame missing from TF).
  std::map<std::string, std::string> unresolved_why;
  std::map<std::string, TfSeen> seen;  // tf_seen_ for this cycle's frames
  // Every frame from the same TF messages: none goes in while these lookups run (TfReceiver).
  auto tf_snapshot = tf_receiver_->snapshot();
  // After every transform looked up below came in: one stamped later was stamped ahead. (Not
  // `stamp_now`: TF that came since the check began would be taken as ahead, and aged from an
  // earlier time than its own.)
  const ros::Time seen_at = ros::Time::now();
  for (const std::string& frame : tf_frames) {
    try {
      const auto tf = tf_buffer_->lookupTransform(fixed_frame_, frame, ros::Time(0));
      const ros::Time& stamp = tf.header.stamp;
      // When this transform was first seen (this cycle if it is new): a frame stamped ahead of
      // ROS time (its publisher's clock ahead of ours) ages from then, as timed poses do. By its
      // own stamp it would stay fresh for as long as it is ahead after its publisher stopped,
      // and one more than kTimeJumpTolerance ahead would turn fresh 1 s before its stamp, long
      // after it came.
      auto before = tf_seen_.find(frame);
      const TfSeen& first = seen[frame] = before != tf_seen_.end() && before->second.stamp == stamp
                                              ? before->second
                                              : TfSeen{stamp, seen_at};
      if (stamp.toSec() > now + kTimeJumpTolerance) {
        // From the future of ROS time: not fresh data (it would stay "fresh" until the clock
        // caught up). Right after a backward jump it is data from before the jump that arrived
        // after the buffer was cleared, and it blocks the new data (tf2 refuses data older than
        // its cache behind the latest): clear again.
        frames[frame] = std::nullopt;
        const std::string ahead = std::to_string(stamp.toSec() - now);
        future_frames.push_back(frame + " (" + ahead + " s ahead)");
        unresolved_why[frame] = "stamped " + ahead + " s after the current ROS time";
      } else {
        frames[frame] =
            FramePose{toTransform3(tf.transform), toStamp(tf.header.stamp), arrivedAt(first.at)};
        if (catch_up) {
          // What the frame did since its last lookup, for catch-up: where TF moved it between
          // two checks that it outran. A frame not looked up before (new to TF, or to the
          // bodies): since a pose_timeout ago, as far as the buffer goes; a body that was not
          // there then takes only what came after it (below).
          const ros::Time since = before != tf_seen_.end()
                                      ? before->second.stamp
                                      : ros::Time(std::max(0.0, now - pose_timeout));
          for (const ros::Time& at :
               tf_receiver_->stampsBetween(tf_snapshot, since, stamp, between_most)) {
            try {
              const auto t = tf_buffer_->lookupTransform(fixed_frame_, frame, at);
              frames_between[frame].push_back(
                  FramePose{toTransform3(t.transform), toStamp(t.header.stamp), std::nullopt});
            } catch (const tf2::TransformException&) {
              // Not every frame of the chain known at that time (a source that started since).
            }
          }
        }
      }
    } catch (const tf2::TransformException& e) {
      frames[frame] = std::nullopt;
      unresolved_why[frame] = capped(e.what(), 512);
    }
  }
  tf_snapshot.unlock();
  logUnresolved(unresolved_why, tf_frames, steady_now);
  // What each body on such a frame says, made once a frame (not once a body, every check).
  std::map<std::string, std::string> body_why;
  for (const auto& [frame, why] : unresolved_why) {
    body_why.emplace(frame, "its frame " + quoteInput(frame) + " cannot be looked up in " +
                                quoteInput(fixed_frame_) + ": " + why);
  }
  // Frames not looked up this cycle (no body on them, a failed lookup) keep the time they were
  // first seen while their stamp is still ahead: seen again later, they are not new data.
  for (auto& [frame, first] : tf_seen_) {
    if (first.stamp > stamp_now) seen.emplace(frame, first);
  }
  tf_seen_.swap(seen);
  if (!future_frames.empty()) {
    const bool clear = steady_now < tf_clear_until_;
    if (future_tf_log_.ready()) {
      ROS_WARN_STREAM(name_ << ": TF stamped more than " << kTimeJumpTolerance
                            << " s after the current ROS time, frames unresolved: "
                            << joined(future_frames)
                            << (clear ? "; cleared the TF buffer (time jumped back)" : ""));
    }
    if (clear) tf_receiver_->clear();
  }

  world::CycleResult cycle;
  std::size_t pose_msgs_applied = 0, checks_with_new_poses = 0;
  visualization_msgs::MarkerArray markers;
  const bool markers_on = publish_markers_;
  const std::uint32_t marker_subscribers = markers_pub_.getNumSubscribers();
  const bool want_markers = markers_on && marker_subscribers > 0;
  {
    const auto lock = lockWorld();
    for (const auto& [id, frame] : attached) {
      auto it = tracked_.find(id);
      if (it == tracked_.end() || !it->second.from_tf || it->second.frame != frame) continue;
      const auto& f = frames[frame];
      if (f) {
        // To a body with no pose yet, nothing from before it came.
        const auto between = frames_between.find(frame);
        if (between != frames_between.end()) {
          const bool posed = world_->pose(id).has_value();
          const world::Stamp came = toStamp(it->second.came);
          for (const FramePose& b : between->second) {
            if (posed || b.stamp >= came) world_->setPose(id, b.pose, b.stamp);
          }
        }
        world_->setPose(id, f->pose, f->stamp, std::nullopt, f->arrived);
      } else {
        world_->markUnresolved(id, body_why[frame]);
      }
    }
    cycle = world_->check(toStamp(stamp_now));
    if (cycle.abandoned) return;  // shutting down: nothing in it is a verdict
    if (new_poses_) ++checks_with_new_poses_;
    new_poses_ = false;
    pose_msgs_applied = pose_msgs_applied_;
    checks_with_new_poses = checks_with_new_poses_;
    if (want_markers) {
      const bool more = marker_subscribers > marker_subscribers_;
      if (markers_subscribed_.exchange(false) || more) marker_builder_.resendAll();
      markers = marker_builder_.build(*world_, cycle, fixed_frame_);
    } else if (!markers_on && markers_published_) {
      markers = marker_builder_.clear(fixed_frame_);  // publish_markers turned off
    }
    marker_subscribers_ = marker_subscribers;
  }
  // The whole cycle, as INTERFACE.md says: TF lookups, the check and the markers (it was the
  // world's check alone).
  cycle.compute_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - steady_now).count();

  for (const auto& e : cycle.events)
    events_pub_.publish(toMsg(e, fixed_frame_, toStamp(stamp_now)));
  state_pub_.publish(toMsg(cycle, fixed_frame_, toStamp(stamp_now)));
  if (!markers.markers.empty()) {
    markers_pub_.publish(markers);
    markers_published_ = markers_on;
  }

  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.cycles;
    stats_.cycle_time_sum += cycle.compute_time;
    stats_.cycle_time_max = std::max(stats_.cycle_time_max, cycle.compute_time);
    stats_.stale = cycle.stale_bodies.size();
    stats_.stale_ids = cycle.stale_bodies;
    stats_.unresolved_frames.clear();
    for (const auto& [frame, why] : unresolved_why)
      stats_.unresolved_frames.push_back(quoteInput(frame) + ": " + why);
    stats_.bodies = cycle.num_bodies;
    stats_.pairs_checked = cycle.num_pairs_checked;
    stats_.pairs_checked_sum += cycle.num_pairs_checked;
    stats_.pairs_caught_up_sum += cycle.num_pairs_caught_up;
    stats_.pose_msgs_applied = pose_msgs_applied;
    stats_.checks_with_new_poses = checks_with_new_poses;
  }
}

void Monitor::diagnosticsThread() {
  // diagnostic_updater sends a report once its period (ROS time) has passed since the last:
  // asked every 0.1 s, a report is at most that late.
  std::unique_lock<std::mutex> lock(loop_mutex_);
  bool abandoned = false;
  while (!stop_) {
    diagnostics_cv_.wait_for(lock, std::chrono::milliseconds(100),
                             [this] { return stop_ || force_diagnostics_; });
    if (stop_) break;
    // The process is shutting down (SIGINT): stop a check in progress now, not in ~Monitor. A
    // callback waiting for the world mutex meanwhile (a pose, a service call) holds the nodelet,
    // so ~Monitor came only after the check had ended (seconds with bodies of 1,000 parts).
    if (!abandoned && ros::isShuttingDown()) {
      world_->abandonChecks();
      abandoned = true;
    }
    const bool force = std::exchange(force_diagnostics_, false);
    lock.unlock();
    logUnlogged();
    if (std::string e = checkDiagnosticPeriod(); !e.empty()) reject("diagnostic_period", e);
    try {
      if (force) {
        diagnostics_->force_update();
      } else {
        diagnostics_->update();
      }
    } catch (const std::exception& e) {
      // A value checkDiagnosticPeriod() let through that diagnostic_updater still cannot use
      // (ros::Time + period beyond 32 bits under simulated time): next round, with 1 s.
      reject("diagnostic_period", "diagnostic_updater failed (" + std::string(e.what()) +
                                      "); ~diagnostic_period set to 1 s");
      pnh_.setParam("diagnostic_period", 1.0);
    }
    lock.lock();
  }
}

// ---------------------------------------------------------------------------------------------
// diagnostics

std::string Monitor::checkDiagnosticPeriod() {
  XmlRpc::XmlRpcValue v;
  if (!pnh_.getParamCached("diagnostic_period", v)) return "";
  // Deleted since it was cached: the master sends an empty struct ("nodelet load" clears the
  // nodelet's namespace so; a reloaded nodelet refused it and wrote 1 s over it).
  // diagnostic_updater keeps its period then, as when it is not set.
  if (v.getType() == XmlRpc::XmlRpcValue::TypeStruct && v.size() == 0) return "";
  double period = 0.0;
  if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    period = static_cast<double>(v);
  } else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    period = static_cast<int>(v);
  } else {
    // diagnostic_updater ignored it and kept its period (a launch argument "inf" or "abc" comes
    // as a string): silent before.
    pnh_.setParam("diagnostic_period", 1.0);
    return "diagnostic_period: not a number" + numberWrittenAsText(v) + "; using 1";
  }
  if (std::isfinite(period) && std::abs(period) <= kMaxDiagnosticPeriod) return "";
  pnh_.setParam("diagnostic_period", 1.0);
  std::ostringstream out;
  out << "diagnostic_period = " << period << " (must be finite and within +-"
      << kMaxDiagnosticPeriod << " s); using 1";
  return out.str();
}

void Monitor::setupDiagnostics() {
  diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh_, pnh_, name_);
  diagnostics_->setHardwareID(name_);  // two monitors (or nodelets) tell apart by it, too
  window_start_ = ros::WallTime::now();
  diagnostics_->add("inputs", [this](diagnostic_updater::DiagnosticStatusWrapper& s) {
    Stats now, before;
    Tunables in_force;
    double dt = 1.0;
    double jumps_window = -1.0;  ///< >= 0: kJumpsWarn jumps back in that long (s), lately
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      now = stats_;
      before = stats_window_start_;
      in_force = reported_tunables_;
      const ros::WallTime t = ros::WallTime::now();
      dt = std::max(1e-3, (t - window_start_).toSec());
      stats_window_start_ = stats_;
      window_start_ = t;
      // The last kJumpsWarn jumps back, if they came within kJumpsWindow s, ended at most that
      // long ago: how long they took.
      if (recent_jumps_.size() == kJumpsWarn && (t - recent_jumps_.back()).toSec() < kJumpsWindow &&
          (recent_jumps_.back() - recent_jumps_.front()).toSec() < kJumpsWindow) {
        jumps_window = (recent_jumps_.back() - recent_jumps_.front()).toSec();
      }
      stats_.cycle_time_max = 0.0;  // max over the report window
    }
    const std::size_t rejected = now.rejected - before.rejected;
    if (!param_errors_.empty() || !robot_errors_.empty() || !body_errors_.empty()) {
      // Each, when several: one hid the other.
      std::string what;
      const auto add = [&what](const char* heading, const std::vector<std::string>& errors) {
        if (!errors.empty()) what += (what.empty() ? "" : "; ") + (heading + joined(errors));
      };
      add("invalid parameters: ", param_errors_);
      add("robot geometry not monitored: ", robot_errors_);
      add("bodies of ~bodies not monitored: ", body_errors_);
      s.summary(diagnostic_msgs::DiagnosticStatus::ERROR, what);
    } else {
      s.summary(diagnostic_msgs::DiagnosticStatus::OK, "ok");
    }
    // Each after the errors, as merged (the ERROR's message hid the stale bodies and the
    // unresolved frames, the likelier mistake).
    if (rejected > 0) {
      s.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%zu inputs rejected: %s", rejected,
                      now.last_rejection.c_str());
    }
    if (now.stale > 0) {
      std::string frames;  // the likely reason: a frame name that TF does not know
      if (!now.unresolved_frames.empty()) {
        frames = "; " + std::to_string(now.unresolved_frames.size()) +
                 " TF frames cannot be looked up in " + quoteInput(fixed_frame_) +
                 " (see unresolved TF frames)";
      }
      s.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%zu stale bodies: %s%s", now.stale,
                      joined(now.stale_ids).c_str(), frames.c_str());
    }
    const double rate = rate_;
    const std::size_t cycles = now.cycles - before.cycles;
    const double mean_cycle =
        cycles ? (now.cycle_time_sum - before.cycle_time_sum) / static_cast<double>(cycles) : 0.0;
    // A check still running after a second (or a period of `rate`, if longer): verdicts are
    // that late, and the figures above are those of the checks before it.
    const auto since = [](std::chrono::steady_clock::rep ticks) {
      return ticks == 0 ? 0.0
                        : std::chrono::duration<double>(
                              std::chrono::steady_clock::now().time_since_epoch() -
                              std::chrono::steady_clock::duration(ticks))
                              .count();
    };
    const double running = since(check_started_.load());
    const double idle = since(last_check_started_.load());
    if (running > std::max(1.0, 1.0 / rate)) {
      s.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                      "a check has been running for %.1f s", running);
    } else if (idle > std::max(1.0, 2.0 / rate)) {
      // No check for two periods of `rate` (and at least a second): verdicts older than the
      // rate promises (a min_check_interval longer than its period).
      s.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                      "no check for %.1f s (rate %.6g Hz, min_check_interval %.6g s)", idle, rate,
                      min_check_interval_.load());
    }
    if (jumps_window >= 0.0) {
      // A bag loop or a reset jumps back once in a while; this often, two clocks disagree:
      // every jump forgets every pose, and the pairs flap between UNKNOWN and their status.
      s.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                      "ROS time jumped back %zu times in %.2g s: is /clock published twice?",
                      kJumpsWarn, jumps_window);
    }
    if (mean_cycle > 1.0 / rate) {
      // The checks cannot keep up with `rate`: verdicts come later than configured.
      s.mergeSummaryf(diagnostic_msgs::DiagnosticStatus::WARN,
                      "overloaded: a check takes %.3g ms on average, longer than the %.3g ms "
                      "period of rate %.6g Hz (%.3g checks/s)",
                      1e3 * mean_cycle, 1e3 / rate, rate, cycles / dt);
    }
    // Every parameter dynamic_reconfigure may change, as in force (a refused value is not).
#define CM_REPORT(field) addValue(s, #field, in_force.field);
    CM_TUNABLES(CM_REPORT)
#undef CM_REPORT
    s.add("mesh decomposition", toString(mesh_decomposition_));
    s.add("fixed_frame", fixed_frame_);
    s.add("bodies", now.bodies);
    s.add("stale bodies", now.stale);
    s.add("stale body ids", joined(now.stale_ids));
    s.add("unresolved TF frames", joined(now.unresolved_frames));
    if (!unknown_params_.empty()) s.add("unknown parameters", joined(unknown_params_));
    s.addf("~bodies rate (Hz)", "%.1f", (now.bodies_msgs - before.bodies_msgs) / dt);
    s.addf("~body_poses rate (Hz)", "%.1f", (now.poses_msgs - before.poses_msgs) / dt);
    s.addf("pose_topic rate (Hz)", "%.1f", (now.pose_topic_msgs - before.pose_topic_msgs) / dt);
    s.add("rejected inputs (total)", now.rejected);
    s.add("rejected inputs (since last report)", rejected);
    s.add("last rejection", now.last_rejection);
    s.addf("check rate (Hz)", "%.1f", cycles / dt);
    s.addf("target rate (Hz)", "%.1f", rate);
    s.addf("mean cycle time (ms)", "%.3f", 1e3 * mean_cycle);
    s.addf("max cycle time since last report (ms)", "%.3f", 1e3 * now.cycle_time_max);
    s.addf("check in progress for (s)", "%.3f", running);
    s.addf("time since the last check started (s)", "%.3f", idle);
    s.add("pairs checked (last cycle)", now.pairs_checked);
    s.addf("pairs checked (mean per check since last report)", "%.1f",
           cycles ? static_cast<double>(now.pairs_checked_sum - before.pairs_checked_sum) /
                        static_cast<double>(cycles)
                  : 0.0);
    s.add("pair checks caught up (since last report)",
          now.pairs_caught_up_sum - before.pairs_caught_up_sum);
    s.add("checks (total)", now.cycles);
    s.add("ROS time jumps back (total)", now.time_jumps_back);
    s.add("~body_poses messages (total)", now.poses_msgs);
    if (ignore_unknown_pose_ids_) {
      s.add("~body_poses entries for unknown ids ignored (total)", now.unknown_pose_ids_ignored);
    }
    s.add("pose_topic messages (total)", now.pose_topic_msgs);
    s.add("pose messages applied (total)", now.pose_msgs_applied);
    s.add("checks with new poses (total)", now.checks_with_new_poses);
    s.add("waits for TF (total)", tf_waits_.load());
    s.add("TF messages (total)", tf_receiver_->messages());
    const auto [tf_refused, tf_last_refusal] = tf_receiver_->refused();
    s.add("TF transforms refused (total)", tf_refused);
    s.add("TF transforms stamped 0 on /tf (total)", tf_receiver_->zeroStamped());
    s.add("last refused TF transform", tf_last_refusal);
    s.add("pose messages coalesced (total)",
          now.pose_msgs_applied - std::min(now.pose_msgs_applied, now.checks_with_new_poses));
    {
      std::lock_guard<std::mutex> lock(pending_mutex_);
      s.add("pose messages deferred during a check (total)", poses_deferred_);
      s.add("pose messages dropped while waiting for a check (total)", poses_dropped_);
    }
    for (const auto& e : param_errors_)
      s.add("invalid parameter", e);
    // The first 10 (a hostile URDF refuses thousands of links); the summary counts them all.
    for (std::size_t i = 0; i < robot_errors_.size() && i < 10; ++i)
      s.add("robot geometry left out", robot_errors_[i]);
    for (std::size_t i = 0; i < body_errors_.size() && i < 10; ++i)
      s.add("parameter body left out", body_errors_[i]);
  });
}

}  // namespace ros_layer
}  // namespace collision_monitor
