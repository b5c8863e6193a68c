/// Velocity, tilt, windowed scale error and NEES, with answers known by construction.

#include <cmath>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "eval_test_util.h"
#include "planetary_vo/eval/evaluation_report.h"
#include "planetary_vo/eval/navigation_metrics.h"
#include "planetary_vo/eval/trajectory_metrics.h"

namespace planetary_vo {
namespace {

EvaluationOptions unaligned() {
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  return options;
}

/// n poses at `rate_hz` from t = 0 with position f(t) and identity attitude.
template <typename F>
Trajectory sampled(int n, double rate_hz, F position) {
  Trajectory trajectory;
  for (int k = 0; k < n; ++k) {
    const double t = k / rate_hz;
    trajectory.push_back({t, test::makePose(Eigen::Matrix3d::Identity(), position(t))});
  }
  return trajectory;
}

// ---------------------------------------------------------------------------------------------------------------
// Velocity
// ---------------------------------------------------------------------------------------------------------------

TEST(VelocityError, ConstantVelocityWithAKnownBias) {
  const Eigen::Vector3d v_mps(2.0, 10.0, -3.0), bias_mps(0.3, 0.0, -0.2);
  const Trajectory gt = sampled(101, 10.0, [&](double t) { return Eigen::Vector3d(v_mps * t); });
  const Trajectory est =
      sampled(101, 10.0, [&](double t) { return Eigen::Vector3d((v_mps + bias_mps) * t); });
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, unaligned());
  EXPECT_EQ(ev.velocity_truth_source, "pose_differences");
  EXPECT_EQ(ev.velocity_estimate_source, "pose_differences");
  EXPECT_EQ(ev.velocity_error_mps.count, 101u);
  EXPECT_NEAR(ev.velocity_error_mps.rmse, bias_mps.norm(), 1e-9);
  EXPECT_NEAR(ev.velocity_error_mps.min, bias_mps.norm(), 1e-9);
  EXPECT_NEAR(ev.velocity_error_mps.max, bias_mps.norm(), 1e-9);
  EXPECT_NEAR(ev.final_errors.velocity_error_mps, bias_mps.norm(), 1e-9);
  EXPECT_LT((ev.poses[50].velocity_gt_mps - v_mps).norm(), 1e-9);

  // The same bias through a velocity file (20 Hz, interpolated at the estimate stamps), with the poses exact.
  EvaluationInputs inputs;
  for (int k = 0; k <= 200; ++k) inputs.estimate_velocity.push_back({0.05 * k, v_mps + bias_mps});
  const TrajectoryEvaluation with_file = evaluateTrajectory(gt, gt, unaligned(), inputs);
  EXPECT_EQ(with_file.velocity_estimate_source, "estimate_velocity");
  EXPECT_NEAR(with_file.velocity_error_mps.min, bias_mps.norm(), 1e-9);
  EXPECT_NEAR(with_file.velocity_error_mps.max, bias_mps.norm(), 1e-9);
  EXPECT_LT(with_file.ate_m.max, 1e-12);
}

/// The descent seen by a monocular-like estimate in another world (scale 1/20, rotated, shifted) that reports its
/// velocity in that world; the truth from a 200 Hz state file (exact velocities); the first-pose alignment with
/// the scale of the first 2 s, which brings the estimate back.
struct OtherWorldDescent {
  Trajectory gt = test::descentGroundTruth();
  double scale = 20.0;
  Eigen::Matrix3d R = test::rotationDeg(40.0, Eigen::Vector3d(1.0, 2.0, -0.5));
  Trajectory est = test::inOtherWorld(gt, scale, R, Eigen::Vector3d(10.0, 20.0, 30.0));
  EvaluationInputs inputs;  ///< ground_truth_state filled
  EvaluationOptions options;

