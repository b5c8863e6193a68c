/// @file vo_node.cpp
/// The `vo_node` executable for those who run no nodelet manager: loads planetary_vo/VisualOdometryNodelet
/// into an in-process nodelet::Loader under the node's own name, with the node's remappings and arguments
/// (as image_proc's node does), so both share one code path.

#include <map>
#include <string>
#include <vector>

#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "vo");
  nodelet::Loader loader(false);  // no load/unload services: this process hosts exactly one nodelet
  const nodelet::M_string remappings(ros::names::getRemappings().begin(), ros::names::getRemappings().end());
  const nodelet::V_string my_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "planetary_vo/VisualOdometryNodelet", remappings, my_argv)) {
    ROS_FATAL("vo_node: could not load planetary_vo/VisualOdometryNodelet");
    return 1;
  }
  ros::spin();
  return 0;
}
