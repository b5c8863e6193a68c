#pragma once
/// Helpers of the VO rostest nodes: wait on conditions (never a fixed sleep) and ask the master who
/// subscribes to a topic.

#include <chrono>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <ros/master.h>
#include <ros/ros.h>

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

/// Whether every subscriber is connected to at least one publisher.
inline bool allConnected(const std::vector<ros::Subscriber>& subs) {
  for (const ros::Subscriber& s : subs)
    if (s.getNumPublishers() == 0) return false;
  return true;
}

}  // namespace planetary_vo::ros_io
