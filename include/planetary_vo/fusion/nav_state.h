#pragma once
/// @file nav_state.h
/// The navigation state the inertial fusion estimates, and its conventions.
///
/// Frames: world = the landing-site frame of the Lunar sequences (origin at the landing site, z up, see
/// render/descent_trajectory.h); body = the IMU frame, which for the Lunar datasets is the camera optical
/// frame (sensors.yaml: T_cam_imu_nominal identity). T_world_body maps body coordinates into the world
/// (geometry/pose.h), so its translation is the IMU position in the world.
///
/// Gravity: the gravity vector g_world (m/s^2, world frame) is always passed explicitly to the functions that
/// need it (preintegration prediction, inertial factor); nothing reads it from global state. The
/// accelerometer measures the specific force f_body = R_world_body^T (a_world - g_world). For the Lunar
/// sequences g_world = kLunarGravityWorldMps2 = (0, 0, -1.62) m/s^2 (world z up), the value the renderer
/// uses.
///
/// Biases are in the IMU (body) frame and are SUBTRACTED from the measurement: true angular velocity =
/// measured - gyro_bias_radps (- noise), true specific force = measured - accel_bias_mps2 (- noise), the
/// convention of sensors/imu_model.h (measured = truth + b + n) and of groundtruth_state.txt.

#include <Eigen/Core>

#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

/// Lunar surface gravity magnitude (m/s^2), the renderer's render::kLunarGravity.
constexpr double kLunarGravityMps2 = 1.62;
/// The Lunar gravity vector in the landing-site world frame (z up): (0, 0, -1.62) m/s^2. A default for
/// callers; every function takes gravity as an argument.
inline const Eigen::Vector3d kLunarGravityWorldMps2{0.0, 0.0, -kLunarGravityMps2};

/// Gyro and accelerometer biases, IMU (body) frame, subtracted from the measurements.
struct ImuBias {
  Eigen::Vector3d gyro_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d accel_mps2 = Eigen::Vector3d::Zero();
};

/// Full inertial navigation state at one instant.
struct NavState {
  double timestamp_s = 0.0;
  Pose T_world_body = Pose::Identity();                       ///< body (IMU) pose in the world
  Eigen::Vector3d v_world_mps = Eigen::Vector3d::Zero();      ///< body velocity, world frame
  Eigen::Vector3d gyro_bias_radps = Eigen::Vector3d::Zero();  ///< IMU frame
  Eigen::Vector3d accel_bias_mps2 = Eigen::Vector3d::Zero();  ///< IMU frame

  ImuBias bias() const { return {gyro_bias_radps, accel_bias_mps2}; }
  void setBias(const ImuBias& bias) {
    gyro_bias_radps = bias.gyro_radps;
    accel_bias_mps2 = bias.accel_mps2;
  }
};

/// True when every number of the state (time, pose, velocity, biases) is finite.
bool isFinite(const NavState& state);

}  // namespace planetary_vo
