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

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/VoStatus.h"
#include "planetary_vo/eval/trajectory_alignment.h"
#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/feature_tracks.h"
#include "planetary_vo/vo/frame_result.h"

namespace planetary_vo::ros_io {

/// @brief Checks a CameraInfo the pipeline can use: finite positive fx, fy, finite cx, cy, non-zero size,
/// finite coefficients, then PinholeCamera::isValid() of fromCameraInfo() (distortion model and its number of
/// coefficients, principal point inside the image, plausible field of view, distortion invertible over the
/// image). Returns "" when usable, else what is wrong.
std::string checkCameraInfo(const sensor_msgs::CameraInfo& info);

/// The vo/status note for a gap of gap_s between two images at the usual period_s: "about N frames dropped
/// (gap ... s, period ... s)", N = round(gap / period) - 1 computed without overflow (64-bit, clamped), for
/// any gap and period > 0.
std::string frameGapNote(double gap_s, double period_s);

/// Largest position magnitude (VO units) a published pose may have: beyond it the estimate has diverged.
constexpr double kMaxOutputPositionMagnitude = 1e9;
/// @brief The final guard before a pose is published: finite, a rotation (orthonormal within 1e-6, det +1, so
/// its quaternion is unit) and a position within kMaxOutputPositionMagnitude. False with *why otherwise.
bool checkOutputPose(const Pose& T_world_cam, std::string* why);

/// FrameResult -> VoStatus (state, counts, motion model, times, scale confidence, scale source, metric,
/// inertial, velocity and biases, message). The counters, mode, initial_state_applied and ros_overhead_ms are
/// left for the caller.
VoStatus toVoStatus(const FrameResult& result, const std_msgs::Header& header);
/// The navigation mode of a configuration: VoStatus::MODE_VISION, MODE_VISION_ALTIMETER, MODE_VISION_IMU or
/// MODE_VISION_IMU_ALTIMETER (imu.enabled, altimeter.enabled).
std::string navigationMode(const VoConfig& config);
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

/// One navigation solution for nav/odometry: a frame's (FrameResult) or the IMU-rate state between images
/// (Pipeline::navStateAt), with the covariance of navCovariance().
struct NavSolution {
  Pose T_world_cam = Pose::Identity();  ///< camera optical frame in the world
  /// Velocity of the body (the IMU; the camera when there is no IMU, T_cam_imu identity), world frame.
  Eigen::Vector3d v_world_mps = Eigen::Vector3d::Zero();
  /// Angular velocity of the body in the body frame (latest gyro sample minus the estimated gyro bias).
  Eigen::Vector3d w_body_radps = Eigen::Vector3d::Zero();
  /// [position (world, m), attitude (rotation vector of the world-frame error, rad), velocity (world, m/s)].
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Identity();
  Eigen::Matrix3d w_covariance = Eigen::Matrix3d::Identity();  ///< of w_body_radps, body frame
};

/// @brief The 9x9 navigation covariance of a frame: FrameResult::covariance when has_covariance, else the
/// parameter model of toOdometry() (sigma, scaled by the inliers, x lost_factor without a pose estimate) with
/// velocity_sigma_mps for the velocity. Without a pose estimate and without IMU factors holding the map
/// (neither hasPoseEstimate() nor inertial), the result is inflated by lost_factor^2 even when it comes from
/// the pipeline: such an output is never confident.
Eigen::Matrix<double, 9, 9> navCovariance(const FrameResult& result, const OdometrySigma& sigma,
                                          double velocity_sigma_mps);

/// @brief The body velocity (world) and angular rate (body) between two poses dt apart, for a metric mode
/// without the IMU (vision + altimeter), where the body is the camera. False when dt <= 0.
bool differentiatePoses(const Pose& T_world_prev, const Pose& T_world_cur, double dt_s,
                        Eigen::Vector3d* v_world, Eigen::Vector3d* w_body);

/// @brief nav/odometry (REP-105): pose of the child frame in the world (T_world_cam * T_cam_child), twist of
/// the child frame in the child frame: linear = R_world_child^T (v_body + w_world x (p_child - p_body)),
/// angular = R_child_body w_body. Pose covariance (x y z, rotations about the world axes) carried from the
/// camera to the child through the lever arm; twist covariance: the velocity block rotated into the child
/// frame, the rate covariance rotated likewise.
/// @param T_cam_imu the body (IMU) pose in the camera (identity without an IMU)
/// @param T_cam_child the child frame in the camera (identity when the child is the camera)
nav_msgs::Odometry toNavOdometry(const NavSolution& solution, const Pose& T_cam_imu, const Pose& T_cam_child,
                                 const std_msgs::Header& header, const std::string& child_frame_id);

/// Map points -> PointCloud2 with float32 fields x, y, z and uint32 observations, in header.frame_id.
/// `S_frame_world` maps the pipeline's world into that frame (identity unless the nodelet re-anchored it).
sensor_msgs::PointCloud2 toPointCloud(const std::vector<MapPointView>& points, const std_msgs::Header& header,
                                      const Sim3Transform& S_frame_world = Sim3Transform());

/// The tracking image: the gray frame in colour, each live track as a line from its previous to its current
/// position and a dot coloured by age (red: new, green: old), and the state in the corner. bgr8.
sensor_msgs::ImagePtr drawTracks(const cv::Mat& gray, const std::vector<FeatureTrack>& tracks,
                                 const FrameResult& result, const std_msgs::Header& header);

}  // namespace planetary_vo::ros_io
