/// @file trajectory_metrics.cpp
/// ATE, RPE, rotation and landing-site errors, and the evaluation that also computes the navigation errors
/// (velocity, tilt, scale, NEES; navigation_metrics.cpp).

#include "planetary_vo/eval/trajectory_metrics.h"

#include <algorithm>
#include <cmath>
#include <iterator>
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
  s.max_abs = std::max(std::abs(s.min), std::abs(s.max));
  return s;
}

ErrorStatistics computeFiniteStatistics(const std::vector<double>& values) {
  std::vector<double> finite;
  finite.reserve(values.size());
  for (double v : values)
    if (std::isfinite(v)) finite.push_back(v);
  return computeStatistics(std::move(finite));
}

void validate(const EvaluationOptions& options) {
  if (!(options.max_dt_s >= 0.0)) throw EvalError("max_dt_s must be >= 0");
  if (!(options.scale_window_s > 0.0)) throw EvalError("scale_window_s must be > 0");
  if (!(options.gap_factor >= 1.0)) throw EvalError("gap_factor must be >= 1");
  if (!(std::abs(options.up_world.norm() - 1.0) < 1e-6)) throw EvalError("up_world must be a unit vector");
  const FirstPoseHandover& h = options.first_pose;
  if (!(h.scale_window_s >= 0.0)) throw EvalError("first_pose.scale_window_s must be >= 0");
  if (!(1.0 + h.scale_error > 0.0)) throw EvalError("first_pose.scale_error must be > -1");
  if (!h.position_error_m.allFinite() || !h.attitude_error_deg.allFinite())
    throw EvalError("first_pose errors must be finite");
  if (options.alignment != AlignmentMode::kFirstPose) {
    if (h.scale_window_s != 0.0 || h.scale_error != 0.0 || !h.position_error_m.isZero(0.0) ||
        !h.attitude_error_deg.isZero(0.0))
      throw EvalError("first_pose (scale window, initial errors) applies to alignment 'first' only, not '" +
                      std::string(toString(options.alignment)) + "'");
  } else if (options.align_num_pairs != 0) {
    throw EvalError("align_num_pairs does not apply to alignment 'first'");
  }
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

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The nearest sample in time to `timestamp_s` within max_dt_s (samples sorted by timestamp_s), or nullptr.
template <typename Sample>
const Sample* nearestSample(const std::vector<Sample>& samples, double timestamp_s, double max_dt_s) {
  const auto after = std::lower_bound(samples.begin(), samples.end(), timestamp_s,
                                      [](const Sample& c, double t) { return c.timestamp_s < t; });
  const Sample* best = nullptr;
  double best_dt = max_dt_s;
  if (after != samples.end() && std::abs(after->timestamp_s - timestamp_s) <= best_dt) {
    best = &*after;
    best_dt = std::abs(after->timestamp_s - timestamp_s);
  }
  if (after != samples.begin() && std::abs(std::prev(after)->timestamp_s - timestamp_s) <= best_dt)
    best = &*std::prev(after);
  return best;
}

/// One vector field of time-stamped samples (member `field`, stamps in `timestamp_s`) interpolated to
/// `stamps`.
template <typename Sample>
std::vector<Eigen::Vector3d> interpolateField(const std::vector<Sample>& samples,
                                              Eigen::Vector3d Sample::*field,
                                              const std::vector<double>& stamps, double gap_factor) {
  std::vector<double> t;
  std::vector<Eigen::Vector3d> values;
  for (const Sample& s : samples) {
    t.push_back(s.timestamp_s);
    values.push_back(s.*field);
  }
  return interpolateVectors(t, values, stamps, gap_factor);
}

/// Velocities of both sides and their errors, per associated pose.
void computeVelocityErrors(const Trajectory& ground_truth, const AssociatedTrajectories& pairs,
                           const Trajectory& aligned, const EvaluationOptions& options,
                           const EvaluationInputs& inputs, TrajectoryEvaluation* ev) {
  const size_t n = pairs.size();
  std::vector<double> est_stamps(n);
  for (size_t k = 0; k < n; ++k) est_stamps[k] = pairs.estimate[k].timestamp_s;

  std::vector<Eigen::Vector3d> v_est(n);
  if (!inputs.estimate_velocity.empty()) {
    ev->velocity_estimate_source = "estimate_velocity";
    v_est = interpolateField(inputs.estimate_velocity, &StampedVelocity::velocity_world, est_stamps,
                             options.gap_factor);
    for (Eigen::Vector3d& v : v_est) v = ev->alignment.scale * ev->alignment.R_gt_est * v;  // -> gt world
  } else {
    ev->velocity_estimate_source = "pose_differences";
    std::vector<Eigen::Vector3d> positions(n);
    for (size_t k = 0; k < n; ++k) positions[k] = aligned[k].T_world_cam.translation();
    v_est = differentiatePositions(est_stamps, positions, options.gap_factor);
  }

  std::vector<Eigen::Vector3d> v_gt(n);
  if (!inputs.ground_truth_state.empty()) {
    ev->velocity_truth_source = "groundtruth_state";
    v_gt = interpolateField(inputs.ground_truth_state, &GroundTruthState::velocity_world_mps, est_stamps,
                            options.gap_factor);
  } else {
    // All ground-truth poses, not only the associated ones: the truth stays dense where the estimate has
    // gaps.
    ev->velocity_truth_source = "pose_differences";
    std::vector<double> stamps(ground_truth.size());
    std::vector<Eigen::Vector3d> positions(ground_truth.size());
    for (size_t g = 0; g < ground_truth.size(); ++g) {
      stamps[g] = ground_truth[g].timestamp_s;
      positions[g] = ground_truth[g].T_world_cam.translation();
    }
    const std::vector<Eigen::Vector3d> all = differentiatePositions(stamps, positions, options.gap_factor);
    for (size_t k = 0; k < n; ++k) v_gt[k] = all[pairs.ground_truth_indices[k]];
  }

  for (size_t k = 0; k < n; ++k) {
    PoseError& p = ev->poses[k];
    p.velocity_gt_mps = v_gt[k];
    p.velocity_est_mps = v_est[k];
    p.velocity_error_mps = v_est[k] - v_gt[k];
    p.velocity_error_norm_mps = p.velocity_error_mps.allFinite() ? p.velocity_error_mps.norm() : kNaN;
  }

  // The velocity NEES, where the estimator gave the velocity's covariance (at the pose's stamp): the covariance
  // brought into the ground-truth world like the velocity (s R P R^T s).
  ev->has_velocity_covariance =
      std::any_of(inputs.estimate_velocity.begin(), inputs.estimate_velocity.end(),
                  [](const StampedVelocity& v) { return v.has_covariance; });
  if (!ev->has_velocity_covariance) return;
  const Eigen::Matrix3d J = ev->alignment.scale * ev->alignment.R_gt_est;
  for (size_t k = 0; k < n; ++k) {
    const StampedVelocity* s = nearestSample(inputs.estimate_velocity, est_stamps[k], options.max_dt_s);
    PoseError& p = ev->poses[k];
    if (s == nullptr || !s->has_covariance || !p.velocity_error_mps.allFinite()) continue;
    const Eigen::LLT<Eigen::Matrix3d> llt(J * s->covariance * J.transpose());
    if (llt.info() != Eigen::Success) throw EvalError("a velocity covariance is not positive definite");
    p.nees_velocity = p.velocity_error_mps.dot(llt.solve(p.velocity_error_mps));
  }
}

}  // namespace

