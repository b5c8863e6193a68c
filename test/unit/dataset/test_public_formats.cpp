/// Readers of the public formats: the real KITTI clip, and small EuRoC / TUM RGB-D / KITTI folders written
/// here.

#include <cstdio>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dataset_test_util.h"
#include "planetary_vo/dataset/dataset.h"
#include "test_support.h"

namespace planetary_vo {
namespace {

using test::makePose;
using test::rotationErrorRad;
using test::translationError;

// ----------------------------------------------------------------------------------------------------------------
// KITTI
// ----------------------------------------------------------------------------------------------------------------

TEST(KittiReader, RealClip) {
  const std::string dir = test::dataPath("kitti_clip_turn");
  ASSERT_TRUE(test::requireDataFile(dir + "/poses.txt"));
  const Dataset d = Dataset::open(dir);
  EXPECT_EQ(d.format(), DatasetFormat::kKitti);
  EXPECT_STREQ(toString(d.format()), "kitti");
  EXPECT_EQ(d.name(), "kitti_clip_turn");
  ASSERT_EQ(d.size(), 51u);
  EXPECT_EQ(d.camera(), PinholeCamera(1241, 376, 718.856, 718.856, 607.1928, 185.2157));
  EXPECT_FALSE(d.camera().hasDistortion());
  EXPECT_DOUBLE_EQ(d.timestamp(0), 0.0);
  EXPECT_DOUBLE_EQ(d.timestamp(50), 5.0);  // no times.txt: 10 Hz
  EXPECT_EQ(d.imagePath(50), dir + "/image_l/000050.png");
  const cv::Mat image = d.loadImage(0);
  EXPECT_EQ(image.type(), CV_8UC1);
  EXPECT_EQ(image.size(), cv::Size(1241, 376));

  ASSERT_TRUE(d.hasGroundTruth());
  ASSERT_EQ(d.groundTruth().size(), 51u);
  const Pose& first = d.groundTruth().front().T_world_cam;
  EXPECT_LT(translationError(first, Pose::Identity()), 1e-9);
  EXPECT_LT(rotationErrorRad(first, Pose::Identity()), 1e-6);
  // Line 2 of poses.txt.
  EXPECT_LT(
      (d.groundTruth()[1].T_world_cam.translation() - Eigen::Vector3d(5.154656e-02, -2.424883e-02, 1.000725))
          .norm(),
      1e-12);
  EXPECT_NEAR(d.groundTruth()[1].T_world_cam.linear()(0, 2), 4.355194e-02, 1e-6);
  const Pose& last = d.groundTruth().back().T_world_cam;
  EXPECT_LT((last.translation() - Eigen::Vector3d(40.02403, -0.8564479, 19.93253)).norm(), 1e-9);
  EXPECT_NEAR(rotationAngleDeg(first.rotation().transpose() * last.rotation()), 98.0695, 1e-3);  // the turn
  for (const StampedPose& p : d.groundTruth()) {
    EXPECT_LT(
        (p.T_world_cam.linear().transpose() * p.T_world_cam.linear() - Eigen::Matrix3d::Identity()).norm(),
        1e-12);
  }
  EXPECT_DOUBLE_EQ(d.groundTruth()[7].timestamp_s, d.timestamp(7));
}

TEST(KittiReader, LabelledCalibTimesFileAndBenchmarkPoseLayout) {
  // dataset/sequences/07/{image_0, calib.txt, times.txt} and dataset/poses/07.txt, as the benchmark ships
  // them.
  const std::string root = test::outputDir("kitti_layout");
  const std::string seq = root + "/sequences/07";
  std::filesystem::create_directories(seq + "/image_0");
  std::filesystem::create_directories(root + "/poses");
  for (int i = 0; i < 3; ++i) {
    char name[64];
    std::snprintf(name, sizeof(name), "/image_0/%06d.png", i);
    // The size of sequence 07's images: its principal point must be inside them (PinholeCamera::isValid()).
    ASSERT_TRUE(cv::imwrite(seq + name, test::syntheticImage(1226, 370, CV_8UC1, i)));
  }
  test::writeText(seq + "/calib.txt",
                  "P0: 7.070912e+02 0 6.018873e+02 0 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n"
                  "P1: 7.070912e+02 0 6.018873e+02 -3.798145e+02 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n");
  test::writeText(seq + "/times.txt", "0.000000e+00\n1.036211e-01\n2.072235e-01\n");
  test::writeText(root + "/poses/07.txt",
                  "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0.1 0 1 0 0 0 0 1 0.9\n1 0 0 0.2 0 1 0 0 0 0 1 1.8\n");
  const Dataset d = Dataset::open(seq);
  EXPECT_EQ(d.name(), "07");
  ASSERT_EQ(d.size(), 3u);
  EXPECT_EQ(d.camera(), PinholeCamera(1226, 370, 707.0912, 707.0912, 601.8873, 183.1104));
  EXPECT_DOUBLE_EQ(d.timestamp(1), 0.1036211);
  ASSERT_EQ(d.groundTruth().size(), 3u);
  EXPECT_DOUBLE_EQ(d.groundTruth()[2].timestamp_s, 0.2072235);  // poses take the times.txt stamps
  EXPECT_LT((d.groundTruth()[2].T_world_cam.translation() - Eigen::Vector3d(0.2, 0, 1.8)).norm(), 1e-15);
}

// ----------------------------------------------------------------------------------------------------------------
// EuRoC
// ----------------------------------------------------------------------------------------------------------------

constexpr long long kEurocStartNs = 1403636579763555584LL;

/// The body motion of the synthetic EuRoC and TUM folders: constant velocity, constant rate about a fixed
/// axis, so that linear interpolation and slerp reproduce it exactly.
Pose bodyPoseAt(double t_rel_s) {
  return makePose(Eigen::Vector3d(0.2, -0.3, 1.0), 0.5 + 0.4 * t_rel_s,
                  Eigen::Vector3d(1.0 + 0.8 * t_rel_s, -2.0 + 0.3 * t_rel_s, 0.7 - 0.1 * t_rel_s));
}

double relativeSeconds(long long stamp_ns) { return static_cast<double>(stamp_ns - kEurocStartNs) * 1e-9; }

TEST(EurocReader, CameraPosesFromBodyGroundTruthAndExtrinsic) {
  const std::string seq = test::outputDir("euroc/MH_synthetic");
  const std::string mav0 = seq + "/mav0";
  for (const char* sub : {"/cam0/data", "/imu0", "/state_groundtruth_estimate0"})
    std::filesystem::create_directories(mav0 + sub);
  // cam0 sensor.yaml: the layout of the EuRoC files, with a non-trivial T_BS.
  const Pose T_BS = makePose(Eigen::Vector3d(0.1, 0.2, 1.0), 1.5, Eigen::Vector3d(-0.0216, -0.0647, 0.0098));
  std::string t_bs_text;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) t_bs_text += (r + c ? ", " : "") + std::to_string(T_BS.matrix()(r, c));
  // EuRoC's cam0 intrinsics with the principal point moved into the 48x32 test images (the original's, at
  // (367, 248), is outside them, which PinholeCamera::isValid() rejects).
  char yaml[2048];
  std::snprintf(yaml, sizeof(yaml),
                "# General sensor definitions.\nsensor_type: camera\ncomment: VI-Sensor cam0 (MT9M034)\n\n"
                "T_BS:\n  cols: 4\n  rows: 4\n  data: [%s]\n\nrate_hz: 20\nresolution: [48, 32]\n"
                "camera_model: pinhole\nintrinsics: [458.654, 457.296, 23.215, 16.375] #fu, fv, cu, cv\n"
                "distortion_model: radial-tangential\n"
                "distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n",
                t_bs_text.c_str());
  test::writeText(mav0 + "/cam0/sensor.yaml", yaml);
  // T_BS as the reader sees it (printed with std::to_string's 6 decimals).
  Pose T_BS_printed = Pose::Identity();
  {
    Eigen::Matrix4d M;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) M(r, c) = std::stod(std::to_string(T_BS.matrix()(r, c)));
    T_BS_printed.matrix() = M;
  }

