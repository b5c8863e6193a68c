#pragma once
/// @file fusion_test_util.h
/// Shared by the fusion tests: the renderer's IMU error model reduced to constant biases, and the true
/// navigation state of a descent trajectory.

#include <string>

#include "planetary_vo/fusion/nav_state.h"
#include "planetary_vo/render/descent_trajectory.h"
#include "planetary_vo/sensors/imu_model.h"

namespace planetary_vo {

/// The error model with only the constant turn-on biases of a grade: no white noise, no bias instability or
/// random walk, no scale factor, misalignment, quantisation or saturation.
inline sensors::ImuErrorParams constantBiasOnly(const std::string& grade) {
  const sensors::ImuErrorParams g = sensors::imuGrade(grade);
  sensors::ImuErrorParams p;
  p.enabled = true;
  p.gyro.turn_on_bias = g.gyro.turn_on_bias;
  p.accel.turn_on_bias = g.accel.turn_on_bias;
  return p;
}

/// The true NavState at t from the continuous trajectory (exact, not on the sample grid).
inline NavState trueState(const render::DescentTrajectory& trajectory, double t, const ImuBias& bias) {
  const render::TrajectoryState s = trajectory.state(t);
  NavState n;
  n.timestamp_s = t;
  n.T_world_body = s.T_world_cam();
  n.v_world_mps = s.velocity;
  n.setBias(bias);
  return n;
}

}  // namespace planetary_vo
