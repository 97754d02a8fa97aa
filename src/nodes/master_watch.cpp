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
#include <ros/xmlrpc_manager.h>
#include <xmlrpcpp/XmlRpc.h>

namespace collision_monitor {
namespace ros_layer {

namespace {

bool isArray(const XmlRpc::XmlRpcValue& v) {
  return v.getType() == XmlRpc::XmlRpcValue::TypeArray;
}

bool isString(const XmlRpc::XmlRpcValue& v) {
  return v.getType() == XmlRpc::XmlRpcValue::TypeString;
}

/// An XML-RPC request of the ROS APIs: the node's name (the caller id), then `args`.
XmlRpc::XmlRpcValue requestOf(std::vector<XmlRpc::XmlRpcValue> args) {
  XmlRpc::XmlRpcValue request;
  request[0] = ros::this_node::getName();
  for (std::size_t i = 0; i < args.size(); ++i)
    request[static_cast<int>(i + 1)] = std::move(args[i]);
  return request;
}

/// A call of the master's API; the payload on success.
bool callMaster(const std::string& method, std::vector<XmlRpc::XmlRpcValue> args,
                XmlRpc::XmlRpcValue* payload, XmlRpc::XmlRpcValue* response = nullptr) {
  XmlRpc::XmlRpcValue reply;
  const bool ok = ros::master::execute(method, requestOf(std::move(args)), reply, *payload, false);
  if (response) *response = reply;
  return ok;
}

/// A call of this node's own slave API (the topics roscpp holds: no public C++ call lists them
/// with their types, nor hands a subscription its publishers).
bool callSelf(const std::string& method, std::vector<XmlRpc::XmlRpcValue> args,
              XmlRpc::XmlRpcValue* payload) {
  std::string host;
  std::uint32_t port = 0;
  const auto& xmlrpc = ros::XMLRPCManager::instance();
  if (!ros::network::splitURI(xmlrpc->getServerURI(), host, port)) return false;
  XmlRpc::XmlRpcValue reply;
  XmlRpc::XmlRpcClient* client = xmlrpc->getXMLRPCClient(host, static_cast<int>(port), "/");
  const bool ok = client->execute(method.c_str(), requestOf(std::move(args)), reply) &&
                  xmlrpc->validateXmlrpcResponse(method, reply, *payload);
  xmlrpc->releaseXMLRPCClient(client);
  return ok;
}

/// [[name, type], ...] of the node's own publications or subscriptions.
std::vector<std::pair<std::string, std::string>> topicsOf(const std::string& method) {
  std::vector<std::pair<std::string, std::string>> out;
  XmlRpc::XmlRpcValue list;
  if (!callSelf(method, {}, &list) || !isArray(list)) return out;
  for (int i = 0; i < list.size(); ++i) {
    XmlRpc::XmlRpcValue& t = list[i];
    if (isArray(t) && t.size() == 2 && isString(t[0]) && isString(t[1]))
      out.emplace_back(static_cast<std::string>(t[0]), static_cast<std::string>(t[1]));
  }
  return out;
}

}  // namespace

MasterWatch::MasterWatch(ros::WallDuration period) : period_(period) {
  // The services come from the master: roscpp's ServiceManager lists none, and this way the
  // names are as remapped, those of roscpp and dynamic_reconfigure included.
  XmlRpc::XmlRpcValue state;
  if (callMaster("getSystemState", {}, &state) && isArray(state) && state.size() == 3 &&
      isArray(state[2])) {
    for (int i = 0; i < state[2].size(); ++i) {
      XmlRpc::XmlRpcValue& s = state[2][i];
      if (!isArray(s) || s.size() != 2 || !isString(s[0]) || !isArray(s[1])) continue;
      for (int k = 0; k < s[1].size(); ++k) {
        if (isString(s[1][k]) && static_cast<std::string>(s[1][k]) == ros::this_node::getName())
          services_.push_back(static_cast<std::string>(s[0]));
      }
    }
  }
  thread_ = std::thread([this] { run(); });
}

MasterWatch::~MasterWatch() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

void MasterWatch::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stop_) {
    wake_.wait_for(lock, std::chrono::duration<double>(period_.toSec()), [this] { return stop_; });
    if (stop_ || !ros::ok()) return;
    lock.unlock();
    const bool go_on = checkOnce();
    lock.lock();
    if (!go_on) return;
  }
}

bool MasterWatch::checkOnce() {
  const std::string& name = ros::this_node::getName();
  const std::string& uri = ros::XMLRPCManager::instance()->getServerURI();
  XmlRpc::XmlRpcValue payload, response;
  if (callMaster("lookupNode", {name}, &payload, &response)) {
    if (isString(payload) && static_cast<std::string>(payload) == uri) return true;  // known
    ROS_ERROR_STREAM(name << ": the ROS master at " << ros::master::getURI()
                          << " gives this node's name to another node ("
                          << (isString(payload) ? static_cast<std::string>(payload) : "?")
                          << "): shutting down, as a master asks a node whose name is taken");
    ros::requestShutdown();
    return false;
  }
  // Not reachable, or reachable and the node unknown to it (code -1): only then register, and
  // not while roscpp unregisters the node (SIGINT, `rosnode kill`): that would leave it
  // registered after it exits.
  if (!isArray(response) || response.size() != 3 ||
      response[0].getType() != XmlRpc::XmlRpcValue::TypeInt ||
      static_cast<int>(response[0]) != -1 || ros::isShuttingDown())
    return true;
  std::string why;
  const bool registered = registerAgain(&why);
  if (ros::isShuttingDown()) return false;
  if (registered) {
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

bool MasterWatch::registerAgain(std::string* why) {
  const std::string& api = ros::XMLRPCManager::instance()->getServerURI();
  XmlRpc::XmlRpcValue payload;
  for (const auto& [topic, type] : topicsOf("getPublications")) {
    if (ros::isShuttingDown()) return false;
    if (!callMaster("registerPublisher", {topic, type, api}, &payload)) {
      *why = "registerPublisher " + topic;
      return false;
    }
  }
  for (const auto& [topic, type] : topicsOf("getSubscriptions")) {
    if (ros::isShuttingDown()) return false;
    if (!callMaster("registerSubscriber", {topic, type, api}, &payload)) {
      *why = "registerSubscriber " + topic;
      return false;
    }
    // The publishers the master knows: roscpp connects to them as when the master tells it of
    // new ones (publisherUpdate, from the master's caller id).
    XmlRpc::XmlRpcValue ignored;
    if (isArray(payload) && !callSelf("publisherUpdate", {topic, payload}, &ignored)) {
      *why = "publisherUpdate " + topic;
      return false;
    }
  }
  const std::string service_api = "rosrpc://" + ros::network::getHost() + ":" +
                                  std::to_string(ros::ConnectionManager::instance()->getTCPPort());
  for (const std::string& service : services_) {
    if (ros::isShuttingDown()) return false;
    if (!ros::ServiceManager::instance()->lookupServicePublication(service)) continue;  // gone
    if (!callMaster("registerService", {service, service_api, api}, &payload)) {
      *why = "registerService " + service;
      return false;
    }
  }
  return true;
}

}  // namespace ros_layer
}  // namespace collision_monitor
