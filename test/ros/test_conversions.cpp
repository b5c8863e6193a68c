/// Conversions between core types and ROS messages (no master), both ways: the player's outputs and the
/// nodelet's inputs (IMU, Range after REP-117, the initial-state handover).

#include <cmath>
#include <limits>
#include <stdexcept>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "planetary_vo/ros_io/conversions.h"

namespace planetary_vo::ros_io {
namespace {

Pose somePose() {
  Pose T = Pose::Identity();
  T.linear() =
      (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(-1.2, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  T.translation() = Eigen::Vector3d(1.5, -2.0, 1234.25);
  return T;
}

TEST(Conversions, StampIsEpochPlusExactDatasetTime) {
  const ros::Time epoch(1000000000, 0);
  for (int k = 0; k < 100; ++k) {
    const ros::Time stamp = toStamp(epoch, k / 10.0);
    EXPECT_EQ(stamp.sec, 1000000000u + static_cast<uint32_t>(k / 10));
    EXPECT_EQ(stamp.nsec, static_cast<uint32_t>(k % 10) * 100000000u) << "k = " << k;
    EXPECT_NEAR(toDatasetTime(epoch, stamp), k / 10.0, 1e-12);
  }
  EXPECT_EQ(toStamp(ros::Time(0, 0), 1403636579.763555527), ros::Time(1403636579, 763555527));
}

TEST(Conversions, StampDifferencesBeyondTheDurationRangeAreDefined) {
  // A stamp decades off (a corrupted or far-future header) against a normal one: ros::Time's difference
  // throws ("Duration is out of dual 32-bit range"); the nodelet's stamp checks must get a number instead.
  const ros::Time now(1700000000, 500000000), far(4294967295u, 999999999u), zero(0, 1);
  EXPECT_THROW((far - zero).toSec(), std::runtime_error);
  EXPECT_NEAR(secondsBetween(far, now), 4294967295.999999999 - 1700000000.5, 1e-6);
  EXPECT_NEAR(secondsBetween(zero, far), -4294967295.999999998, 1e-6);
  EXPECT_NEAR(toDatasetTime(now, far), secondsBetween(far, now), 0.0);
  EXPECT_DOUBLE_EQ(secondsBetween(ros::Time(5, 250000000), ros::Time(4, 750000000)), 0.5);
}

TEST(Conversions, CameraInfoWithoutDistortion) {
  const PinholeCamera camera(1241, 376, 718.856, 718.856, 607.1928, 185.2157);
  const sensor_msgs::CameraInfo info = toCameraInfo(camera, makeHeader(ros::Time(5, 6), "camera_optical"));
  EXPECT_EQ(info.header.stamp, ros::Time(5, 6));
  EXPECT_EQ(info.header.frame_id, "camera_optical");
  EXPECT_EQ(info.width, 1241u);
  EXPECT_EQ(info.height, 376u);
  EXPECT_EQ(info.distortion_model, "plumb_bob");
  ASSERT_EQ(info.D.size(), 5u);
  for (double d : info.D) EXPECT_EQ(d, 0.0);
  const boost::array<double, 9> K = {718.856, 0, 607.1928, 0, 718.856, 185.2157, 0, 0, 1};
  EXPECT_EQ(info.K, K);
  const boost::array<double, 9> R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  EXPECT_EQ(info.R, R);
  const boost::array<double, 12> P = {718.856, 0, 607.1928, 0, 0, 718.856, 185.2157, 0, 0, 0, 1, 0};
  EXPECT_EQ(info.P, P);
  EXPECT_EQ(fromCameraInfo(info), camera);
}

TEST(Conversions, CameraInfoKeepsDistortionModelAndCoefficients) {
  const PinholeCamera plumb(752, 480, 458.654, 457.296, 367.215, 248.375, "plumb_bob",
                            {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0});
  const sensor_msgs::CameraInfo info = toCameraInfo(plumb, std_msgs::Header());
  EXPECT_EQ(info.distortion_model, "plumb_bob");
  EXPECT_EQ(info.D, plumb.distortion());
  EXPECT_EQ(info.K[4], 457.296);
  EXPECT_EQ(fromCameraInfo(info), plumb);

  const PinholeCamera fisheye(640, 480, 300.0, 301.0, 320.5, 240.5, "equidistant",
                              {0.1, -0.01, 0.002, -0.0003});
  const sensor_msgs::CameraInfo info2 = toCameraInfo(fisheye, std_msgs::Header());
  EXPECT_EQ(info2.distortion_model, "equidistant");
  EXPECT_EQ(info2.D, fisheye.distortion());
  EXPECT_EQ(fromCameraInfo(info2), fisheye);
}

TEST(Conversions, PoseRoundTripAndQuaternion) {
  const Pose T = somePose();
  const geometry_msgs::Pose msg = toPoseMsg(T);
  EXPECT_DOUBLE_EQ(msg.position.x, 1.5);
  EXPECT_DOUBLE_EQ(msg.position.y, -2.0);
  EXPECT_DOUBLE_EQ(msg.position.z, 1234.25);
  const Eigen::Quaterniond q(msg.orientation.w, msg.orientation.x, msg.orientation.y, msg.orientation.z);
  EXPECT_NEAR(q.norm(), 1.0, 1e-12);
  EXPECT_TRUE(q.toRotationMatrix().isApprox(T.rotation(), 1e-12));
  EXPECT_TRUE(fromPoseMsg(msg).isApprox(T, 1e-12));

  const geometry_msgs::PoseStamped stamped = toPoseStamped(T, makeHeader(ros::Time(7, 0), "world"));
  EXPECT_EQ(stamped.header.frame_id, "world");
  EXPECT_EQ(stamped.header.stamp, ros::Time(7, 0));
  EXPECT_EQ(stamped.pose, msg);
}

TEST(Conversions, PoseFromMessageNormalisesTheQuaternion) {
  geometry_msgs::Pose msg;
  msg.orientation.w = 2.0;  // not unit
  msg.position.x = 3.0;
  Pose T = fromPoseMsg(msg);
  EXPECT_TRUE(T.rotation().isApprox(Eigen::Matrix3d::Identity(), 1e-15));
  EXPECT_EQ(T.translation().x(), 3.0);
  msg.orientation.w = 0.0;  // all zero: identity, not NaN
  T = fromPoseMsg(msg);
  EXPECT_TRUE(T.rotation().isApprox(Eigen::Matrix3d::Identity(), 1e-15));
}

TEST(Conversions, TransformStampedIsParentToChild) {
  const Pose T_world_cam = somePose();
  const geometry_msgs::TransformStamped tf =
      toTransformStamped(T_world_cam, makeHeader(ros::Time(9, 1), "world"), "camera_gt");
  EXPECT_EQ(tf.header.frame_id, "world");
  EXPECT_EQ(tf.child_frame_id, "camera_gt");
  EXPECT_EQ(tf.header.stamp, ros::Time(9, 1));
  EXPECT_DOUBLE_EQ(tf.transform.translation.z, 1234.25);
  EXPECT_TRUE(fromTransformMsg(tf.transform).isApprox(T_world_cam, 1e-12));
  // The camera centre maps to the translation, a point 1 m ahead on the optical axis to centre + R * z.
  const Pose T = fromTransformMsg(tf.transform);
  EXPECT_TRUE(
      (T * Eigen::Vector3d(0, 0, 1)).isApprox(T_world_cam.translation() + T_world_cam.rotation().col(2)));
}

TEST(Conversions, ImuCarriesRateAndSpecificForceWithoutOrientation) {
  ImuSample s;
  s.timestamp_s = 3.25;
  s.angular_velocity_radps = Eigen::Vector3d(0.1, -0.2, 0.3);
  s.specific_force_mps2 = Eigen::Vector3d(0.0, 0.5, -1.62);
  const sensor_msgs::Imu msg = toImu(s, makeHeader(ros::Time(2, 0), "camera_optical"));
  EXPECT_EQ(msg.header.frame_id, "camera_optical");
  EXPECT_EQ(msg.angular_velocity.x, 0.1);
  EXPECT_EQ(msg.angular_velocity.y, -0.2);
  EXPECT_EQ(msg.angular_velocity.z, 0.3);
  EXPECT_EQ(msg.linear_acceleration.y, 0.5);
  EXPECT_EQ(msg.linear_acceleration.z, -1.62);
  EXPECT_EQ(msg.orientation_covariance[0], -1.0);
}

TEST(Conversions, ImuCovarianceAndRangeLimitsFollowTheDataSheet) {
  SensorSpecification spec;
  EXPECT_EQ(imuNoiseSpec(spec).gyro_sigma_radps, 0.0);  // undescribed IMU: covariance unknown (0)
  EXPECT_EQ(altimeterSpec(spec).max_range_m, AltimeterSpec().max_range_m);
  spec.has_imu = true;
  spec.imu_rate_hz = 200.0;
  spec.gyro_noise_density_radps_per_sqrt_hz = 1e-4;
  spec.accel_noise_density_mps2_per_sqrt_hz = 1e-3;
  spec.has_altimeter = true;
  spec.altimeter_min_range_m = 10.0;
  spec.altimeter_max_range_m = 2000.0;
  spec.altimeter_beam_divergence_rad = 5e-4;
  const sensor_msgs::Imu msg = toImu(ImuSample(), makeHeader(ros::Time(2, 0), "imu"), imuNoiseSpec(spec));
  // sigma = density * sqrt(rate): 1e-4 * sqrt(200) rad/s and 1e-3 * sqrt(200) m/s^2, on the diagonal only.
  EXPECT_NEAR(msg.angular_velocity_covariance[0], 2e-6, 1e-15);
  EXPECT_NEAR(msg.angular_velocity_covariance[8], 2e-6, 1e-15);
  EXPECT_NEAR(msg.linear_acceleration_covariance[4], 2e-4, 1e-13);
  EXPECT_EQ(msg.angular_velocity_covariance[1], 0.0);
  const AltimeterSpec a = altimeterSpec(spec);
  EXPECT_EQ(a.min_range_m, 10.0);
  EXPECT_EQ(a.max_range_m, 2000.0);
  EXPECT_EQ(a.field_of_view_rad, 5e-4);
}

TEST(Conversions, RangeIsTheSlantRange) {
  AltimeterSample s;
  s.slant_range_m = 1523.5;
  AltimeterSpec spec;
  spec.max_range_m = 20000.0;
  const sensor_msgs::Range msg = toRange(s, makeHeader(ros::Time(4, 0), "camera_optical"), spec);
  EXPECT_EQ(msg.range, 1523.5f);
  EXPECT_EQ(msg.radiation_type, sensor_msgs::Range::INFRARED);
  EXPECT_EQ(msg.max_range, 20000.0f);
  EXPECT_GT(msg.field_of_view, 0.0f);
  EXPECT_LT(msg.min_range, msg.range);
  EXPECT_EQ(msg.header.frame_id, "camera_optical");
}

TEST(Conversions, NoReturnIsPlusInfinity) {
  // REP-117: a range finder that saw no return reports +Inf.
  AltimeterSample s;
  s.slant_range_m = std::numeric_limits<double>::infinity();
  const sensor_msgs::Range msg = toRange(s, makeHeader(ros::Time(4, 0), "camera_optical"), AltimeterSpec());
  EXPECT_TRUE(std::isinf(msg.range) && msg.range > 0);
}

TEST(Conversions, ImuMessageBecomesASampleOnTheEpochClock) {
  ImuSample s;
  s.angular_velocity_radps = Eigen::Vector3d(0.1, -0.2, 0.3);
  s.specific_force_mps2 = Eigen::Vector3d(0.0, 0.5, -1.62);
  const ros::Time epoch(1000000000, 0);
  const sensor_msgs::Imu msg = toImu(s, makeHeader(toStamp(epoch, 2.005), "imu"));
  ImuSample back;
  std::string why;
  ASSERT_TRUE(fromImu(msg, epoch, &back, &why)) << why;
  EXPECT_NEAR(back.timestamp_s, 2.005, 1e-9);
  EXPECT_EQ(back.angular_velocity_radps, s.angular_velocity_radps);
  EXPECT_EQ(back.specific_force_mps2, s.specific_force_mps2);
  EXPECT_TRUE(why.empty());
}

TEST(Conversions, UnusableImuMessagesAreRefusedWithAReason) {
  const ros::Time epoch(100, 0);
  sensor_msgs::Imu good = toImu(ImuSample(), makeHeader(ros::Time(101, 0), "imu"));
  ImuSample out;
  std::string why;
  sensor_msgs::Imu m = good;
  m.angular_velocity.y = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(fromImu(m, epoch, &out, &why));
  EXPECT_NE(why.find("non-finite"), std::string::npos) << why;
  m = good;
  m.linear_acceleration.z = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(fromImu(m, epoch, &out, &why));
  m = good;
  m.header.stamp = ros::Time();
  EXPECT_FALSE(fromImu(m, epoch, &out, &why));
  EXPECT_NE(why.find("zero stamp"), std::string::npos) << why;
  m = good;
  m.angular_velocity_covariance[0] = -1.0;  // REP-145: no angular velocity in this message
  EXPECT_FALSE(fromImu(m, epoch, &out, &why));
  EXPECT_NE(why.find("angular velocity"), std::string::npos) << why;
  m = good;
  m.linear_acceleration_covariance[0] = -1.0;
  EXPECT_FALSE(fromImu(m, epoch, &out, &why));
  EXPECT_NE(why.find("linear acceleration"), std::string::npos) << why;
  // The orientation is not used: "no orientation" (-1) is the normal case.
  EXPECT_TRUE(fromImu(good, epoch, &out, &why));
  EXPECT_EQ(good.orientation_covariance[0], -1.0);
}

TEST(Conversions, RangeFollowsRep117) {
  const ros::Time epoch(100, 0);
  AltimeterSpec spec;
  spec.min_range_m = 10.0;
  spec.max_range_m = 2000.0;
  auto reading = [&](double range, AltimeterSample* out, std::string* why) {
    AltimeterSample s;
    s.slant_range_m = range;
    return fromRange(toRange(s, makeHeader(ros::Time(100, 500000000), "alt"), spec), epoch, out, why);
  };
  AltimeterSample out;
  std::string why;
  EXPECT_EQ(reading(523.5, &out, &why), RangeReading::kRange);
  EXPECT_EQ(out.slant_range_m, 523.5);
  EXPECT_NEAR(out.timestamp_s, 0.5, 1e-9);
  EXPECT_TRUE(out.hasReturn());
  const double inf = std::numeric_limits<double>::infinity();
  // +Inf: no return; -Inf: too close to measure; outside the limits: discarded. All "no range", given to
  // the pipeline as its "no return" (+Inf), so it never falls back on an older reading.
  for (double r : {inf, -inf, 5.0, 2500.0}) {
    out.slant_range_m = 1.0;
    EXPECT_EQ(reading(r, &out, &why), RangeReading::kNoRange) << r;
    EXPECT_FALSE(out.hasReturn()) << r;
    EXPECT_FALSE(why.empty()) << r;
  }
  EXPECT_EQ(reading(inf, &out, &why), RangeReading::kNoRange);
  EXPECT_NE(why.find("no return"), std::string::npos) << why;
  EXPECT_EQ(reading(-inf, &out, &why), RangeReading::kNoRange);
  EXPECT_NE(why.find("too close"), std::string::npos) << why;
  // NaN: an erroneous reading; a negative finite range is not a range either.
  EXPECT_EQ(reading(std::numeric_limits<double>::quiet_NaN(), &out, &why), RangeReading::kInvalid);
  EXPECT_EQ(reading(-3.0, &out, &why), RangeReading::kInvalid);
  EXPECT_EQ(std::string(toString(RangeReading::kInvalid)), "invalid");
  // Limits left 0 by a driver are not applied.
  AltimeterSample s;
  s.slant_range_m = 7.0;
  sensor_msgs::Range m = toRange(s, makeHeader(ros::Time(101, 0), "alt"), spec);
  m.min_range = m.max_range = 0.0f;
  EXPECT_EQ(fromRange(m, epoch, &out, &why), RangeReading::kRange);
  m.header.stamp = ros::Time();
  EXPECT_EQ(fromRange(m, epoch, &out, &why), RangeReading::kInvalid);
}

TEST(Conversions, InitialStateRoundTripAndLeverArm) {
  const Pose T_world_cam = somePose();
  const Eigen::Vector3d v_cam(6.0, 75.0, -14.0);
  const nav_msgs::Odometry msg =
      toInitialStateMsg(T_world_cam, v_cam, makeHeader(ros::Time(7, 0), "world"), "camera_optical");
  EXPECT_EQ(msg.header.frame_id, "world");
  EXPECT_EQ(msg.child_frame_id, "camera_optical");
  EXPECT_EQ(msg.twist.twist.linear.y, 75.0);
  InitialState state;
  std::string why;
  ASSERT_TRUE(fromInitialStateMsg(msg, Pose::Identity(), &state, &why)) << why;
  EXPECT_TRUE(state.T_world_cam.isApprox(T_world_cam, 1e-12));
  EXPECT_TRUE(state.v_world_imu_mps.isApprox(v_cam, 1e-12));
  // An IMU 0.5 m along the camera's x axis on a body turning about the world z axis at 0.2 rad/s:
  // v_imu = v_cam + w x (R_world_cam * t_cam_imu).
  Pose T_cam_imu = Pose::Identity();
  T_cam_imu.translation() = Eigen::Vector3d(0.5, 0.0, 0.0);
  nav_msgs::Odometry turning = msg;
  turning.twist.twist.angular.z = 0.2;
  ASSERT_TRUE(fromInitialStateMsg(turning, T_cam_imu, &state, &why)) << why;
  const Eigen::Vector3d expected =
      v_cam + Eigen::Vector3d(0, 0, 0.2).cross(T_world_cam.rotation() * Eigen::Vector3d(0.5, 0, 0));
  EXPECT_TRUE(state.v_world_imu_mps.isApprox(expected, 1e-12));
  // Refused: non-finite pose or velocity, a quaternion that is not a rotation.
  nav_msgs::Odometry bad = msg;
  bad.twist.twist.linear.x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(fromInitialStateMsg(bad, Pose::Identity(), &state, &why));
  EXPECT_NE(why.find("velocity"), std::string::npos) << why;
  bad = msg;
  bad.pose.pose.position.z = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(fromInitialStateMsg(bad, Pose::Identity(), &state, &why));
  bad = msg;
  bad.pose.pose.orientation.w = bad.pose.pose.orientation.x = bad.pose.pose.orientation.y =
      bad.pose.pose.orientation.z = 0.0;
  EXPECT_FALSE(fromInitialStateMsg(bad, Pose::Identity(), &state, &why));
  EXPECT_NE(why.find("quaternion"), std::string::npos) << why;
}

TEST(Conversions, ImageMono8AndMono16) {
  cv::Mat gray(3, 4, CV_8UC1);
  for (int i = 0; i < 12; ++i) gray.at<uint8_t>(i / 4, i % 4) = static_cast<uint8_t>(10 * i);
  const sensor_msgs::ImagePtr msg = toImageMsg(gray, makeHeader(ros::Time(1, 2), "camera_optical"));
  EXPECT_EQ(msg->encoding, "mono8");
  EXPECT_EQ(msg->width, 4u);
  EXPECT_EQ(msg->height, 3u);
  EXPECT_EQ(msg->step, 4u);
  EXPECT_EQ(msg->header.stamp, ros::Time(1, 2));
  ASSERT_EQ(msg->data.size(), 12u);
  for (int i = 0; i < 12; ++i) EXPECT_EQ(msg->data[i], 10 * i);

  cv::Mat gray16(2, 2, CV_16UC1, cv::Scalar(40000));
  const sensor_msgs::ImagePtr msg16 = toImageMsg(gray16, std_msgs::Header());
  EXPECT_EQ(msg16->encoding, "mono16");
  EXPECT_EQ(msg16->step, 4u);

  EXPECT_THROW(toImageMsg(cv::Mat(2, 2, CV_8UC3), std_msgs::Header()), std::invalid_argument);
  EXPECT_THROW(toImageMsg(cv::Mat(2, 2, CV_32FC1), std_msgs::Header()), std::invalid_argument);
}

}  // namespace
}  // namespace planetary_vo::ros_io