  // Images at 20 Hz from the start; ground truth at 200 Hz from start + 12.3 ms: the first image has none.
  std::string images_csv = "#timestamp [ns],filename\n";
  for (int i = 0; i < 6; ++i) {
    const long long ns = kEurocStartNs + i * 50000000LL;
    const std::string name = std::to_string(ns) + ".png";
    images_csv += std::to_string(ns) + "," + name + "\r\n";  // EuRoC's csv files have CRLF line ends
    ASSERT_TRUE(cv::imwrite(mav0 + "/cam0/data/" + name, test::syntheticImage(48, 32, CV_8UC1, i)));
  }
  test::writeText(mav0 + "/cam0/data.csv", images_csv);
  std::string gt_csv =
      "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], "
      "v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad "
      "s^-1], "
      "b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n";
  for (long long ns = kEurocStartNs + 12300000LL; ns <= kEurocStartNs + 260000000LL; ns += 5000000LL) {
    const Pose T = bodyPoseAt(relativeSeconds(ns));
    const Eigen::Quaterniond q(T.rotation());
    char line[512];
    std::snprintf(line, sizeof(line),
                  "%lld,%.12f,%.12f,%.12f,%.15f,%.15f,%.15f,%.15f,0.8,0.3,-0.1,0,0,0,0,0,0\n", ns,
                  T.translation().x(), T.translation().y(), T.translation().z(), q.w(), q.x(), q.y(), q.z());
    gt_csv += line;
  }
  test::writeText(mav0 + "/state_groundtruth_estimate0/data.csv", gt_csv);
  test::writeText(mav0 + "/imu0/data.csv",
                  "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                  "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n"
                  "1403636579758555392,-0.099134701513277898,0.14730578886832138,0.02722713633111154,"
                  "8.1476917083333333,-0.37592158333333331,-2.4026292499999999\n"
                  "1403636579763555584,-0.099134701513277898,0.14032447186034408,0.029321531433504733,"
                  "8.033280791666666,-0.40861041666666664,-2.4026292499999999\n");

