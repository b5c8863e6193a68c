/// @file trajectory_metrics.cpp
/// ATE, RPE, rotation and landing-site errors.

#include "planetary_vo/eval/trajectory_metrics.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace planetary_vo {

ErrorStatistics computeStatistics(std::vector<double> values) {
  ErrorStatistics s;
  s.count = values.size();
  if (values.empty()) return s;
  const double n = static_cast<double>(values.size());
  double sum = 0.0, sum_sq = 0.0;
  for (double v : values) {
    sum += v;
    sum_sq += v * v;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (double v : values) var += (v - s.mean) * (v - s.mean);
  s.std_dev = std::sqrt(var / n);
  std::sort(values.begin(), values.end());
  s.min = values.front();
  s.max = values.back();
  const size_t mid = values.size() / 2;
  s.median = values.size() % 2 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
  return s;
}

std::vector<double> cumulativePathLength(const Trajectory& trajectory) {
  std::vector<double> length(trajectory.size(), 0.0);
  for (size_t k = 1; k < trajectory.size(); ++k)
    length[k] =
        length[k - 1] +
        (trajectory[k].T_world_cam.translation() - trajectory[k - 1].T_world_cam.translation()).norm();
  return length;
}

std::vector<PoseError> computePoseErrors(const Trajectory& ground_truth, const Trajectory& aligned_estimate) {
  std::vector<PoseError> errors;
  for (size_t k = 0; k < std::min(ground_truth.size(), aligned_estimate.size()); ++k) {
    const Pose& gt = ground_truth[k].T_world_cam;
    const Pose& est = aligned_estimate[k].T_world_cam;
    PoseError e;
    e.timestamp_s = ground_truth[k].timestamp_s;
    e.position_gt_m = gt.translation();
    e.position_est_m = est.translation();
    e.q_world_cam_gt = Eigen::Quaterniond(gt.rotation());
    e.q_world_cam_est = Eigen::Quaterniond(est.rotation());
    if (e.q_world_cam_est.dot(e.q_world_cam_gt) < 0.0) e.q_world_cam_est.coeffs() *= -1.0;  // same hemisphere
    e.position_error_m = e.position_est_m - e.position_gt_m;
    e.translation_error_m = e.position_error_m.norm();
    e.rotation_error_deg = rotationAngleDeg(gt.rotation().transpose() * est.rotation());
    errors.push_back(e);
  }
  return errors;
}

namespace {

/// Accumulates the errors of pairs (i, j) into a RelativeError.
class RelativeErrorAccumulator {
 public:
  RelativeErrorAccumulator(const Trajectory& gt, const Trajectory& est)
      : gt_(gt), est_(est), path_m_(cumulativePathLength(gt)) {}

  void add(size_t i, size_t j) {
    const Pose gt_rel = gt_[i].T_world_cam.inverse() * gt_[j].T_world_cam;
    const Pose est_rel = est_[i].T_world_cam.inverse() * est_[j].T_world_cam;
    const Pose E = gt_rel.inverse() * est_rel;
    const double t_err = E.translation().norm();
    const double r_err = rotationAngleDeg(E.rotation());
    const double distance = path_m_[j] - path_m_[i];
    translation_m_.push_back(t_err);
    rotation_deg_.push_back(r_err);
    if (distance > 1e-9) {  // per-distance errors are undefined without motion
      translation_percent_.push_back(100.0 * t_err / distance);
      rotation_deg_per_m_.push_back(r_err / distance);
    }
  }

  const std::vector<double>& pathLength() const { return path_m_; }

  RelativeError result(const std::string& unit, double delta) const {
    RelativeError r;
    r.delta_unit = unit;
    r.delta = delta;
    r.num_pairs = translation_m_.size();
    r.translation_m = computeStatistics(translation_m_);
    r.translation_percent = computeStatistics(translation_percent_);
    r.rotation_deg = computeStatistics(rotation_deg_);
    r.rotation_deg_per_m = computeStatistics(rotation_deg_per_m_);
    return r;
  }

 private:
  const Trajectory& gt_;
  const Trajectory& est_;
  std::vector<double> path_m_;
  std::vector<double> translation_m_, translation_percent_, rotation_deg_, rotation_deg_per_m_;
};

}  // namespace

RelativeError relativeErrorOverFrames(const Trajectory& ground_truth, const Trajectory& aligned_estimate,
                                      int delta_frames) {
  if (delta_frames < 1)
    throw EvalError("RPE frame delta must be at least 1, got " + std::to_string(delta_frames));
  RelativeErrorAccumulator acc(ground_truth, aligned_estimate);
  const size_t n = std::min(ground_truth.size(), aligned_estimate.size());
  for (size_t i = 0; i + delta_frames < n; ++i) acc.add(i, i + delta_frames);
  return acc.result("frames", delta_frames);
}

RelativeError relativeErrorOverDistance(const Trajectory& ground_truth, const Trajectory& aligned_estimate,
                                        double delta_m) {
  if (!(delta_m > 0.0))
    throw EvalError("RPE distance delta must be positive, got " + std::to_string(delta_m));
  RelativeErrorAccumulator acc(ground_truth, aligned_estimate);
  const std::vector<double>& path = acc.pathLength();
  const size_t n = std::min(ground_truth.size(), aligned_estimate.size());
  size_t j = 0;
  for (size_t i = 0; i < n; ++i) {
    j = std::max(j, i + 1);
    // Small tolerance so that a sampled path of exactly delta_m (e.g. 10 steps of 1 m) is not missed by
    // rounding.
    while (j < n && path[j] - path[i] < delta_m * (1.0 - 1e-9)) ++j;
    if (j >= n) break;
    acc.add(i, j);
  }
  return acc.result("m", delta_m);
}

std::vector<double> attitudeDriftDeg(const Trajectory& ground_truth, const Trajectory& estimate) {
  const size_t n = std::min(ground_truth.size(), estimate.size());
  std::vector<double> drift_deg;
  drift_deg.reserve(n);
  if (n == 0) return drift_deg;
  const Eigen::Matrix3d R_gt0_t = ground_truth.front().T_world_cam.linear().transpose();
  const Eigen::Matrix3d R_est0_t = estimate.front().T_world_cam.linear().transpose();
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Matrix3d dR_gt = R_gt0_t * ground_truth[k].T_world_cam.linear();
    const Eigen::Matrix3d dR_est = R_est0_t * estimate[k].T_world_cam.linear();
    drift_deg.push_back(rotationAngleDeg(dR_gt.transpose() * dR_est));
  }
  return drift_deg;
}

