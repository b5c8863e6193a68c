#pragma once
/// @file pose.h
/// Rigid poses and their naming convention.
///
/// `T_a_b` maps coordinates of frame b into frame a: p_in_a = T_a_b * p_in_b. So `T_world_cam` is the pose of
/// the camera optical frame in the world frame (its translation is the camera centre in world coordinates).
/// Timestamps are seconds as double.

#include <vector>

#include <Eigen/Geometry>

namespace planetary_vo {

using Pose = Eigen::Isometry3d;

struct StampedPose {
  double timestamp_s = 0.0;
  Pose T_world_cam = Pose::Identity();
};

using Trajectory = std::vector<StampedPose>;

/// Angle of a rotation in degrees, in [0, 180].
double rotationAngleDeg(const Eigen::Matrix3d& R);
/// Angle between two directions in degrees, in [0, 180]; 0 when either is zero.
double angleBetweenDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);
/// [v]x, the matrix of the cross product: skew(v) * u = v.cross(u).
Eigen::Matrix3d skew(const Eigen::Vector3d& v);

}  // namespace planetary_vo