  OtherWorldDescent() {
    for (int k = 0; k <= 2380; ++k) {  // 200 Hz over the 11.9 s
      GroundTruthState s;
      s.timestamp_s = gt.front().timestamp_s + 0.005 * k;
      s.velocity_world_mps = test::descentVelocity(0.005 * k);
      inputs.ground_truth_state.push_back(s);
    }
    options.alignment = AlignmentMode::kFirstPose;
    options.first_pose.scale_window_s = 2.0;
  }
  /// The true velocity at pose k plus `error` (ground-truth world), as the estimate reports it in its world.
  StampedVelocity reported(size_t k, const Eigen::Vector3d& error = Eigen::Vector3d::Zero()) const {
    const double t = gt[k].timestamp_s;
    return {t, R.transpose() * (test::descentVelocity(t - gt.front().timestamp_s) + error) / scale};
  }
};

TEST(VelocityError, FileVelocityIsRotatedAndScaledByTheAlignment) {
  // Truth from a state file: exact velocities, so the error is zero to round-off.
  OtherWorldDescent d;
  const Trajectory& gt = d.gt;
  const Trajectory& est = d.est;
  EvaluationInputs& inputs = d.inputs;
  for (size_t k = 0; k < gt.size(); ++k) inputs.estimate_velocity.push_back(d.reported(k));
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, d.options, inputs);
  EXPECT_EQ(ev.velocity_truth_source, "groundtruth_state");
  EXPECT_EQ(ev.velocity_error_mps.count, gt.size());
  // Linear interpolation of the 200 Hz truth where the stamps do not fall on a sample exactly (they do up to
  // round-off here): error bound |a'| dt^2 / 8 ~ 1e-7 m/s; round-off of the scale (20) ~1e-12.
  EXPECT_LT(ev.velocity_error_mps.max, 1e-6);
  // Without the alignment's rotation and scale the file velocity would be wrong by ~100 m/s.
  EvaluationOptions none = unaligned();
  EXPECT_GT(evaluateTrajectory(gt, est, none, inputs).velocity_error_mps.min, 10.0);
}

TEST(VelocityError, NoDifferenceAcrossAGapAndIsolatedPosesHaveNone) {
  // 10 Hz truth whose velocity turns at t = 5.5 s from (0, 10, 0) to (5, 10, 0) m/s.
  const auto position = [](double t) {
    return t <= 5.5 ? Eigen::Vector3d(0.0, 10.0 * t, 0.0) : Eigen::Vector3d(5.0 * (t - 5.5), 10.0 * t, 0.0);
  };
  const Trajectory gt = sampled(101, 10.0, position);
  // The estimate (exact) lost frames 51..59 (a 1 s gap over the turn) and 77..79, 81..83 (pose 80 alone).
  Trajectory est;
  for (int k = 0; k <= 100; ++k)
    if (!(k >= 51 && k <= 59) && !(k >= 77 && k <= 79) && !(k >= 81 && k <= 83)) est.push_back(gt[k]);
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, unaligned());
  ASSERT_EQ(ev.num_associated, est.size());
  // Every pose but the isolated one has a velocity, one-sided beside the gaps, exact for this motion.
  EXPECT_EQ(ev.velocity_error_mps.count, est.size() - 1);
  EXPECT_LT(ev.velocity_error_mps.max, 1e-9);
  const auto at = [&](double t) -> const PoseError& {
    for (const PoseError& p : ev.poses)
      if (std::abs(p.timestamp_s - t) < 1e-9) return p;
    ADD_FAILURE() << "no pose at " << t;
    return ev.poses.front();
  };
  EXPECT_TRUE(std::isnan(at(8.0).velocity_error_norm_mps));
  EXPECT_FALSE(at(8.0).velocity_est_mps.allFinite());
  EXPECT_LT((at(5.0).velocity_est_mps - Eigen::Vector3d(0, 10, 0)).norm(), 1e-9);
  EXPECT_LT((at(6.0).velocity_est_mps - Eigen::Vector3d(5, 10, 0)).norm(), 1e-9);
  // Differentiated across the gap (gap handling off), the pose at 5.0 s gets the parabola through 4.9, 5.0
  // and 6.0 s: x velocity 2.5 m x 0.1 s / (1.1 s x 1.0 s) = 0.2273 m/s.
  EvaluationOptions no_gaps = unaligned();
  no_gaps.gap_factor = 1e6;
  const TrajectoryEvaluation across = evaluateTrajectory(gt, est, no_gaps);
  EXPECT_NEAR(across.velocity_error_mps.max, 2.5 * 0.1 / 1.1, 1e-9);
  EXPECT_EQ(across.velocity_error_mps.count, est.size());
}