TrajectoryEvaluation evaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const EvaluationOptions& options, const EvaluationInputs& inputs) {
  validate(options);
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
  const size_t n = pairs.size();
  ev.duration_s = pairs.ground_truth.back().timestamp_s - pairs.ground_truth.front().timestamp_s;
  ev.gt_path_length_m = cumulativePathLength(pairs.ground_truth).back();
  const std::vector<double> gt_distance_m = cumulativePathLength(ground_truth);  // all ground-truth poses
  const double distance_at_start_m = gt_distance_m[pairs.ground_truth_indices.front()];
  ev.distance_travelled_m = gt_distance_m[pairs.ground_truth_indices.back()] - distance_at_start_m;

  if (options.alignment == AlignmentMode::kFirstPose) {
    ev.alignment = alignFirstPose(pairs, options.first_pose);
    if (options.first_pose.scale_window_s > 0.0)
      ev.first_pose_window_scale = firstPoseWindowScale(pairs, options.first_pose.scale_window_s);
  } else {
    ev.alignment = alignTrajectories(pairs, options.alignment, options.align_num_pairs);
  }
  const Trajectory aligned = ev.alignment.transformTrajectory(pairs.estimate);

  ev.poses = computePoseErrors(pairs.ground_truth, aligned);
  std::vector<double> stamps(n);
  std::vector<Eigen::Vector3d> gt_positions(n), est_positions(n);
  for (size_t k = 0; k < n; ++k) {
    PoseError& p = ev.poses[k];
    stamps[k] = p.timestamp_s;
    gt_positions[k] = p.position_gt_m;
    est_positions[k] = p.position_est_m;
    p.time_since_start_s = p.timestamp_s - ev.poses.front().timestamp_s;
    p.distance_travelled_m = gt_distance_m[pairs.ground_truth_indices[k]] - distance_at_start_m;
    p.position_error_percent_of_distance =
        p.distance_travelled_m > 0.0 ? 100.0 * p.translation_error_m / p.distance_travelled_m : kNaN;
    p.tilt_error_deg = tiltErrorDeg(pairs.ground_truth[k].T_world_cam.rotation(),
                                    aligned[k].T_world_cam.rotation(), options.up_world);
  }
  computeVelocityErrors(ground_truth, pairs, aligned, options, inputs, &ev);
  const std::vector<double> scale_error =
      windowedScaleErrorPercent(stamps, gt_positions, est_positions, options.scale_window_s);
  for (size_t k = 0; k < n; ++k) ev.poses[k].scale_error_percent = scale_error[k];

  if (!inputs.estimate_covariance.empty()) {
    ev.covariance_dimension = static_cast<int>(inputs.estimate_covariance.front().covariance.rows());
    for (size_t k = 0; k < n; ++k) {
      const StampedCovariance* c =
          nearestSample(inputs.estimate_covariance, pairs.estimate[k].timestamp_s, options.max_dt_s);
      if (c == nullptr) continue;
      if (c->covariance.rows() != ev.covariance_dimension)
        throw EvalError("the estimate's covariances must all have the same size");
      const PoseNees nees = computePoseNees(pairs.ground_truth[k].T_world_cam, aligned[k].T_world_cam,
                                            transformCovariance(c->covariance, ev.alignment));
      ev.poses[k].nees_position = nees.position;
      ev.poses[k].nees_attitude = nees.attitude;
      ev.poses[k].nees_pose = nees.pose;
    }
  }

  std::vector<double> ate, rot, x, y, z, velocity, tilt, nees_position, nees_attitude, nees_pose, nees_velocity;
  for (const PoseError& e : ev.poses) {
    ate.push_back(e.translation_error_m);
    rot.push_back(e.rotation_error_deg);
    x.push_back(e.position_error_m.x());
    y.push_back(e.position_error_m.y());
    z.push_back(e.position_error_m.z());
    velocity.push_back(e.velocity_error_norm_mps);
    tilt.push_back(e.tilt_error_deg);
    nees_position.push_back(e.nees_position);
    nees_attitude.push_back(e.nees_attitude);
    nees_pose.push_back(e.nees_pose);
    nees_velocity.push_back(e.nees_velocity);
  }
  ev.ate_m = computeStatistics(ate);
  ev.ate_rmse_percent = ev.gt_path_length_m > 0.0 ? 100.0 * ev.ate_m.rmse / ev.gt_path_length_m : 0.0;
  ev.rotation_deg = computeStatistics(rot);
  ev.attitude_drift_deg = computeStatistics(attitudeDriftDeg(pairs.ground_truth, pairs.estimate));
  ev.crossrange_error_m = computeStatistics(x);
  ev.downrange_error_m = computeStatistics(y);
  ev.altitude_error_m = computeStatistics(z);
  ev.final_position_error_m = ate.back();
  ev.velocity_error_mps = computeFiniteStatistics(velocity);
  ev.tilt_error_deg = computeStatistics(tilt);
  ev.scale_error_percent = computeFiniteStatistics(scale_error);
  if (ev.covariance_dimension > 0) ev.nees_position = computeNeesStatistics(nees_position, 3);
  if (ev.covariance_dimension == 6) {
    ev.nees_attitude = computeNeesStatistics(nees_attitude, 3);
    ev.nees_pose = computeNeesStatistics(nees_pose, 6);
  }
  if (ev.has_velocity_covariance) ev.nees_velocity = computeNeesStatistics(nees_velocity, 3);

  const PoseError& last = ev.poses.back();
  FinalErrors& f = ev.final_errors;
  f.timestamp_s = last.timestamp_s;
  f.time_since_start_s = last.time_since_start_s;
  f.position_error_m = last.translation_error_m;
  f.position_error_percent_of_distance =
      ev.distance_travelled_m > 0.0 ? 100.0 * last.translation_error_m / ev.distance_travelled_m : kNaN;
  f.position_error_world_m = last.position_error_m;
  f.velocity_error_mps = last.velocity_error_norm_mps;
  f.velocity_error_world_mps = last.velocity_error_mps;
  f.attitude_error_deg = last.rotation_error_deg;
  f.tilt_error_deg = last.tilt_error_deg;
  f.scale_error_percent = last.scale_error_percent;

  for (int delta : options.rpe_frame_deltas)
    if (delta < 1 || static_cast<size_t>(delta) < pairs.size())  // < 1 throws
      ev.rpe.push_back(relativeErrorOverFrames(pairs.ground_truth, aligned, delta));
  std::vector<double> distances = options.rpe_distance_deltas_m;
  const bool default_distances = distances.empty();
  if (default_distances && ev.gt_path_length_m > 0.0)
    for (double fraction : {0.1, 0.2, 0.3, 0.4, 0.5}) distances.push_back(fraction * ev.gt_path_length_m);
  for (double delta_m : distances) {
    RelativeError r = relativeErrorOverDistance(pairs.ground_truth, aligned, delta_m);
    if (default_distances) r.path_fraction = delta_m / ev.gt_path_length_m;
    if (r.num_pairs > 0) ev.rpe.push_back(r);
  }
  return ev;
}

}  // namespace planetary_vo
