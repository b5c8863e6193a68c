/// @file hazard_nodelet.cpp
/// The nodelet planetary_vo/HazardNodelet: hazard detection over the navigation's map (thesis Phase 4, issue
/// 11). In: vo/map_events (planetary_vo/VoMapEvents, zero-copy when loaded into the VO's nodelet manager),
/// camera/camera_info (the camera the keyframe images come from, for the densifier), vo/status (how far the
/// navigation has got). Out: hazard/map (the rasters), hazard/occupancy (nav_msgs/OccupancyGrid: 0 safe, 100
/// hazard, -1 unknown), hazard/landing_sites (ranked, with margins), hazard/site_poses (PoseArray),
/// hazard/best_site (PoseStamped), hazard/markers and hazard/elevation_cloud (rviz), hazard/status. Topics
/// and parameters: docs/ros_interface.md.
///
/// Everything here is glue: the estimation state is in the ROS-free terrain::HazardMapper (terrain model,
/// densifier, hazard mask, landing sites), the conversions are free functions (hazard_conversions.h) and the
/// parameters come from ros_params.h. The events are applied as they arrive; the products (122 ms over the
/// default 513 x 513 cells at the end of approach_30deg 1024, see hazard_mapper.h) are recomputed by a wall
/// timer every ~publish_period_s when the map changed. All callbacks run on the nodelet's single-threaded
/// queue, so they never overlap. No exception leaves a callback: a malformed message is counted, logged and
/// reported on hazard/status, and the node goes on with the next one.
///
/// hazard/status carries the stamp of the latest vo/status received before the products were computed: in
/// one nodelet manager the VO publishes a frame's map events before its status, and both reach this
/// nodelet's queue in that order, so the products include every event up to that frame (a player can wait on
/// it: lunar_demo's exit ack).

#include <algorithm>
#include <memory>
#include <optional>

#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/OccupancyGrid.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/MarkerArray.h>
#include <boost/make_shared.hpp>
#include <pluginlib/class_list_macros.hpp>

#include "planetary_vo/HazardMap.h"
#include "planetary_vo/HazardStatus.h"
#include "planetary_vo/LandingSites.h"
#include "planetary_vo/VoMapEvents.h"
#include "planetary_vo/VoStatus.h"
#include "planetary_vo/ros_io/containment.h"
#include "planetary_vo/ros_io/conversions.h"
#include "planetary_vo/ros_io/hazard_conversions.h"
#include "planetary_vo/ros_io/map_event_conversions.h"
#include "planetary_vo/ros_io/ros_params.h"
#include "planetary_vo/terrain/hazard_mapper.h"

