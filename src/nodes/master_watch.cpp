/// \file
/// MasterWatch (master_watch.h).
#include "master_watch.h"

#include <chrono>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <ros/connection_manager.h>
#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <ros/service_manager.h>
#include <ros/topic_manager.h>
#include <ros/xmlrpc_manager.h>
#include <xmlrpcpp/XmlRpc.h>

namespace collision_monitor {
namespace ros_layer {

namespace {

/// How long one XML-RPC call of the watch may take (s). roscpp's own client waits for ever: a
/// master host that accepts and never answers (a half-open connection to one that went away)
/// held the watch for good, and the node's exit with it (the thirty-eighth session's audit).
constexpr double kCallTimeout = 2.0;
/// How often the node's services are read again from a master that knows the node (s).
constexpr double kServicesRefresh = 10.0;

bool isArray(const XmlRpc::XmlRpcValue& v) {
  return v.getType() == XmlRpc::XmlRpcValue::TypeArray;
}

bool isString(const XmlRpc::XmlRpcValue& v) {
  return v.getType() == XmlRpc::XmlRpcValue::TypeString;
}

/// XmlRpcClient::execute() with a deadline, one call a connection.
class TimedClient : public XmlRpc::XmlRpcClient {
 public:
  TimedClient(const std::string& host, int port) : XmlRpcClient(host.c_str(), port, "/") {}
  ~TimedClient() override { close(); }
  TimedClient(const TimedClient&) = delete;
  TimedClient& operator=(const TimedClient&) = delete;

  bool call(const std::string& method, const XmlRpc::XmlRpcValue& params,
            XmlRpc::XmlRpcValue* result) {
    _sendAttempts = 0;
    _isFault = false;
    result->clear();
    if (!setupConnection() || !generateRequest(method.c_str(), params)) return false;
    _disp.work(kCallTimeout);  // until the answer is read, the connection lost, or the deadline
    return _connectionState == IDLE && parseResponse(*result);
  }
};

/// An answer of a ROS API: [code, message, value].
struct Reply {
  bool answered = false;  ///< in time, and of that form
  int code = 0;           ///< 1: success, -1: error (e.g. lookupNode's unknown node)
  XmlRpc::XmlRpcValue value;
};

/// `method` of the ROS API at host:port, the node's name (the caller id) first, then `args`.
Reply callApi(const std::string& host, int port, const std::string& method,
              const std::vector<XmlRpc::XmlRpcValue>& args) {
  XmlRpc::XmlRpcValue request, response;
  request[0] = ros::this_node::getName();
  for (std::size_t i = 0; i < args.size(); ++i)
    request[static_cast<int>(i + 1)] = args[i];
  Reply r;
  TimedClient client(host, port);
  if (!client.call(method, request, &response) || !isArray(response) || response.size() != 3 ||
      response[0].getType() != XmlRpc::XmlRpcValue::TypeInt)
    return r;
  r.answered = true;
  r.code = static_cast<int>(response[0]);
  r.value = response[2];
  return r;
}

Reply callMaster(const std::string& method, const std::vector<XmlRpc::XmlRpcValue>& args) {
  return callApi(ros::master::getHost(), static_cast<int>(ros::master::getPort()), method, args);
}

/// The node's own slave API (the topics roscpp holds: no public C++ call lists them with their
/// types, nor hands a subscription its publishers).
Reply callSelf(const std::string& method, const std::vector<XmlRpc::XmlRpcValue>& args) {
  std::string host;
  std::uint32_t port = 0;
  if (!ros::network::splitURI(ros::XMLRPCManager::instance()->getServerURI(), host, port))
    return Reply();
  return callApi(host, static_cast<int>(port), method, args);
}

/// [[name, type], ...] of the node's own publications or subscriptions.
std::vector<std::pair<std::string, std::string>> topicsOf(const std::string& method) {
  std::vector<std::pair<std::string, std::string>> out;
  Reply r = callSelf(method, {});
  if (r.code != 1 || !isArray(r.value)) return out;
  for (int i = 0; i < r.value.size(); ++i) {
    XmlRpc::XmlRpcValue& t = r.value[i];
    if (isArray(t) && t.size() == 2 && isString(t[0]) && isString(t[1]))
      out.emplace_back(static_cast<std::string>(t[0]), static_cast<std::string>(t[1]));
  }
  return out;
}

}  // namespace

void waitForRosout(ros::WallDuration timeout) {
  const std::string rosout = "/rosout";
  Reply state = callMaster("getSystemState", {});
  if (state.code != 1 || !isArray(state.value) || state.value.size() != 3 ||
      !isArray(state.value[1]))
    return;
  bool listened = false;
  for (int i = 0; i < state.value[1].size() && !listened; ++i) {
    XmlRpc::XmlRpcValue& t = state.value[1][i];
    listened = isArray(t) && t.size() == 2 && isString(t[0]) &&
               static_cast<std::string>(t[0]) == rosout && isArray(t[1]) && t[1].size() > 0;
  }
  const ros::WallTime deadline = ros::WallTime::now() + timeout;
  while (listened && ros::ok() && ros::TopicManager::instance()->getNumSubscribers(rosout) == 0 &&
         ros::WallTime::now() < deadline) {
    ros::WallDuration(0.005).sleep();
  }
}

MasterWatch::MasterWatch(ros::WallDuration period) : period_(period) {
  readServices();
  thread_ = std::thread([this] { run(); });
}

MasterWatch::~MasterWatch() {
  stop_ = true;
  {
    std::lock_guard<std::mutex> lock(mutex_);  // not between run()'s test and its wait
  }
  wake_.notify_all();
  thread_.join();  // at most one call's kCallTimeout
}

void MasterWatch::readServices() {
  // From the master: roscpp's ServiceManager lists none, and this way the names are as
  // remapped, those of roscpp and dynamic_reconfigure included.
  Reply state = callMaster("getSystemState", {});
  if (state.code != 1 || !isArray(state.value) || state.value.size() != 3 ||
      !isArray(state.value[2]))
    return;
  std::vector<std::string> services;
  for (int i = 0; i < state.value[2].size(); ++i) {
    XmlRpc::XmlRpcValue& s = state.value[2][i];
    if (!isArray(s) || s.size() != 2 || !isString(s[0]) || !isArray(s[1])) continue;
    for (int k = 0; k < s[1].size(); ++k) {
      if (isString(s[1][k]) && static_cast<std::string>(s[1][k]) == ros::this_node::getName())
        services.push_back(static_cast<std::string>(s[0]));
    }
  }
  services_.swap(services);
  services_read_ = std::chrono::steady_clock::now();
}

bool MasterWatch::stopping() const {
  return stop_ || ros::isShuttingDown() || !ros::ok();
}

void MasterWatch::run() {
  while (!stopping()) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, std::chrono::duration<double>(period_.toSec()),
                     [this] { return stop_.load(); });
    }
    if (stopping() || !checkOnce()) return;
  }
}

