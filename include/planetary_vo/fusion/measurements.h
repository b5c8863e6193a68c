#pragma once
/// @file measurements.h
/// The inertial and altimeter measurements the navigation consumes, as plain value types of the core library:
/// the VO pipeline and the fusion stages take these, and every source (dataset reader, ROS nodelet, a flight
/// driver) converts to them. Frames follow REP-103; for the Lunar datasets the IMU body frame is the camera
/// optical frame (sensors.yaml: T_cam_imu_nominal identity) and the altimeter looks along the camera's +z.

#include <limits>

#include <Eigen/Core>

namespace planetary_vo {

/// One IMU reading in the IMU (body) frame, as the instrument outputs it (biases and noise included).
struct ImuSample {
  double timestamp_s = 0.0;
  Eigen::Vector3d angular_velocity_radps = Eigen::Vector3d::Zero();
  Eigen::Vector3d specific_force_mps2 = Eigen::Vector3d::Zero();  ///< non-gravitational acceleration
};

/// One laser altimeter reading: only what the instrument measures.
struct AltimeterSample {
  double timestamp_s = 0.0;
  /// Measured range along the altimeter's boresight (the camera boresight for the Lunar sequences) to the
  /// terrain; +infinity when there was no return (REP-117's convention for sensor_msgs/Range).
  double slant_range_m = 0.0;
  bool hasReturn() const { return slant_range_m < std::numeric_limits<double>::max(); }
};

}  // namespace planetary_vo