TEST(VelocityError, TruthFromTheStateFileVersusDifferencesOfTheTruth) {
  // x = A sin(w t): the central difference at spacing h gives A w cos(w t) sin(w h) / (w h), off by
  // A w cos(w t) (1 - sinc(w h)) from the true velocity (0.033 m/s at most for A = 20 m, w = 1 rad/s, h = 0.1
  // s).
  const double A = 20.0, w = 1.0, h = 0.1;
  const Trajectory gt =
      sampled(101, 1.0 / h, [&](double t) { return Eigen::Vector3d(A * std::sin(w * t), 10.0 * t, 0.0); });
  const auto velocity = [&](double t) { return Eigen::Vector3d(A * w * std::cos(w * t), 10.0, 0.0); };
  EvaluationInputs inputs;  // the estimate reports the exact velocity
  for (const StampedPose& p : gt)
    inputs.estimate_velocity.push_back({p.timestamp_s, velocity(p.timestamp_s)});

  const TrajectoryEvaluation from_differences = evaluateTrajectory(gt, gt, unaligned(), inputs);
  EXPECT_EQ(from_differences.velocity_truth_source, "pose_differences");
  for (size_t k = 1; k + 1 < gt.size(); ++k) {
    const double t = gt[k].timestamp_s;
    const double expected = std::abs(A * w * std::cos(w * t) * (1.0 - std::sin(w * h) / (w * h)));
    EXPECT_NEAR(from_differences.poses[k].velocity_error_norm_mps, expected, 1e-9) << t;
  }
  EXPECT_GT(from_differences.velocity_error_mps.max, 0.03);

  // With the true velocity at 200 Hz, interpolated at stamps 2.5 ms off the samples (mid-way): error
  // A w cos(w t) (1 - cos(w dt / 2)) < A w^3 dt^2 / 8 = 6.25e-5 m/s for dt = 5 ms (bound plus round-off
  // margin).
  for (int k = 0; k <= 2000; ++k) {
    GroundTruthState s;
    s.timestamp_s = 0.005 * k;
    s.velocity_world_mps = velocity(s.timestamp_s);
    inputs.ground_truth_state.push_back(s);
  }
  Trajectory shifted = gt;
  for (StampedPose& p : shifted) p.timestamp_s += 0.0025;
  inputs.estimate_velocity.clear();
  for (const StampedPose& p : shifted)
    inputs.estimate_velocity.push_back({p.timestamp_s, velocity(p.timestamp_s)});
  const TrajectoryEvaluation from_state = evaluateTrajectory(gt, shifted, unaligned(), inputs);
  EXPECT_EQ(from_state.velocity_truth_source, "groundtruth_state");
  EXPECT_EQ(from_state.velocity_error_mps.count, gt.size() - 1);  // the last stamp is beyond the state file
  EXPECT_LT(from_state.velocity_error_mps.max, 6.26e-5);
  EXPECT_GT(from_state.velocity_error_mps.max, 1e-6);  // interpolated, not exact
}

