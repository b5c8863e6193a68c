/// @file terrain_truth_node.cpp
/// The `terrain_truth_node`: a display and evaluation aid that uses ground truth (never an input of the
/// navigation or of the hazard map). Reads the true terrain of the landing area that lunar_render wrote into
/// the dataset (groundtruth_terrain.yaml and its TIFFs, render/terrain_truth.h) and publishes it, latched, in
/// the dataset's world frame: ground_truth/terrain_cloud (sensor_msgs/PointCloud2: x, y, z = true elevation,
/// intensity = true slope in deg) and ground_truth/hazard (nav_msgs/OccupancyGrid: the true hazards at the
/// thresholds given, 0 safe / 100 hazard / -1 unknown), so that rviz shows the estimate over the truth.
///
/// Parameters: ~dataset (string, required), ~world_frame ("world"), ~cloud_stride (4: every n-th cell),
/// ~max_slope_deg, ~max_roughness_m (the defaults of terrain/hazard.h when not set).

#include <string>

#include <ros/ros.h>

#include "planetary_vo/ros_io/hazard_conversions.h"
#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/hazard.h"

int main(int argc, char** argv) {
  using namespace planetary_vo;
  ros::init(argc, argv, "terrain_truth_node");
  ros::NodeHandle nh, pnh("~");
  std::string dataset;
  if (!pnh.getParam("dataset", dataset) || dataset.empty()) {
    ROS_FATAL("terrain_truth_node: set ~dataset to the dataset folder");
    return 1;
  }
  terrain::HazardThresholds thresholds;
  pnh.param("max_slope_deg", thresholds.max_slope_deg, thresholds.max_slope_deg);
  pnh.param("max_roughness_m", thresholds.max_roughness_m, thresholds.max_roughness_m);
  const int stride = std::max(1, pnh.param("cloud_stride", 4));
  std_msgs::Header header;
  header.frame_id = pnh.param<std::string>("world_frame", "world");
  ros::Publisher cloud_pub = nh.advertise<sensor_msgs::PointCloud2>("ground_truth/terrain_cloud", 1, true);
  ros::Publisher hazard_pub = nh.advertise<nav_msgs::OccupancyGrid>("ground_truth/hazard", 1, true);
  try {
    // The name under which lunar_render writes the truth (render::kGroundTruthTerrainName).
    const terrain::GridSet truth = terrain::readGridSet(dataset, "groundtruth_terrain");
    header.stamp = ros::Time::now();
    cloud_pub.publish(ros_io::toElevationCloud(truth, stride, header));
    const cv::Mat hazard =
        terrain::hazardMask(truth.layers.at("slope_deg"), truth.layers.at("roughness_m"), thresholds);
    hazard_pub.publish(ros_io::toOccupancyGrid(hazard, truth.geometry, header));
    ROS_INFO_STREAM("terrain_truth_node: the true terrain of " << dataset
                                                               << " on ground_truth/terrain_cloud and "
                                                               << "ground_truth/hazard");
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("terrain_truth_node: no true terrain to show: " << e.what());
  }
  ros::spin();
  return 0;
}
