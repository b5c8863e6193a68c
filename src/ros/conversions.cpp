/// @file conversions.cpp
/// Core types <-> ROS messages (see conversions.h).

#include "planetary_vo/ros_io/conversions.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

namespace planetary_vo::ros_io {

ros::Time toStamp(const ros::Time& epoch, double dataset_time_s) {
  return epoch + ros::Duration().fromSec(dataset_time_s);
}

double secondsBetween(const ros::Time& later, const ros::Time& earlier) {
  // toNSec() < 2^63 for every valid stamp (sec < 2^32), so the difference of the two as int64 is exact.
  return 1e-9 *
         static_cast<double>(static_cast<int64_t>(later.toNSec()) - static_cast<int64_t>(earlier.toNSec()));
}

double toDatasetTime(const ros::Time& epoch, const ros::Time& stamp) { return secondsBetween(stamp, epoch); }

std_msgs::Header makeHeader(const ros::Time& stamp, const std::string& frame_id) {
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = frame_id;
  return header;
}

sensor_msgs::CameraInfo toCameraInfo(const PinholeCamera& camera, const std_msgs::Header& header) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = static_cast<uint32_t>(camera.width());
  info.height = static_cast<uint32_t>(camera.height());
  if (camera.distortionModel().empty()) {
    info.distortion_model = "plumb_bob";
    info.D.assign(5, 0.0);
  } else {
    info.distortion_model = camera.distortionModel();
    info.D = camera.distortion();
  }
  info.K = {camera.fx(), 0.0, camera.cx(), 0.0, camera.fy(), camera.cy(), 0.0, 0.0, 1.0};
  info.R = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
  info.P = {camera.fx(), 0.0, camera.cx(), 0.0, 0.0, camera.fy(), camera.cy(), 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

PinholeCamera fromCameraInfo(const sensor_msgs::CameraInfo& info) {
  std::string model = info.distortion_model;
  std::vector<double> D = info.D;
  bool all_zero = true;
  for (double d : D)
    if (d != 0.0) all_zero = false;
  if (all_zero) {
    model.clear();
    D.clear();
  }
  return PinholeCamera(static_cast<int>(info.width), static_cast<int>(info.height), info.K[0], info.K[4],
                       info.K[2], info.K[5], model, D);
}

geometry_msgs::Pose toPoseMsg(const Pose& T_parent_child) {
  geometry_msgs::Pose msg;
  const Eigen::Vector3d t = T_parent_child.translation();
  const Eigen::Quaterniond q(T_parent_child.rotation());
  msg.position.x = t.x();
  msg.position.y = t.y();
  msg.position.z = t.z();
  msg.orientation.x = q.x();
  msg.orientation.y = q.y();
  msg.orientation.z = q.z();
  msg.orientation.w = q.w();
  return msg;
}

namespace {

Pose makePose(double x, double y, double z, double qx, double qy, double qz, double qw) {
  Eigen::Quaterniond q(qw, qx, qy, qz);
  if (q.norm() == 0.0)
    q = Eigen::Quaterniond::Identity();
  else
    q.normalize();
  Pose T = Pose::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

}  // namespace

Pose fromPoseMsg(const geometry_msgs::Pose& msg) {
  return makePose(msg.position.x, msg.position.y, msg.position.z, msg.orientation.x, msg.orientation.y,
                  msg.orientation.z, msg.orientation.w);
}

Pose fromTransformMsg(const geometry_msgs::Transform& msg) {
  return makePose(msg.translation.x, msg.translation.y, msg.translation.z, msg.rotation.x, msg.rotation.y,
                  msg.rotation.z, msg.rotation.w);
}

geometry_msgs::PoseStamped toPoseStamped(const Pose& T_parent_child, const std_msgs::Header& header) {
  geometry_msgs::PoseStamped msg;
  msg.header = header;
  msg.pose = toPoseMsg(T_parent_child);
  return msg;
}

geometry_msgs::TransformStamped toTransformStamped(const Pose& T_parent_child, const std_msgs::Header& header,
                                                   const std::string& child_frame_id) {
  const geometry_msgs::Pose pose = toPoseMsg(T_parent_child);
  geometry_msgs::TransformStamped msg;
  msg.header = header;
  msg.child_frame_id = child_frame_id;
  msg.transform.translation.x = pose.position.x;
  msg.transform.translation.y = pose.position.y;
  msg.transform.translation.z = pose.position.z;
  msg.transform.rotation = pose.orientation;
  return msg;
}

ImuNoiseSpec imuNoiseSpec(const SensorSpecification& spec) {
  ImuNoiseSpec n;
  if (!spec.has_imu || !(spec.imu_rate_hz > 0.0)) return n;
  n.gyro_sigma_radps = spec.gyro_noise_density_radps_per_sqrt_hz * std::sqrt(spec.imu_rate_hz);
  n.accel_sigma_mps2 = spec.accel_noise_density_mps2_per_sqrt_hz * std::sqrt(spec.imu_rate_hz);
  return n;
}

AltimeterSpec altimeterSpec(const SensorSpecification& spec, const AltimeterSpec& fallback) {
  if (!spec.has_altimeter) return fallback;
  AltimeterSpec a;
  a.field_of_view_rad = spec.altimeter_beam_divergence_rad;
  a.min_range_m = spec.altimeter_min_range_m;
  a.max_range_m = spec.altimeter_max_range_m;
  return a;
}

sensor_msgs::Imu toImu(const ImuSample& sample, const std_msgs::Header& header, const ImuNoiseSpec& noise) {
  sensor_msgs::Imu msg;
  msg.header = header;
  msg.orientation.w = 1.0;
  msg.orientation_covariance[0] = -1.0;
  for (int i = 0; i < 3; ++i) {
    msg.angular_velocity_covariance[4 * i] = noise.gyro_sigma_radps * noise.gyro_sigma_radps;
    msg.linear_acceleration_covariance[4 * i] = noise.accel_sigma_mps2 * noise.accel_sigma_mps2;
  }
  msg.angular_velocity.x = sample.angular_velocity_radps.x();
  msg.angular_velocity.y = sample.angular_velocity_radps.y();
  msg.angular_velocity.z = sample.angular_velocity_radps.z();
  msg.linear_acceleration.x = sample.specific_force_mps2.x();
  msg.linear_acceleration.y = sample.specific_force_mps2.y();
  msg.linear_acceleration.z = sample.specific_force_mps2.z();
  return msg;
}

sensor_msgs::Range toRange(const AltimeterSample& sample, const std_msgs::Header& header,
                           const AltimeterSpec& spec) {
  sensor_msgs::Range msg;
  msg.header = header;
  msg.radiation_type = sensor_msgs::Range::INFRARED;
  msg.field_of_view = static_cast<float>(spec.field_of_view_rad);
  msg.min_range = static_cast<float>(spec.min_range_m);
  msg.max_range = static_cast<float>(spec.max_range_m);
  msg.range = static_cast<float>(sample.slant_range_m);
  return msg;
}

namespace {

bool finite3(double x, double y, double z) {
  return std::isfinite(x) && std::isfinite(y) && std::isfinite(z);
}

std::string num(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

bool fromImu(const sensor_msgs::Imu& msg, const ros::Time& epoch, ImuSample* sample, std::string* why) {
  if (msg.header.stamp.isZero()) {
    *why = "IMU message with a zero stamp";
    return false;
  }
  if (msg.angular_velocity_covariance[0] == -1.0 || msg.linear_acceleration_covariance[0] == -1.0) {
    *why = std::string("IMU message without ") +
           (msg.angular_velocity_covariance[0] == -1.0 ? "angular velocity" : "linear acceleration") +
           " (covariance[0] = -1)";
    return false;
  }
  const auto& w = msg.angular_velocity;
  const auto& a = msg.linear_acceleration;
  if (!finite3(w.x, w.y, w.z) || !finite3(a.x, a.y, a.z)) {
    *why = "IMU message with a non-finite angular velocity or linear acceleration";
    return false;
  }
  sample->timestamp_s = toDatasetTime(epoch, msg.header.stamp);
  sample->angular_velocity_radps = Eigen::Vector3d(w.x, w.y, w.z);
  sample->specific_force_mps2 = Eigen::Vector3d(a.x, a.y, a.z);
  return true;
}

const char* toString(RangeReading reading) {
  switch (reading) {
    case RangeReading::kRange:
      return "range";
    case RangeReading::kNoRange:
      return "no_range";
    case RangeReading::kInvalid:
      return "invalid";
  }
  return "?";
}

RangeReading fromRange(const sensor_msgs::Range& msg, const ros::Time& epoch, AltimeterSample* sample,
                       std::string* why) {
  const double r = msg.range;
  if (msg.header.stamp.isZero()) {
    *why = "altimeter message with a zero stamp";
    return RangeReading::kInvalid;
  }
  if (std::isnan(r) || (std::isfinite(r) && r < 0.0)) {
    *why = "altimeter range " + num(r) + " (NaN or negative: an erroneous reading)";
    return RangeReading::kInvalid;
  }
  sample->timestamp_s = toDatasetTime(epoch, msg.header.stamp);
  sample->slant_range_m = std::numeric_limits<double>::infinity();
  const double lo = msg.min_range, hi = msg.max_range;
  const bool limits = std::isfinite(lo) && std::isfinite(hi) && lo >= 0.0 && lo < hi;
  if (std::isinf(r)) {
    *why = r > 0.0 ? "no return (+Inf)" : "target too close to measure (-Inf)";
    return RangeReading::kNoRange;
  }
  if (limits && r < lo) {
    *why = "range " + num(r) + " m below min_range " + num(lo) + " m";
    return RangeReading::kNoRange;
  }
  if (limits && r > hi) {
    *why = "range " + num(r) + " m above max_range " + num(hi) + " m";
    return RangeReading::kNoRange;
  }
  sample->slant_range_m = r;
  why->clear();
  return RangeReading::kRange;
}

bool fromInitialStateMsg(const nav_msgs::Odometry& msg, const Pose& T_cam_imu, InitialState* state,
                         std::string* why) {
  const auto& p = msg.pose.pose.position;
  const auto& q = msg.pose.pose.orientation;
  const auto& v = msg.twist.twist.linear;
  const auto& w = msg.twist.twist.angular;
  if (!finite3(p.x, p.y, p.z) || !finite3(q.x, q.y, q.z) || !std::isfinite(q.w)) {
    *why = "initial state: non-finite pose";
    return false;
  }
  if (!finite3(v.x, v.y, v.z) || !finite3(w.x, w.y, w.z)) {
    *why = "initial state: non-finite velocity";
    return false;
  }
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (std::abs(norm - 1.0) > 1e-3) {
    *why = "initial state: quaternion norm " + num(norm) + " (expected 1)";
    return false;
  }
  state->T_world_cam = fromPoseMsg(msg.pose.pose);
  const Eigen::Vector3d lever_world = state->T_world_cam.rotation() * T_cam_imu.translation();
  state->v_world_imu_mps = Eigen::Vector3d(v.x, v.y, v.z) + Eigen::Vector3d(w.x, w.y, w.z).cross(lever_world);
  return true;
}

nav_msgs::Odometry toInitialStateMsg(const Pose& T_world_cam, const Eigen::Vector3d& v_world_cam_mps,
                                     const std_msgs::Header& header, const std::string& camera_frame) {
  nav_msgs::Odometry msg;
  msg.header = header;
  msg.child_frame_id = camera_frame;
  msg.pose.pose = toPoseMsg(T_world_cam);
  msg.twist.twist.linear.x = v_world_cam_mps.x();
  msg.twist.twist.linear.y = v_world_cam_mps.y();
  msg.twist.twist.linear.z = v_world_cam_mps.z();
  return msg;
}

sensor_msgs::ImagePtr toImageMsg(const cv::Mat& gray, const std_msgs::Header& header) {
  std::string encoding;
  if (gray.type() == CV_8UC1)
    encoding = sensor_msgs::image_encodings::MONO8;
  else if (gray.type() == CV_16UC1)
    encoding = sensor_msgs::image_encodings::MONO16;
  else
    throw std::invalid_argument(
        "toImageMsg: expected an 8- or 16-bit single-channel image, got OpenCV type " +
        std::to_string(gray.type()));
  return cv_bridge::CvImage(header, encoding, gray).toImageMsg();
}

bool isSupportedEncoding(const std::string& encoding) {
  namespace enc = sensor_msgs::image_encodings;
  return encoding == enc::MONO8 || encoding == enc::MONO16 || encoding == enc::RGB8 ||
         encoding == enc::BGR8 || encoding == enc::RGBA8 || encoding == enc::BGRA8;
}

namespace {

/// Whatever a conversion did, the pipeline gets one 8-bit channel of the message's size, or a reason.
bool checkedGray(const sensor_msgs::ImageConstPtr& msg, cv::Mat* gray, std::string* why) {
  if (gray->type() == CV_8UC1 && gray->cols == int(msg->width) && gray->rows == int(msg->height)) return true;
  *why = "image conversion of '" + msg->encoding + "' (is_bigendian " +
         std::to_string(int(msg->is_bigendian)) + ") gave " + std::to_string(gray->channels()) +
         " channel(s) of depth " + std::to_string(gray->depth()) + ", " + std::to_string(gray->cols) + "x" +
         std::to_string(gray->rows) + ": not an 8-bit gray image";
  return false;
}

}  // namespace

bool toGray8(const sensor_msgs::ImageConstPtr& msg, cv::Mat* gray, std::string* why, int mono16_bits) {
  namespace enc = sensor_msgs::image_encodings;
  if (!isSupportedEncoding(msg->encoding)) {
    *why = "unsupported image encoding '" + msg->encoding +
           "' (accepted: mono8, mono16, rgb8, bgr8, rgba8, bgra8)";
    return false;
  }
  if (mono16_bits < 8 || mono16_bits > 16) {
    *why = "mono16 significant bits " + std::to_string(mono16_bits) + " outside 8..16";
    return false;
  }
  if (msg->width == 0 || msg->height == 0) {
    *why = "empty image (" + std::to_string(msg->width) + "x" + std::to_string(msg->height) + ")";
    return false;
  }
  const size_t row_bytes =
      size_t(msg->width) * size_t(enc::numChannels(msg->encoding)) * size_t(enc::bitDepth(msg->encoding) / 8);
  if (msg->step < row_bytes || msg->data.size() < size_t(msg->step) * msg->height) {
    *why = "image data (" + std::to_string(msg->data.size()) + " bytes, step " + std::to_string(msg->step) +
           ") does not hold " + std::to_string(msg->width) + "x" + std::to_string(msg->height) + " " +
           msg->encoding + " pixels";
    return false;
  }
  try {
    if (msg->encoding == enc::MONO16) {
      // Not through cv_bridge: for a byte order other than the host's it returns two 8-bit channels. Each
      // pixel is decoded in the message's byte order (is_bigendian), row by row (step).
      cv::Mat host(int(msg->height), int(msg->width), CV_16UC1);
      const bool big_endian = msg->is_bigendian != 0;
      for (uint32_t r = 0; r < msg->height; ++r) {
        const uint8_t* src = msg->data.data() + size_t(r) * msg->step;
        uint16_t* dst = host.ptr<uint16_t>(int(r));
        for (uint32_t c = 0; c < msg->width; ++c, src += 2)
          dst[c] = big_endian ? uint16_t((uint16_t(src[0]) << 8) | src[1])
                              : uint16_t(src[0] | (uint16_t(src[1]) << 8));
      }
      // The top mono16_bits bits to 8 bits (saturating: a right-aligned 12-bit sensor never exceeds 4095).
      host.convertTo(*gray, CV_8U, 1.0 / double(1 << (mono16_bits - 8)));
      return checkedGray(msg, gray, why);
    }
    const cv_bridge::CvImageConstPtr shared = cv_bridge::toCvShare(msg);  // no copy: the Mat views msg->data
    const cv::Mat& in = shared->image;
    if (msg->encoding == enc::MONO8)
      *gray = in;
    else if (msg->encoding == enc::RGB8)
      cv::cvtColor(in, *gray, cv::COLOR_RGB2GRAY);
    else if (msg->encoding == enc::BGR8)
      cv::cvtColor(in, *gray, cv::COLOR_BGR2GRAY);
    else if (msg->encoding == enc::RGBA8)
      cv::cvtColor(in, *gray, cv::COLOR_RGBA2GRAY);
    else
      cv::cvtColor(in, *gray, cv::COLOR_BGRA2GRAY);
  } catch (const std::exception& e) {
    *why = std::string("image conversion failed: ") + e.what();
    return false;
  }
  return checkedGray(msg, gray, why);
}

}  // namespace planetary_vo::ros_io