TEST(Differentiation, ExactForParabolasOnUnevenStampsAndMedianPeriod) {
  const std::vector<double> t = {0.0, 0.1, 0.25, 0.3, 0.42, 0.5};
  std::vector<Eigen::Vector3d> p;
  for (double s : t) p.push_back(Eigen::Vector3d(1.0 + 2.0 * s - 3.0 * s * s, 0.5 * s * s, -s));
  const std::vector<Eigen::Vector3d> v = differentiatePositions(t, p, 3.0);
  for (size_t k = 0; k < t.size(); ++k)
    EXPECT_LT((v[k] - Eigen::Vector3d(2.0 - 6.0 * t[k], t[k], -1.0)).norm(), 1e-9) << k;
  EXPECT_NEAR(medianPeriod(t), 0.1, 1e-12);  // differences 0.1 0.15 0.05 0.12 0.08
  EXPECT_NEAR(medianPeriod({0.0, 1.0, 3.0, 4.0}), 1.0, 1e-12);
  EXPECT_NEAR(medianPeriod({0.0, 1.0, 3.0, 6.0, 7.0}), 1.5, 1e-12);
  // Two samples: the two-point difference; one sample: none.
  const std::vector<Eigen::Vector3d> two =
      differentiatePositions({0.0, 0.5}, {Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 2, 3)}, 3.0);
  EXPECT_LT((two[0] - Eigen::Vector3d(2, 4, 6)).norm(), 1e-12);
  EXPECT_FALSE(differentiatePositions({0.0}, {Eigen::Vector3d::Zero()}, 3.0)[0].allFinite());
  // Interpolation: inside, on a sample, outside, across a gap.
  const std::vector<double> s = {0.0, 1.0, 2.0, 10.0};
  const std::vector<Eigen::Vector3d> x = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones(),
                                          2 * Eigen::Vector3d::Ones(), 10 * Eigen::Vector3d::Ones()};
  EXPECT_LT((interpolateVector(s, x, 1.25, 3.0) - 1.25 * Eigen::Vector3d::Ones()).norm(), 1e-12);
  EXPECT_LT((interpolateVector(s, x, 10.0, 3.0) - 10 * Eigen::Vector3d::Ones()).norm(), 1e-12);
  EXPECT_FALSE(interpolateVector(s, x, 10.5, 3.0).allFinite());
  EXPECT_FALSE(interpolateVector(s, x, 5.0, 3.0).allFinite());
  EXPECT_TRUE(interpolateVector(s, x, 5.0, 10.0).allFinite());
}

// ---------------------------------------------------------------------------------------------------------------
// Tilt
// ---------------------------------------------------------------------------------------------------------------

