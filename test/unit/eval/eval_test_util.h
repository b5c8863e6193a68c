#pragma once
/// Trajectories with known errors for the evaluator tests.

#include <cmath>

#include <Eigen/Geometry>

#include "planetary_vo/geometry/pose.h"

namespace planetary_vo::test {

inline Pose makePose(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  Pose T = Pose::Identity();
  T.linear() = R;
  T.translation() = t;
  return T;
}

/// A descent-like ground truth in the landing-site frame (x crossrange, y downrange, z up): curved in 3D (so
/// that the alignment rotation is observable), camera attitude slowly turning. 10 Hz.
inline Trajectory descentGroundTruth(int n = 120) {
  Trajectory gt;
  for (int k = 0; k < n; ++k) {
    const double t = 0.1 * k;
    const Eigen::Vector3d p(30.0 * std::sin(0.05 * t), -400.0 + 25.0 * t + 0.3 * t * t,
                            1500.0 - 100.0 * t + 2.0 * t * t);
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()) *  // looking down
                               Eigen::AngleAxisd(0.02 * t, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.01 * t, Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    gt.push_back({1000.0 + t, makePose(R, p)});
  }
  return gt;
}

/// Velocity of descentGroundTruth() at time t since its start [m/s] (derivative of its positions).
inline Eigen::Vector3d descentVelocity(double t) {
  return Eigen::Vector3d(30.0 * 0.05 * std::cos(0.05 * t), 25.0 + 0.6 * t, -100.0 + 4.0 * t);
}

/// The same trajectory in another world and at another scale, as a monocular VO reports it: p_est = S^-1
/// p_gt, R_est = R^T R_gt, with S = (scale, R, t) mapping estimate world -> ground-truth world.
inline Trajectory inOtherWorld(const Trajectory& gt, double scale, const Eigen::Matrix3d& R,
                               const Eigen::Vector3d& t) {
  Trajectory est = gt;
  for (StampedPose& p : est) {
    const Pose& T = p.T_world_cam;
    p.T_world_cam = makePose(R.transpose() * T.rotation(), R.transpose() * (T.translation() - t) / scale);
  }
  return est;
}

/// Rotation of `deg` degrees about `axis` (normalised here).
inline Eigen::Matrix3d rotationDeg(double deg, const Eigen::Vector3d& axis) {
  return Eigen::AngleAxisd(deg * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}

/// A straight line of n poses, 1 m apart along y, identity attitude, 10 Hz.
inline Trajectory straightLine(int n) {
  Trajectory gt;
  for (int k = 0; k < n; ++k)
    gt.push_back({0.1 * k, makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0, k, 0))});
  return gt;
}

/// est_0 = gt_0, est_{k+1} = est_k * (gt_k^-1 gt_{k+1}) * D: the same per-step error D at every step.
inline Trajectory withPerStepDrift(const Trajectory& gt, const Pose& D) {
  Trajectory est = gt;
  for (size_t k = 1; k < gt.size(); ++k)
    est[k].T_world_cam = est[k - 1].T_world_cam * (gt[k - 1].T_world_cam.inverse() * gt[k].T_world_cam) * D;
  return est;
}

}  // namespace planetary_vo::test
