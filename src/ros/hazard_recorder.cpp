/// @file hazard_recorder.cpp
/// The `hazard_recorder` node: writes the latest hazard/map and hazard/landing_sites of the hazard nodelet
/// to ~output_dir as `terrain.yaml` with its layer TIFFs (terrain/grid.h) and `landing_sites.yaml`
/// (terrain/landing_sites.h), the files `vo_run --output-terrain` writes, so that `terrain_eval --est DIR`
/// scores what the ROS graph produced. Each message replaces the files (written to a temporary name and
/// renamed, so that a reader never sees half a file); ~stamp_file gets the stamp of the last map written.
///
/// Once the map and the sites of the last products announced on hazard/status are written, it publishes
/// hazard/recorded (std_msgs/Header) with that status' stamp: the files include the navigation up to there
/// (a player's exit ack, launch/agnc.launch).
///
/// Parameters: ~output_dir (string, required; created); written on every message.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <optional>
#include <string>

#include <ros/ros.h>

#include <std_msgs/Header.h>

#include "planetary_vo/HazardMap.h"
#include "planetary_vo/HazardStatus.h"
#include "planetary_vo/LandingSites.h"
#include "planetary_vo/ros_io/hazard_conversions.h"
#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/landing_sites.h"

namespace {

using namespace planetary_vo;

class HazardRecorder {
 public:
  HazardRecorder(ros::NodeHandle& nh, const std::string& dir) : dir_(dir) {
    std::filesystem::create_directories(dir_);
    map_sub_ = nh.subscribe("hazard/map", 2, &HazardRecorder::onMap, this);
    sites_sub_ = nh.subscribe("hazard/landing_sites", 2, &HazardRecorder::onSites, this);
    status_sub_ = nh.subscribe("hazard/status", 10, &HazardRecorder::onStatus, this);
    recorded_pub_ = nh.advertise<std_msgs::Header>("hazard/recorded", 10);
  }

 private:
  void onMap(const HazardMap::ConstPtr& msg) {
    try {
      const terrain::GridSet grids = ros_io::fromHazardMapMsg(*msg);
      const std::string tmp = dir_ + "/.terrain_tmp";
      std::filesystem::create_directories(tmp);
      terrain::writeGridSet(tmp, "terrain", grids);
      for (const auto& entry : std::filesystem::directory_iterator(tmp))
        std::filesystem::rename(entry.path(), dir_ + "/" + entry.path().filename().string());
      std::filesystem::remove(tmp);
      std::ofstream stamp(dir_ + "/stamp.txt");
      stamp << std::fixed << std::setprecision(9) << msg->header.stamp.toSec() << "\n";
      map_written_ = msg->sequence;
      acknowledge();
      ROS_INFO_STREAM_THROTTLE(10, "hazard_recorder: hazard/map (" << msg->cells_known << " cells known) -> "
                                                                   << dir_ << "/terrain.yaml");
    } catch (const std::exception& e) {
      ROS_ERROR_STREAM("hazard_recorder: hazard/map not written: " << e.what());
    }
  }

  void onSites(const LandingSites::ConstPtr& msg) {
    try {
      terrain::LandingSiteParams params;
      const terrain::LandingSiteResult result = ros_io::fromLandingSitesMsg(*msg, &params);
      const std::string path = dir_ + "/landing_sites.yaml";
      terrain::writeLandingSites(path + ".tmp", result, params);
      std::filesystem::rename(path + ".tmp", path);
      sites_written_ = msg->sequence;
      acknowledge();
    } catch (const std::exception& e) {
      ROS_ERROR_STREAM("hazard_recorder: hazard/landing_sites not written: " << e.what());
    }
  }

  void onStatus(const HazardStatus::ConstPtr& msg) {
    status_ = *msg;
    acknowledge();
  }

  /// hazard/recorded when the files hold the last products the status announced.
  void acknowledge() {
    if (!status_ || status_->products_published == 0 || map_written_ != status_->products_published ||
        sites_written_ != status_->products_published || status_->header.stamp <= acked_)
      return;
    acked_ = status_->header.stamp;
    std_msgs::Header h = status_->header;
    recorded_pub_.publish(h);
  }

  std::string dir_;
  std::optional<HazardStatus> status_;
  uint32_t map_written_ = 0, sites_written_ = 0;
  ros::Time acked_;
  ros::Subscriber map_sub_, sites_sub_, status_sub_;
  ros::Publisher recorded_pub_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "hazard_recorder");
  ros::NodeHandle nh, pnh("~");
  std::string dir;
  if (!pnh.getParam("output_dir", dir) || dir.empty()) {
    ROS_FATAL("hazard_recorder: set ~output_dir to the folder to write");
    return 1;
  }
  try {
    HazardRecorder recorder(nh, dir);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("hazard_recorder: " << e.what());
    return 1;
  }
  return 0;
}
