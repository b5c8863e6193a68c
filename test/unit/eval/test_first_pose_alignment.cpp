/// Alignment on the first pose (a navigation handed its initial state): errors known by construction.

#include <gtest/gtest.h>

#include "eval_test_util.h"
#include "planetary_vo/eval/trajectory_metrics.h"

namespace planetary_vo {
namespace {

// Round-off bound for positions of ~1500 m after a similarity with scale ~27 (double precision ~1e-16
// relative: ~1e-10 m); 1e-6 m leaves margin and is still far below any error a broken alignment produces
// (metres).
constexpr double kZeroPosition_m = 1e-6;
constexpr double kZeroAngle_deg = 1e-6;

/// A world change with a large rotation, offset and scale, as a monocular VO would report its trajectory.
const double kScale = 1.0 / 0.037;
Eigen::Matrix3d worldRotation() { return test::rotationDeg(70.0, Eigen::Vector3d(0.3, -1.0, 0.4)); }
const Eigen::Vector3d kWorldOffset(120.0, -45.0, 1600.0);

EvaluationOptions firstPoseOptions(double scale_window_s) {
  EvaluationOptions options;
  options.alignment = AlignmentMode::kFirstPose;
  options.first_pose.scale_window_s = scale_window_s;
  return options;
}

TEST(FirstPoseAlignment, AnyRigidTransformAndScaleWithAScaleWindowGivesZeroErrors) {
  const Trajectory gt = test::descentGroundTruth();
  const Trajectory est = test::inOtherWorld(gt, kScale, worldRotation(), kWorldOffset);
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, firstPoseOptions(2.0));
  EXPECT_EQ(ev.num_associated, gt.size());
  EXPECT_NEAR(ev.alignment.scale, kScale, 1e-9 * kScale);
  EXPECT_NEAR(ev.first_pose_window_scale, kScale, 1e-9 * kScale);
  EXPECT_LT((ev.alignment.R_gt_est - worldRotation()).norm(), 1e-12);
  EXPECT_LT(ev.ate_m.max, kZeroPosition_m);
  EXPECT_LT(ev.rotation_deg.max, kZeroAngle_deg);
  EXPECT_LT(ev.tilt_error_deg.max, kZeroAngle_deg);
  EXPECT_EQ(ev.velocity_error_mps.count, gt.size());
  EXPECT_LT(ev.velocity_error_mps.max, 1e-5);  // differences of positions ~1e-10 m apart over 0.1 s
  EXPECT_GT(ev.scale_error_percent.count, 0u);
  EXPECT_LT(ev.scale_error_percent.max_abs, 1e-7);
  EXPECT_LT(ev.final_errors.position_error_m, kZeroPosition_m);
  EXPECT_LT(ev.final_errors.velocity_error_mps, 1e-5);

  // Without the scale window the estimate keeps its own units: kilometres of error.
  const TrajectoryEvaluation unscaled = evaluateTrajectory(gt, est, firstPoseOptions(0.0));
  EXPECT_DOUBLE_EQ(unscaled.alignment.scale, 1.0);
  EXPECT_GT(unscaled.final_errors.position_error_m, 500.0);
  EXPECT_LT(unscaled.rotation_deg.max, kZeroAngle_deg);  // the attitude is handed over all the same
  EXPECT_NEAR(unscaled.final_errors.scale_error_percent, 100.0 * (1.0 / kScale - 1.0), 1e-6);

  // A metric estimate in another world (rigid transform, scale 1) needs no window.
  const Trajectory rigid = test::inOtherWorld(gt, 1.0, worldRotation(), kWorldOffset);
  EXPECT_LT(evaluateTrajectory(gt, rigid, firstPoseOptions(0.0)).ate_m.max, kZeroPosition_m);
}

TEST(FirstPoseAlignment, LinearDriftGivesTheAnalyticFinalError) {
  const Trajectory gt = test::descentGroundTruth();
  // The estimate drifts by b metres per second from the first pose on, then lives in another world.
  const Eigen::Vector3d b_mps(0.02, -0.05, 0.01);
  Trajectory drifting = gt;
  for (StampedPose& p : drifting)
    p.T_world_cam.translation() += b_mps * (p.timestamp_s - gt.front().timestamp_s);
  const Trajectory est = test::inOtherWorld(drifting, 1.0, worldRotation(), kWorldOffset);
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, firstPoseOptions(0.0));
  const double duration_s = gt.back().timestamp_s - gt.front().timestamp_s;  // 11.9 s
  EXPECT_NEAR(ev.final_errors.position_error_m, b_mps.norm() * duration_s, 1e-6);
  EXPECT_NEAR(ev.final_position_error_m, b_mps.norm() * duration_s, 1e-6);
  EXPECT_LT((ev.final_errors.position_error_world_m - b_mps * duration_s).norm(), 1e-6);
  double distance_m = 0.0;
  for (size_t k = 1; k < gt.size(); ++k)
    distance_m += (gt[k].T_world_cam.translation() - gt[k - 1].T_world_cam.translation()).norm();
  EXPECT_NEAR(ev.distance_travelled_m, distance_m, 1e-9);
  EXPECT_NEAR(ev.final_errors.position_error_percent_of_distance,
              100.0 * b_mps.norm() * duration_s / distance_m, 1e-7);
  for (const PoseError& p : ev.poses)
    EXPECT_NEAR(p.translation_error_m, b_mps.norm() * p.time_since_start_s, 1e-6) << p.time_since_start_s;
  // The drift is a constant velocity error b, at every pose.
  EXPECT_NEAR(ev.velocity_error_mps.min, b_mps.norm(), 1e-6);
  EXPECT_NEAR(ev.velocity_error_mps.max, b_mps.norm(), 1e-6);
  EXPECT_LT((ev.final_errors.velocity_error_world_mps - b_mps).norm(), 1e-6);
  EXPECT_LT(ev.rotation_deg.max, kZeroAngle_deg);
}

