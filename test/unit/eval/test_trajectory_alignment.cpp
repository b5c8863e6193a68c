/// Association by time stamp and Umeyama alignment, with answers known by construction.

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "eval_test_util.h"
#include "planetary_vo/eval/trajectory_alignment.h"
#include "planetary_vo/eval/trajectory_metrics.h"

namespace planetary_vo {
namespace {

TEST(Association, JitteredStampsPairWithTheirOwnGroundTruth) {
  const Trajectory gt = test::straightLine(50);  // 10 Hz
  Trajectory est;
  cv::RNG rng(5);                              // OpenCV is linked through the dataset library
  for (size_t k = 0; k < gt.size(); k += 2) {  // every other pose, jittered by up to +-4 ms
    StampedPose p = gt[k];
    p.timestamp_s += rng.uniform(-0.004, 0.004);
    est.push_back(p);
  }
  est.push_back({gt.back().timestamp_s + 0.5, Pose::Identity()});  // beyond the ground truth: unmatched
  const AssociatedTrajectories a = associateByTimestamp(gt, est, 0.005);
  ASSERT_EQ(a.size(), 25u);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a.estimate_indices[k], k);
    EXPECT_EQ(a.ground_truth_indices[k], 2 * k);
    EXPECT_EQ(a.ground_truth[k].T_world_cam.translation(), gt[2 * k].T_world_cam.translation());
    EXPECT_NEAR(a.estimate[k].timestamp_s, a.ground_truth[k].timestamp_s, 0.004);
  }
  // A tolerance below the jitter loses pairs; zero tolerance keeps only exact stamps.
  EXPECT_LT(associateByTimestamp(gt, est, 0.001).size(), 25u);
  EXPECT_EQ(associateByTimestamp(gt, gt, 0.0).size(), gt.size());
}

TEST(Association, IsOneToOneWhenTheEstimateIsFaster) {
  const Trajectory gt = test::straightLine(10);  // 10 Hz
  Trajectory est;
  for (int k = 0; k < 20; ++k) est.push_back({0.05 * k + 0.001, Pose::Identity()});  // 20 Hz, 1 ms late
  const AssociatedTrajectories a = associateByTimestamp(gt, est, 0.03);
  ASSERT_EQ(a.size(), 10u);  // each ground-truth pose used once, by the nearest estimate
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a.ground_truth_indices[k], k);
    EXPECT_EQ(a.estimate_indices[k], 2 * k);
  }
}

TEST(Alignment, Sim3RecoversAKnownSimilarity) {
  const Trajectory gt = test::descentGroundTruth();
  // The estimate lives in another world frame, at another scale: est = S^-1 * gt.
  Sim3Transform S;  // maps estimate world -> gt world
  S.scale = 1.0 / 0.037;
  S.R_gt_est = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  S.t_gt_est_m = Eigen::Vector3d(120.0, -45.0, 1600.0);
  Trajectory est = gt;
  for (StampedPose& p : est) {
    const Pose& T = p.T_world_cam;
    p.T_world_cam = test::makePose(S.R_gt_est.transpose() * T.rotation(),
                                   S.R_gt_est.transpose() * (T.translation() - S.t_gt_est_m) / S.scale);
  }
  const AssociatedTrajectories pairs = associateByTimestamp(gt, est, 0.001);
  const Sim3Transform found = alignTrajectories(pairs, AlignmentMode::kSim3);
  EXPECT_NEAR(found.scale, S.scale, 1e-9 * S.scale);
  EXPECT_LT((found.R_gt_est - S.R_gt_est).norm(), 1e-9);
  EXPECT_LT((found.t_gt_est_m - S.t_gt_est_m).norm(), 1e-6);

  EvaluationOptions options;
  options.alignment = AlignmentMode::kSim3;
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
  EXPECT_EQ(ev.num_associated, gt.size());
  EXPECT_LT(ev.ate_m.max, 1e-6);
  EXPECT_LT(ev.rotation_deg.max, 1e-6);
  EXPECT_NEAR(ev.alignment.scale, S.scale, 1e-9 * S.scale);
  for (const RelativeError& r : ev.rpe)
    EXPECT_LT(r.translation_m.max, 1e-6) << r.delta << " " << r.delta_unit;

  // Aligning on the first 20 poses only gives the same transform here (no noise).
  EXPECT_NEAR(alignTrajectories(pairs, AlignmentMode::kSim3, 20).scale, S.scale, 1e-8 * S.scale);
  // se3 cannot remove the scale error: the error stays of the size of the trajectory.
  options.alignment = AlignmentMode::kSe3;
  const TrajectoryEvaluation se3 = evaluateTrajectory(gt, est, options);
  EXPECT_DOUBLE_EQ(se3.alignment.scale, 1.0);
  EXPECT_GT(se3.ate_m.rmse, 100.0);
}

