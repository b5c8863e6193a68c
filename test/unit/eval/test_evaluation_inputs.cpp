/// Readers of the evaluator's optional inputs: groundtruth_state.txt (as DatasetWriter writes it), estimated
/// velocities and covariances, the --gt folder lookup and the up axis.

#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "eval_test_util.h"
#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/evaluation_inputs.h"
#include "test_support.h"

namespace planetary_vo {
namespace {

void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

/// Runs `read` on a file holding `text` and returns the EvalError message ("" if it did not throw).
template <typename Reader>
std::string errorOf(const std::string& path, const std::string& text, Reader read) {
  writeText(path, text);
  try {
    read(path);
  } catch (const EvalError& e) {
    return e.what();
  }
  return "";
}

TEST(GroundTruthState, ReadsWhatTheDatasetWriterWrites) {
  const std::string dir = test::outputDir("eval_inputs_state");
  std::vector<GroundTruthState> written;
  {
    DatasetWriter writer(dir + "/seq", PinholeCamera::fromFieldOfView(16, 12, 45.0));
    const Trajectory gt = test::descentGroundTruth(3);
    for (const StampedPose& p : gt)
      writer.addFrame(p.timestamp_s, cv::Mat(12, 16, CV_8UC1, cv::Scalar(7)), p.T_world_cam);
    for (int k = 0; k < 50; ++k) {
      GroundTruthState s;
      s.timestamp_s = 1000.0 + 0.005 * k;
      s.T_world_body = test::makePose(test::rotationDeg(10.0 + k, Eigen::Vector3d(1, 2, 3)),
                                      Eigen::Vector3d(30.0 + k, -400.0 + 0.125 * k, 1500.0 - 0.5 * k));
      s.velocity_world_mps = test::descentVelocity(0.005 * k);
      s.gyro_bias_radps = Eigen::Vector3d(1e-5, -2e-5, 3e-5 * k);
      s.accel_bias_mps2 = Eigen::Vector3d(-1e-3, 2e-3 * k, 5e-4);
      writer.addGroundTruthState(s);
      written.push_back(s);
    }
    writer.finish();
  }
  const GroundTruthFiles files = findGroundTruthFiles(dir + "/seq");
  EXPECT_EQ(files.trajectory_path, dir + "/seq/groundtruth.txt");
  EXPECT_EQ(files.state_path, dir + "/seq/groundtruth_state.txt");
  const std::vector<GroundTruthState> read = readGroundTruthStates(files.state_path);
  ASSERT_EQ(read.size(), written.size());
  for (size_t k = 0; k < read.size(); ++k) {
    EXPECT_NEAR(read[k].timestamp_s, written[k].timestamp_s, 1e-9);  // %.9f
    EXPECT_LT((read[k].T_world_body.translation() - written[k].T_world_body.translation()).norm(), 1e-8);
    EXPECT_LT((read[k].T_world_body.rotation() - written[k].T_world_body.rotation()).norm(), 1e-10);
    EXPECT_EQ(read[k].velocity_world_mps, written[k].velocity_world_mps);  // written to read back exactly
    EXPECT_EQ(read[k].gyro_bias_radps, written[k].gyro_bias_radps);
    EXPECT_EQ(read[k].accel_bias_mps2, written[k].accel_bias_mps2);
  }
}

TEST(GroundTruthState, BadFilesNameTheFileAndLine) {
  const std::string dir = test::outputDir("eval_inputs_bad");
  const std::string good = "0.0 1 2 3 0 0 0 1 4 5 6 0 0 0 0 0 0\n";
  const auto states = [](const std::string& p) { readGroundTruthStates(p); };
  EXPECT_EQ(errorOf(dir + "/s.txt", "# header\n" + good, states), "");
  EXPECT_NE(errorOf(dir + "/s.txt", "# header\n" + good + "0.1 1 2 3 0 0 0 1 4 5 6\n", states)
                .find("s.txt:3: expected 17 values, got 11"),
            std::string::npos);
  EXPECT_NE(errorOf(dir + "/s.txt", good + good, states).find("s.txt:2: time stamps must increase"),
            std::string::npos);
  EXPECT_NE(errorOf(dir + "/s.txt", "0.0 1 2 3 0 0 0 2 4 5 6 0 0 0 0 0 0\n", states).find("quaternion norm"),
            std::string::npos);
  EXPECT_NE(
      errorOf(dir + "/s.txt", "0.0 1 2 x 0 0 0 1 4 5 6 0 0 0 0 0 0\n", states).find("'x' is not a finite"),
      std::string::npos);
  EXPECT_THROW(readGroundTruthStates(dir + "/missing.txt"), EvalError);
}

TEST(EstimateFiles, VelocitiesAndCovariances) {
  const std::string dir = test::outputDir("eval_inputs_est");
  writeText(dir + "/v.txt", "# t vx vy vz\n1.0 0.5 -1 2\n1.1 0.6 -1 2\n");
  const std::vector<StampedVelocity> v = readEstimateVelocities(dir + "/v.txt");
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[1].velocity_world, Eigen::Vector3d(0.6, -1, 2));
  const auto velocities = [](const std::string& p) { readEstimateVelocities(p); };
  EXPECT_NE(errorOf(dir + "/v.txt", "1.0 0.5 -1\n", velocities).find("v.txt:1: expected 4 values, got 3"),
            std::string::npos);
  // With the six IMU bias estimates, or the motion filter's 3x3 velocity covariance.
  writeText(dir + "/v10.txt", "1.0 0.5 -1 2 0 0 0 0 0 0\n");
  EXPECT_EQ(readEstimateVelocities(dir + "/v10.txt").size(), 1u);
  EXPECT_FALSE(readEstimateVelocities(dir + "/v10.txt")[0].has_covariance);
  writeText(dir + "/v13.txt", "1.0 0.5 -1 2 4 1 0 1 9 0 0 0 16\n");
  const std::vector<StampedVelocity> v13 = readEstimateVelocities(dir + "/v13.txt");
  EXPECT_EQ(v13[0].velocity_world, Eigen::Vector3d(0.5, -1, 2));
  ASSERT_TRUE(v13[0].has_covariance);
  EXPECT_DOUBLE_EQ(v13[0].covariance(1, 0), 1.0);
  EXPECT_DOUBLE_EQ(v13[0].covariance(2, 2), 16.0);
  EXPECT_NE(errorOf(dir + "/v.txt", "1.0 0.5 -1 2 4 1 0 0 9 0 0 0 16\n", velocities).find("v.txt:1: the covariance is not symmetric"),
            std::string::npos);
  EXPECT_NE(errorOf(dir + "/v.txt", "1.0 0.5 -1 2 1 0 0 0 -1 0 0 0 1\n", velocities).find("not positive definite"),
            std::string::npos);
  EXPECT_NE(errorOf(dir + "/v.txt", "1.0 0.5 -1 2 1\n", velocities).find("expected 4 values, got 5"),
            std::string::npos);

