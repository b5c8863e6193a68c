/// DatasetWriter -> Dataset::open round trip of the planetary_vo format, camera YAML and TUM trajectories.

#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "dataset_test_util.h"
#include "planetary_vo/dataset/dataset.h"
#include "test_support.h"

namespace planetary_vo {
namespace {

using test::makePose;
using test::rotationErrorRad;
using test::translationError;

struct WrittenSequence {
  PinholeCamera camera;
  std::vector<double> stamps_s;
  std::vector<cv::Mat> images;
  Trajectory poses;
  std::vector<ImuSample> imu;
  std::vector<AltimeterSample> altimeter;
  std::string yaml;
};

/// Writes a small descent-like sequence with all streams; returns what was written.
WrittenSequence writeSequence(const std::string& dir, int image_type) {
  WrittenSequence w;
  w.camera =
      PinholeCamera(64, 48, 70.123456789, 71.5, 31.5, 23.25, "plumb_bob", {-0.1, 0.01, 1e-4, -2e-4, 0.0});
  w.yaml = "name: descent_test\ntrajectory:\n  start_altitude_m: 2000\nseed: 7\n";
  DatasetWriter writer(dir, w.camera);
  writer.setSequenceYaml(w.yaml);
  cv::RNG rng(3);
  for (int i = 0; i < 6; ++i) {
    const double t = 1234.000000001 + 0.1 * i + 1e-9 * i;
    const Pose T = makePose(Eigen::Vector3d(rng.uniform(-1., 1.), rng.uniform(-1., 1.), 1.0), 0.3 * i - 1.0,
                            Eigen::Vector3d(100.0 * i + 0.123456789, -2000.5 + i, 1999.0 - 50.0 * i));
    w.stamps_s.push_back(t);
    w.images.push_back(test::syntheticImage(64, 48, image_type, i));
    w.poses.push_back({t, T});
    writer.addFrame(t, w.images.back(), T);
  }
  for (int k = 0; k < 200; ++k) {
    ImuSample s;
    s.timestamp_s = 1234.0 + k * 0.005;
    s.angular_velocity_radps = Eigen::Vector3d(rng.gaussian(0.01), rng.gaussian(0.01), rng.gaussian(0.01));
    s.specific_force_mps2 = Eigen::Vector3d(rng.gaussian(1.0), rng.gaussian(1.0), 1.62 + rng.gaussian(0.1));
    w.imu.push_back(s);
    writer.addImu(s);
  }
  for (int k = 0; k < 20; ++k) {
    // Every 7th sample has no return (+inf, REP-117).
    const AltimeterSample s{1234.0 + k * 0.05,
                            k % 7 == 3 ? std::numeric_limits<double>::infinity() : 2100.0 - k * 1.0 / 3.0};
    w.altimeter.push_back(s);
    writer.addAltimeter(s);
  }
  writer.finish();
  EXPECT_EQ(writer.numFrames(), 6u);
  return w;
}

void expectSameSequence(const WrittenSequence& w, const Dataset& d) {
  EXPECT_EQ(d.format(), DatasetFormat::kPlanetaryVo);
  EXPECT_EQ(d.name(), "descent_test");
  EXPECT_EQ(d.camera(), w.camera);
  EXPECT_EQ(d.sequenceYaml(), w.yaml);
  ASSERT_EQ(d.size(), w.stamps_s.size());
  ASSERT_TRUE(d.hasGroundTruth());
  ASSERT_EQ(d.groundTruth().size(), w.poses.size());
  for (size_t i = 0; i < d.size(); ++i) {
    EXPECT_NEAR(d.timestamp(i), w.stamps_s[i], 1e-9);
    EXPECT_NEAR(d.groundTruth()[i].timestamp_s, w.stamps_s[i], 1e-9);
    EXPECT_LT(translationError(d.groundTruth()[i].T_world_cam, w.poses[i].T_world_cam), 1e-9) << i;
    EXPECT_LT(rotationErrorRad(d.groundTruth()[i].T_world_cam, w.poses[i].T_world_cam), 1e-9) << i;
    const cv::Mat raw = d.loadImageUnchanged(i);
    ASSERT_EQ(raw.type(), w.images[i].type());
    EXPECT_EQ(cv::norm(raw, w.images[i], cv::NORM_INF), 0.0) << "image " << i << " is not bit exact";
    char name[32];
    std::snprintf(name, sizeof(name), "%06zu.png", i);
    EXPECT_EQ(d.imagePath(i), d.directory() + "/images/" + name);
  }
  ASSERT_EQ(d.imu().size(), w.imu.size());
  for (size_t k = 0; k < w.imu.size(); ++k) {
    EXPECT_NEAR(d.imu()[k].timestamp_s, w.imu[k].timestamp_s, 1e-9);
    EXPECT_EQ(d.imu()[k].angular_velocity_radps, w.imu[k].angular_velocity_radps) << k;
    EXPECT_EQ(d.imu()[k].specific_force_mps2, w.imu[k].specific_force_mps2) << k;
  }
  ASSERT_EQ(d.altimeter().size(), w.altimeter.size());
  for (size_t k = 0; k < w.altimeter.size(); ++k) {
    EXPECT_NEAR(d.altimeter()[k].timestamp_s, w.altimeter[k].timestamp_s, 1e-9);
    EXPECT_EQ(d.altimeter()[k].slant_range_m, w.altimeter[k].slant_range_m);
    EXPECT_EQ(d.altimeter()[k].hasReturn(), k % 7 != 3);
  }
}

TEST(DatasetRoundTrip, EightBitSequenceReadsBackExactly) {
  const std::string dir = test::outputDir("dataset_roundtrip_8bit");
  const WrittenSequence w = writeSequence(dir, CV_8UC1);
  const Dataset d = Dataset::open(dir);
  expectSameSequence(w, d);
  const cv::Mat gray = d.loadImage(2);
  EXPECT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(gray, w.images[2], cv::NORM_INF), 0.0);
}

TEST(DatasetRoundTrip, SixteenBitImagesStayExactAndLoadAsScaledEightBit) {
  const std::string dir = test::outputDir("dataset_roundtrip_16bit");
  const WrittenSequence w = writeSequence(dir, CV_16UC1);
  const Dataset d = Dataset::open(dir + "/");  // a trailing slash must not change the name or paths
  expectSameSequence(w, d);
  const cv::Mat gray = d.loadImage(1);
  ASSERT_EQ(gray.type(), CV_8UC1);
  cv::Mat expected;
  w.images[1].convertTo(expected, CV_8U, 1.0 / 257.0);
  EXPECT_EQ(cv::norm(gray, expected, cv::NORM_INF), 0.0);
  EXPECT_EQ(gray.at<uint8_t>(0, 0), cv::saturate_cast<uint8_t>(w.images[1].at<uint16_t>(0, 0) / 257.0));
}

TEST(DatasetRoundTrip, DestructorFinishesAndGroundTruthIsOptional) {
  const std::string dir = test::outputDir("dataset_no_gt");
  {
    DatasetWriter writer(dir, PinholeCamera::fromFieldOfView(32, 24, 60.0));
    writer.addFrame(0.5, test::syntheticImage(32, 24, CV_8UC1, 1), Pose::Identity());
    writer.addFrame(0.75, test::syntheticImage(32, 24, CV_8UC1, 2), Pose::Identity());
  }  // no finish(): the destructor writes the text files
  ASSERT_EQ(std::remove((dir + "/groundtruth.txt").c_str()), 0);
  const Dataset d = Dataset::open(dir);
  EXPECT_FALSE(d.hasGroundTruth());
  EXPECT_EQ(d.name(), "dataset_no_gt");  // empty sequence.yaml: the folder name
  ASSERT_EQ(d.size(), 2u);
  EXPECT_DOUBLE_EQ(d.timestamp(1), 0.75);
  EXPECT_TRUE(d.imu().empty());
  EXPECT_TRUE(d.altimeter().empty());
  EXPECT_EQ(d.camera(), PinholeCamera::fromFieldOfView(32, 24, 60.0));
}

TEST(CameraInfoYaml, IdealCameraIsWrittenAsPlumbBobZerosAndReadBackIdeal) {
  const std::string dir = test::outputDir("camera_yaml");
  const PinholeCamera ideal(1241, 376, 718.856, 718.856, 607.1928, 185.2157);
  writeCameraInfoYaml(dir + "/ideal.yaml", ideal, "kitti_left");
  EXPECT_EQ(readCameraInfoYaml(dir + "/ideal.yaml"), ideal);
  const PinholeCamera fisheye(640, 480, 300.0, 301.0, 320.0, 240.0, "equidistant",
                              {0.1, -0.01, 0.001, -1e-4});
  writeCameraInfoYaml(dir + "/fisheye.yaml", fisheye, "fisheye");
  EXPECT_EQ(readCameraInfoYaml(dir + "/fisheye.yaml"), fisheye);

  // A file as written by ROS camera_calibration_parsers.
  test::writeText(
      dir + "/ros.yaml",
      "image_width: 752\nimage_height: 480\ncamera_name: cam0\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
      "  data: [458.654, 0, 367.215, 0, 457.296, 248.375, 0, 0, 1]\ndistortion_model: plumb_bob\n"
      "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [-0.28340811, 0.07395907, 0.00019359, "
      "1.76187114e-05, 0]\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, "
      "1]\nprojection_matrix:\n  rows: 3\n  cols: 4\n  data: [458.654, 0, 367.215, 0, 0, 457.296, "
      "248.375, 0, 0, 0, 1, 0]\n");
  const PinholeCamera ros = readCameraInfoYaml(dir + "/ros.yaml");
  EXPECT_EQ(ros, PinholeCamera(752, 480, 458.654, 457.296, 367.215, 248.375, "plumb_bob",
                               {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0}));
}

TEST(TrajectoryFiles, TumWriteReadAndFormatDetection) {
  const std::string dir = test::outputDir("trajectory_files");
  Trajectory written;
  for (int i = 0; i < 10; ++i)
    written.push_back({1.5e9 + 0.033 * i,
                       makePose(Eigen::Vector3d(1, 2, 3), 0.2 * i, Eigen::Vector3d(i, -0.5 * i, 1e4 + i))});
  writeTumTrajectory(dir + "/traj.txt", written);
  for (const Trajectory& read : {readTumTrajectory(dir + "/traj.txt"), readTrajectory(dir + "/traj.txt")}) {
    ASSERT_EQ(read.size(), written.size());
    for (size_t i = 0; i < read.size(); ++i) {
      EXPECT_NEAR(read[i].timestamp_s, written[i].timestamp_s, 1e-6);  // 1.5e9 s: double resolution 2.4e-7 s
      EXPECT_LT(translationError(read[i].T_world_cam, written[i].T_world_cam), 1e-9);
      EXPECT_LT(rotationErrorRad(read[i].T_world_cam, written[i].T_world_cam), 1e-9);
    }
  }
  test::writeText(dir + "/kitti.txt",
                  "1 0 0 1.5 0 1 0 -2 0 0 1 3\n"
                  "0 -1 0 4 1 0 0 5 0 0 1 6\n");
  const Trajectory kitti = readTrajectory(dir + "/kitti.txt");
  ASSERT_EQ(kitti.size(), 2u);
  EXPECT_DOUBLE_EQ(kitti[1].timestamp_s, 0.1);
  EXPECT_EQ(kitti[0].T_world_cam.translation(), Eigen::Vector3d(1.5, -2, 3));
  EXPECT_LT(rotationErrorRad(kitti[1].T_world_cam,
                             makePose(Eigen::Vector3d::UnitZ(), M_PI / 2, Eigen::Vector3d(4, 5, 6))),
            1e-12);
  EXPECT_DOUBLE_EQ(readKittiTrajectory(dir + "/kitti.txt", 20.0)[1].timestamp_s, 0.05);
}

// Ground truth that only the evaluator reads goes to its own files, never into the sensor streams.
TEST(DatasetRoundTrip, GroundTruthFilesAreSeparateFromTheSensorStreams) {
  const std::string dir = test::outputDir("dataset_ground_truth_files");
  const PinholeCamera calibrated(64, 48, 70.0, 70.0, 31.5, 23.5, "plumb_bob", {-0.04, 0.002, 0, 0, 0});
  const PinholeCamera truth(64, 48, 70.05, 70.05, 31.8, 23.2, "plumb_bob", {-0.0405, 0.002, 0, 0, 0});
  {
    DatasetWriter writer(dir, calibrated);
    writer.setTrueCamera(truth);
    writer.addFrame(1.0, test::syntheticImage(64, 48, CV_8UC1, 0), Pose::Identity());
    writer.addAltimeter({1.0, 812.25});
    writer.addAltimeter({1.05, std::numeric_limits<double>::infinity()});
    GroundTruthState g;
    g.timestamp_s = 1.0;
    g.T_world_body.translation() = Eigen::Vector3d(1, -2, 650);
    g.velocity_world_mps = Eigen::Vector3d(0.5, 20.25, -3);
    g.gyro_bias_radps = Eigen::Vector3d(1e-5, -2e-5, 3e-5);
    g.accel_bias_mps2 = Eigen::Vector3d(0.001, 0.002, -0.003);
    writer.addGroundTruthState(g);
    g.timestamp_s = 1.005;
    writer.addGroundTruthState(g);
    EXPECT_THROW(writer.addGroundTruthState(g), DatasetError);  // stamps must increase
    writer.addAltimeterTruth({1.0, 812.0, 800.0, 12.5, true, false});
    writer.addAltimeterTruth({1.05, std::numeric_limits<double>::infinity(), 799.0,
                              std::numeric_limits<double>::quiet_NaN(), false, false});
    writer.setTextFile("groundtruth_sensors.yaml", "sensor_seed: 3\n");
    EXPECT_THROW(writer.setTextFile("../escape.yaml", "x"), DatasetError);
  }
  // The reader sees the calibration and the measured range only.
  const Dataset d = Dataset::open(dir);
  EXPECT_EQ(d.camera(), calibrated);
  ASSERT_EQ(d.altimeter().size(), 2u);
  EXPECT_EQ(d.altimeter()[0].slant_range_m, 812.25);
  EXPECT_FALSE(d.altimeter()[1].hasReturn());
  EXPECT_EQ(readCameraInfoYaml(dir + "/groundtruth_camera.yaml"), truth);
  // groundtruth_state.txt: 17 values a line; groundtruth_altimeter.txt: 6.
  auto dataLines = [](const std::string& path) {
    std::vector<std::vector<std::string>> rows;
    std::ifstream in(path);
    for (std::string line; std::getline(in, line);) {
      if (line.empty() || line[0] == '#') continue;
      std::istringstream ss(line);
      rows.emplace_back();
      for (std::string tok; ss >> tok;) rows.back().push_back(tok);
    }
    return rows;
  };
  const auto state = dataLines(dir + "/groundtruth_state.txt");
  ASSERT_EQ(state.size(), 2u);
  ASSERT_EQ(state[0].size(), 17u);
  EXPECT_EQ(std::stod(state[0][3]), 650.0);
  EXPECT_EQ(std::stod(state[0][9]), 20.25);
  EXPECT_EQ(std::stod(state[0][16]), -0.003);
  const auto alt = dataLines(dir + "/groundtruth_altimeter.txt");
  ASSERT_EQ(alt.size(), 2u);
  ASSERT_EQ(alt[0].size(), 6u);
  EXPECT_EQ(alt[0][2], "800");
  EXPECT_EQ(alt[1][1], "inf");
  EXPECT_EQ(alt[1][4], "0");
  // altimeter.txt carries the time and the measured range, nothing else.
  const auto measured = dataLines(dir + "/altimeter.txt");
  ASSERT_EQ(measured.size(), 2u);
  EXPECT_EQ(measured[0].size(), 2u);
  EXPECT_EQ(measured[1][1], "inf");
  EXPECT_EQ(test::readText(dir + "/groundtruth_sensors.yaml"), "sensor_seed: 3\n");
}

TEST(DatasetRoundTrip, SensorsYamlGivesTheDataSheetValues) {
  const std::string dir = test::outputDir("dataset_sensors_yaml");
  {
    DatasetWriter writer(dir, PinholeCamera(64, 48, 70.0, 70.0, 31.5, 23.5));
    writer.addFrame(1.0, test::syntheticImage(64, 48, CV_8UC1, 0), Pose::Identity());
  }
  EXPECT_FALSE(Dataset::open(dir).sensorSpecification().has_imu);  // no sensors.yaml: nothing known
  test::writeText(dir + "/sensors.yaml",
                  "preset: flight\nimu:\n  rate_hz: 200\n  gyro_noise_density_radps_per_sqrt_hz: 4.5e-05\n"
                  "  accel_noise_density_mps2_per_sqrt_hz: 0.001\naltimeter:\n  max_range_m: 2000\n"
                  "  min_range_m: 10\n  beam_divergence_rad: 0.0005\n  range_noise_floor_m: 0.3\n");
  const SensorSpecification s = Dataset::open(dir).sensorSpecification();
  EXPECT_TRUE(s.has_imu);
  EXPECT_EQ(s.imu_rate_hz, 200.0);
  EXPECT_EQ(s.gyro_noise_density_radps_per_sqrt_hz, 4.5e-5);
  EXPECT_EQ(s.accel_noise_density_mps2_per_sqrt_hz, 1e-3);
  EXPECT_TRUE(s.has_altimeter);
  EXPECT_EQ(s.altimeter_max_range_m, 2000.0);
  EXPECT_EQ(s.altimeter_min_range_m, 10.0);
  EXPECT_EQ(s.altimeter_beam_divergence_rad, 5e-4);
  EXPECT_EQ(s.altimeter_range_noise_floor_m, 0.3);
  test::writeText(dir + "/sensors.yaml", "altimeter:\n  max_range_m: 5\n  min_range_m: 10\n");
  EXPECT_THROW(Dataset::open(dir), DatasetError);
  test::writeText(dir + "/sensors.yaml", "imu:\n  rate_hz: fast\n");
  EXPECT_THROW(Dataset::open(dir), DatasetError);
}

TEST(DatasetRoundTrip, ExistingFramesKeepTheirImagesAndOldAltimeterFilesStillRead) {
  const std::string dir = test::outputDir("dataset_existing_frames");
  const PinholeCamera camera(32, 24, 30.0, 30.0, 15.5, 11.5);
  const cv::Mat image = test::syntheticImage(32, 24, CV_16UC1, 2);
  {
    DatasetWriter writer(dir, camera);
    writer.addFrame(0.0, image, Pose::Identity());
  }
  {
    DatasetWriter writer(dir, camera);  // a cached render whose streams are written again
    writer.addExistingFrame(0.0, Pose::Identity());
    EXPECT_THROW(writer.addExistingFrame(0.1, Pose::Identity()), DatasetError);  // no images/000001.png
  }
  // Renderer 1.2 wrote a third altimeter column (the true altitude): it is ignored.
  test::writeText(dir + "/altimeter.txt", "# t range altitude\n0.0 812.5 800.0\n0.05 inf 799.5\n");
  const Dataset d = Dataset::open(dir);
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(cv::norm(d.loadImageUnchanged(0), image, cv::NORM_INF), 0.0);
  ASSERT_EQ(d.altimeter().size(), 2u);
  EXPECT_EQ(d.altimeter()[0].slant_range_m, 812.5);
  EXPECT_FALSE(d.altimeter()[1].hasReturn());
  test::writeText(dir + "/altimeter.txt", "0.0 -5\n");
  EXPECT_THROW(Dataset::open(dir), DatasetError);  // a negative range
  test::writeText(dir + "/altimeter.txt", "0.0 5 6 7\n");
  EXPECT_THROW(Dataset::open(dir), DatasetError);
}

TEST(TrajectoryFiles, InterpolatePoseIsLinearInPositionAndSlerpInRotation) {
  const Trajectory samples = {{10.0, makePose(Eigen::Vector3d::UnitX(), 0.2, Eigen::Vector3d(0, 0, 0))},
                              {10.5, makePose(Eigen::Vector3d::UnitX(), 0.6, Eigen::Vector3d(1, 2, -4))},
                              {11.0, makePose(Eigen::Vector3d::UnitY(), 0.1, Eigen::Vector3d(1, 2, -4))}};
  Pose T;
  ASSERT_TRUE(interpolatePose(samples, 10.125, &T));
  const Pose expected = makePose(Eigen::Vector3d::UnitX(), 0.3, Eigen::Vector3d(0.25, 0.5, -1.0));
  EXPECT_LT(translationError(T, expected), 1e-12);
  EXPECT_LT(rotationErrorRad(T, expected), 1e-12);
  ASSERT_TRUE(interpolatePose(samples, 11.0, &T));
  EXPECT_LT(rotationErrorRad(T, samples[2].T_world_cam), 1e-12);
  EXPECT_FALSE(interpolatePose(samples, 9.999, &T));
  EXPECT_FALSE(interpolatePose(samples, 11.001, &T));
  EXPECT_FALSE(interpolatePose({}, 10.0, &T));
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