namespace planetary_vo::ros_io {

class HazardNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    params_ = loadHazardNodeletParams(pnh);
    status_pub_ = nh.advertise<HazardStatus>("hazard/status", 10);
    try {
      config_ = loadHazardConfigFromParams(pnh);
      // A misspelt section or parameter would be silently ignored: an error like an unknown key.
      std::vector<std::string> known = hazardNodeletParamNames();
      known.insert(known.end(), hazardConfigSections().begin(), hazardConfigSections().end());
      const std::vector<std::string> unknown = unknownPrivateNames(pnh, known);
      if (!unknown.empty()) throw terrain::HazardConfigError(unknown);
      mapper_.emplace(config_);
    } catch (const std::exception& e) {
      status_.message = std::string("configuration error: ") + e.what();
      NODELET_ERROR_STREAM(status_.message << "\nThe hazard nodelet does not subscribe.");
      status_timer_ = nh.createWallTimer(ros::WallDuration(params_.publish_period_s),
                                         [this](const ros::WallTimerEvent&) { publishStatus(); });
      return;
    }
    NODELET_DEBUG_STREAM("hazard configuration:\n" << terrain::dumpHazardMapperConfig(config_));
    map_pub_ = nh.advertise<HazardMap>("hazard/map", 1, true);
    occupancy_pub_ = nh.advertise<nav_msgs::OccupancyGrid>("hazard/occupancy", 1, true);
    sites_pub_ = nh.advertise<LandingSites>("hazard/landing_sites", 1, true);
    site_poses_pub_ = nh.advertise<geometry_msgs::PoseArray>("hazard/site_poses", 1, true);
    best_site_pub_ = nh.advertise<geometry_msgs::PoseStamped>("hazard/best_site", 1, true);
    markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("hazard/markers", 1, true);
    cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("hazard/elevation_cloud", 1, true);
    events_sub_ = nh.subscribe("vo/map_events", params_.events_queue_size, &HazardNodelet::eventsCb, this);
    info_sub_ = nh.subscribe("camera/camera_info", 1, &HazardNodelet::infoCb, this);
    vo_status_sub_ = nh.subscribe("vo/status", 100, &HazardNodelet::voStatusCb, this);
    timer_ = nh.createWallTimer(ros::WallDuration(params_.publish_period_s), &HazardNodelet::timerCb, this);
  }

  void eventsCb(const VoMapEvents::ConstPtr& msg) {
    const std::optional<std::string> why = ros_io::runContained([&] {
      cv::Mat keyframe_image;
      const MapEvents events = fromMsg(*msg, ros::Time(0), &keyframe_image);
      if (frame_id_.empty()) frame_id_ = msg->header.frame_id;
      if (msg->header.frame_id != frame_id_)
        throw std::invalid_argument("frame_id '" + msg->header.frame_id + "' is not the map's '" + frame_id_ +
                                    "'");
      const terrain::HazardMapperUpdate update = mapper_->apply(events, msg->metric_scale, keyframe_image);
      ++status_.events_applied;
      if (update.densified) ++status_.keyframes_densified;
      if (msg->header.stamp > events_stamp_) events_stamp_ = msg->header.stamp;
      dirty_ = true;
    });
    if (why) reject("vo/map_events", *why);
  }

  void infoCb(const sensor_msgs::CameraInfo::ConstPtr& info) {
    const std::optional<std::string> why = ros_io::runContained([&] {
      if (last_info_ && last_info_->K == info->K && last_info_->D == info->D &&
          last_info_->width == info->width && last_info_->height == info->height &&
          last_info_->distortion_model == info->distortion_model)
        return;
      mapper_->setCamera(fromCameraInfo(*info));
      last_info_ = *info;
      NODELET_INFO_STREAM("camera " << info->width << "x" << info->height << " for the densifier");
    });
    if (why) reject("camera/camera_info", *why);
  }

  void voStatusCb(const VoStatus::ConstPtr& msg) {
    if (msg->header.stamp > nav_stamp_) nav_stamp_ = msg->header.stamp;
  }

  void timerCb(const ros::WallTimerEvent&) {
    const std::optional<std::string> why = ros_io::runContained([&] {
      if (dirty_)
        publishProducts();
      else if (nav_stamp_ > products_stamp_)
        products_stamp_ = nav_stamp_;  // nothing new since: the products are current up to there too
    });
    if (why) reject("computing the products", *why);
    publishStatus();
  }

  void publishProducts() {
    // Everything applied so far is in these products, including the events of every frame up to the
    // latest vo/status received.
    const ros::Time covered = std::max(nav_stamp_, events_stamp_);
    const terrain::HazardProducts products = mapper_->products();
    dirty_ = false;
    std_msgs::Header header;
    header.stamp = covered;
    header.frame_id = frame_id_;
    const terrain::GridSet& grids = products.terrain.grids;
    const uint32_t sequence = status_.products_published + 1;
    auto map = boost::make_shared<HazardMap>(toHazardMapMsg(products, config_, header));
    map->sequence = sequence;
    map_pub_.publish(map);
    occupancy_pub_.publish(toOccupancyGrid(products.hazard, grids.geometry, header));
    LandingSites sites = toLandingSitesMsg(products.sites, config_.sites, products.terrain.metric, header);
    sites.sequence = sequence;
    sites_pub_.publish(sites);
    site_poses_pub_.publish(toPoseArray(sites));
    if (!sites.sites.empty()) {
      geometry_msgs::PoseStamped best;
      best.header = header;
      best.pose = toPoseArray(sites).poses.front();
      best_site_pub_.publish(best);
    }
    markers_pub_.publish(toMarkers(sites));
    if (cloud_pub_.getNumSubscribers() > 0)
      cloud_pub_.publish(toElevationCloud(grids, params_.cloud_stride, header));
    status_.num_points = static_cast<uint32_t>(mapper_->numPoints());
    status_.products_published = sequence;
    products_stamp_ = covered;
    if (sites.sites.empty() && sites.reason != last_reason_)
      NODELET_INFO_STREAM("no landing site: " << sites.reason);
    last_reason_ = sites.reason;
  }

  /// Called from the callbacks and their catch blocks: never throws.
  void publishStatus() noexcept {
    try {
      HazardStatus s = status_;
      s.header.stamp = products_stamp_;
      s.header.frame_id = frame_id_;
      if (mapper_) {
        s.metric = mapper_->metric();
        s.densifying = mapper_->metric() && mapper_->hasCamera() && config_.densify;
      }
      status_pub_.publish(s);
    } catch (...) {
      NODELET_ERROR_THROTTLE(1.0, "hazard/status could not be published");
    }
  }

  /// "<where>: <why>" into the status and the log; never throws.
  void reject(const char* where, const std::string& why) noexcept {
    ++status_.inputs_rejected;
    try {
      status_.message = std::string(where) + ": " + why;
      NODELET_ERROR_STREAM_THROTTLE(1.0, status_.message);
    } catch (...) {
    }
    publishStatus();
  }

  HazardNodeletParams params_;
  terrain::HazardMapperConfig config_;
  std::optional<terrain::HazardMapper> mapper_;
  std::optional<sensor_msgs::CameraInfo> last_info_;
  HazardStatus status_;
  std::string frame_id_, last_reason_;
  bool dirty_ = false;
  ros::Time nav_stamp_, events_stamp_, products_stamp_;
  ros::Publisher status_pub_, map_pub_, occupancy_pub_, sites_pub_, site_poses_pub_, best_site_pub_,
      markers_pub_, cloud_pub_;
  ros::Subscriber events_sub_, info_sub_, vo_status_sub_;
  ros::WallTimer timer_, status_timer_;
};

}  // namespace planetary_vo::ros_io

PLUGINLIB_EXPORT_CLASS(planetary_vo::ros_io::HazardNodelet, nodelet::Nodelet)
