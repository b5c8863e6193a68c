#pragma once
/// @file vo_conversions.h
/// Free functions between the pipeline's values (FrameResult, map points, tracks) and the nodelet's output
/// messages, and the input checks applied before an image reaches the pipeline. No node handle: unit-tested
/// in test/ros/test_vo_conversions.cpp without a master.

#include <string>
#include <vector>

#include <nav_msgs/Odometry.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>

#include <opencv2/core.hpp>

#include "planetary_vo/VoStatus.h"
#include "planetary_vo/eval/trajectory_alignment.h"
#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/vo/feature_tracks.h"
#include "planetary_vo/vo/frame_result.h"

namespace planetary_vo::ros_io {

/// @brief Checks a CameraInfo the pipeline can use: finite positive fx, fy, finite cx, cy, non-zero size, a
/// supported distortion model ("", plumb_bob, rational_polynomial is not) with the right number of finite
/// coefficients. Returns "" when usable, else what is wrong.
std::string checkCameraInfo(const sensor_msgs::CameraInfo& info);

/// @brief Checks that an 8-bit image is neither blank (grey-level stddev below min_stddev: black, or any
/// uniform frame) nor saturated (more than max_saturated_ratio of the pixels at 255). Returns "" when usable.
std::string checkExposure(const cv::Mat& gray, double min_stddev, double max_saturated_ratio);

/// FrameResult -> VoStatus (state, counts, motion model, times, scale confidence, message). The counters and
/// ros_overhead_ms are left 0 for the caller.
VoStatus toVoStatus(const FrameResult& result, const std_msgs::Header& header);
/// A status for a frame rejected before the pipeline: STATE_BAD_INPUT, processed = false, `why` as message.
VoStatus badInputStatus(const std::string& why, const std_msgs::Header& header);

/// Odometry covariance model: 1-sigma for the position (m, in VO units) and orientation (rad) while tracking
/// with `reference_inliers` inliers; scaled by sqrt(reference_inliers / inliers) and by lost_factor while the
/// pose is held or initialising.
struct OdometrySigma {
  double position_m = 0.05;
  double orientation_rad = 0.01;
  double lost_factor = 100.0;
  int reference_inliers = 100;
};

/// @brief The odometry message of a frame. Pose: T_world_child; twist: the body-frame velocity (in
/// child_frame_id, REP-105) from the previous output pose, zero when dt <= 0; covariances diagonal, from
/// `sigma`, with the twist's from the pose's divided by dt.
nav_msgs::Odometry toOdometry(const FrameResult& result, const Pose& T_world_child, const Pose& T_world_prev,
                              double dt_s, const std_msgs::Header& header, const std::string& child_frame_id,
                              const OdometrySigma& sigma);

/// Map points -> PointCloud2 with float32 fields x, y, z and uint32 observations, in header.frame_id.
/// `S_frame_world` maps the pipeline's world into that frame (identity unless the nodelet re-anchored it).
sensor_msgs::PointCloud2 toPointCloud(const std::vector<MapPointView>& points, const std_msgs::Header& header,
                                      const Sim3Transform& S_frame_world = Sim3Transform());

/// The tracking image: the gray frame in colour, each live track as a line from its previous to its current
/// position and a dot coloured by age (red: new, green: old), and the state in the corner. bgr8.
sensor_msgs::ImagePtr drawTracks(const cv::Mat& gray, const std::vector<FeatureTrack>& tracks,
                                 const FrameResult& result, const std_msgs::Header& header);

}  // namespace planetary_vo::ros_io