TEST(Alignment, Se3RemovesARigidMotionButNotAScaleError) {
  const Trajectory gt = test::descentGroundTruth();
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(-1.2, Eigen::Vector3d(0.3, 0.1, 1).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(-5, 7, 11);
  Trajectory rigid = gt, scaled = gt;
  for (size_t k = 0; k < gt.size(); ++k) {
    const Pose& T = gt[k].T_world_cam;
    rigid[k].T_world_cam = test::makePose(R * T.rotation(), R * T.translation() + t);
    scaled[k].T_world_cam.translation() = 1.1 * T.translation();  // 10 % scale error about the world origin
  }
  EvaluationOptions options;
  options.alignment = AlignmentMode::kSe3;
  EXPECT_LT(evaluateTrajectory(gt, rigid, options).ate_m.max, 1e-6);
  const TrajectoryEvaluation se3 = evaluateTrajectory(gt, scaled, options);
  // The best rigid fit of a 10 % scaled copy leaves 10 % of the spread about the centroid (exact for se3 via
  // least squares: the residual is 0.1 * |p - mean|).
  double expected_sq = 0.0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const StampedPose& p : gt) mean += p.T_world_cam.translation() / gt.size();
  for (const StampedPose& p : gt) expected_sq += (0.1 * (p.T_world_cam.translation() - mean)).squaredNorm();
  EXPECT_NEAR(se3.ate_m.rmse, std::sqrt(expected_sq / gt.size()), 1e-6);
  options.alignment = AlignmentMode::kSim3;
  const TrajectoryEvaluation sim3 = evaluateTrajectory(gt, scaled, options);
  EXPECT_LT(sim3.ate_m.max, 1e-6);
  EXPECT_NEAR(sim3.alignment.scale, 1.0 / 1.1, 1e-12);
}

TEST(Alignment, DegenerateAndUnassociatedInputThrow) {
  const Trajectory line = test::straightLine(20);
  const AssociatedTrajectories pairs = associateByTimestamp(line, line, 0.001);
  EXPECT_THROW(alignTrajectories(pairs, AlignmentMode::kSim3),
               EvalError);  // rotation about the line unobservable
  EXPECT_THROW(alignTrajectories(pairs, AlignmentMode::kSe3, 2), EvalError);  // too few pairs
  EXPECT_NO_THROW(alignTrajectories(pairs, AlignmentMode::kNone));
  Trajectory late = line;
  for (StampedPose& p : late) p.timestamp_s += 100.0;
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  try {
    evaluateTrajectory(line, late, options);
    FAIL() << "no association must throw";
  } catch (const EvalError& e) {
    EXPECT_NE(std::string(e.what()).find("no estimated pose is within"), std::string::npos) << e.what();
  }
  EXPECT_EQ(parseAlignmentMode("se3"), AlignmentMode::kSe3);
  EXPECT_THROW(parseAlignmentMode("posyaw"), EvalError);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
