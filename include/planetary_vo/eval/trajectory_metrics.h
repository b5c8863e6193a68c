#pragma once
/// @file trajectory_metrics.h
/// Trajectory error metrics after association and alignment: absolute trajectory error (ATE), relative pose
/// error (RPE) over frame and distance deltas, rotation error, and per-pose errors in the landing-site frame.
///
/// Landing-site frame convention (the world frame of the Lunar sequences): x = crossrange, y = downrange,
/// z = altitude (up). Errors are estimate minus ground truth, in metres, in that frame.

#include <string>
#include <vector>

#include "planetary_vo/eval/trajectory_alignment.h"

namespace planetary_vo {

/// Summary statistics of a list of values (all NaN-free). count == 0 leaves the others 0.
struct ErrorStatistics {
  size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std_dev = 0.0;  ///< population standard deviation about the mean
  double min = 0.0;
  double max = 0.0;
};
ErrorStatistics computeStatistics(std::vector<double> values);

/// Errors of one associated pose after alignment.
struct PoseError {
  double timestamp_s = 0.0;  ///< ground-truth stamp
  Eigen::Vector3d position_gt_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d position_est_m = Eigen::Vector3d::Zero();  ///< aligned
  Eigen::Quaterniond q_world_cam_gt = Eigen::Quaterniond::Identity();
  Eigen::Quaterniond q_world_cam_est = Eigen::Quaterniond::Identity();  ///< aligned, same hemisphere as gt
  Eigen::Vector3d position_error_m =
      Eigen::Vector3d::Zero();       ///< est - gt: (crossrange, downrange, altitude)
  double translation_error_m = 0.0;  ///< |position_error_m| (the ATE of this pose)
  double rotation_error_deg = 0.0;   ///< angle of R_gt^T R_est
};

/// Relative pose error for one delta (a number of frames, or a travelled distance along the ground truth).
/// For a pair (i, j): E = (T_gt_i^-1 T_gt_j)^-1 (T_est_i^-1 T_est_j), estimate aligned (so scaled for sim3).
struct RelativeError {
  std::string delta_unit;  ///< "frames" or "m"
  double delta = 0.0;      ///< frames, or metres of ground-truth path
  size_t num_pairs = 0;
  ErrorStatistics translation_m;        ///< |t(E)|
  ErrorStatistics translation_percent;  ///< 100 |t(E)| / ground-truth path length between i and j
  ErrorStatistics rotation_deg;         ///< angle(E)
  ErrorStatistics rotation_deg_per_m;   ///< angle(E) / ground-truth path length between i and j
};

struct EvaluationOptions {
  AlignmentMode alignment = AlignmentMode::kSim3;
  double max_dt_s = 0.02;      ///< association tolerance
  size_t align_num_pairs = 0;  ///< align on the first N pairs only (0: all)
  std::vector<int> rpe_frame_deltas = {1, 10};
  /// RPE distance deltas in metres; empty: 10, 20, 30, 40, 50 % of the ground-truth path length (as
  /// rpg_trajectory_evaluation).
  std::vector<double> rpe_distance_deltas_m;
};

/// The full result of evaluateTrajectory().
struct TrajectoryEvaluation {
  EvaluationOptions options;
  size_t num_ground_truth = 0;
  size_t num_estimate = 0;
  size_t num_associated = 0;
  double duration_s = 0.0;        ///< time span of the associated ground truth
  double gt_path_length_m = 0.0;  ///< path length of the associated ground truth
  Sim3Transform alignment;        ///< estimate world -> ground-truth world

  ErrorStatistics ate_m;          ///< absolute translation error after alignment
  double ate_rmse_percent = 0.0;  ///< 100 * ate_m.rmse / gt_path_length_m
  ErrorStatistics rotation_deg;   ///< absolute rotation error after alignment
  /// Error of the attitude change since the first associated pose: angle of
  /// (R_gt_0^T R_gt_k)^T (R_est_0^T R_est_k). It does not depend on the alignment, so it stays meaningful
  /// when the positions barely constrain the alignment's rotation (a nearly straight descent leaves the roll
  /// about the path free, and rotation_deg then carries that alignment error, not the VO's).
  ErrorStatistics attitude_drift_deg;
  ErrorStatistics crossrange_error_m;   ///< signed x error
  ErrorStatistics downrange_error_m;    ///< signed y error
  ErrorStatistics altitude_error_m;     ///< signed z error
  double final_position_error_m = 0.0;  ///< ATE of the last associated pose (the landing error)

  std::vector<RelativeError> rpe;  ///< frame deltas, then distance deltas
  std::vector<PoseError> poses;    ///< per associated pose
};

/// Associates, aligns and computes every metric. Throws EvalError if nothing associates or alignment is
/// degenerate.
TrajectoryEvaluation evaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const EvaluationOptions& options);

/// Attitude-change errors since the first pose of associated pairs (see
/// TrajectoryEvaluation::attitude_drift_deg).
std::vector<double> attitudeDriftDeg(const Trajectory& ground_truth, const Trajectory& estimate);

/// Per-pose errors of already associated and aligned pairs.
std::vector<PoseError> computePoseErrors(const Trajectory& ground_truth, const Trajectory& aligned_estimate);

/// RPE over pairs (i, i + delta_frames) of associated poses.
RelativeError relativeErrorOverFrames(const Trajectory& ground_truth, const Trajectory& aligned_estimate,
                                      int delta_frames);
/// RPE over pairs (i, j) where j is the first pose at least `delta_m` further along the ground-truth path
/// (KITTI devkit style, every first pose i).
RelativeError relativeErrorOverDistance(const Trajectory& ground_truth, const Trajectory& aligned_estimate,
                                        double delta_m);

/// Cumulative path length of the positions of a trajectory: [0, |p1-p0|, ...] in metres.
std::vector<double> cumulativePathLength(const Trajectory& trajectory);

}  // namespace planetary_vo
