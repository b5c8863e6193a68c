/// @file trajectory_alignment.cpp
/// Time-stamp association and Umeyama alignment.

#include "planetary_vo/eval/trajectory_alignment.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include <Eigen/Geometry>
#include <Eigen/SVD>

namespace planetary_vo {

const char* toString(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kNone:
      return "none";
    case AlignmentMode::kSe3:
      return "se3";
    case AlignmentMode::kSim3:
      return "sim3";
    case AlignmentMode::kFirstPose:
      return "first";
  }
  return "unknown";
}

AlignmentMode parseAlignmentMode(const std::string& text) {
  if (text == "none") return AlignmentMode::kNone;
  if (text == "se3") return AlignmentMode::kSe3;
  if (text == "sim3") return AlignmentMode::kSim3;
  if (text == "first") return AlignmentMode::kFirstPose;
  throw EvalError("unknown alignment '" + text + "' (expected sim3, se3, first or none)");
}

AssociatedTrajectories associateByTimestamp(const Trajectory& ground_truth, const Trajectory& estimate,
                                            double max_dt_s) {
  // Candidates: each estimate with the ground-truth poses just before and just after its stamp.
  std::vector<std::tuple<double, size_t, size_t>> candidates;  // |dt|, estimate index, ground-truth index
  for (size_t e = 0; e < estimate.size(); ++e) {
    const double t = estimate[e].timestamp_s;
    const auto after = std::lower_bound(ground_truth.begin(), ground_truth.end(), t,
                                        [](const StampedPose& p, double s) { return p.timestamp_s < s; });
    const size_t g_after = static_cast<size_t>(after - ground_truth.begin());
    for (size_t g : {g_after - 1, g_after}) {  // g_after - 1 wraps to SIZE_MAX when g_after == 0
      if (g >= ground_truth.size()) continue;
      const double dt = std::abs(ground_truth[g].timestamp_s - t);
      if (dt <= max_dt_s) candidates.emplace_back(dt, e, g);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> used_gt(ground_truth.size(), false), used_est(estimate.size(), false);
  std::vector<std::pair<size_t, size_t>> pairs;  // estimate index, ground-truth index
  for (const auto& [dt, e, g] : candidates) {
    if (used_est[e] || used_gt[g]) continue;
    used_est[e] = used_gt[g] = true;
    pairs.emplace_back(e, g);
  }
  std::sort(pairs.begin(), pairs.end());
  AssociatedTrajectories result;
  for (const auto& [e, g] : pairs) {
    result.estimate.push_back(estimate[e]);
    result.ground_truth.push_back(ground_truth[g]);
    result.estimate_indices.push_back(e);
    result.ground_truth_indices.push_back(g);
  }
  return result;
}

Pose Sim3Transform::transformPose(const Pose& T_estworld_cam) const {
  Pose T = Pose::Identity();
  T.linear() = R_gt_est * T_estworld_cam.rotation();
  T.translation() = transformPoint(T_estworld_cam.translation());
  return T;
}

Trajectory Sim3Transform::transformTrajectory(const Trajectory& trajectory) const {
  Trajectory out = trajectory;
  for (StampedPose& p : out) p.T_world_cam = transformPose(p.T_world_cam);
  return out;
}

Sim3Transform alignTrajectories(const AssociatedTrajectories& pairs, AlignmentMode mode, size_t num_pairs) {
  if (mode == AlignmentMode::kNone) return {};
  if (mode == AlignmentMode::kFirstPose) return alignFirstPose(pairs, FirstPoseHandover());
  const size_t n = num_pairs == 0 ? pairs.size() : std::min(num_pairs, pairs.size());
  if (n < 3)
    throw EvalError("alignment " + std::string(toString(mode)) + " needs at least 3 associated poses, got " +
                    std::to_string(n));
  Eigen::Matrix3Xd est(3, n), gt(3, n);
  for (size_t k = 0; k < n; ++k) {
    est.col(k) = pairs.estimate[k].T_world_cam.translation();
    gt.col(k) = pairs.ground_truth[k].T_world_cam.translation();
  }
  // Rotation is unobservable when the positions of either side are (nearly) collinear or coincident.
  for (const Eigen::Matrix3Xd* points : {&est, &gt}) {
    const Eigen::Matrix3Xd centred = points->colwise() - points->rowwise().mean();
    const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3Xd>(centred).singularValues();
    if (!(sv(0) > 1e-9) || sv(1) < 1e-6 * sv(0))
      throw EvalError(
          std::string("alignment ") + toString(mode) + ": the " +
          (points == &est ? "estimated" : "ground-truth") +
          " positions are collinear or coincident, the rotation is unobservable (use --align none)");
  }
  const Eigen::Matrix4d T = Eigen::umeyama(est, gt, mode == AlignmentMode::kSim3);
  Sim3Transform s;
  s.scale = T.topLeftCorner<3, 3>().col(0).norm();  // umeyama returns [s R, t]
  s.R_gt_est = T.topLeftCorner<3, 3>() / s.scale;
  s.t_gt_est_m = T.topRightCorner<3, 1>();
  if (mode == AlignmentMode::kSe3) s.scale = 1.0;
  return s;
}

double firstPoseWindowScale(const AssociatedTrajectories& pairs, double window_s) {
  if (!(window_s > 0.0)) throw EvalError("the first-pose scale window must be positive");
  constexpr double kTolerance_s = 1e-6;  // a window of exactly N frame periods keeps its last frame
  double gt_m = 0.0, est_m = 0.0;
  size_t used = pairs.size() > 0 ? 1 : 0;
  for (size_t k = 1; k < pairs.size(); ++k) {
    if (pairs.ground_truth[k].timestamp_s - pairs.ground_truth[0].timestamp_s > window_s + kTolerance_s)
      break;
    gt_m += (pairs.ground_truth[k].T_world_cam.translation() -
             pairs.ground_truth[k - 1].T_world_cam.translation())
                .norm();
    est_m += (pairs.estimate[k].T_world_cam.translation() - pairs.estimate[k - 1].T_world_cam.translation())
                 .norm();
    ++used;
  }
  if (used < 2)
    throw EvalError("the first-pose scale window of " + std::to_string(window_s) +
                    " s holds fewer than 2 associated poses");
  if (!(est_m > 0.0) || !(gt_m > 0.0))
    throw EvalError("no motion within the first-pose scale window of " + std::to_string(window_s) +
                    " s: the scale is undefined");
  return gt_m / est_m;
}

Sim3Transform alignFirstPose(const AssociatedTrajectories& pairs, const FirstPoseHandover& handover) {
  if (pairs.size() == 0) throw EvalError("first-pose alignment needs at least one associated pose");
  if (!(handover.scale_window_s >= 0.0)) throw EvalError("the first-pose scale window must be >= 0");
  if (!(1.0 + handover.scale_error > 0.0)) throw EvalError("the initial scale error must be > -1");
  const double window_scale =
      handover.scale_window_s > 0.0 ? firstPoseWindowScale(pairs, handover.scale_window_s) : 1.0;
  const Pose& T_gt0 = pairs.ground_truth.front().T_world_cam;
  const Pose& T_est0 = pairs.estimate.front().T_world_cam;
  const Eigen::Vector3d e_rad = handover.attitude_error_deg * M_PI / 180.0;
  const Eigen::Matrix3d R_error = e_rad.norm() > 0.0
                                      ? Eigen::AngleAxisd(e_rad.norm(), e_rad.normalized()).toRotationMatrix()
                                      : Eigen::Matrix3d::Identity();
  Sim3Transform s;
  s.scale = window_scale * (1.0 + handover.scale_error);
  s.R_gt_est = R_error * T_gt0.rotation() * T_est0.rotation().transpose();
  s.t_gt_est_m =
      T_gt0.translation() + handover.position_error_m - s.scale * s.R_gt_est * T_est0.translation();
  return s;
}

}  // namespace planetary_vo
