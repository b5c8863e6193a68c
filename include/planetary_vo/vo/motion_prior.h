#pragma once
/// @file motion_prior.h
/// The motion model of the vision-only chain: where the camera is expected to be when no image gives its pose
/// (tracking lost, re-initialisation under way, the start of a recovery). Constant velocity of the camera
/// centre from the two newest keyframes, attitude held: while lost the output keeps moving as the vehicle did
/// instead of freezing and then jumping when the chain recovers. With an IMU this prior is replaced by the
/// inertial propagation of the fused state.

#include <Eigen/Core>

#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/map.h"

namespace planetary_vo {

/// Velocity of the camera centre between the two newest keyframes of `map` (world units per second). False
/// with fewer than two keyframes or a non-increasing time between them.
bool keyframeVelocity(const Map& map, Eigen::Vector3d* v_world_per_s);

/// `T_world_cam_last` (the last good pose, taken at t_last_s) moved on at keyframeVelocity() to `t_s`,
/// attitude held; `T_world_cam_last` itself when the map gives no velocity.
Pose predictConstantVelocity(const Pose& T_world_cam_last, double t_last_s, const Map& map, double t_s);

}  // namespace planetary_vo