  // 3x3 and 6x6, row-major.
  writeText(dir + "/c3.txt", "2.0 4 1 0 1 9 0 0 0 16\n2.1 1 0 0 0 1 0 0 0 1\n");
  const std::vector<StampedCovariance> c3 = readEstimateCovariances(dir + "/c3.txt");
  ASSERT_EQ(c3.size(), 2u);
  EXPECT_EQ(c3[0].covariance.rows(), 3);
  EXPECT_DOUBLE_EQ(c3[0].covariance(0, 1), 1.0);
  EXPECT_DOUBLE_EQ(c3[0].covariance(2, 2), 16.0);
  std::string line6 = "5.0";
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) line6 += r == c ? " " + std::to_string(r + 1) : (r + c == 5 ? " 0.1" : " 0");
  writeText(dir + "/c6.txt", line6 + "\n");
  const std::vector<StampedCovariance> c6 = readEstimateCovariances(dir + "/c6.txt");
  ASSERT_EQ(c6.size(), 1u);
  EXPECT_EQ(c6[0].covariance.rows(), 6);
  EXPECT_DOUBLE_EQ(c6[0].covariance(0, 5), 0.1);
  EXPECT_DOUBLE_EQ(c6[0].covariance(5, 5), 6.0);

  const auto covariances = [](const std::string& p) { readEstimateCovariances(p); };
  EXPECT_NE(errorOf(dir + "/c.txt", "1 2 3\n", covariances).find("c.txt:1: expected 10 or 37 values"),
            std::string::npos);
  EXPECT_NE(errorOf(dir + "/c.txt", "2.0 4 1 0 1 9 0 0 0 16\n" + line6 + "\n", covariances)
                .find("c.txt:2: expected 10 values"),
            std::string::npos);
  EXPECT_NE(errorOf(dir + "/c.txt", "2.0 4 1 0 0 9 0 0 0 16\n", covariances)
                .find("c.txt:1: the covariance is not symmetric"),
            std::string::npos);
  EXPECT_NE(errorOf(dir + "/c.txt", "2.0 1 2 0 2 1 0 0 0 1\n", covariances)
                .find("c.txt:1: the covariance is not positive definite"),
            std::string::npos);
}

TEST(GroundTruthFilesAndAxes, FolderFileAndUpAxis) {
  const std::string dir = test::outputDir("eval_inputs_gt");
  writeTumTrajectory(dir + "/groundtruth.txt", test::straightLine(5));
  GroundTruthFiles files = findGroundTruthFiles(dir);  // a folder without groundtruth_state.txt
  EXPECT_EQ(files.trajectory_path, dir + "/groundtruth.txt");
  EXPECT_EQ(files.state_path, "");
  files = findGroundTruthFiles(dir + "/groundtruth.txt");  // a file
  EXPECT_EQ(files.trajectory_path, dir + "/groundtruth.txt");
  EXPECT_EQ(files.state_path, "");
  EXPECT_THROW(findGroundTruthFiles(dir + "/nothing"), EvalError);
  const std::string empty = test::outputDir("eval_inputs_empty");
  EXPECT_THROW(findGroundTruthFiles(empty), EvalError);

  EXPECT_EQ(parseAxis("+z"), Eigen::Vector3d::UnitZ());
  EXPECT_EQ(parseAxis("z"), Eigen::Vector3d::UnitZ());
  EXPECT_EQ(parseAxis("-y"), -Eigen::Vector3d::UnitY());
  EXPECT_EQ(parseAxis("+x"), Eigen::Vector3d::UnitX());
  for (const char* bad : {"", "w", "+w", "*z", "-zz", "up"}) EXPECT_THROW(parseAxis(bad), EvalError) << bad;
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
