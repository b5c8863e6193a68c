/// ATE, RPE, landing-site errors and the report outputs, with answers known by construction.

#include <cstdio>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "eval_test_util.h"
#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/evaluation_report.h"
#include "planetary_vo/eval/trajectory_metrics.h"
#include "test_support.h"

namespace planetary_vo {
namespace {

TEST(Statistics, KnownValues) {
  const ErrorStatistics s = computeStatistics({3.0, -1.0, 2.0, 4.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.mean, 2.0);
  EXPECT_DOUBLE_EQ(s.median, 2.5);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4.0));
  EXPECT_DOUBLE_EQ(s.std_dev, std::sqrt(14.0 / 4.0));
  EXPECT_DOUBLE_EQ(s.min, -1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(computeStatistics({5.0, 1.0, 3.0}).median, 3.0);
  EXPECT_EQ(computeStatistics({}).count, 0u);
}

TEST(Ate, ConstantOffsetWithoutAlignmentIsThatOffsetInLandingSiteAxes) {
  const Trajectory gt = test::descentGroundTruth();
  const Eigen::Vector3d offset_m(1.5, -2.0, 0.25);  // crossrange, downrange, altitude
  Trajectory est = gt;
  for (StampedPose& p : est) p.T_world_cam.translation() += offset_m;
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
  EXPECT_NEAR(ev.ate_m.rmse, offset_m.norm(), 1e-9);
  EXPECT_NEAR(ev.ate_m.min, offset_m.norm(), 1e-9);
  EXPECT_NEAR(ev.ate_m.max, offset_m.norm(), 1e-9);
  EXPECT_NEAR(ev.final_position_error_m, offset_m.norm(), 1e-9);
  EXPECT_NEAR(ev.crossrange_error_m.mean, 1.5, 1e-9);
  EXPECT_NEAR(ev.downrange_error_m.mean, -2.0, 1e-9);
  EXPECT_NEAR(ev.altitude_error_m.mean, 0.25, 1e-9);
  EXPECT_NEAR(ev.downrange_error_m.rmse, 2.0, 1e-9);
  EXPECT_LT(ev.rotation_deg.max, 1e-9);
  // Path length of the sampled ground truth, and ATE as a percentage of it.
  double length = 0.0;
  for (size_t k = 1; k < gt.size(); ++k)
    length += (gt[k].T_world_cam.translation() - gt[k - 1].T_world_cam.translation()).norm();
  EXPECT_NEAR(ev.gt_path_length_m, length, 1e-9);
  EXPECT_NEAR(ev.ate_rmse_percent, 100.0 * offset_m.norm() / length, 1e-9);
  EXPECT_NEAR(ev.duration_s, 11.9, 1e-9);
  // A constant offset has no relative error.
  for (const RelativeError& r : ev.rpe) EXPECT_LT(r.translation_m.max, 1e-9);
  // With se3 alignment the offset disappears.
  options.alignment = AlignmentMode::kSe3;
  EXPECT_LT(evaluateTrajectory(gt, est, options).ate_m.max, 1e-6);
}

TEST(Ate, ConstantAttitudeErrorIsReportedInDegrees) {
  const Trajectory gt = test::descentGroundTruth();
  Trajectory est = gt;
  const Eigen::Matrix3d dR =
      Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d(1, 1, 0).normalized()).toRotationMatrix();
  for (StampedPose& p : est) p.T_world_cam.linear() = p.T_world_cam.rotation() * dR;  // camera-side error
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
  EXPECT_NEAR(ev.rotation_deg.rmse, 2.0, 1e-9);
  EXPECT_NEAR(ev.rotation_deg.max, 2.0, 1e-9);
  EXPECT_LT(ev.ate_m.max, 1e-9);
  EXPECT_GT(ev.poses[5].q_world_cam_est.dot(ev.poses[5].q_world_cam_gt), 0.0);  // same hemisphere
}

TEST(AttitudeDrift, IndependentOfAWorldRotationAndEqualToAKnownDrift) {
  const Trajectory gt = test::descentGroundTruth();
  // The estimate lives in a world frame turned by 70 deg: its attitude change since the first pose is exact.
  const Pose T_est_gt = test::makePose(
      Eigen::AngleAxisd(70.0 * M_PI / 180.0, Eigen::Vector3d(0.2, 1, 0.3).normalized()).toRotationMatrix(),
      Eigen::Vector3d(5, -3, 2));
  Trajectory rotated = gt;
  for (StampedPose& p : rotated) p.T_world_cam = T_est_gt * p.T_world_cam;
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  const TrajectoryEvaluation ev_rotated = evaluateTrajectory(gt, rotated, options);
  EXPECT_NEAR(ev_rotated.rotation_deg.rmse, 70.0, 1e-6);  // the unaligned attitude error is the world turn
  EXPECT_LT(ev_rotated.attitude_drift_deg.max, 1e-6);

  // An attitude that drifts by 0.01 deg per frame about the camera axis has drift 0.01 k deg at frame k.
  Trajectory drifting = gt;
  for (size_t k = 0; k < drifting.size(); ++k)
    drifting[k].T_world_cam.linear() =
        drifting[k].T_world_cam.rotation() *
        Eigen::AngleAxisd(0.01 * k * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const std::vector<double> drift = attitudeDriftDeg(gt, drifting);
  ASSERT_EQ(drift.size(), gt.size());
  for (size_t k = 0; k < drift.size(); ++k) EXPECT_NEAR(drift[k], 0.01 * k, 1e-6) << "frame " << k;
  EXPECT_NEAR(evaluateTrajectory(gt, drifting, options).attitude_drift_deg.max, 0.01 * (gt.size() - 1), 1e-6);
}

TEST(Rpe, KnownPerStepTranslationDrift) {
  const Trajectory gt = test::straightLine(101);  // 100 m along y, 1 m per step
  const Trajectory est =
      test::withPerStepDrift(gt, test::makePose(Eigen::Matrix3d::Identity(), {0.01, 0, 0}));
  const RelativeError r1 = relativeErrorOverFrames(gt, est, 1);
  EXPECT_EQ(r1.num_pairs, 100u);
  EXPECT_NEAR(r1.translation_m.mean, 0.01, 1e-12);
  EXPECT_NEAR(r1.translation_m.min, 0.01, 1e-12);
  EXPECT_NEAR(r1.translation_percent.mean, 1.0, 1e-9);
  EXPECT_LT(r1.rotation_deg.max, 1e-9);
  const RelativeError r10 = relativeErrorOverFrames(gt, est, 10);
  EXPECT_EQ(r10.num_pairs, 91u);
  EXPECT_NEAR(r10.translation_m.mean, 0.1, 1e-12);  // drift adds up over 10 steps
  EXPECT_NEAR(r10.translation_percent.max, 1.0, 1e-9);
  const RelativeError d20 = relativeErrorOverDistance(gt, est, 20.0);
  EXPECT_EQ(d20.delta_unit, "m");
  EXPECT_EQ(d20.num_pairs, 81u);  // pairs (i, i + 20) for i = 0..80
  EXPECT_NEAR(d20.translation_m.mean, 0.2, 1e-12);
  EXPECT_NEAR(d20.translation_percent.mean, 1.0, 1e-9);
  // The absolute error grows linearly: 0.01 m per step, last pose 1 m off in crossrange x.
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
  EXPECT_NEAR(ev.final_position_error_m, 1.0, 1e-9);
  EXPECT_NEAR(ev.crossrange_error_m.max, 1.0, 1e-9);
  EXPECT_NEAR(ev.crossrange_error_m.mean, 0.5, 1e-9);
  ASSERT_EQ(ev.rpe.size(), 2u + 5u);  // frames 1, 10; distances 10..50 % of 100 m
  EXPECT_EQ(ev.rpe[0].delta_unit, "frames");
  EXPECT_NEAR(ev.rpe[2].delta, 10.0, 1e-9);
  EXPECT_NEAR(ev.rpe[6].delta, 50.0, 1e-9);
  EXPECT_NEAR(ev.rpe[6].translation_m.mean, 0.5, 1e-9);
}

TEST(Rpe, KnownPerStepRotationDrift) {
  // Roll about the direction of travel: the path stays straight, the attitude drifts 0.1 deg per metre.
  const Trajectory gt = test::straightLine(51);
  const double step_deg = 0.1;
  const Trajectory est = test::withPerStepDrift(
      gt,
      test::makePose(Eigen::AngleAxisd(step_deg * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix(),
                     Eigen::Vector3d::Zero()));
  const RelativeError r1 = relativeErrorOverFrames(gt, est, 1);
  EXPECT_NEAR(r1.rotation_deg.mean, step_deg, 1e-9);
  EXPECT_NEAR(r1.rotation_deg_per_m.max, step_deg, 1e-9);
  EXPECT_LT(r1.translation_m.max, 1e-9);
  const RelativeError r5 = relativeErrorOverFrames(gt, est, 5);
  EXPECT_NEAR(r5.rotation_deg.mean, 5 * step_deg, 1e-9);
  EXPECT_NEAR(r5.rotation_deg_per_m.mean, step_deg, 1e-9);
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  EXPECT_NEAR(evaluateTrajectory(gt, est, options).rotation_deg.max, 50 * step_deg, 1e-9);
}

TEST(KittiTrajectories, EstimateInKittiFormatAgainstTheRealClip) {
  const std::string gt_path = test::dataPath("kitti_clip_turn/poses.txt");
  ASSERT_TRUE(test::requireDataFile(gt_path));
  const Trajectory gt = readTrajectory(gt_path);
  ASSERT_EQ(gt.size(), 51u);
  EXPECT_DOUBLE_EQ(gt[10].timestamp_s, 1.0);
  // The same poses at half scale, written as KITTI 3x4 lines: sim3 must give scale 2 and ~zero error.
  const std::string dir = test::outputDir("eval_kitti");
  {
    std::ofstream out(dir + "/est.txt");
    for (const StampedPose& p : gt) {
      const Eigen::Matrix3d R = p.T_world_cam.rotation();
      const Eigen::Vector3d t = 0.5 * p.T_world_cam.translation();
      char line[512];
      std::snprintf(line, sizeof(line), "%.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e\n",
                    R(0, 0), R(0, 1), R(0, 2), t.x(), R(1, 0), R(1, 1), R(1, 2), t.y(), R(2, 0), R(2, 1),
                    R(2, 2), t.z());
      out << line;
    }
  }
  const Trajectory est = readTrajectory(dir + "/est.txt");
  EvaluationOptions options;
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);
  EXPECT_EQ(ev.num_associated, 51u);
  EXPECT_NEAR(ev.alignment.scale, 2.0, 1e-7);
  EXPECT_LT(ev.ate_m.max, 1e-6);
  EXPECT_NEAR(ev.gt_path_length_m, 51.759, 1e-3);  // as computed from poses.txt
}

TEST(Report, TextJsonAndCsvCarryTheResults) {
  const Trajectory gt = test::descentGroundTruth(40);
  Trajectory est = gt;
  for (StampedPose& p : est) p.T_world_cam.translation() += Eigen::Vector3d(0, 0, 3.0);
  EvaluationOptions options;
  options.alignment = AlignmentMode::kNone;
  const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options);

  const std::string text = formatReport(ev);
  EXPECT_NE(text.find("associated 40"), std::string::npos) << text;
  EXPECT_NE(text.find("alignment: none, scale 1.000000"), std::string::npos) << text;
  EXPECT_NE(text.find("translation  rmse 3.0000  mean 3.0000"), std::string::npos) << text;
  EXPECT_NE(text.find("altitude   z rmse 3.0000"), std::string::npos) << text;

  const std::string dir = test::outputDir("eval_report");
  writeJson(dir + "/eval.json", ev);
  writePoseErrorsCsv(dir + "/poses.csv", ev);
  // The JSON must parse (Python's json module is the reference) and hold the numbers.
  const std::string check =
      "/usr/bin/python3 -c \"import json,sys; d=json.load(open('" + dir +
      "/eval.json')); sys.exit(0 if abs(d['ate_m']['rmse']-3)<1e-9 and "
      "d['num_associated']==40 and len(d['poses'])==40 and "
      "d['alignment']['mode']=='none' and abs(d['altitude_error_m']['mean']-3)<1e-9 else 1)\"";
  EXPECT_EQ(std::system(check.c_str()), 0) << toJson(ev, false);
  std::ifstream csv(dir + "/poses.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  EXPECT_EQ(header.rfind("t_s,gt_x_m,gt_y_m,gt_z_m,est_x_m", 0), 0u);
  int rows = 1;
  for (std::string line; std::getline(csv, line);) ++rows;
  EXPECT_EQ(rows, 40);
  std::stringstream ss(first);
  std::vector<double> values;
  for (std::string cell; std::getline(ss, cell, ',');) values.push_back(std::stod(cell));
  ASSERT_EQ(values.size(), 38u);        // 20 pose columns + 18 navigation columns
  EXPECT_NEAR(values[9], 3.0, 1e-6);    // err_z_m
  EXPECT_NEAR(values[10], 3.0, 1e-6);   // ate_m
  EXPECT_NEAR(values[20], 0.0, 1e-12);  // t_rel_s
  EXPECT_NEAR(values[31], 0.0, 1e-6);   // vel_err_mps: a constant offset has no velocity error
  EXPECT_TRUE(std::isnan(values[33]));  // scale_err_pct: the 5 s window is not full at the first pose
  EXPECT_TRUE(std::isnan(values[34]));  // nees_pos: no covariance
  EXPECT_TRUE(std::isnan(values[37]));  // nees_vel: no velocity covariance
  EXPECT_NE(header.find(",vel_err_mps,tilt_err_deg,scale_err_pct,nees_pos,nees_att,nees_pose,nees_vel"),
            std::string::npos);
  // JSON: no NEES without a covariance; statistics without values are null, not 0.
  const std::string no_nees =
      "/usr/bin/python3 -c \"import json,sys; d=json.load(open('" + dir +
      "/eval.json')); sys.exit(0 if 'nees' not in d and d['scale_error_percent']['count'] == 0 and "
      "d['scale_error_percent']['rmse'] is None and d['final']['scale_error_percent'] is None and "
      "len(d['series']['t_s']) == 40 and abs(d['final']['position_error_m'] - 3) < 1e-9 else 1)\"";
  EvaluationOptions short_window = options;
  short_window.scale_window_s = 10.0;  // longer than the 3.9 s of the 40 poses
  writeJson(dir + "/eval.json", evaluateTrajectory(gt, est, short_window));
  EXPECT_EQ(std::system(no_nees.c_str()), 0);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
