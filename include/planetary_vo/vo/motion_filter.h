#pragma once
/// @file motion_filter.h
/// Stage 5b: the motion filter of the vision-only chain's output (issue 13: "motion-only refinement with a
/// motion prior"; the one-frame relative error that guidance differentiates into a velocity).
///
/// Each frame's pose against the map is a fresh measurement: its error is mostly white from one frame to the
/// next (the map moves slowly, the pixel noise of the tracks does not), so the difference of two consecutive
/// poses is noisy even when the trajectory drifts little. This filter fuses each frame's pose with the
/// prediction of a constant-velocity, constant-rate motion model (an error-state Kalman filter over the
/// camera centre, attitude, velocity and angular rate; random accelerations as the process noise), or, with
/// `constant_acceleration`, of a constant linear acceleration as well (driven by a random jerk), weighting
/// the measurement by its own information: the reprojection Jacobians of the frame's inlier points. The
/// directions the points pin down (the bearing of a nadir view) keep the measurement; the weak ones (the
/// depth along the optical axis, the translation a small rotation mimics) take the prediction.
///
/// The units are the map's (scale free: the monocular map's unit is its first baseline). The linear process
/// noise is therefore relative: a random acceleration of accel_sigma_ratio_per_s times the speed (with a
/// floor of a fraction of the scene depth per second, for a hover). Rotation is unit free (rad).
///
/// A measurement the prediction cannot explain (normalised innovation squared over gate_nis: a jolt, the map
/// moved by the optimiser, a bad frame) is taken as it is, so the filter never holds the output away from
/// what the images say; the rates are kept, made as uncertain as two frames make them, for the next frames to
/// correct. A second rejection in a row starts the rates again from the last two frames (wrong rates would
/// otherwise never be corrected). The caller resets the filter whenever the map is replaced
/// (re-initialisation) or rescaled.
///
/// The filter holds only its own state; what it filters is the caller's choice (the Pipeline: the published
/// pose of each frame tracked against the map, vision only; the map, the keyframes and the motion model of
/// the tracking keep the frame's own pose).

#include <vector>

#include <Eigen/Core>

#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/frame_result.h"  // FilteredMotion

namespace planetary_vo {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

/// A frame's pose against the map and its information, in the error coordinates of the filter: [camera centre
/// (world), rotation vector of the world-frame attitude error (R_true = Exp(dtheta) * R_est)].
struct PoseMeasurement {
  double timestamp_s = 0.0;
  Pose T_world_cam = Pose::Identity();
  Matrix6d information = Matrix6d::Zero();
  Matrix6d covariance = Matrix6d::Zero();  ///< its inverse (when valid)
  double median_depth = 0.0;               ///< median depth of the points in front of the camera (map units)
  double pixel_sigma_px = 0.0;             ///< the pixel noise the information was scaled with
  bool valid = false;  ///< at least 3 points in front of the camera and a positive-definite information
};

/// The measurement of a frame posed at `T_world_cam` from the world points `p_world` seen at the ideal
/// (undistorted) pixels `px` (intrinsics fx, fy, cx, cy); only the entries with `inlier` non-zero count
/// (empty: all). The pixel noise is the RMS reprojection residual of those points, at least
/// `min_pixel_sigma_px`. `depth_scratch` (optional): a buffer kept by a caller that measures every frame, so
/// that the call allocates nothing.
PoseMeasurement poseMeasurement(double timestamp_s, const Pose& T_world_cam,
                                const std::vector<Eigen::Vector3d>& p_world,
                                const std::vector<Eigen::Vector2d>& px,
                                const std::vector<unsigned char>& inlier, double fx, double fy, double cx,
                                double cy, double min_pixel_sigma_px,
                                std::vector<double>* depth_scratch = nullptr);

/// What MotionFilter::update() gives back.
struct FilteredPose {
  Pose T_world_cam = Pose::Identity();
  /// The rates after this update, valid when filtered or gated (not over the first two frames).
  FilteredMotion motion;
  bool filtered =
      false;           ///< false: the measurement itself (first two frames, or after a rejected prediction)
  bool gated = false;  ///< the prediction was rejected (normalised innovation squared over gate_nis)
  double nis = 0.0;    ///< normalised innovation squared of this update (6 dof), 0 when not filtered
};

class MotionFilter {
 public:
  explicit MotionFilter(const MotionFilterConfig& config);

  /// Forgets the state: the next measurement starts the filter again.
  void reset();
  /// Fuses `m` (which must be valid and later than the last update) with the prediction to its time.
  /// Gaps longer than max_gap_s restart the filter from `m`.
  FilteredPose update(const PoseMeasurement& m);

  /// The map the measurements are taken against moved rigidly by `T_new_old` (the optimiser adjusted it): the
  /// state moves with it, so that the next measurement, taken against the moved map, does not read the move
  /// as motion. Positions, attitudes and the rates are transformed; the covariance is rotated.
  void moveWithMap(const Pose& T_new_old);

  /// Two measurements since the last restart: the next one is filtered.
  bool running() const { return num_updates_ >= 2; }

 private:
  using Matrix15d = Eigen::Matrix<double, 15, 15>;
  void restartPose(const PoseMeasurement& m);
  /// Position and attitude from `m`, the rates from last_ to `m` (dt apart).
  void startFromTwo(const PoseMeasurement& m, double dt);
  /// The current rates and their covariances, valid.
  FilteredMotion motion() const;

  MotionFilterConfig config_;
  int num_updates_ = 0;  ///< since the last restart
  double t_s_ = 0.0;
  Eigen::Vector3d c_world_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d R_world_cam_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d v_world_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_world_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_world_ = Eigen::Vector3d::Zero();  ///< zero, with zero covariance, for constant velocity
  Matrix15d P_ = Matrix15d::Zero();  ///< [dc, dtheta, dv, domega, da]
  /// The last measurement: the second one takes the rates from it, and its covariance sizes the rates' after
  /// a rejected prediction.
  PoseMeasurement last_;
  bool last_gated_ = false;  ///< the last update rejected the prediction
};

}  // namespace planetary_vo