  for (const std::string& dir : {seq, mav0}) {  // the sequence folder or mav0 itself
    const Dataset d = Dataset::open(dir);
    EXPECT_EQ(d.format(), DatasetFormat::kEuroc);
    EXPECT_EQ(d.name(), "MH_synthetic");
    EXPECT_EQ(d.camera(), PinholeCamera(48, 32, 458.654, 457.296, 23.215, 16.375, "plumb_bob",
                                        {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0}));
    // Images 1..5 are inside the ground-truth span [12.3 ms, 260 ms]; image 0 (at 0 ms) is dropped.
    ASSERT_EQ(d.size(), 5u);
    ASSERT_EQ(d.groundTruth().size(), 5u);
    for (size_t k = 0; k < d.size(); ++k) {
      const long long ns = kEurocStartNs + static_cast<long long>(k + 1) * 50000000LL;
      EXPECT_NEAR(d.timestamp(k), static_cast<double>(ns) * 1e-9, 1e-6);
      EXPECT_EQ(d.imagePath(k), mav0 + "/cam0/data/" + std::to_string(ns) + ".png");
      const Pose expected = bodyPoseAt(relativeSeconds(ns)) * T_BS_printed;
      // Stamps of 1.4e9 s have a resolution of 2.4e-7 s; at 0.8 m/s that is 2e-7 m.
      EXPECT_LT(translationError(d.groundTruth()[k].T_world_cam, expected), 1e-6) << k;
      EXPECT_LT(rotationErrorRad(d.groundTruth()[k].T_world_cam, expected), 1e-6) << k;
      // T_BS on the wrong side, or no T_BS at all, would be far off.
      EXPECT_GT(
          translationError(d.groundTruth()[k].T_world_cam, T_BS_printed * bodyPoseAt(relativeSeconds(ns))),
          1e-3);
    }
    EXPECT_EQ(cv::norm(d.loadImage(0), test::syntheticImage(48, 32, CV_8UC1, 1), cv::NORM_INF), 0.0);
    ASSERT_EQ(d.imu().size(), 2u);
    EXPECT_NEAR(d.imu()[1].timestamp_s, 1403636579.763555584, 1e-6);
    EXPECT_EQ(d.imu()[0].angular_velocity_radps,
              Eigen::Vector3d(-0.099134701513277898, 0.14730578886832138, 0.02722713633111154));
    EXPECT_EQ(d.imu()[1].specific_force_mps2,
              Eigen::Vector3d(8.033280791666666, -0.40861041666666664, -2.4026292499999999));
  }
}