TrajectoryEvaluation evaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const EvaluationOptions& options) {
  TrajectoryEvaluation ev;
  ev.options = options;
  ev.num_ground_truth = ground_truth.size();
  ev.num_estimate = estimate.size();
  const AssociatedTrajectories pairs = associateByTimestamp(ground_truth, estimate, options.max_dt_s);
  ev.num_associated = pairs.size();
  if (pairs.size() == 0)
    throw EvalError("no estimated pose is within " + std::to_string(options.max_dt_s) +
                    " s of a ground-truth pose (ground truth " + std::to_string(ground_truth.size()) +
                    " poses, estimate " + std::to_string(estimate.size()) +
                    "): check the time stamps or --max-dt");
  ev.duration_s = pairs.ground_truth.back().timestamp_s - pairs.ground_truth.front().timestamp_s;
  ev.gt_path_length_m = cumulativePathLength(pairs.ground_truth).back();

  ev.alignment = alignTrajectories(pairs, options.alignment, options.align_num_pairs);
  const Trajectory aligned = ev.alignment.transformTrajectory(pairs.estimate);

  ev.poses = computePoseErrors(pairs.ground_truth, aligned);
  std::vector<double> ate, rot, x, y, z;
  for (const PoseError& e : ev.poses) {
    ate.push_back(e.translation_error_m);
    rot.push_back(e.rotation_error_deg);
    x.push_back(e.position_error_m.x());
    y.push_back(e.position_error_m.y());
    z.push_back(e.position_error_m.z());
  }
  ev.ate_m = computeStatistics(ate);
  ev.ate_rmse_percent = ev.gt_path_length_m > 0.0 ? 100.0 * ev.ate_m.rmse / ev.gt_path_length_m : 0.0;
  ev.rotation_deg = computeStatistics(rot);
  ev.attitude_drift_deg = computeStatistics(attitudeDriftDeg(pairs.ground_truth, pairs.estimate));
  ev.crossrange_error_m = computeStatistics(x);
  ev.downrange_error_m = computeStatistics(y);
  ev.altitude_error_m = computeStatistics(z);
  ev.final_position_error_m = ate.back();

  for (int delta : options.rpe_frame_deltas)
    if (delta < 1 || static_cast<size_t>(delta) < pairs.size())  // < 1 throws
      ev.rpe.push_back(relativeErrorOverFrames(pairs.ground_truth, aligned, delta));
  std::vector<double> distances = options.rpe_distance_deltas_m;
  if (distances.empty() && ev.gt_path_length_m > 0.0)
    for (double fraction : {0.1, 0.2, 0.3, 0.4, 0.5}) distances.push_back(fraction * ev.gt_path_length_m);
  for (double delta_m : distances) {
    RelativeError r = relativeErrorOverDistance(pairs.ground_truth, aligned, delta_m);
    if (r.num_pairs > 0) ev.rpe.push_back(r);
  }
  return ev;
}

}  // namespace planetary_vo
