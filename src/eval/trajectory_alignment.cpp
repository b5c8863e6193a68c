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
  }
  return "unknown";
}

AlignmentMode parseAlignmentMode(const std::string& text) {
  if (text == "none") return AlignmentMode::kNone;
  if (text == "se3") return AlignmentMode::kSe3;
  if (text == "sim3") return AlignmentMode::kSim3;
  throw EvalError("unknown alignment '" + text + "' (expected sim3, se3 or none)");
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

}  // namespace planetary_vo
