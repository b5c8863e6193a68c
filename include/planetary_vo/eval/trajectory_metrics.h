#pragma once
/// @file trajectory_metrics.h
/// Trajectory error metrics after association and alignment: absolute trajectory error (ATE), relative pose
/// error (RPE) over frame and distance deltas, rotation error, per-pose errors in the landing-site frame, and
/// the navigation errors guidance needs (final error at the low gate, velocity, tilt, scale drift, NEES; see
/// navigation_metrics.h), each also as a per-pose time series.
///
/// Landing-site frame convention (the world frame of the Lunar sequences): x = crossrange, y = downrange,
/// z = altitude (up). Errors are estimate minus ground truth, in metres, in that frame.

#include <limits>
#include <string>
#include <vector>

#include "planetary_vo/eval/evaluation_inputs.h"
#include "planetary_vo/eval/navigation_metrics.h"
#include "planetary_vo/eval/trajectory_alignment.h"

namespace planetary_vo {

/// Summary statistics of a list of values (all NaN-free; computeFiniteStatistics() leaves out the NaN). count
/// == 0 leaves the others 0.
struct ErrorStatistics {
  size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std_dev = 0.0;  ///< population standard deviation about the mean
  double min = 0.0;
  double max = 0.0;
  double max_abs = 0.0;  ///< largest |value| (for signed errors)
};
ErrorStatistics computeStatistics(std::vector<double> values);
/// computeStatistics() of the finite values only (undefined per-pose values are NaN).
ErrorStatistics computeFiniteStatistics(const std::vector<double>& values);

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
  double rotation_error_deg = 0.0;   ///< angle of R_gt^T R_est (the attitude error)

  // Filled by evaluateTrajectory(); NaN where undefined (and in the outputs null).
  double time_since_start_s = 0.0;    ///< t - t of the first associated pose
  double distance_travelled_m = 0.0;  ///< ground-truth path length from the first associated pose
  /// 100 translation_error_m / distance_travelled_m (NaN before any motion)
  double position_error_percent_of_distance = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d velocity_gt_mps = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Vector3d velocity_est_mps = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// velocity_est_mps - velocity_gt_mps, ground-truth world (crossrange, downrange, up for the Lunar
  /// sequences)
  Eigen::Vector3d velocity_error_mps = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double velocity_error_norm_mps = std::numeric_limits<double>::quiet_NaN();  ///< |velocity_error_mps|
  double tilt_error_deg = 0.0;  ///< angle between R_gt^T up and R_est^T up
  /// scale error over the trailing window EvaluationOptions::scale_window_s [%]
  double scale_error_percent = std::numeric_limits<double>::quiet_NaN();
  double nees_position = std::numeric_limits<double>::quiet_NaN();  ///< 3 dof, with a covariance
  double nees_attitude = std::numeric_limits<double>::quiet_NaN();  ///< 3 dof, with a 6x6 covariance
  double nees_pose = std::numeric_limits<double>::quiet_NaN();      ///< 6 dof, with a 6x6 covariance
  /// 3 dof, where the estimated velocity came with its covariance (EvaluationInputs::estimate_velocity)
  double nees_velocity = std::numeric_limits<double>::quiet_NaN();
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
  /// For the default distance deltas: delta / ground-truth path length (0.1 ... 0.5); NaN for deltas given in
  /// frames or metres.
  double path_fraction = std::numeric_limits<double>::quiet_NaN();
};

struct EvaluationOptions {
  AlignmentMode alignment = AlignmentMode::kSim3;
  double max_dt_s = 0.02;      ///< association tolerance
  size_t align_num_pairs = 0;  ///< align on the first N pairs only (0: all)
  std::vector<int> rpe_frame_deltas = {1, 10};
  /// RPE distance deltas in metres; empty: 10, 20, 30, 40, 50 % of the ground-truth path length (as
  /// rpg_trajectory_evaluation).
  std::vector<double> rpe_distance_deltas_m;
  /// The handed-over state for alignment kFirstPose (must stay at its defaults for the other modes).
  FirstPoseHandover first_pose;
  /// Up direction in the ground-truth world (opposite to gravity), for the tilt error: +z for the Lunar
  /// landing-site frame, -y for KITTI (world = first camera frame, y down). Unit vector.
  Eigen::Vector3d up_world = Eigen::Vector3d::UnitZ();
  /// Length of the trailing window of the scale error over time [s].
  double scale_window_s = 5.0;
  /// Two consecutive samples more than gap_factor x their median period apart are not differentiated or
  /// interpolated together (velocity).
  double gap_factor = 3.0;
};

/// Throws EvalError naming the field when an option is out of range.
void validate(const EvaluationOptions& options);

/// The errors at the last associated pose (the low gate / end of the run); NaN where undefined.
struct FinalErrors {
  double timestamp_s = 0.0;         ///< ground-truth stamp of the last associated pose
  double time_since_start_s = 0.0;  ///< since the first associated pose
  double position_error_m = 0.0;
  double position_error_percent_of_distance = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d position_error_world_m = Eigen::Vector3d::Zero();  ///< est - gt, world axes
  double velocity_error_mps = std::numeric_limits<double>::quiet_NaN();
  Eigen::Vector3d velocity_error_world_mps =
      Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double attitude_error_deg = 0.0;
  double tilt_error_deg = 0.0;
  double scale_error_percent = std::numeric_limits<double>::quiet_NaN();
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

  /// Ground-truth path length between the first and the last associated pose, over all ground-truth poses
  /// (gt_path_length_m uses the associated ones only, so it cuts corners across gaps of the estimate).
  double distance_travelled_m = 0.0;
  FinalErrors final_errors;
  /// kFirstPose with a scale window: the window's scale before the initial scale error (NaN otherwise).
  double first_pose_window_scale = std::numeric_limits<double>::quiet_NaN();
  std::string velocity_truth_source;     ///< "groundtruth_state" or "pose_differences"
  std::string velocity_estimate_source;  ///< "estimate_velocity" or "pose_differences"
  ErrorStatistics velocity_error_mps;    ///< |v_est - v_gt| over the poses with both velocities
  ErrorStatistics tilt_error_deg;
  ErrorStatistics scale_error_percent;  ///< signed; over the poses whose window is full
  /// 0 without covariance input, 3 (position) or 6 (position and attitude): which nees_* are meaningful.
  int covariance_dimension = 0;
  NeesStatistics nees_position;  ///< 3 dof
  NeesStatistics nees_attitude;  ///< 3 dof, 6x6 covariances only
  NeesStatistics nees_pose;      ///< 6 dof, 6x6 covariances only
  /// The estimated velocity came with its covariance: nees_velocity (3 dof) is meaningful.
  bool has_velocity_covariance = false;
  NeesStatistics nees_velocity;

  std::vector<RelativeError> rpe;  ///< frame deltas, then distance deltas
  std::vector<PoseError> poses;    ///< per associated pose
};

/// Associates, aligns and computes every metric. `inputs` adds the true velocity, the estimated velocity and
/// the estimated covariance (NEES) when given. Throws EvalError if nothing associates, the alignment is
/// degenerate or an option is out of range.
TrajectoryEvaluation evaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const EvaluationOptions& options,
                                        const EvaluationInputs& inputs = EvaluationInputs());

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
