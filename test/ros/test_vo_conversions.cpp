/// Unit tests (no master) of the VO nodelet's free functions: image conversion to 8-bit gray, input checks,
/// FrameResult -> VoStatus (with the fusion fields), odometry twist and covariance, the navigation output
/// nav/odometry (twist of the child in the child frame, lever arms, covariances), the sample buffer of the
/// IMU and altimeter inputs, map points -> PointCloud2.

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <opencv2/imgproc.hpp>

#include "planetary_vo/VoReconfigureConfig.h"
#include "planetary_vo/ros_io/conversions.h"
#include "planetary_vo/ros_io/ros_params.h"
#include "planetary_vo/ros_io/sample_buffer.h"
#include "planetary_vo/ros_io/vo_conversions.h"

namespace planetary_vo::ros_io {
namespace {

sensor_msgs::ImageConstPtr makeImage(const cv::Mat& m, const std::string& encoding) {
  return cv_bridge::CvImage(std_msgs::Header(), encoding, m).toImageMsg();
}

cv::Mat ramp() {
  cv::Mat gray(4, 6, CV_8UC1);
  for (int i = 0; i < gray.rows * gray.cols; ++i) gray.data[i] = static_cast<uint8_t>(10 * i);
  return gray;
}

TEST(VoConversions, EveryEncodingBecomesTheSameGray) {
  const cv::Mat gray = ramp();
  cv::Mat bgr, rgb, bgra, rgba, mono16, out;
  cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(gray, rgb, cv::COLOR_GRAY2RGB);
  cv::cvtColor(gray, bgra, cv::COLOR_GRAY2BGRA);
  cv::cvtColor(gray, rgba, cv::COLOR_GRAY2RGBA);
  gray.convertTo(mono16, CV_16U, 256.0);
  const std::pair<cv::Mat, std::string> cases[] = {{gray, "mono8"}, {mono16, "mono16"}, {bgr, "bgr8"},
                                                   {rgb, "rgb8"},   {bgra, "bgra8"},    {rgba, "rgba8"}};
  for (const auto& [mat, encoding] : cases) {
    std::string why;
    const sensor_msgs::ImageConstPtr msg = makeImage(mat, encoding);  // mono8 output views its data
    ASSERT_TRUE(toGray8(msg, &out, &why)) << encoding << ": " << why;
    ASSERT_EQ(out.type(), CV_8UC1) << encoding;
    EXPECT_EQ(cv::norm(out, gray, cv::NORM_INF), 0.0) << encoding;
  }
}

TEST(VoConversions, Mono16BigEndianIsSwappedNotTwoChannels) {
  // Issue 12: cv_bridge returned 2 channels for a big-endian mono16 image, and the exposure check asserted on
  // them. The bytes of each pixel are swapped into the host's order; the gray is the same as little-endian.
  const cv::Mat gray = ramp();
  sensor_msgs::Image msg;
  msg.encoding = "mono16";
  msg.width = gray.cols;
  msg.height = gray.rows;
  msg.step = 2 * gray.cols;
  msg.is_bigendian = 1;
  for (int i = 0; i < gray.rows * gray.cols; ++i) {
    const uint16_t v = uint16_t(gray.data[i] * 256 + 77);  // 77: the low byte, dropped by the 8-bit scaling
    msg.data.push_back(uint8_t(v >> 8));
    msg.data.push_back(uint8_t(v & 0xff));
  }
  cv::Mat out;
  std::string why;
  ASSERT_TRUE(toGray8(boost::make_shared<sensor_msgs::Image>(msg), &out, &why)) << why;
  ASSERT_EQ(out.type(), CV_8UC1);
  ASSERT_EQ(out.size(), gray.size());
  EXPECT_EQ(cv::norm(out, gray, cv::NORM_INF), 0.0);
  // Row padding (step > width * 2) is honoured too.
  sensor_msgs::Image padded = msg;
  padded.step = msg.step + 4;
  padded.data.clear();
  for (int r = 0; r < gray.rows; ++r) {
    padded.data.insert(padded.data.end(), msg.data.begin() + r * msg.step,
                       msg.data.begin() + (r + 1) * msg.step);
    padded.data.insert(padded.data.end(), 4, 0xEE);
  }
  ASSERT_TRUE(toGray8(boost::make_shared<sensor_msgs::Image>(padded), &out, &why)) << why;
  EXPECT_EQ(cv::norm(out, gray, cv::NORM_INF), 0.0);
}

TEST(VoConversions, Mono16RightAlignedSamplesUseTheirSignificantBits) {
  // Issue 12: a 12-bit sensor writing right-aligned samples (0..4095) into mono16 came out near-black
  // (4095 / 256 = 15 gray levels). With ~mono16_significant_bits 12 its range maps to 0..255.
  sensor_msgs::Image msg;
  msg.encoding = "mono16";
  msg.width = 4;
  msg.height = 1;
  msg.step = 8;
  for (const uint16_t v : {0, 1024, 2048, 4095}) {  // host order is little-endian on our targets
    msg.data.push_back(uint8_t(v & 0xff));
    msg.data.push_back(uint8_t(v >> 8));
  }
  const auto ptr = boost::make_shared<sensor_msgs::Image>(msg);
  cv::Mat out;
  std::string why;
  ASSERT_TRUE(toGray8(ptr, &out, &why)) << why;
  EXPECT_EQ(out.at<uint8_t>(0, 3), 16) << "16 significant bits: 4095 / 256";
  ASSERT_TRUE(toGray8(ptr, &out, &why, 12)) << why;
  EXPECT_EQ(out.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(out.at<uint8_t>(0, 1), 64);
  EXPECT_EQ(out.at<uint8_t>(0, 2), 128);
  EXPECT_EQ(out.at<uint8_t>(0, 3), 255);
  ASSERT_TRUE(toGray8(ptr, &out, &why, 10)) << why;
  EXPECT_EQ(out.at<uint8_t>(0, 1), 255) << "beyond 10 bits saturates";
  EXPECT_FALSE(toGray8(ptr, &out, &why, 17));
  EXPECT_NE(why.find("outside 8..16"), std::string::npos) << why;
}

TEST(ReconfigureKnobs, DefaultsAndRangesAreTheCoreConfigs) {
  // Issue 12: dynamic_reconfigure repeated the defaults and clamped num_features to [20, 5000] while the
  // configuration accepts [1, 100000]. The knobs' defaults and ranges must be the core's.
  const VoConfig core;
  const VoReconfigureConfig& defaults = VoReconfigureConfig::__getDefault__();
  EXPECT_EQ(defaults.num_features, core.detector.num_features);
  EXPECT_EQ(defaults.motion_model, toString(core.motion.model));
  EXPECT_EQ(defaults.bundle_adjustment_enabled, core.bundle_adjustment.enabled);
  double lo = 0.0, hi = 0.0;
  ASSERT_TRUE(configRange("detector", "num_features", &lo, &hi));
  EXPECT_EQ(VoReconfigureConfig::__getMin__().num_features, lo);
  EXPECT_EQ(VoReconfigureConfig::__getMax__().num_features, hi);
  EXPECT_FALSE(configRange("detector", "num_featurs", &lo, &hi));
}

TEST(VoConversions, ColourWeightsAreBt601) {
  cv::Mat rgb(1, 1, CV_8UC3, cv::Scalar(255, 0, 0));  // pure red in rgb8
  cv::Mat out;
  std::string why;
  ASSERT_TRUE(toGray8(makeImage(rgb, "rgb8"), &out, &why));
  EXPECT_NEAR(out.at<uint8_t>(0, 0), 0.299 * 255, 1.0);
  ASSERT_TRUE(toGray8(makeImage(rgb, "bgr8"), &out, &why));  // the same bytes read as blue
  EXPECT_NEAR(out.at<uint8_t>(0, 0), 0.114 * 255, 1.0);
}

TEST(VoConversions, Mono8IsShared) {
  const sensor_msgs::ImageConstPtr msg = makeImage(ramp(), "mono8");
  cv::Mat out;
  std::string why;
  ASSERT_TRUE(toGray8(msg, &out, &why));
  EXPECT_EQ(static_cast<const void*>(out.data), static_cast<const void*>(msg->data.data()));
}

TEST(VoConversions, RejectsUnsupportedAndInconsistentImages) {
  cv::Mat out;
  std::string why;
  EXPECT_FALSE(toGray8(makeImage(cv::Mat(4, 4, CV_32FC1, cv::Scalar(0.5)), "32FC1"), &out, &why));
  EXPECT_NE(why.find("unsupported image encoding '32FC1'"), std::string::npos) << why;
  sensor_msgs::ImagePtr truncated = cv_bridge::CvImage(std_msgs::Header(), "mono8", ramp()).toImageMsg();
  truncated->data.resize(10);
  EXPECT_FALSE(toGray8(truncated, &out, &why));
  EXPECT_NE(why.find("does not hold"), std::string::npos) << why;
  sensor_msgs::ImagePtr empty(new sensor_msgs::Image);
  empty->encoding = "mono8";
  EXPECT_FALSE(toGray8(empty, &out, &why));
}

TEST(VoConversions, CameraInfoChecks) {
  const sensor_msgs::CameraInfo good = toCameraInfo(PinholeCamera(640, 480, 500, 500, 320, 240), {});
  EXPECT_EQ(checkCameraInfo(good), "");
  sensor_msgs::CameraInfo bad = good;
  bad.K[4] = std::nan("");
  EXPECT_NE(checkCameraInfo(bad).find("not finite"), std::string::npos);
  bad = good;
  bad.K.fill(0.0);
  EXPECT_NE(checkCameraInfo(bad).find("zero"), std::string::npos);
  bad = good;
  bad.width = 0;
  EXPECT_NE(checkCameraInfo(bad), "");
  bad = good;
  bad.distortion_model = "kannala_brandt";
  bad.D.assign(4, 0.1);
  EXPECT_NE(checkCameraInfo(bad).find("unsupported distortion"), std::string::npos);
  // Issue 12: the number of coefficients per model (a plumb_bob D of 3 made cv::undistortPoints assert and
  // abort the manager), the principal point, the field of view; rational_polynomial is supported.
  sensor_msgs::CameraInfo rational = good;
  rational.distortion_model = "rational_polynomial";
  rational.D = {0.1, 0.01, 0.0, 0.0, 0.001, 0.1, 0.01, 0.001};
  EXPECT_EQ(checkCameraInfo(rational), "");
  rational.D.resize(5);
  EXPECT_NE(checkCameraInfo(rational).find("needs 8 coefficients, got 5"), std::string::npos);
  for (size_t n : {3u, 6u, 7u, 100u}) {
    bad = good;
    bad.D.assign(n, 0.01);
    EXPECT_NE(checkCameraInfo(bad).find("plumb_bob distortion needs 5 coefficients"), std::string::npos) << n;
  }
  bad = good;
  bad.K[2] = 1e9;
  EXPECT_NE(checkCameraInfo(bad).find("principal point"), std::string::npos) << checkCameraInfo(bad);
  bad = good;
  bad.K[0] = bad.K[4] = 1e9;
  EXPECT_NE(checkCameraInfo(bad).find("field of view"), std::string::npos) << checkCameraInfo(bad);
  sensor_msgs::CameraInfo fisheye = good;
  fisheye.distortion_model = "equidistant";
  fisheye.D = {0.1, 0.01, 0.0, 0.0};
  EXPECT_EQ(checkCameraInfo(fisheye), "");
}

TEST(VoConversions, OutputPoseGuard) {
  // Issue 12: absurd intrinsics drove positions to 1e43 and quaternions off unit norm, published as TRACKING.
  std::string why;
  Pose good = Pose::Identity();
  good.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  good.translation() = Eigen::Vector3d(1e3, -2e4, 5e5);
  EXPECT_TRUE(checkOutputPose(good, &why)) << why;
  Pose bad = good;
  bad.translation().x() = std::nan("");
  EXPECT_FALSE(checkOutputPose(bad, &why));
  EXPECT_NE(why.find("non-finite"), std::string::npos) << why;
  bad = good;
  bad.linear() *= 1.01;  // its quaternion would not be unit
  EXPECT_FALSE(checkOutputPose(bad, &why));
  EXPECT_NE(why.find("not a rotation"), std::string::npos) << why;
  bad = good;
  bad.linear().col(2) *= -1.0;  // a reflection
  EXPECT_FALSE(checkOutputPose(bad, &why));
  bad = good;
  bad.translation() = Eigen::Vector3d(1e43, 0, 0);
  EXPECT_FALSE(checkOutputPose(bad, &why));
  EXPECT_NE(why.find("diverged"), std::string::npos) << why;
}

TEST(VoConversions, InvalidNodeletParametersKeepTheirDefaults) {
  // Issue 12: ~position_sigma_m: .nan gave NaN covariances on every vo/odometry message.
  const NodeletParams defaults;
  NodeletParams p;
  p.position_sigma_m = std::nan("");
  p.orientation_sigma_rad = -1.0;
  p.lost_sigma_factor = std::numeric_limits<double>::infinity();
  p.max_frame_gap_factor = 0.5;  // every frame would be a gap
  p.queue_size = 0;
  const std::vector<std::string> problems = validateNodeletParams(&p);
  ASSERT_EQ(problems.size(), 5u);
  EXPECT_NE(problems[0].find("~position_sigma_m = nan is invalid"), std::string::npos) << problems[0];
  EXPECT_EQ(p.position_sigma_m, defaults.position_sigma_m);
  EXPECT_EQ(p.orientation_sigma_rad, defaults.orientation_sigma_rad);
  EXPECT_EQ(p.lost_sigma_factor, defaults.lost_sigma_factor);
  EXPECT_EQ(p.max_frame_gap_factor, defaults.max_frame_gap_factor);
  EXPECT_EQ(p.queue_size, defaults.queue_size);
  NodeletParams ok;
  EXPECT_TRUE(validateNodeletParams(&ok).empty());
}

TEST(VoConversions, StatusMirrorsTheFrameResult) {
  static_assert(VoStatus::STATE_INITIALISING == uint8_t(TrackingState::kInitialising));
  static_assert(VoStatus::STATE_TRACKING == uint8_t(TrackingState::kTracking));
  static_assert(VoStatus::STATE_LOST == uint8_t(TrackingState::kLost));
  static_assert(VoStatus::STATE_RECOVERED == uint8_t(TrackingState::kRecovered));
  static_assert(VoStatus::MODEL_PNP == uint8_t(MotionEstimate::kPnp));
  static_assert(VoStatus::MODEL_HOMOGRAPHY == uint8_t(MotionEstimate::kHomography));
  FrameResult r;
  r.processed = true;
  r.state = TrackingState::kRecovered;
  r.motion = MotionEstimate::kPnp;
  r.num_inliers = 42;
  r.num_map_points = 700;
  r.times.total_ms = 12.5;
  r.message = "bridged";
  const VoStatus s = toVoStatus(r, makeHeader(ros::Time(5, 0), "world"));
  EXPECT_EQ(s.state, VoStatus::STATE_RECOVERED);
  EXPECT_EQ(s.state_name, "recovered");
  EXPECT_EQ(s.motion_model, VoStatus::MODEL_PNP);
  EXPECT_EQ(s.num_inliers, 42u);
  EXPECT_EQ(s.num_map_points, 700u);
  EXPECT_FLOAT_EQ(s.total_ms, 12.5f);
  EXPECT_EQ(s.message, "bridged");
  EXPECT_EQ(s.header.stamp, ros::Time(5, 0));
  const VoStatus bad = badInputStatus("black frame", {});
  EXPECT_EQ(bad.state, VoStatus::STATE_BAD_INPUT);
  EXPECT_FALSE(bad.processed);
}

TEST(VoConversions, OdometryTwistIsInTheChildFrame) {
  FrameResult r;
  r.processed = true;
  r.state = TrackingState::kTracking;
  r.num_inliers = 100;
  Pose prev = Pose::Identity();
  prev.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  Pose cur = prev;
  cur.translation() = Eigen::Vector3d(1.0, 0.0, 0.0);  // 1 m along world x in 0.5 s
  cur.linear() = Eigen::AngleAxisd(M_PI / 2 + 0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const OdometrySigma sigma{0.1, 0.01, 100.0, 100};
  const nav_msgs::Odometry o =
      toOdometry(r, cur, prev, 0.5, makeHeader(ros::Time(1, 0), "world"), "cam", sigma);
  EXPECT_EQ(o.child_frame_id, "cam");
  const Eigen::Vector3d v_child = cur.rotation().transpose() * Eigen::Vector3d(2.0, 0.0, 0.0);
  EXPECT_NEAR(o.twist.twist.linear.x, v_child.x(), 1e-9);
  EXPECT_NEAR(o.twist.twist.linear.y, v_child.y(), 1e-9);
  EXPECT_NEAR(o.twist.twist.angular.z, 0.2, 1e-9);
  EXPECT_NEAR(o.pose.covariance[0], 0.01, 1e-12);  // (0.1 m)^2 with the reference inlier count
  r.state = TrackingState::kLost;
  const nav_msgs::Odometry lost = toOdometry(r, cur, prev, 0.5, {}, "cam", sigma);
  EXPECT_NEAR(lost.pose.covariance[0], 100.0, 1e-9);  // (0.1 m x 100)^2
  const nav_msgs::Odometry first = toOdometry(r, cur, prev, 0.0, {}, "cam", sigma);
  EXPECT_EQ(first.twist.twist.linear.x, 0.0);
}

TEST(VoConversions, StatusCarriesTheFusionState) {
  FrameResult r;
  r.processed = true;
  r.state = TrackingState::kTracking;
  r.metric_scale = true;
  r.scale_source = ScaleSource::kAltimeter;
  r.inertial = true;
  r.has_velocity = true;
  r.v_world_mps = Eigen::Vector3d(6.0, 75.0, -14.0);
  r.imu_bias.gyro_radps = Eigen::Vector3d(1e-5, -2e-5, 3e-5);
  r.imu_bias.accel_mps2 = Eigen::Vector3d(-0.009, 0.004, 0.002);
  const VoStatus s = toVoStatus(r, {});
  EXPECT_TRUE(s.metric);
  EXPECT_TRUE(s.inertial);
  EXPECT_EQ(s.scale_source, "altimeter");
  ASSERT_TRUE(s.has_velocity);
  EXPECT_EQ(s.velocity_world_mps[1], 75.0);
  EXPECT_EQ(s.gyro_bias_radps[2], 3e-5);
  EXPECT_EQ(s.accel_bias_mps2[0], -0.009);
  EXPECT_EQ(toVoStatus(FrameResult(), {}).scale_source, "none");

  VoConfig c;
  EXPECT_EQ(navigationMode(c), VoStatus::MODE_VISION);
  c.altimeter.enabled = true;
  EXPECT_EQ(navigationMode(c), "vision+altimeter");
  c.imu.enabled = true;
  EXPECT_EQ(navigationMode(c), "vision+imu+altimeter");
  c.altimeter.enabled = false;
  EXPECT_EQ(navigationMode(c), "vision+imu");
}

TEST(VoConversions, SampleBufferGivesSamplesInStampOrderAndRefusesWhatThePipelineWould) {
  SampleBuffer<ImuSample> buffer(10.0);
  auto sample = [](double t) {
    ImuSample s;
    s.timestamp_s = t;
    return s;
  };
  using Insert = SampleBuffer<ImuSample>::Insert;
  EXPECT_EQ(buffer.insert(sample(0.010)), Insert::kBuffered);
  EXPECT_EQ(buffer.insert(sample(0.000)), Insert::kBuffered);  // arrived late, still in time: reordered
  EXPECT_EQ(buffer.insert(sample(0.005)), Insert::kBuffered);
  EXPECT_EQ(buffer.insert(sample(0.020)), Insert::kBuffered);
  EXPECT_EQ(buffer.insert(sample(0.005)), Insert::kDuplicate);
  std::vector<double> given;
  EXPECT_EQ(buffer.giveUpTo(0.010, [&](const ImuSample& s) { given.push_back(s.timestamp_s); }), 3u);
  EXPECT_EQ(given, (std::vector<double>{0.0, 0.005, 0.010}));
  ASSERT_TRUE(buffer.lastGiven().has_value());
  EXPECT_EQ(*buffer.lastGiven(), 0.010);
  // After a sample was given, nothing at or before it can be: the pipeline has moved past it.
  EXPECT_EQ(buffer.insert(sample(0.010)), Insert::kDuplicate);
  EXPECT_EQ(buffer.insert(sample(0.007)), Insert::kTooOld);
  EXPECT_EQ(buffer.insert(sample(0.015)), Insert::kBuffered);
  given.clear();
  buffer.giveAll([&](const ImuSample& s) { given.push_back(s.timestamp_s); });
  EXPECT_EQ(given, (std::vector<double>{0.015, 0.020}));
  EXPECT_TRUE(buffer.empty());
  // A new pipeline takes any stamp again.
  buffer.restart();
  EXPECT_EQ(buffer.insert(sample(0.001)), Insert::kBuffered);
  // Flat memory while nothing consumes: older than max_span before the newest is dropped.
  for (int i = 1; i <= 3000; ++i) buffer.insert(sample(0.001 + 0.005 * i));
  EXPECT_LE(buffer.size(), 2001u);
  EXPECT_GT(buffer.dropped(), 0u);
  buffer.discardUpTo(14.0);
  given.clear();
  buffer.giveAll([&](const ImuSample& s) { given.push_back(s.timestamp_s); });
  ASSERT_FALSE(given.empty());
  EXPECT_GT(given.front(), 14.0);
}

TEST(VoConversions, SampleBufferSurvivesStampJumps) {
  // Issue 12: one IMU sample stamped a year ahead became the newest in the buffer, and every later sample was
  // "more than max_span older than the newest" and dropped on insert: the IMU stream was dead for good.
  using Insert = SampleBuffer<ImuSample>::Insert;
  auto sample = [](double t) {
    ImuSample s;
    s.timestamp_s = t;
    return s;
  };
  SampleBuffer<ImuSample> buffer(10.0, 1.0);
  for (int i = 0; i < 10; ++i) ASSERT_EQ(buffer.insert(sample(0.005 * i)), Insert::kBuffered);
  EXPECT_EQ(buffer.insert(sample(3.15e7)), Insert::kSuspect) << "a year ahead: refused once";
  for (int i = 10; i < 20; ++i) EXPECT_EQ(buffer.insert(sample(0.005 * i)), Insert::kBuffered) << i;
  EXPECT_EQ(buffer.size(), 20u) << "the outlier pushed nothing out";
  EXPECT_EQ(buffer.dropped(), 0u);
  std::vector<double> given;
  buffer.giveUpTo(0.1, [&](const ImuSample& s) { given.push_back(s.timestamp_s); });
  EXPECT_EQ(given.size(), 20u);
  // The clock really jumps 5 s: the first sample after the jump is refused as suspect, the next one follows
  // it and confirms the jump; the stream goes on from there.
  EXPECT_EQ(buffer.insert(sample(5.1)), Insert::kSuspect);
  EXPECT_EQ(buffer.insert(sample(5.105)), Insert::kBuffered);
  EXPECT_EQ(buffer.insert(sample(5.110)), Insert::kBuffered);
  EXPECT_EQ(buffer.jumps(), 1u);
  // A suspect followed by the old timeline was an outlier: no jump, nothing lost after it.
  SampleBuffer<ImuSample> other(10.0, 1.0);
  other.insert(sample(0.0));
  EXPECT_EQ(other.insert(sample(7.0)), Insert::kSuspect);
  EXPECT_EQ(other.insert(sample(0.005)), Insert::kBuffered);
  EXPECT_EQ(other.insert(sample(7.005)), Insert::kSuspect) << "the earlier suspect no longer counts";
  EXPECT_EQ(other.jumps(), 0u);
}

TEST(VoConversions, NavCovarianceFromThePipelineOrTheParameters) {
  const OdometrySigma sigma{0.1, 0.01, 100.0, 100};
  FrameResult r;
  r.processed = true;
  r.state = TrackingState::kTracking;
  r.num_inliers = 100;
  Eigen::Matrix<double, 9, 9> cov = navCovariance(r, sigma, 0.2);
  EXPECT_NEAR(cov(0, 0), 0.01, 1e-15);
  EXPECT_NEAR(cov(4, 4), 1e-4, 1e-15);
  EXPECT_NEAR(cov(8, 8), 0.04, 1e-15);
  r.has_covariance = true;
  r.covariance = 4.0 * Eigen::Matrix<double, 9, 9>::Identity();
  EXPECT_EQ(navCovariance(r, sigma, 0.2)(6, 6), 4.0);
  // Lost without IMU factors: never confident, even with the pipeline's covariance.
  r.state = TrackingState::kLost;
  EXPECT_EQ(navCovariance(r, sigma, 0.2)(6, 6), 4.0 * 1e4);
  r.inertial = true;  // the IMU holds the map: the pipeline's covariance stands
  EXPECT_EQ(navCovariance(r, sigma, 0.2)(6, 6), 4.0);
  r.has_covariance = false;
  r.inertial = false;
  EXPECT_NEAR(navCovariance(r, sigma, 0.2)(0, 0), 100.0, 1e-9);  // (0.1 m x 100)^2
}

TEST(VoConversions, NavOdometryTwistIsTheChildsInTheChildFrame) {
  NavSolution s;
  s.T_world_cam.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  s.T_world_cam.translation() = Eigen::Vector3d(-250, -2400, 650);
  s.v_world_mps = Eigen::Vector3d(6.0, 75.0, -14.0);
  s.w_body_radps = Eigen::Vector3d(0.01, -0.02, 0.05);
  s.covariance = Eigen::Matrix<double, 9, 9>::Identity() * 1e-4;
  s.covariance.bottomRightCorner<3, 3>() = Eigen::Vector3d(1.0, 4.0, 9.0).asDiagonal();
  s.w_covariance = Eigen::Matrix3d::Identity() * 1e-6;
  // IMU and camera co-located, child = camera: twist = R^T v and the gyro rate.
  nav_msgs::Odometry o =
      toNavOdometry(s, Pose::Identity(), Pose::Identity(), makeHeader(ros::Time(3, 0), "world"), "cam");
  EXPECT_EQ(o.header.frame_id, "world");
  EXPECT_EQ(o.child_frame_id, "cam");
  const Eigen::Vector3d v_cam = s.T_world_cam.rotation().transpose() * s.v_world_mps;
  EXPECT_NEAR(o.twist.twist.linear.x, v_cam.x(), 1e-12);
  EXPECT_NEAR(o.twist.twist.linear.z, v_cam.z(), 1e-12);
  EXPECT_NEAR(o.twist.twist.angular.z, 0.05, 1e-15);
  EXPECT_NEAR(o.pose.pose.position.y, -2400.0, 1e-12);
  EXPECT_NEAR(o.pose.covariance[0], 1e-4, 1e-15);
  // Velocity covariance rotated into the child frame: the trace is kept.
  EXPECT_NEAR(o.twist.covariance[0] + o.twist.covariance[7] + o.twist.covariance[14], 14.0, 1e-12);

  // A base frame 2 m along the camera's z axis, turned 90 degrees about it; the IMU 0.3 m along x.
  Pose T_cam_child = Pose::Identity();
  T_cam_child.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_cam_child.translation() = Eigen::Vector3d(0, 0, 2.0);
  Pose T_cam_imu = Pose::Identity();
  T_cam_imu.translation() = Eigen::Vector3d(0.3, 0, 0);
  o = toNavOdometry(s, T_cam_imu, T_cam_child, {}, "base");
  const Pose T_world_child = s.T_world_cam * T_cam_child;
  const Pose T_world_imu = s.T_world_cam * T_cam_imu;
  const Eigen::Vector3d w_world = T_world_imu.rotation() * s.w_body_radps;
  const Eigen::Vector3d v_child =
      T_world_child.rotation().transpose() *
      (s.v_world_mps + w_world.cross(T_world_child.translation() - T_world_imu.translation()));
  EXPECT_NEAR(o.twist.twist.linear.x, v_child.x(), 1e-12);
  EXPECT_NEAR(o.twist.twist.linear.y, v_child.y(), 1e-12);
  EXPECT_NEAR(o.twist.twist.linear.z, v_child.z(), 1e-12);
  const Eigen::Vector3d w_child = T_world_child.rotation().transpose() * w_world;
  EXPECT_NEAR(o.twist.twist.angular.x, w_child.x(), 1e-15);
  EXPECT_NEAR(o.twist.twist.angular.y, w_child.y(), 1e-15);
  EXPECT_NEAR(o.pose.pose.position.x, T_world_child.translation().x(), 1e-9);
  // The attitude error moves the base 2 m away: its position variance grows by (2 m)^2 x 1e-4 per axis
  // perpendicular to the lever arm.
  double trace = 0.0;
  for (int i = 0; i < 3; ++i) trace += o.pose.covariance[i * 7];
  EXPECT_NEAR(trace, 3e-4 + 2.0 * 4.0 * 1e-4, 1e-12);
}

TEST(VoConversions, DifferentiatedPosesGiveBodyRates) {
  Pose a = Pose::Identity(), b = Pose::Identity();
  a.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX()).toRotationMatrix();
  b.linear() = a.linear() * Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY()).toRotationMatrix();
  b.translation() = Eigen::Vector3d(1.0, 2.0, -3.0);
  Eigen::Vector3d v, w;
  ASSERT_TRUE(differentiatePoses(a, b, 0.1, &v, &w));
  EXPECT_TRUE(v.isApprox(Eigen::Vector3d(10.0, 20.0, -30.0), 1e-12));
  EXPECT_TRUE(w.isApprox(Eigen::Vector3d(0.0, 0.2, 0.0), 1e-9));
  EXPECT_FALSE(differentiatePoses(a, b, 0.0, &v, &w));
}

// Issue 12: the note computed int(gap / period), undefined beyond 2^31 frames (a gap of days at 1 kHz).
TEST(VoConversions, FrameGapNoteCountsWithoutOverflow) {
  EXPECT_NE(frameGapNote(0.5, 0.1).find("about 4 frames dropped"), std::string::npos)
      << frameGapNote(0.5, 0.1);
  // A year at 1 kHz: 3.15e10 frames, beyond any int.
  const std::string year = frameGapNote(365.0 * 86400.0, 1e-3);
  EXPECT_NE(year.find("about 31535999999 frames dropped"), std::string::npos) << year;
  EXPECT_EQ(year.find("-"), std::string::npos) << year;  // never a negative count
  EXPECT_NE(frameGapNote(1e30, 1e-9).find("about 9000000000000000000 frames"), std::string::npos);
}

TEST(VoConversions, PointCloudHasXyzAndObservations) {
  std::vector<MapPointView> points(2);
  points[0].p_world = Eigen::Vector3d(1, 2, 3);
  points[0].num_observations = 4;
  points[1].p_world = Eigen::Vector3d(-1, 0, 5);
  points[1].num_observations = 2;
  Sim3Transform S;
  S.scale = 2.0;
  S.t_gt_est_m = Eigen::Vector3d(0, 0, 1);
  const sensor_msgs::PointCloud2 cloud = toPointCloud(points, makeHeader(ros::Time(1, 0), "world"), S);
  ASSERT_EQ(cloud.width, 2u);
  ASSERT_EQ(cloud.fields.size(), 4u);
  sensor_msgs::PointCloud2ConstIterator<float> x(cloud, "x"), z(cloud, "z");
  sensor_msgs::PointCloud2ConstIterator<uint32_t> n(cloud, "observations");
  EXPECT_FLOAT_EQ(*x, 2.0f);
  EXPECT_FLOAT_EQ(*z, 7.0f);
  EXPECT_EQ(*n, 4u);
  ++n;
  EXPECT_EQ(*n, 2u);
  // An empty map (the first frames): fields, no points, and no iterator over the empty data (UBSan, issue 12).
  const sensor_msgs::PointCloud2 empty = toPointCloud({}, makeHeader(ros::Time(1, 0), "world"));
  EXPECT_EQ(empty.width, 0u);
  EXPECT_EQ(empty.fields.size(), 4u);
  EXPECT_TRUE(empty.data.empty());
}

}  // namespace
}  // namespace planetary_vo::ros_io
