#pragma once
/// @file inertial_initializer.h
/// Visual-inertial alignment (the initialisation of the camera + IMU mode without a handed-over velocity):
/// from the keyframes of an up-to-scale visual map and the IMU preintegrated between them, the metric scale,
/// the gravity direction in the map frame, the velocity of every keyframe and the gyro bias, by linear least
/// squares (the approach of VINS-Mono's visual-inertial alignment, Qin et al. 2018; written from the equations,
/// docs/fusion/README.md):
///
///  1. gyro bias: the rotations between keyframes from vision against the preintegrated ones,
///     min sum |Log(dR(bg)^T R_i^T R_j)|^2, linearised in bg (one Gauss-Newton step, then re-integration);
///  2. velocities, gravity and scale: per keyframe pair, with body positions p_b = s p_c + R_wc t_ci,
///       s (p_j - p_i) - v_i dt - g dt^2 / 2 = R_i dp + (R_wc,i - R_wc,j) t_ci
///       v_j - v_i - g dt = R_i dv
///     linear in (v_0..v_n, g, s); with the gravity direction known (a gravity-aligned world) g is fixed,
///     with the scale known (an altimeter-metric map) s is fixed;
///  3. unknown gravity: refined on the sphere of the known magnitude (two tangent unknowns, four passes).
///
/// It fails (valid false with the reason) when the motion does not make the scale observable: the scale's
/// 1-sigma from the least-squares residuals above max_scale_sigma (e.g. a constant-velocity descent, whose
/// accelerometer sees only gravity), a gravity magnitude more than 10 % off before the refinement (with the
/// gravity direction unknown, a constant acceleration a cannot be told from gravity: g + (k - 1) a fits with
/// the scale k s; the acceleration must vary, or the attitude be handed over), or a non-positive scale. The IMU body is mounted at T_cam_imu; biases of the accelerometer are taken as zero (its
/// turn-on bias is left to the windowed optimiser).

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/fusion/imu_preintegration.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

struct InertialAlignmentInput {
  std::vector<double> timestamps_s;  ///< keyframe times, ascending
  std::vector<Pose> T_map_cam;       ///< keyframe camera poses in the map frame (map units)
  /// IMU preintegrated between keyframe k and k+1 (size - 1 entries), at any linearisation bias.
  std::vector<std::shared_ptr<const ImuPreintegration>> preintegrations;
  Pose T_cam_imu = Pose::Identity();
  double gravity_mps2 = 1.62;
  /// The gravity vector in the map frame when the map frame is gravity-aligned (handed-over pose).
  std::optional<Eigen::Vector3d> known_gravity_map;
  /// The map is metric already (altimeter): the scale is fixed to 1.
  bool known_scale = false;
  double max_scale_sigma = 0.01;  ///< relative 1-sigma of the scale above which the alignment is refused
  double max_gravity_sigma_deg = 0.1;  ///< 1-sigma of the gravity direction above which it is refused
  /// Optional prior of the gyro bias (0: none): its 1-sigma (e.g. the data sheet's turn-on bias) against the
  /// 1-sigma of the visual rotation between two keyframes; a tactical gyro's bias is smaller than what the
  /// visual rotations over a few keyframes can resolve.
  double gyro_bias_prior_sigma_radps = 0.0;
  double rotation_sigma_rad = 1e-4;
};

struct InertialAlignment {
  bool valid = false;
  std::string reason;                  ///< why not valid
  double scale = 1.0;                  ///< metres per map unit
  double scale_sigma = 0.0;            ///< relative 1-sigma from the residuals
  double gravity_sigma_deg = 0.0;      ///< 1-sigma of the gravity direction (unknown gravity only), deg
  Eigen::Vector3d gravity_map = Eigen::Vector3d::Zero();  ///< gravity vector in the map frame (m/s^2)
  Eigen::Vector3d gyro_bias_radps = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> velocities_map_mps;  ///< IMU body velocity per keyframe, map axes, metric
  double residual_rms = 0.0;           ///< RMS of the linear system's residuals (m, m/s)
};

/// Throws std::invalid_argument for fewer than 3 keyframes, sizes that do not match, a null preintegration,
/// or preintegration intervals that are not the keyframe intervals (1e-6 s).
InertialAlignment alignVisualInertial(const InertialAlignmentInput& input);

}  // namespace planetary_vo
