/// Broken input gives a DatasetError whose message names the file (and line) and the problem.

#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "dataset_test_util.h"
#include "planetary_vo/dataset/dataset.h"
#include "test_support.h"

namespace planetary_vo {
namespace {

using test::throwsDatasetError;

/// A valid 3-frame planetary_vo dataset to break.
std::string writeValidDataset(const std::string& name) {
  const std::string dir = test::outputDir(name);
  DatasetWriter writer(dir, PinholeCamera::fromFieldOfView(16, 12, 45.0));
  for (int i = 0; i < 3; ++i)
    writer.addFrame(i * 0.1, test::syntheticImage(16, 12, CV_8UC1, i), Pose::Identity());
  writer.addImu({0.0, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 1.62)});
  writer.finish();
  return dir;
}

TEST(DatasetErrors, MissingFolderAndUnknownLayout) {
  EXPECT_TRUE(throwsDatasetError([] { Dataset::open("/nonexistent/planetary_vo/seq"); },
                                 "dataset folder /nonexistent/planetary_vo/seq does not exist"));
  const std::string empty = test::outputDir("errors_empty");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(empty); }, "unknown dataset layout in " + empty));
}

TEST(DatasetErrors, BadLinesNameFileAndLine) {
  const std::string dir = writeValidDataset("errors_bad_lines");
  test::writeText(dir + "/groundtruth.txt",
                  "# t tx ty tz qx qy qz qw\n0.0 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 1\n0.2 0 0 0 0 0 0 1\n");
  EXPECT_TRUE(
      throwsDatasetError([&] { Dataset::open(dir); }, dir + "/groundtruth.txt:3: expected 8 values, got 7"));
  test::writeText(dir + "/groundtruth.txt", "0.0 0 0 0 0 0 0 1\n0.1 0 0 zero 0 0 0 1\n0.2 0 0 0 0 0 0 1\n");
  EXPECT_TRUE(
      throwsDatasetError([&] { Dataset::open(dir); }, "groundtruth.txt:2: value 4 'zero' is not a finite"));
  test::writeText(dir + "/groundtruth.txt", "0.0 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 0 2\n0.2 0 0 0 0 0 0 1\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir); }, "groundtruth.txt:2: quaternion norm"));
  test::writeText(dir + "/groundtruth.txt", "0.0 0 0 0 0 0 0 1\n0.2 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 0 1\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir); },
                                 "groundtruth.txt:3: time stamp 0.100000000 is not after"));
  std::remove((dir + "/groundtruth.txt").c_str());
  test::writeText(dir + "/imu.txt", "# t wx wy wz ax ay az\n0.0 0 0 0 0 0 1.62\n0.005 0 0 0 0 0\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir); }, dir + "/imu.txt:3: expected 7 values, got 6"));
  std::remove((dir + "/imu.txt").c_str());
  test::writeText(dir + "/altimeter.txt", "# t slant_range_m\n\n0.0 100 90 7\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir); },
                                 dir + "/altimeter.txt:3: expected 2 values (t slant_range_m), got 4"));
  test::writeText(dir + "/altimeter.txt", "# t slant_range_m\n0.0 1e5x\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir); }, dir + "/altimeter.txt:2:"));
}

TEST(DatasetErrors, InconsistentFiles) {
  const std::string dir = writeValidDataset("errors_inconsistent");
  std::remove((dir + "/images/000002.png").c_str());
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir); }, ": 2 images but 3 time stamps"));

  const std::string dir2 = writeValidDataset("errors_gt_stamps");
  test::writeText(dir2 + "/groundtruth.txt", "0.0 0 0 0 0 0 0 1\n0.15 0 0 0 0 0 0 1\n0.2 0 0 0 0 0 0 1\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir2); }, "pose 1 is not at the stamp of image 1"));
  std::remove((dir2 + "/times.txt").c_str());
  std::remove((dir2 + "/groundtruth.txt").c_str());
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir2); }, "neither times.txt nor groundtruth.txt"));

  const std::string dir3 = writeValidDataset("errors_camera");
  test::writeText(dir3 + "/camera.yaml",
                  "image_width: 16\nimage_height: 12\ncamera_matrix:\n  data: [1, 0, 0]\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir3); },
                                 "camera.yaml: 'camera_matrix' has 3 values, expected 9"));
  test::writeText(dir3 + "/camera.yaml", "image_width: [16\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir3); }, "camera.yaml: not valid YAML"));
  test::writeText(
      dir3 + "/camera.yaml",
      "image_width: 16\nimage_height: 12\ncamera_matrix:\n  data: [-5, 0, 8, 0, 5, 6, 0, 0, 1]\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir3); }, "invalid camera: focal length"));
  // Issue 12: finite but absurd intrinsics and a distortion vector of the wrong length are refused when the
  // dataset opens (vo_run with cx = 1e9 used to exit 0 with non-unit quaternions).
  const std::string k = "image_width: 16\nimage_height: 12\ncamera_matrix:\n  data: [";
  test::writeText(dir3 + "/camera.yaml", k + "14.5, 0, 1e9, 0, 14.5, 5.5, 0, 0, 1]\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir3); }, "invalid camera: principal point"));
  test::writeText(dir3 + "/camera.yaml", k + "1e9, 0, 7.5, 0, 1e9, 5.5, 0, 0, 1]\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir3); }, "field of view"));
  test::writeText(dir3 + "/camera.yaml", k + "14.5, 0, 7.5, 0, 14.5, 5.5, 0, 0, 1]\ndistortion_model: plumb_bob\n"
                                             "distortion_coefficients:\n  data: [0.01, 0.001, 0.0001]\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(dir3); }, "plumb_bob distortion needs 5 coefficients, got 3"));
}

TEST(DatasetErrors, UnreadableImageAndKittiPoseCount) {
  const std::string dir = writeValidDataset("errors_image");
  const Dataset d = Dataset::open(dir);
  test::writeText(dir + "/images/000001.png", "not a png");
  EXPECT_TRUE(throwsDatasetError([&] { d.loadImage(1); }, "cannot read image " + dir + "/images/000001.png"));

  const std::string kitti = test::outputDir("errors_kitti");
  std::filesystem::create_directories(kitti + "/image_0");
  for (int i = 0; i < 2; ++i)
    ASSERT_TRUE(cv::imwrite(kitti + "/image_0/00000" + std::to_string(i) + ".png",
                            test::syntheticImage(8, 8, CV_8UC1, i)));
  test::writeText(kitti + "/calib.txt", "P0: 100 0 4 0 0 100 4 0 0 0 1 0\n");
  test::writeText(kitti + "/poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_TRUE(throwsDatasetError([&] { Dataset::open(kitti); }, "poses.txt: 1 poses for 2 images"));
  test::writeText(kitti + "/poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n2 0 0 0 0 1 0 0 0 0 1 0\n");
  EXPECT_TRUE(
      throwsDatasetError([&] { Dataset::open(kitti); }, "poses.txt:2: the 3x3 block is not a rotation"));
}

TEST(DatasetErrors, TrajectoryFilesAndWriterMisuse) {
  const std::string dir = test::outputDir("errors_trajectory");
  test::writeText(dir + "/five.txt", "# comment\n1 2 3 4 5\n");
  EXPECT_TRUE(throwsDatasetError([&] { readTrajectory(dir + "/five.txt"); },
                                 "five.txt:2: 5 values: neither TUM (8: t tx ty tz qx qy qz qw) nor KITTI"));
  test::writeText(dir + "/empty.txt", "# nothing\n");
  EXPECT_TRUE(
      throwsDatasetError([&] { readTrajectory(dir + "/empty.txt"); }, "empty.txt: no pose in the file"));
  EXPECT_TRUE(throwsDatasetError([&] { readTrajectory(dir + "/missing.txt"); },
                                 "cannot open " + dir + "/missing.txt"));

  DatasetWriter writer(dir + "/seq", PinholeCamera::fromFieldOfView(16, 12, 45.0));
  EXPECT_TRUE(throwsDatasetError(
      [&] { writer.addFrame(0.0, cv::Mat(12, 16, CV_8UC3, cv::Scalar::all(0)), Pose::Identity()); },
      "8- or 16-bit single-channel"));
  EXPECT_TRUE(throwsDatasetError([&] { writer.addFrame(0.0, cv::Mat(10, 16, CV_8UC1), Pose::Identity()); },
                                 "image is 16x10, the camera 16x12"));
  writer.addFrame(1.0, test::syntheticImage(16, 12, CV_8UC1, 0), Pose::Identity());
  EXPECT_TRUE(throwsDatasetError(
      [&] { writer.addFrame(1.0, test::syntheticImage(16, 12, CV_8UC1, 1), Pose::Identity()); },
      "time stamps must increase"));
  EXPECT_TRUE(throwsDatasetError(
      [] { DatasetWriter("/proc/cannot_create_here", PinholeCamera::fromFieldOfView(16, 12, 45.0)); },
      "cannot create /proc/cannot_create_here/images"));
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