TEST(TiltError, ZeroAboutTheUpAxisAndTheAngleAboutAHorizontalAxis) {
  const Trajectory gt = test::descentGroundTruth();
  const auto rotated = [&](const Eigen::Matrix3d& R_world) {
    Trajectory est = gt;
    for (StampedPose& p : est) p.T_world_cam.linear() = R_world * p.T_world_cam.rotation();
    return est;
  };
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  const TrajectoryEvaluation yaw = evaluateTrajectory(gt, rotated(test::rotationDeg(2.0, z)), unaligned());
  EXPECT_NEAR(yaw.rotation_deg.max, 2.0, 1e-9);
  EXPECT_LT(yaw.tilt_error_deg.max, 1e-9);
  const TrajectoryEvaluation pitch =
      evaluateTrajectory(gt, rotated(test::rotationDeg(2.0, x + y)), unaligned());
  EXPECT_NEAR(pitch.tilt_error_deg.min, 2.0, 1e-9);
  EXPECT_NEAR(pitch.tilt_error_deg.max, 2.0, 1e-9);
  EXPECT_NEAR(pitch.final_errors.tilt_error_deg, 2.0, 1e-9);
  // A body-frame error about the body's own up direction (R_gt^T z) does not tilt either.
  Trajectory body_yaw = gt;
  for (StampedPose& p : body_yaw)
    p.T_world_cam.linear() =
        p.T_world_cam.rotation() * test::rotationDeg(3.0, p.T_world_cam.rotation().transpose() * z);
  EXPECT_LT(evaluateTrajectory(gt, body_yaw, unaligned()).tilt_error_deg.max, 1e-9);
  // A KITTI-like world (up = -y): a rotation about y is a heading error, about z a tilt.
  EvaluationOptions kitti = unaligned();
  kitti.up_world = -y;
  EXPECT_LT(evaluateTrajectory(gt, rotated(test::rotationDeg(2.0, y)), kitti).tilt_error_deg.max, 1e-9);
  EXPECT_NEAR(evaluateTrajectory(gt, rotated(test::rotationDeg(2.0, z)), kitti).tilt_error_deg.max, 2.0,
              1e-9);
  EXPECT_NEAR(tiltErrorDeg(Eigen::Matrix3d::Identity(), test::rotationDeg(5.0, x), z), 5.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------------------------
// Scale error
// ---------------------------------------------------------------------------------------------------------------

TEST(ScaleError, LinearlyGrowingScaleGivesTheAnalyticWindowedError) {
  // Along a straight line at 10 m/s the estimate's scale grows as 1 + c t: s_est(t) = 10 (t + c t^2 / 2).
  // Over the trailing window [t - S, t] the path ratio is 1 + c (t - S / 2), exactly (a straight line).
  const double c = 0.002, S = 2.0;
  const Trajectory gt = sampled(201, 10.0, [](double t) { return Eigen::Vector3d(0.0, 10.0 * t, 0.0); });
  const Trajectory est =
      sampled(201, 10.0, [&](double t) { return Eigen::Vector3d(0.0, 10.0 * (t + 0.5 * c * t * t), 0.0); });
  EvaluationOptions options = unaligned();
  options.scale_window_s = S;
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
  for (const PoseError& p : ev.poses) {
    if (p.time_since_start_s < S - 1e-9) {
      EXPECT_TRUE(std::isnan(p.scale_error_percent)) << p.time_since_start_s;  // window not full yet
    } else {
      EXPECT_NEAR(p.scale_error_percent, 100.0 * c * (p.time_since_start_s - 0.5 * S), 1e-9)
          << p.time_since_start_s;
    }
  }
  EXPECT_EQ(ev.scale_error_percent.count, 201u - 20u);
  EXPECT_NEAR(ev.final_errors.scale_error_percent, 100.0 * c * (20.0 - 1.0), 1e-9);
  EXPECT_NEAR(ev.scale_error_percent.max_abs, 100.0 * c * 19.0, 1e-9);
  // With sim3 the global scale is factored out: the error changes sign over the run (drift about the mean).
  EvaluationOptions sim3 = options;
  sim3.alignment = AlignmentMode::kSim3;
  Trajectory curved_gt = test::descentGroundTruth(200), curved_est = curved_gt;
  const Eigen::Vector3d p0 = curved_gt.front().T_world_cam.translation();
  for (StampedPose& p : curved_est) {
    const double t = p.timestamp_s - curved_gt.front().timestamp_s;
    p.T_world_cam.translation() = p0 + (1.0 + c * t) * (p.T_world_cam.translation() - p0);
  }
  const TrajectoryEvaluation drift = evaluateTrajectory(curved_gt, curved_est, sim3);
  EXPECT_LT(drift.scale_error_percent.min, 0.0);
  EXPECT_GT(drift.scale_error_percent.max, 0.0);
}

// ---------------------------------------------------------------------------------------------------------------
// NEES
// ---------------------------------------------------------------------------------------------------------------

TEST(ChiSquare, QuantilesMatchTables) {
  // Reference values: chi-square tables (e.g. NIST/SEMATECH e-Handbook 1.3.6.7.4), to the digits printed
  // there.
  EXPECT_NEAR(chiSquareQuantile(0.975, 3), 9.348, 5e-4);
  EXPECT_NEAR(chiSquareQuantile(0.025, 3), 0.216, 5e-4);
  EXPECT_NEAR(chiSquareQuantile(0.975, 6), 14.449, 5e-4);
  EXPECT_NEAR(chiSquareQuantile(0.025, 6), 1.237, 5e-4);
  EXPECT_NEAR(chiSquareQuantile(0.95, 1), 3.841, 5e-4);
  EXPECT_NEAR(chiSquareQuantile(0.99, 100), 135.807, 5e-3);
  // Closed form for 2 dof: x = -2 ln(1 - p).
  EXPECT_NEAR(chiSquareQuantile(0.3, 2), -2.0 * std::log(0.7), 1e-10);
  EXPECT_NEAR(chiSquareQuantile(0.975, 2), -2.0 * std::log(0.025), 1e-10);
  // Large dof (the bound of a mean over 2000 poses x 3 dof): Wilson-Hilferty is accurate to ~1e-5 relative.
  const double k = 6000.0, z = 1.959963984540054;
  const double wilson_hilferty = k * std::pow(1.0 - 2.0 / (9.0 * k) + z * std::sqrt(2.0 / (9.0 * k)), 3.0);
  EXPECT_NEAR(chiSquareQuantile(0.975, k), wilson_hilferty, 1e-4 * k);
}

/// Poses along the descent whose errors are drawn from random covariances (fixed seed); the estimate reports
/// covariance_factor x the true covariance.
struct NoisyEstimate {
  Trajectory ground_truth, estimate;
  EvaluationInputs inputs;
};
NoisyEstimate drawFromCovariance(int n, double covariance_factor, bool full, uint64_t seed) {
  NoisyEstimate r;
  r.ground_truth = test::descentGroundTruth(n);
  r.estimate = r.ground_truth;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.5, 2.0);
  for (int k = 0; k < n; ++k) {
    // A random correlated covariance: position ~0.5..2 m, attitude ~0.1..0.5 deg per axis.
    Eigen::Matrix<double, 6, 6> A;
    for (int i = 0; i < 36; ++i) A(i) = normal(rng);
    Eigen::Matrix<double, 6, 1> sigma;
    for (int i = 0; i < 3; ++i) sigma(i) = uniform(rng);
    for (int i = 3; i < 6; ++i) sigma(i) = 0.25 * uniform(rng) * M_PI / 180.0;
    Eigen::Matrix<double, 6, 6> P =
        sigma.asDiagonal() * (A * A.transpose() / 6.0 + 0.2 * Eigen::Matrix<double, 6, 6>::Identity()) *
        sigma.asDiagonal();
    if (!full) {
      P.block<3, 3>(0, 3).setZero();
      P.block<3, 3>(3, 0).setZero();
    }
    Eigen::Matrix<double, 6, 1> z;
    for (int i = 0; i < 6; ++i) z(i) = normal(rng);
    const Eigen::Matrix<double, 6, 1> e = Eigen::LLT<Eigen::Matrix<double, 6, 6>>(P).matrixL() * z;
    // e = [p_gt - p_est; delta] with R_gt = Exp(delta) R_est.
    Pose& T = r.estimate[k].T_world_cam;
    T.translation() -= e.head<3>();
    T.linear() =
        Eigen::AngleAxisd(-e.tail<3>().norm(), e.tail<3>().normalized()).toRotationMatrix() * T.rotation();
    const Eigen::MatrixXd reported =
        covariance_factor * (full ? Eigen::MatrixXd(P) : Eigen::MatrixXd(P.topLeftCorner<3, 3>()));
    r.inputs.estimate_covariance.push_back({r.estimate[k].timestamp_s, reported});
  }
  return r;
}

TEST(Nees, ConsistentCovarianceIsWithinTheBounds) {
  const int n = 500;
  const NoisyEstimate d = drawFromCovariance(n, 1.0, true, 42);
  const TrajectoryEvaluation ev = evaluateTrajectory(d.ground_truth, d.estimate, unaligned(), d.inputs);
  ASSERT_EQ(ev.covariance_dimension, 6);
  for (const NeesStatistics* s : {&ev.nees_position, &ev.nees_attitude, &ev.nees_pose}) {
    std::cout << s->dof << " dof: mean NEES " << s->mean << " in [" << s->mean_lower_95 << ", "
              << s->mean_upper_95 << "], " << 100.0 * s->fraction_inside_95 << " % of the poses inside\n";
    EXPECT_EQ(s->count, static_cast<size_t>(n));
    // A consistent estimator's mean NEES is inside its 95 % bounds (dof +- ~0.2 for 3 dof, 500 poses). With
    // this fixed seed it is; a covariance 20 % off would already leave them (3 x 1.2 = 3.6 > 3.22).
    EXPECT_GT(s->mean, s->mean_lower_95) << s->dof;
    EXPECT_LT(s->mean, s->mean_upper_95) << s->dof;
    EXPECT_STREQ(s->verdict(), "consistent");
    // 95 % of the poses inside the per-pose bounds, +- 3 sigma of a binomial share: sqrt(0.95 0.05 / 500) =
    // 0.0097.
    EXPECT_NEAR(s->fraction_inside_95, 0.95, 3 * 0.0097) << s->dof;
  }
  // Bounds of the mean: chi-square(n dof) / n, close to the normal approximation dof +- 1.96 sqrt(2 dof / n)
  // (the chi-square skew moves both by ~0.004 here).
  EXPECT_NEAR(ev.nees_position.mean_upper_95, 3.0 + 1.96 * std::sqrt(2.0 * 3.0 / n), 0.01);
  EXPECT_NEAR(ev.nees_position.mean_lower_95, 3.0 - 1.96 * std::sqrt(2.0 * 3.0 / n), 0.01);
  EXPECT_NEAR(ev.nees_pose.mean_lower_95, 6.0 - 1.96 * std::sqrt(2.0 * 6.0 / n), 0.01);
  EXPECT_NEAR(ev.nees_pose.pose_upper_95, 14.449, 1e-3);

  // Position-only covariances (9 values): only the position NEES.
  const NoisyEstimate p = drawFromCovariance(n, 1.0, false, 43);
  const TrajectoryEvaluation ev3 = evaluateTrajectory(p.ground_truth, p.estimate, unaligned(), p.inputs);
  EXPECT_EQ(ev3.covariance_dimension, 3);
  EXPECT_STREQ(ev3.nees_position.verdict(), "consistent");
  EXPECT_EQ(ev3.nees_attitude.count, 0u);
  EXPECT_TRUE(std::isnan(ev3.poses[0].nees_attitude));
  // Without a covariance there is no NEES at all.
  EXPECT_EQ(evaluateTrajectory(p.ground_truth, p.estimate, unaligned()).covariance_dimension, 0);
}

TEST(Nees, CovarianceFourTimesTooSmallIsOptimistic) {
  const int n = 500;
  const NoisyEstimate d = drawFromCovariance(n, 0.25, true, 42);
  const TrajectoryEvaluation ev = evaluateTrajectory(d.ground_truth, d.estimate, unaligned(), d.inputs);
  // NEES ~ 4 dof: mean 12 (3 dof) and 24 (6 dof); the standard deviation of the mean is 4 sqrt(2 dof / n) =
  // 0.44 and 0.62; 3 sigma.
  EXPECT_NEAR(ev.nees_position.mean, 12.0, 3 * 0.44);
  EXPECT_NEAR(ev.nees_attitude.mean, 12.0, 3 * 0.44);
  EXPECT_NEAR(ev.nees_pose.mean, 24.0, 3 * 0.62);
  for (const NeesStatistics* s : {&ev.nees_position, &ev.nees_attitude, &ev.nees_pose}) {
    std::cout << s->dof << " dof, covariance / 4: mean NEES " << s->mean << ", upper bound "
              << s->mean_upper_95 << ", " << 100.0 * s->fraction_inside_95 << " % inside\n";
    EXPECT_GT(s->mean, s->mean_upper_95);
    EXPECT_STREQ(s->verdict(), "optimistic");
    EXPECT_LT(s->fraction_inside_95, 0.8);
  }
}

TEST(Nees, CovarianceIsRotatedAndScaledByTheAlignment) {
  // The same consistent errors, but the estimate (and its covariance) expressed in another world at another
  // scale: after the sim3 alignment the NEES must be as consistent as before.
  const int n = 500;
  const NoisyEstimate d = drawFromCovariance(n, 1.0, true, 7);
  const double scale = 0.05;  // estimate units per metre
  const Eigen::Matrix3d R = test::rotationDeg(60.0, Eigen::Vector3d(1.0, -1.0, 2.0));
  const Eigen::Vector3d t(100.0, 50.0, -20.0);
  const Trajectory est = test::inOtherWorld(d.estimate, 1.0 / scale, R, t);
  EvaluationInputs inputs = d.inputs;
  Eigen::MatrixXd J_inv = Eigen::MatrixXd::Zero(6, 6);  // ground-truth world -> estimate world
  J_inv.topLeftCorner<3, 3>() = scale * R.transpose();
  J_inv.bottomRightCorner<3, 3>() = R.transpose();
  for (StampedCovariance& c : inputs.estimate_covariance)
    c.covariance = J_inv * c.covariance * J_inv.transpose();
  EvaluationOptions options;
  options.alignment = AlignmentMode::kSim3;
  const TrajectoryEvaluation ev = evaluateTrajectory(d.ground_truth, est, options, inputs);
  EXPECT_NEAR(ev.alignment.scale, 1.0 / scale, 1e-3 / scale);
  // Against the same errors evaluated in the ground-truth world without alignment: the fitted sim3 removes 7
  // of the 1500 position degrees of freedom and rotates by ~1e-4 rad, so the means agree to a few per cent.
  const TrajectoryEvaluation direct = evaluateTrajectory(d.ground_truth, d.estimate, unaligned(), d.inputs);
  const NeesStatistics* aligned_stats[] = {&ev.nees_position, &ev.nees_attitude, &ev.nees_pose};
  const NeesStatistics* direct_stats[] = {&direct.nees_position, &direct.nees_attitude, &direct.nees_pose};
  for (int i = 0; i < 3; ++i) {
    const NeesStatistics& s = *aligned_stats[i];
    std::cout << s.dof << " dof after sim3: mean NEES " << s.mean << " in [" << s.mean_lower_95 << ", "
              << s.mean_upper_95 << "], without the world change " << direct_stats[i]->mean << "\n";
    EXPECT_STREQ(s.verdict(), "consistent") << s.dof << " dof: mean " << s.mean;
    EXPECT_NEAR(s.mean, direct_stats[i]->mean, 0.03 * s.dof);
  }
}

TEST(Nees, VelocityNeesFromTheReportedCovarianceInTheEstimatesWorld) {
  // The descent's true velocity reported by a monocular-like estimate in another world (scale 1/20, rotated),
  // with known errors and covariances given in that world: errors of (1, 0, 0) m/s with a covariance of
  // diag(0.25, 1, 1) (m/s)^2 and (0, 2, 0) m/s with diag(1, 1, 1) alternate, so the NEES are 4 and 4 after the
  // alignment brings both into the ground-truth world; the velocity's rotation and scale must be applied to
  // the covariance as well.
  OtherWorldDescent d;
  const Trajectory& gt = d.gt;
  const Trajectory& est = d.est;
  EvaluationInputs& inputs = d.inputs;
  const EvaluationOptions& options = d.options;
  for (size_t k = 0; k < gt.size(); ++k) {
    const bool even = k % 2 == 0;
    const Eigen::Vector3d error = even ? Eigen::Vector3d(1.0, 0.0, 0.0) : Eigen::Vector3d(0.0, 2.0, 0.0);
    const Eigen::Matrix3d C = even ? Eigen::Vector3d(0.25, 1.0, 1.0).asDiagonal().toDenseMatrix()
                                   : Eigen::Matrix3d::Identity();
    StampedVelocity v = d.reported(k, error);
    v.has_covariance = true;
    v.covariance = d.R.transpose() * C * d.R / (d.scale * d.scale);
    inputs.estimate_velocity.push_back(v);
  }
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options, inputs);
  ASSERT_TRUE(ev.has_velocity_covariance);
  EXPECT_EQ(ev.covariance_dimension, 0);  // no pose covariance given
  EXPECT_EQ(ev.nees_velocity.count, gt.size());
  EXPECT_NEAR(ev.nees_velocity.mean, 4.0, 1e-4);
  EXPECT_NEAR(ev.nees_velocity.max, 4.0, 1e-4);
  EXPECT_STREQ(ev.nees_velocity.verdict(), "optimistic");  // 4 against 3 over 120 poses
  // Covariances 4/3 as large: consistent on average (mean 3).
  for (StampedVelocity& v : inputs.estimate_velocity) v.covariance *= 4.0 / 3.0;
  const TrajectoryEvaluation scaled = evaluateTrajectory(gt, est, options, inputs);
  EXPECT_NEAR(scaled.nees_velocity.mean, 3.0, 1e-4);
  // The report and the JSON carry it; without covariances there is none.
  EXPECT_NE(formatReport(scaled).find("  velocity mean 3.000"), std::string::npos) << formatReport(scaled);
  EXPECT_NE(toJson(scaled, false).find("\"velocity\""), std::string::npos);
  for (StampedVelocity& v : inputs.estimate_velocity) v.has_covariance = false;
  const TrajectoryEvaluation without = evaluateTrajectory(gt, est, options, inputs);
  EXPECT_FALSE(without.has_velocity_covariance);
  EXPECT_EQ(toJson(without, false).find("\"nees\""), std::string::npos);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