MasterWatch::Holder MasterWatch::holder() const {
  const Reply r = callMaster("lookupNode", {ros::this_node::getName()});
  if (!r.answered) return Holder::NoAnswer;
  if (r.code != 1) return Holder::Nobody;
  return isString(r.value) &&
                 static_cast<std::string>(r.value) == ros::XMLRPCManager::instance()->getServerURI()
             ? Holder::This
             : Holder::Another;
}

bool MasterWatch::checkOnce() {
  const std::string& name = ros::this_node::getName();
  switch (holder()) {
    case Holder::NoAnswer:
      return true;  // the master down: again at the next period, without a word
    case Holder::Another:
      return nameTaken();
    case Holder::This:
      if (!incomplete_) {
        if (std::chrono::steady_clock::now() - services_read_ >
            std::chrono::duration<double>(kServicesRefresh))
          readServices();
        return true;
      }
      break;  // a registration left incomplete: again
    case Holder::Nobody:
      break;
  }
  std::string why;
  const Outcome outcome = registerAgain(&why);
  if (outcome == Outcome::Stopped) return false;
  if (outcome == Outcome::Taken) return nameTaken();
  incomplete_ = outcome != Outcome::Done;
  if (!incomplete_) {
    ROS_WARN_STREAM(name << ": the ROS master at " << ros::master::getURI()
                         << " did not know this node (roscore restarted?): registered its topics "
                            "and "
                         << services_.size() << " services again");
  } else {
    ROS_ERROR_STREAM(name << ": the ROS master at " << ros::master::getURI()
                          << " does not know this node (roscore restarted?) and registering it "
                             "again failed: "
                          << why << "; trying again in " << period_.toSec() << " s");
  }
  return true;
}

bool MasterWatch::nameTaken() const {
  ROS_ERROR_STREAM(ros::this_node::getName()
                   << ": the ROS master at " << ros::master::getURI()
                   << " gives this node's name to another node: shutting down, as a master asks "
                      "a node whose name is taken");
  ros::requestShutdown();
  return false;
}

MasterWatch::Outcome MasterWatch::registerAgain(std::string* why) {
  const std::string& api = ros::XMLRPCManager::instance()->getServerURI();
  // Before each registration: the name still free or this node's. A node of the same name that
  // registered meanwhile (a second instance started after the restart) would get it back from
  // the master with the next registration of ours, and be shut down by it, after it had shut
  // this one down: both gone (the audit, 1 in 20 starts timed onto the watch's).
  Outcome stop = Outcome::Done;
  const auto mayGoOn = [&](const std::string& call) {
    if (stopping()) {
      stop = Outcome::Stopped;
      return false;
    }
    const Holder h = holder();
    if (h == Holder::Another) stop = Outcome::Taken;
    if (h == Holder::NoAnswer) {
      stop = Outcome::Failed;
      *why = "no answer before " + call;
    }
    return stop == Outcome::Done;
  };
  // One registration, `what` naming it; its reply in `reply` when given.
  const auto registered = [&](const char* method, const std::vector<XmlRpc::XmlRpcValue>& args,
                              const std::string& what, Reply* reply = nullptr) {
    if (!mayGoOn(what)) return false;
    Reply r = callMaster(method, args);
    if (r.code != 1) {
      stop = Outcome::Failed;
      *why = what;
      return false;
    }
    if (reply) *reply = std::move(r);
    return true;
  };
  for (const auto& [topic, type] : topicsOf("getPublications")) {
    if (!registered("registerPublisher", {topic, type, api}, "registerPublisher " + topic))
      return stop;
  }
  for (const auto& [topic, type] : topicsOf("getSubscriptions")) {
    Reply r;
    if (!registered("registerSubscriber", {topic, type, api}, "registerSubscriber " + topic, &r))
      return stop;
    // The publishers the master knows: roscpp connects to them as when the master tells it of
    // new ones (publisherUpdate).
    if (isArray(r.value) && callSelf("publisherUpdate", {topic, r.value}).code != 1) {
      *why = "publisherUpdate " + topic;
      return Outcome::Failed;
    }
  }
  const std::string service_api = "rosrpc://" + ros::network::getHost() + ":" +
                                  std::to_string(ros::ConnectionManager::instance()->getTCPPort());
  for (const std::string& service : services_) {
    if (!ros::ServiceManager::instance()->lookupServicePublication(service)) continue;  // gone
    if (!registered("registerService", {service, service_api, api}, "registerService " + service))
      return stop;
  }
  return Outcome::Done;
}

}  // namespace ros_layer
}  // namespace collision_monitor
