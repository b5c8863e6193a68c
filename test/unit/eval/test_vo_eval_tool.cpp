/// Runs the vo_eval executable, which catkin puts beside the test executables (devel/lib/planetary_vo/): exit
/// codes, report, JSON and plots. Fails (does not skip) when the executable has not been built.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "eval_test_util.h"
#include "planetary_vo/dataset/dataset.h"
#include "test_support.h"

namespace planetary_vo {
namespace {

using test::executableDir;
using test::readText;

/// Runs vo_eval with `args`, output to `log`; returns its exit status.
int runVoEval(const std::string& args, const std::string& log) { return test::runTool("vo_eval", args, log); }

TEST(VoEvalTool, ReportJsonPlotsAndErrorExitCodes) {
  ASSERT_TRUE(test::requireDataFile(executableDir() + "/vo_eval")) << "build the vo_eval target first";
  const std::string gt = test::dataPath("kitti_clip_turn/poses.txt");
  ASSERT_TRUE(test::requireDataFile(gt));
  const std::string dir = test::outputDir("vo_eval_tool");
  // Estimate: the ground truth shifted by 0.5 m in z, in TUM format (KITTI stamps are index / 10 Hz).
  Trajectory est = readTrajectory(gt);
  for (StampedPose& p : est) p.T_world_cam.translation().z() += 0.5;
  writeTumTrajectory(dir + "/est.txt", est);

  ASSERT_EQ(runVoEval("--gt " + gt + " --est " + dir + "/est.txt --align none --json " + dir +
                          "/eval.json --plot " + dir + "/plots --axes xyz",
                      dir + "/log.txt"),
            0)
      << readText(dir + "/log.txt");
  const std::string log = readText(dir + "/log.txt");
  EXPECT_NE(log.find("associated 51"), std::string::npos) << log;
  EXPECT_NE(log.find("translation  rmse 0.5000"), std::string::npos) << log;
  EXPECT_NE(readText(dir + "/eval.json").find("\"num_associated\": 51"), std::string::npos);
  for (const char* png :
       {"trajectory.png", "position_vs_time.png", "attitude.png", "ate_vs_time.png", "gnc_errors.png"})
    EXPECT_TRUE(test::requireDataFile(dir + "/plots/" + png));

  EXPECT_EQ(runVoEval("--gt " + dir + "/missing.txt --est " + dir + "/est.txt", dir + "/log2.txt"), 1);
  EXPECT_NE(readText(dir + "/log2.txt").find("cannot open " + dir + "/missing.txt"), std::string::npos);
  EXPECT_EQ(runVoEval("--gt " + gt + " --est " + dir + "/est.txt --max-dt -1", dir + "/log3.txt"), 2);
  EXPECT_EQ(runVoEval("--gt " + gt, dir + "/log4.txt"), 2);
}

/// Runs a Python check on a JSON file: `condition` is an expression over `d` (the parsed JSON); returns the
/// script's exit status (0 when it holds), printing the failed expression.
int checkJson(const std::string& json_path, const std::string& condition) {
  const std::string dir = json_path.substr(0, json_path.find_last_of('/'));
  const std::string script = dir + "/check.py";
  {
    std::ofstream out(script);
    out << "import json, sys\nd = json.load(open(sys.argv[1]))\nok = bool(" << condition
        << ")\nif not ok: print('failed: ' + sys.argv[2])\nsys.exit(0 if ok else 1)\n";
  }
  return std::system(("/usr/bin/python3 " + script + " " + json_path + " \"condition\"").c_str());
}

TEST(VoEvalTool, DatasetFolderFirstPoseVelocityNeesAndJsonKeys) {
  ASSERT_TRUE(test::requireDataFile(executableDir() + "/vo_eval")) << "build the vo_eval target first";
  const std::string dir = test::outputDir("vo_eval_gnc");
  // A planetary_vo dataset folder with groundtruth.txt (10 Hz) and groundtruth_state.txt (200 Hz, exact
  // velocity), as the renderer writes them (only the ground-truth files matter here).
  const Trajectory gt = test::descentGroundTruth();  // 11.9 s, stamps 1000 + t
  ASSERT_EQ(std::system(("mkdir -p " + dir + "/seq").c_str()), 0);
  writeTumTrajectory(dir + "/seq/groundtruth.txt", gt);
  {
    std::FILE* f = std::fopen((dir + "/seq/groundtruth_state.txt").c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fprintf(f, "# GROUND TRUTH timestamp[s] px py pz qx qy qz qw vx vy vz bgx bgy bgz bax bay baz\n");
    for (int k = 0; k <= 2380; ++k) {
      const double t = 0.005 * k;
      const Eigen::Vector3d v = test::descentVelocity(t);
      // Position and attitude are not used for the velocity: any valid pose does.
      std::fprintf(f, "%.9f 0 0 0 0 0 0 1 %.15g %.15g %.15g 0 0 0 0 0 0\n", 1000.0 + t, v.x(), v.y(), v.z());
    }
    std::fclose(f);
  }
  // A monocular-like estimate: another world, scale 1/20, exact for 2 s (the scale window), then drifting
  // 0.05 m/s in crossrange x; its velocity (drift included) in its own world; a 3x3 position covariance of
  // 1 m^2 per axis in metres, (1/20)^2 in estimate units.
  const double scale = 20.0;
  const Eigen::Matrix3d R = test::rotationDeg(35.0, Eigen::Vector3d(0.2, 1.0, -0.3));
  const Eigen::Vector3d drift_mps(0.05, 0.0, 0.0);
  Trajectory drifting = gt;
  const auto driftTime = [](double stamp_s) { return std::max(0.0, stamp_s - 1002.0); };
  for (StampedPose& p : drifting) p.T_world_cam.translation() += drift_mps * driftTime(p.timestamp_s);
  const Trajectory est = test::inOtherWorld(drifting, scale, R, Eigen::Vector3d(5.0, -7.0, 9.0));
  writeTumTrajectory(dir + "/est.txt", est);
  {
    std::ofstream velocity(dir + "/est_velocity.txt"), covariance(dir + "/est_cov.txt");
    char line[256];
    for (const StampedPose& p : est) {
      const Eigen::Vector3d v_mps = test::descentVelocity(p.timestamp_s - 1000.0) +
                                    (driftTime(p.timestamp_s) > 1e-6 ? drift_mps : Eigen::Vector3d::Zero());
      const Eigen::Vector3d v = R.transpose() * v_mps / scale;
      std::snprintf(line, sizeof(line), "%.9f %.15g %.15g %.15g\n", p.timestamp_s, v.x(), v.y(), v.z());
      velocity << line;
      const double var = 1.0 / (scale * scale);
      std::snprintf(line, sizeof(line), "%.9f %.15g 0 0 0 %.15g 0 0 0 %.15g\n", p.timestamp_s, var, var, var);
      covariance << line;
    }
  }
  const std::string json = dir + "/eval.json";
  ASSERT_EQ(runVoEval("--gt " + dir + "/seq --est " + dir + "/est.txt --align first --first-scale-window 2 " +
                          "--est-cov " + dir + "/est_cov.txt --json " + json + " --plot " + dir + "/plots",
                      dir + "/log.txt"),
            0)
      << readText(dir + "/log.txt");
  const std::string log = readText(dir + "/log.txt");
  EXPECT_NE(log.find("ground-truth state: " + dir + "/seq/groundtruth_state.txt"), std::string::npos) << log;
  EXPECT_NE(log.find("NEES (estimated covariance 3x3)"), std::string::npos) << log;
  EXPECT_TRUE(test::requireDataFile(dir + "/plots/gnc_errors.png"));

  // The window scale of the first 2 s (no drift yet): 20, up to the 1e-9 rounding of the TUM file.
  EXPECT_EQ(checkJson(json,
                      "abs(d['alignment']['first_pose']['window_scale'] - 20) < 1e-6 and "
                      "d['alignment']['mode'] == 'first'"),
            0);
  // Keys kept for scripts/vo_benchmark.py.
  EXPECT_EQ(checkJson(json,
                      "all(k in d for k in ['ate_rmse_percent_of_path']) and "
                      "'rmse' in d['attitude_drift_deg'] and 'rmse' in d['rotation_error_deg']"),
            0);
  // Series: equal lengths over the 120 associated poses; nees_position only with a covariance.
  EXPECT_EQ(checkJson(json,
                      "set(d['series']) == {'t_s', 't_rel_s', 'distance_travelled_m', "
                      "'position_error_m', 'position_error_percent_of_distance', 'crossrange_error_m', "
                      "'downrange_error_m', 'altitude_error_m', 'velocity_error_mps', "
                      "'velocity_error_x_mps', 'velocity_error_y_mps', 'velocity_error_z_mps', "
                      "'attitude_error_deg', 'tilt_error_deg', 'scale_error_percent', 'nees_position'} and "
                      "all(len(v) == 120 for v in d['series'].values()) and d['series']['t_rel_s'][0] == 0"),
            0);
  // The final error is the drift: 0.05 m/s x 9.9 s = 0.495 m crosswise, in % of the distance travelled.
  EXPECT_EQ(checkJson(json,
                      "abs(d['final']['position_error_m'] - 0.495) < 1e-5 and "
                      "abs(d['final']['position_error_percent_of_distance'] - "
                      "100 * 0.495 / d['distance_travelled_m']) < 1e-5 and "
                      "abs(d['final']['position_error_world_m'][0] - 0.495) < 1e-5 and "
                      "abs(d['series']['crossrange_error_m'][-1] - 0.495) < 1e-5 and "
                      "d['series']['position_error_percent_of_distance'][0] is None and "
                      "abs(d['series']['position_error_percent_of_distance'][-1] - "
                      "d['final']['position_error_percent_of_distance']) < 1e-9 and "
                      "abs(d['series']['distance_travelled_m'][-1] - d['distance_travelled_m']) < 1e-9 and "
                      "set(d['final']) >= {'velocity_error_mps', 'attitude_error_deg', 'tilt_error_deg', "
                      "'scale_error_percent'} and d['final']['tilt_error_deg'] < 1e-6"),
            0);
  // Velocity: truth from groundtruth_state.txt, estimate from differences: 0 before the drift, 0.05 m/s after
  // it (the differences of the parabolic descent are exact; its 0.05 rad/s crossrange sine adds < 2e-5 m/s).
  EXPECT_EQ(checkJson(json,
                      "d['velocity_truth_source'] == 'groundtruth_state' and "
                      "d['velocity_estimate_source'] == 'pose_differences' and "
                      "abs(d['velocity_error_mps']['max'] - 0.05) < 1e-4 and "
                      "d['velocity_error_mps']['min'] < 1e-4 and "
                      "abs(d['final']['velocity_error_mps'] - 0.05) < 1e-4 and "
                      "abs(d['series']['velocity_error_mps'][-1] - 0.05) < 1e-4"),
            0);
  // NEES of the position: the drift e over sigma 1 m (covariance scaled back from estimate units): mean of
  // |e|^2 over the poses.
  EXPECT_EQ(checkJson(json,
                      "d['nees']['covariance_dimension'] == 3 and 'attitude' not in d['nees'] and "
                      "abs(d['nees']['position']['mean'] - sum((0.05 * max(0, t - 2)) ** 2 for t in "
                      "d['series']['t_rel_s']) / 120) < 1e-6 and d['nees']['position']['dof'] == 3 and "
                      "d['nees']['position']['verdict'] == 'pessimistic'"),
            0);

  // The same with the estimate's own velocity file and the ground truth as a plain file (no state, no NEES).
  ASSERT_EQ(runVoEval("--gt " + dir + "/seq/groundtruth.txt --est " + dir + "/est.txt --align first " +
                          "--first-scale-window 2 --est-velocity " + dir + "/est_velocity.txt --json " + json,
                      dir + "/log2.txt"),
            0)
      << readText(dir + "/log2.txt");
  EXPECT_EQ(checkJson(json,
                      "'nees' not in d and 'nees_position' not in d['series'] and "
                      "d['velocity_truth_source'] == 'pose_differences' and "
                      "d['velocity_estimate_source'] == 'estimate_velocity' and "
                      "abs(d['velocity_error_mps']['max'] - 0.05) < 1e-3"),
            0);

  // Options that do not fit: exit 2.
  const std::string base = "--gt " + dir + "/seq --est " + dir + "/est.txt ";
  EXPECT_EQ(runVoEval(base + "--align sim3 --initial-error-m 1,2,3", dir + "/log3.txt"), 2);
  EXPECT_NE(readText(dir + "/log3.txt").find("applies to alignment 'first' only"), std::string::npos);
  EXPECT_EQ(runVoEval(base + "--up-axis w", dir + "/log4.txt"), 2);
  EXPECT_EQ(runVoEval(base + "--align first --initial-error-deg 1,2", dir + "/log5.txt"), 2);
  // A covariance file that does not parse: exit 1, naming file and line.
  {
    std::ofstream bad(dir + "/bad_cov.txt");
    bad << "1000.0 1 2 3\n";
  }
  EXPECT_EQ(runVoEval(base + "--align first --est-cov " + dir + "/bad_cov.txt", dir + "/log6.txt"), 1);
  EXPECT_NE(readText(dir + "/log6.txt").find("bad_cov.txt:1: expected 10 or 37 values"), std::string::npos);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