// ----------------------------------------------------------------------------------------------------------------
// TUM RGB-D
// ----------------------------------------------------------------------------------------------------------------

TEST(TumRgbdReader, ColorImagesAsGrayAndInterpolatedGroundTruth) {
  const std::string dir = test::outputDir("tum/rgbd_dataset_freiburg1_synthetic");
  std::filesystem::create_directories(dir + "/rgb");
  const double t0 = 1305031102.175304;
  std::string rgb_txt =
      "# color images\n# file: 'rgbd_dataset_freiburg1_synthetic.bag'\n# timestamp filename\n";
  std::vector<cv::Mat> color;
  std::vector<double> stamps;
  std::vector<std::string> stamp_texts;
  for (int i = 0; i < 5; ++i) {
    char stamp[32];
    std::snprintf(stamp, sizeof(stamp), "%.6f", t0 + 0.0333 * i + 0.001 * (i % 2));
    stamps.push_back(std::stod(stamp));
    stamp_texts.push_back(stamp);
    cv::Mat bgr(24, 32, CV_8UC3);
    cv::randu(bgr, 0, 256);
    color.push_back(bgr);
    ASSERT_TRUE(cv::imwrite(dir + "/rgb/" + stamp + ".png", bgr));
    rgb_txt += std::string(stamp) + " rgb/" + stamp + ".png\n";
  }
  test::writeText(dir + "/rgb.txt", rgb_txt);
  // Ground truth at ~100 Hz from t0 - 0.0047 to t0 + 0.1213: the last image (t0 + 0.1332) has none.
  std::string gt =
      "# ground truth trajectory\n# file: 'rgbd_dataset_freiburg1_synthetic.bag'\n"
      "# timestamp tx ty tz qx qy qz qw\n";
  for (int k = 0; k <= 12; ++k) {
    const double t = t0 - 0.0047 + 0.0105 * k;
    char stamp[32];
    std::snprintf(stamp, sizeof(stamp), "%.4f", t);
    const Pose T = bodyPoseAt(std::stod(stamp) - t0);
    const Eigen::Quaterniond q(T.rotation());
    char line[256];
    std::snprintf(line, sizeof(line), "%s %.9f %.9f %.9f %.12f %.12f %.12f %.12f\n", stamp,
                  T.translation().x(), T.translation().y(), T.translation().z(), q.x(), q.y(), q.z(), q.w());
    gt += line;
  }
  test::writeText(dir + "/groundtruth.txt", gt);

  Dataset d = Dataset::open(dir);
  EXPECT_EQ(d.format(), DatasetFormat::kTumRgbd);
  EXPECT_EQ(d.name(), "rgbd_dataset_freiburg1_synthetic");
  EXPECT_EQ(d.camera(), PinholeCamera(640, 480, 525.0, 525.0, 319.5, 239.5));
  ASSERT_EQ(d.size(), 4u);
  ASSERT_EQ(d.groundTruth().size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_NEAR(d.timestamp(i), stamps[i], 1e-6);
    EXPECT_EQ(d.imagePath(i), dir + "/rgb/" + stamp_texts[i] + ".png");
    const Pose expected = bodyPoseAt(stamps[i] - t0);
    EXPECT_LT(translationError(d.groundTruth()[i].T_world_cam, expected), 2e-6) << i;
    EXPECT_LT(rotationErrorRad(d.groundTruth()[i].T_world_cam, expected), 2e-6) << i;
    cv::Mat expected_gray;
    cv::cvtColor(color[i], expected_gray, cv::COLOR_BGR2GRAY);
    const cv::Mat gray = d.loadImage(i);
    ASSERT_EQ(gray.type(), CV_8UC1);
    EXPECT_EQ(cv::norm(gray, expected_gray, cv::NORM_INF), 0.0);
    EXPECT_EQ(d.loadImageUnchanged(i).type(), CV_8UC3);
  }

  // A camera.yaml beside rgb.txt replaces the default intrinsics.
  const PinholeCamera fr1(640, 480, 517.3, 516.5, 318.6, 255.3, "plumb_bob",
                          {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  writeCameraInfoYaml(dir + "/camera.yaml", fr1, "freiburg1");
  d = Dataset::open(dir);
  EXPECT_EQ(d.camera(), fr1);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
