#pragma once
/// @file evaluation_inputs.h
/// Optional inputs of the evaluator besides the two trajectories, and their text readers: the ground-truth
/// navigation state of a planetary_vo dataset (groundtruth_state.txt, at the IMU rate: true velocity), the
/// velocity the estimator reports (vo_eval --est-velocity) and its covariance (--est-cov, for NEES).
///
/// The ground-truth files are for the evaluator only: nothing read here may reach an estimator. The readers
/// use plain std/Eigen parsing; every error is an EvalError naming the file and the line.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/trajectory_alignment.h"

namespace planetary_vo {

/// A velocity reported by the estimator, in the world frame of the estimate (estimate length units per
/// second: metres for a metric estimate; rotated and scaled by the alignment before it is compared).
struct StampedVelocity {
  double timestamp_s = 0.0;
  Eigen::Vector3d velocity_world = Eigen::Vector3d::Zero();
  /// The estimator's covariance of that velocity (same frame and units, squared), when it reports one (vo_run
  /// --output-velocity without the IMU: the motion filter's): the velocity NEES.
  bool has_covariance = false;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
};

/// A covariance reported by the estimator for its pose at `timestamp_s`. 3x3: position [m^2, world of the
/// estimate]. 6x6: [position; orientation], the orientation error a small angle [rad] in the world frame of
/// the estimate with R_true = Exp(delta) R_est. Symmetric positive definite.
struct StampedCovariance {
  double timestamp_s = 0.0;
  Eigen::MatrixXd covariance;
};

/// Inputs of evaluateTrajectory() besides the trajectories; each may be empty.
struct EvaluationInputs {
  /// groundtruth_state.txt: true velocity (interpolated at the estimate stamps). Empty: the ground-truth
  /// velocity is differentiated from the ground-truth poses.
  std::vector<GroundTruthState> ground_truth_state;
  /// Velocity reported by the estimator. Empty: differentiated from the aligned estimated positions.
  std::vector<StampedVelocity> estimate_velocity;
  /// Covariance reported by the estimator. Empty: no NEES (absent from the outputs).
  std::vector<StampedCovariance> estimate_covariance;
};

/// groundtruth_state.txt: '#' comments, lines `t px py pz qx qy qz qw vx vy vz bgx bgy bgz bax bay baz` (17
/// values: T_world_body, world velocity [m/s], true gyro [rad/s] and accelerometer [m/s^2] biases in the IMU
/// frame). Stamps strictly increasing. Throws EvalError (file:line) on a bad line or an unreadable file.
std::vector<GroundTruthState> readGroundTruthStates(const std::string& path);

/// Estimated velocities: lines `t vx vy vz`, '#' comments, stamps strictly increasing. Throws EvalError.
std::vector<StampedVelocity> readEstimateVelocities(const std::string& path);

/// Estimated covariances: lines `t` + 9 values (3x3 position covariance, row-major) or `t` + 36 values (6x6
/// [position; orientation], row-major), the same size on every line; '#' comments, stamps strictly
/// increasing. Each matrix must be symmetric (to 1e-9 of its largest entry; then symmetrised) and positive
/// definite. Throws EvalError (file:line).
std::vector<StampedCovariance> readEstimateCovariances(const std::string& path);

/// The ground-truth files behind vo_eval's --gt argument.
struct GroundTruthFiles {
  std::string trajectory_path;  ///< TUM or KITTI poses
  std::string state_path;       ///< groundtruth_state.txt, empty when there is none
};
/// `path` a file: that trajectory, no state file. A folder (a planetary_vo dataset): its groundtruth.txt and,
/// if present, its groundtruth_state.txt. Throws EvalError for a folder without groundtruth.txt or a missing
/// path.
GroundTruthFiles findGroundTruthFiles(const std::string& path);

/// World axis from "+x", "-x", "+y", "-y", "+z", "-z" (the sign may be left out for +): a unit vector. Throws
/// EvalError otherwise.
Eigen::Vector3d parseAxis(const std::string& text);

}  // namespace planetary_vo
