#pragma once
/// @file evaluation_report.h
/// Outputs of a TrajectoryEvaluation: a readable text report, JSON (hand-written, no dependency) and the
/// per-pose CSV read by scripts/plot_trajectory.py.

#include <string>

#include "planetary_vo/eval/trajectory_metrics.h"

namespace planetary_vo {

/// Multi-line text report: counts, alignment (scale), ATE, rotation, landing-site errors, navigation errors
/// (final, velocity, tilt, scale, NEES when a covariance was given), RPE, with units.
std::string formatReport(const TrajectoryEvaluation& evaluation);

/// JSON document of the evaluation (keys in docs/evaluation.md); the per-pose `series` arrays and `poses`
/// list included when `with_poses`. Non-finite numbers are null; NEES keys only with a covariance.
std::string toJson(const TrajectoryEvaluation& evaluation, bool with_poses);
/// Writes toJson(evaluation, with_poses) to `path`. Throws EvalError if it cannot.
void writeJson(const std::string& path, const TrajectoryEvaluation& evaluation, bool with_poses = true);

/// Per-pose CSV with a header line: t_s, gt_x/y/z_m, est_x/y/z_m, err_x/y/z_m (crossrange, downrange,
/// altitude), ate_m, rot_err_deg, gt_qx/qy/qz/qw, est_qx/qy/qz/qw, then t_rel_s, dist_m, gt_vx/vy/vz_mps,
/// est_vx/vy/vz_mps, vel_err_x/y/z_mps, vel_err_mps, tilt_err_deg, scale_err_pct, nees_pos, nees_att,
/// nees_pose (undefined values written as nan). Throws EvalError if it cannot be written.
void writePoseErrorsCsv(const std::string& path, const TrajectoryEvaluation& evaluation);

}  // namespace planetary_vo