TEST(FirstPoseAlignment, InitialErrorOptionsShiftTheResultAsExpected) {
  const Trajectory gt = test::descentGroundTruth();
  const Trajectory est = test::inOtherWorld(gt, kScale, worldRotation(), kWorldOffset);
  const Eigen::Vector3d p0 = gt.front().T_world_cam.translation();

  {  // Position error: a constant offset of every pose.
    EvaluationOptions options = firstPoseOptions(2.0);
    options.first_pose.position_error_m = Eigen::Vector3d(3.0, -2.0, 1.0);
    const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
    for (const PoseError& p : ev.poses)
      EXPECT_LT((p.position_error_m - options.first_pose.position_error_m).norm(), kZeroPosition_m);
    EXPECT_LT(ev.velocity_error_mps.max, 1e-5);
    EXPECT_LT(ev.rotation_deg.max, kZeroAngle_deg);
  }
  {  // Attitude error about the up axis: the path turns about the first pose, error (Rz - I)(p_k - p_0); no
     // tilt.
    EvaluationOptions options = firstPoseOptions(2.0);
    options.first_pose.attitude_error_deg = Eigen::Vector3d(0.0, 0.0, 0.5);
    const Eigen::Matrix3d Rz = test::rotationDeg(0.5, Eigen::Vector3d::UnitZ());
    const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
    for (size_t k = 0; k < gt.size(); ++k) {
      const Eigen::Vector3d expected =
          (Rz - Eigen::Matrix3d::Identity()) * (gt[k].T_world_cam.translation() - p0);
      EXPECT_LT((ev.poses[k].position_error_m - expected).norm(), kZeroPosition_m) << k;
      EXPECT_NEAR(ev.poses[k].rotation_error_deg, 0.5, kZeroAngle_deg) << k;
      EXPECT_LT(ev.poses[k].tilt_error_deg, kZeroAngle_deg) << k;
    }
    EXPECT_GT(ev.final_errors.position_error_m, 1.0);  // ~0.0087 x ~1300 m from the first pose
  }
  {  // Attitude error about a horizontal axis: a tilt of that angle at every pose.
    EvaluationOptions options = firstPoseOptions(2.0);
    options.first_pose.attitude_error_deg = Eigen::Vector3d(0.3, 0.0, 0.0);
    const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
    EXPECT_NEAR(ev.tilt_error_deg.min, 0.3, kZeroAngle_deg);
    EXPECT_NEAR(ev.tilt_error_deg.max, 0.3, kZeroAngle_deg);
    EXPECT_NEAR(ev.final_errors.tilt_error_deg, 0.3, kZeroAngle_deg);
  }
  {  // Scale error f: error f (p_k - p_0), scale error 100 f % in every full window.
    EvaluationOptions options = firstPoseOptions(2.0);
    options.first_pose.scale_error = 0.01;
    const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
    EXPECT_NEAR(ev.alignment.scale, 1.01 * kScale, 1e-9 * kScale);
    for (size_t k = 0; k < gt.size(); ++k) {
      const Eigen::Vector3d expected = 0.01 * (gt[k].T_world_cam.translation() - p0);
      EXPECT_LT((ev.poses[k].position_error_m - expected).norm(), kZeroPosition_m) << k;
    }
    EXPECT_NEAR(ev.scale_error_percent.min, 1.0, 1e-7);
    EXPECT_NEAR(ev.scale_error_percent.max, 1.0, 1e-7);
    EXPECT_NEAR(ev.final_errors.velocity_error_mps, 0.01 * test::descentVelocity(11.9).norm(), 1e-5);
  }
}

TEST(FirstPoseAlignment, BadWindowsAndOptionsAreRejected) {
  const Trajectory gt = test::descentGroundTruth();
  Trajectory still = gt;
  for (StampedPose& p : still) p.T_world_cam.translation().setZero();
  // A window shorter than the frame period holds one pose; a still estimate has no scale.
  EXPECT_THROW(evaluateTrajectory(gt, gt, firstPoseOptions(0.05)), EvalError);
  EXPECT_THROW(evaluateTrajectory(gt, still, firstPoseOptions(2.0)), EvalError);
  // The handed-over state errors apply to alignment 'first' only.
  EvaluationOptions sim3;
  sim3.first_pose.position_error_m = Eigen::Vector3d(1.0, 0.0, 0.0);
  EXPECT_THROW(evaluateTrajectory(gt, gt, sim3), EvalError);
  EvaluationOptions bad_scale = firstPoseOptions(0.0);
  bad_scale.first_pose.scale_error = -1.0;
  EXPECT_THROW(evaluateTrajectory(gt, gt, bad_scale), EvalError);
  EXPECT_EQ(parseAlignmentMode("first"), AlignmentMode::kFirstPose);
  EXPECT_STREQ(toString(AlignmentMode::kFirstPose), "first");
  // alignTrajectories() with kFirstPose: the default handover (scale 1), any number of poses.
  const AssociatedTrajectories one = associateByTimestamp(Trajectory{gt[5]}, Trajectory{gt[5]}, 0.001);
  const Sim3Transform s = alignTrajectories(one, AlignmentMode::kFirstPose);
  EXPECT_DOUBLE_EQ(s.scale, 1.0);
  EXPECT_LT(s.t_gt_est_m.norm(), 1e-9);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
