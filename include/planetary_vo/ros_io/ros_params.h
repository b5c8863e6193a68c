#pragma once
/// @file ros_params.h
/// ROS parameters -> the core VoConfig and the nodelet's own settings. ros_params.cpp is the only file of the
/// ROS layer that reads the parameter server.
///
/// The pipeline parameters use the keys of config/default.yaml under the node's private namespace
/// (~detector/num_features, ~motion/model, ...), so `<rosparam file="$(find
/// planetary_vo)/config/default.yaml" ns="..."/>` loads them. They are turned back into YAML and parsed by
/// the core loader (parseVoConfig), so both paths share one set of defaults, one validation and the same
/// "unknown key" errors.

#include <string>
#include <vector>

#include <ros/node_handle.h>

#include "planetary_vo/terrain/hazard_mapper.h"
#include "planetary_vo/vo/config.h"

namespace planetary_vo::ros_io {

/// Sections of VoConfig, as named in the YAML and under the private namespace.
extern const char* const kVoConfigSections[12];

/// @brief Reads ~<section>/<key> for every section of VoConfig.
/// @throws ConfigError naming every unknown or invalid key (with the "~" prefix of the namespace).
VoConfig loadVoConfigFromParams(const ros::NodeHandle& private_nh);

/// The YAML text loadVoConfigFromParams() parses (exposed for tests and for the startup log).
std::string voConfigYamlFromParams(const ros::NodeHandle& private_nh);

/// The camera frame of tf and of the outputs' child_frame_id when neither ~camera_frame nor the image header
/// names one (tf refuses an empty child frame).
extern const char* const kFallbackCameraFrame;

/// Settings of the nodelet itself (not of the pipeline). Defaults are stated here once.
struct NodeletParams {
  std::string world_frame = "world";  ///< ~world_frame: fixed frame of pose, path, map and tf (or "odom")
  /// ~camera_frame: "" = the image header's frame_id, or kFallbackCameraFrame when that is empty too
  std::string camera_frame;
  std::string base_frame;  ///< ~base_frame: "" = tf world -> camera; else world -> base through static tf
  bool publish_tf = true;  ///< ~publish_tf
  int queue_size = 5;      ///< ~queue_size: image + camera_info subscriber queue
  /// ~max_path_length: poses kept in vo/path (the oldest are dropped); 0 = all, which grows without bound.
  /// 10000 poses: 17 min at 10 Hz, about 1 MB per message.
  int max_path_length = 10000;
  /// ~path_publish_period_s: vo/path (the whole path, for rviz) is published at most this often (wall
  /// clock), and only while subscribed; vo/pose carries every pose. Must be > 0.
  double path_publish_period_s = 1.0;
  /// ~mono16_significant_bits: bits of a mono16 pixel that carry the sample (16: left-aligned, the full
  /// range; 10 or 12: a sensor writing right-aligned samples, which would otherwise look near-black). 8..16.
  int mono16_significant_bits = 16;
  /// ~position_sigma_m, ~orientation_sigma_rad: 1-sigma of the odometry covariance with min_inliers_for_sigma
  /// inliers while tracking; scaled by sqrt(reference / inliers), and by lost_sigma_factor while lost.
  double position_sigma_m = 0.05;
  double orientation_sigma_rad = 0.01;
  double lost_sigma_factor = 100.0;
  double max_frame_gap_factor = 3.0;  ///< ~max_frame_gap_factor: gap > this x median period = dropped frames
  double min_rate_hz = 1.0;           ///< ~min_rate_hz, ~max_rate_hz: vo/odometry frequency diagnostic bounds
  double max_rate_hz = 1000.0;
  /// ~velocity_sigma_mps: 1-sigma of the nav/odometry velocity when the pipeline gives no covariance, scaled
  /// like position_sigma_m.
  double velocity_sigma_mps = 0.1;
  /// ~wait_for_initial_state: process no image until a state arrives on nav/initial_state (and again after
  /// vo/reset).
  bool wait_for_initial_state = false;
  /// ~initial_state_tolerance: the handed-over state belongs to the first image within this of its stamp;
  /// images before it are skipped, a state older than the next image by more than this is not applied.
  double initial_state_tolerance_s = 0.01;
  int imu_queue_size = 1000;       ///< ~imu_queue_size: imu subscriber queue (messages)
  int altimeter_queue_size = 100;  ///< ~altimeter_queue_size
};
/// Reads the nodelet's parameters; each invalid one (validateNodeletParams) keeps its default and is named in
/// *problems (if given), which the nodelet logs as an error at startup.
NodeletParams loadNodeletParams(const ros::NodeHandle& private_nh,
                                std::vector<std::string>* problems = nullptr);
/// The names loadNodeletParams() reads (under the private namespace).
std::vector<std::string> nodeletParamNames();

/// @brief Names directly under the private namespace that are none of `known` (parameters, sections of the
/// configuration, dynamic_reconfigure knobs): a misspelt section or parameter, which would otherwise be
/// silently ignored. One message per name ("~detecter: not a parameter or section of this nodelet").
std::vector<std::string> unknownPrivateNames(const ros::NodeHandle& private_nh,
                                             const std::vector<std::string>& known);
/// @brief Sets every invalid field of `p` back to its default (NodeletParams{}): NaN or infinite numbers
/// (`~position_sigma_m: .nan` made every vo/odometry covariance NaN), non-positive sigmas and rates, a
/// lost_sigma_factor below 1, a max_frame_gap_factor not above 1, queue sizes below 1. Returns one message
/// per field reset.
std::vector<std::string> validateNodeletParams(NodeletParams* p);

/// The YAML text of the given sections of the private namespace (scalars only; a list or map value is
/// written so that the core loader names the key as of the wrong type).
std::string yamlFromParams(const ros::NodeHandle& private_nh, const std::vector<std::string>& sections);

/// Sections of HazardMapperConfig (config/hazard.yaml) under the hazard nodelet's private namespace.
const std::vector<std::string>& hazardConfigSections();
/// @brief ~area/..., ~map/..., ~densifier/..., ~thresholds/..., ~sites/... -> the hazard mapper's config, by
/// the core loader (one set of defaults: config/hazard.yaml).
/// @throws terrain::HazardConfigError naming every unknown or invalid key (with the namespace).
terrain::HazardMapperConfig loadHazardConfigFromParams(const ros::NodeHandle& private_nh);

/// Settings of the hazard nodelet itself. Defaults are stated here once.
struct HazardNodeletParams {
  /// ~publish_period_s: the products are recomputed and published at most this often (wall clock), when
  /// the map changed; hazard/status at this period. Must be > 0.
  double publish_period_s = 2.0;
  int cloud_stride = 2;         ///< ~cloud_stride: every n-th cell in hazard/elevation_cloud (rviz)
  int events_queue_size = 100;  ///< ~events_queue_size: vo/map_events subscriber queue (messages)
};
HazardNodeletParams loadHazardNodeletParams(const ros::NodeHandle& private_nh);
/// The names loadHazardNodeletParams() reads.
std::vector<std::string> hazardNodeletParamNames();

}  // namespace planetary_vo::ros_io
