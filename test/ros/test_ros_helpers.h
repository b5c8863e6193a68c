#pragma once
/// Helpers of the VO rostest nodes: wait on conditions (never a fixed sleep), ask the master who subscribes
/// to a topic, and ask another node about its connections (XML-RPC slave API).

#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <xmlrpcpp/XmlRpcClient.h>

#include <gtest/gtest.h>

namespace planetary_vo::ros_io {

/// Polls `done` (callbacks run in an AsyncSpinner) until it holds or `timeout_s` of wall time pass.
inline bool waitFor(const std::function<bool()>& done, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (ros::ok() && std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(
        std::chrono::milliseconds(10));  // polling period of the condition, not a delay
  }
  return done();
}

/// Whether any node subscribes to `topic` (resolved name), from the master's system state.
inline bool topicHasSubscriber(const std::string& topic) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  if (!ros::master::execute("getSystemState", args, result, payload, false)) return false;
  XmlRpc::XmlRpcValue& subscribers = payload[1];
  for (int i = 0; i < subscribers.size(); ++i)
    if (std::string(subscribers[i][0]) == topic) return subscribers[i][1].size() > 0;
  return false;
}

/// Whether every subscriber is connected to at least one publisher. Seen from the subscriber only: roscpp
/// counts a publisher as soon as it has opened the TCP connection, before the publisher has read the
/// connection header, and a message published in between is not sent to us (only a latched one is, later). To
/// know that a non-latched message will reach us, use publisherSendsTo().
inline bool allConnected(const std::vector<ros::Subscriber>& subs) {
  for (const ros::Subscriber& s : subs)
    if (s.getNumPublishers() == 0) return false;
  return true;
}

/// Calls the XML-RPC slave API `method` of node `node` with this node's caller id as the only argument; false
/// if the node cannot be found or the call fails.
inline bool callNode(const std::string& node, const std::string& method, XmlRpc::XmlRpcValue* response) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = node;
  if (!ros::master::execute("lookupNode", args, result, payload, false)) return false;
  std::string host;
  uint32_t port = 0;
  if (!ros::network::splitURI(std::string(payload), host, port)) return false;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue request;
  request[0] = ros::this_node::getName();
  return client.execute(method.c_str(), request, *response) && !client.isFault() &&
         response->getType() == XmlRpc::XmlRpcValue::TypeArray;
}

/// Whether node `publisher` has accepted the subscription of node `subscriber` (default: this node) to
/// `topic` (resolved name), seen from the publisher's side (getBusInfo): from then on everything it publishes
/// on `topic` is sent to that subscriber.
inline bool publisherSendsTo(const std::string& publisher, const std::string& topic,
                             const std::string& subscriber = ros::this_node::getName()) {
  XmlRpc::XmlRpcValue response;
  if (!callNode(publisher, "getBusInfo", &response) || response.size() < 3 || int(response[0]) != 1)
    return false;
  XmlRpc::XmlRpcValue& connections = response[2];  // [code, status message, connections]
  // Each connection: [id, peer node, direction ("o": we publish to the peer), transport, topic, ...].
  for (int i = 0; i < connections.size(); ++i)
    if (connections[i].size() >= 5 && std::string(connections[i][1]) == subscriber &&
        std::string(connections[i][2]) == "o" && std::string(connections[i][4]) == topic)
      return true;
  return false;
}

/// Starts the paused player (service <player>/resume) once the nodelet manager receives every topic of
/// `inputs` from it and this node every subscription of `subs` from its publisher (the player for
/// /ground_truth/pose, the manager for the rest), as the publishers see it: whatever a publisher sends before
/// it has accepted a subscriber is lost for that subscriber.
inline ::testing::AssertionResult resumePlayerWhenConnected(const std::string& player,
                                                            const std::string& manager,
                                                            const std::vector<std::string>& inputs,
                                                            const std::vector<ros::Subscriber>& subs) {
  const bool connected = waitFor(
      [&] {
        for (const std::string& topic : inputs)
          if (!publisherSendsTo(player, topic, manager)) return false;
        for (const ros::Subscriber& s : subs)
          if (!publisherSendsTo(s.getTopic() == "/ground_truth/pose" ? player : manager, s.getTopic()))
            return false;
        return true;
      },
      30.0);
  if (!connected)
    return ::testing::AssertionFailure()
           << "the nodelet did not connect to the player, or this node to the outputs";
  std_srvs::Trigger resume;
  if (!ros::service::waitForService(player + "/resume", ros::Duration(30.0)) ||
      !ros::service::call(player + "/resume", resume))
    return ::testing::AssertionFailure() << "could not call " << player << "/resume";
  return ::testing::AssertionSuccess();
}

/// How many messages node `subscriber` has read on `topic` (resolved name) from its one publisher (its
/// getBusStats; roscpp reports only one connection per topic there); -1 if it cannot be asked. roscpp counts
/// a message as it queues it for the callbacks, in the thread that reads every connection.
inline int messagesReceived(const std::string& subscriber, const std::string& topic) {
  // roscpp answers getBusStats with the bare [publish stats, subscribe stats, service stats], no status code.
  XmlRpc::XmlRpcValue stats;
  if (!callNode(subscriber, "getBusStats", &stats) || stats.size() < 2) return -1;
  // stats[1]: one [topic, [[connection id, bytes, messages, drops, ...], ...]] per subscribed topic.
  XmlRpc::XmlRpcValue& subscriptions = stats[1];
  int messages = 0;
  for (int i = 0; i < subscriptions.size(); ++i) {
    if (std::string(subscriptions[i][0]) != topic) continue;
    for (int j = 0; j < subscriptions[i][1].size(); ++j) messages += int(subscriptions[i][1][j][2]);
  }
  return messages;
}

/// main() of a rostest gtest node: gtest and ROS initialised, callbacks served by two spinner threads while
/// the tests wait, ROS shut down afterwards. Returns gtest's result.
inline int runRosTests(int argc, char** argv, const char* node_name) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, node_name);
  ros::AsyncSpinner spinner(2);
  spinner.start();
  const int rc = RUN_ALL_TESTS();
  ros::shutdown();
  return rc;
}

}  // namespace planetary_vo::ros_io
