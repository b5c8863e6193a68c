/// @file vo_conversions.cpp
/// Pipeline values -> nodelet output messages, and input checks (see vo_conversions.h).

#include "planetary_vo/ros_io/vo_conversions.h"

#include <algorithm>
#include <cmath>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <sensor_msgs/point_cloud2_iterator.h>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "planetary_vo/geometry/pose.h"  // skew()
#include "planetary_vo/ros_io/conversions.h"

namespace planetary_vo::ros_io {
namespace {

/// Linear and angular velocity into a geometry_msgs/Twist.
void setTwist(const Eigen::Vector3d& v, const Eigen::Vector3d& w, geometry_msgs::Twist* twist) {
  twist->linear.x = v.x();
  twist->linear.y = v.y();
  twist->linear.z = v.z();
  twist->angular.x = w.x();
  twist->angular.y = w.y();
  twist->angular.z = w.z();
}

}  // namespace

std::string checkCameraInfo(const sensor_msgs::CameraInfo& info) {
  const double fx = info.K[0], fy = info.K[4], cx = info.K[2], cy = info.K[5];
  if (!std::isfinite(fx) || !std::isfinite(fy) || !std::isfinite(cx) || !std::isfinite(cy))
    return "camera_info intrinsics are not finite (K = [" + std::to_string(fx) + ", " + std::to_string(fy) +
           ", " + std::to_string(cx) + ", " + std::to_string(cy) + "])";
  if (fx <= 0.0 || fy <= 0.0)
    return "camera_info intrinsics are zero or negative (fx = " + std::to_string(fx) +
           ", fy = " + std::to_string(fy) + "): uncalibrated camera";
  if (info.width == 0 || info.height == 0) return "camera_info has no image size (width/height 0)";
  for (double d : info.D)
    if (!std::isfinite(d)) return "camera_info distortion coefficients are not finite";
  // The rest (distortion model and length, principal point, field of view, invertible distortion) is the
  // core's PinholeCamera::isValid(), shared with vo_run and the dataset readers.
  std::string why;
  if (!fromCameraInfo(info).isValid(&why)) return "camera_info rejected: " + why;
  return "";
}

std::string frameGapNote(double gap_s, double period_s) {
  // An int of gap / period overflowed (undefined) for a long gap at a short period, e.g. days at 1 kHz.
  const double frames = std::min(9.0e18, std::max(0.0, std::floor(gap_s / period_s + 0.5) - 1.0));
  return "about " + std::to_string(static_cast<long long>(frames)) + " frames dropped (gap " +
         std::to_string(gap_s) + " s, period " + std::to_string(period_s) + " s)";
}

bool checkOutputPose(const Pose& T, std::string* why) {
  if (!T.matrix().allFinite()) {
    *why = "the pipeline returned a non-finite pose";
    return false;
  }
  const Eigen::Matrix3d R = T.linear();
  const double orthonormality = (R.transpose() * R - Eigen::Matrix3d::Identity()).norm();
  if (!(orthonormality < 1e-6) || !(R.determinant() > 0.0)) {
    *why = "the pipeline returned a pose whose attitude is not a rotation (|R^T R - I| = " +
           std::to_string(orthonormality) + ", det " + std::to_string(R.determinant()) + ")";
    return false;
  }
  if (!(T.translation().norm() < kMaxOutputPositionMagnitude)) {
    *why = "the pipeline returned a position " + std::to_string(T.translation().norm()) +
           " units from the origin (diverged)";
    return false;
  }
  return true;
}

VoStatus toVoStatus(const FrameResult& r, const std_msgs::Header& header) {
  VoStatus s;
  s.header = header;
  s.state = static_cast<uint8_t>(r.state);
  s.state_name = toString(r.state);
  s.motion_model = static_cast<uint8_t>(r.motion);
  s.processed = r.processed;
  s.is_keyframe = r.is_keyframe;
  s.num_features_detected = static_cast<uint32_t>(std::max(0, r.num_new_features));
  s.num_features_tracked = static_cast<uint32_t>(std::max(0, r.num_tracked));
  s.num_inliers = static_cast<uint32_t>(std::max(0, r.num_inliers));
  s.num_map_points = static_cast<uint32_t>(std::max(0, r.num_map_points));
  s.num_keyframes = static_cast<uint32_t>(std::max(0, r.num_keyframes));
  s.tracking_ms = static_cast<float>(r.times.tracking_ms);
  s.motion_ms = static_cast<float>(r.times.motion_ms);
  s.mapping_ms = static_cast<float>(r.times.mapping_ms);
  s.ba_ms = static_cast<float>(r.times.ba_ms);
  s.total_ms = static_cast<float>(r.times.total_ms);
  s.scale_confidence = static_cast<float>(r.scale_confidence);
  s.scale_source = toString(r.scale_source);
  s.metric = r.metric_scale;
  s.inertial = r.inertial;
  s.has_velocity = r.has_velocity;
  if (r.has_velocity) {
    for (int i = 0; i < 3; ++i) {
      s.velocity_world_mps[i] = r.v_world_mps[i];
      s.gyro_bias_radps[i] = r.imu_bias.gyro_radps[i];
      s.accel_bias_mps2[i] = r.imu_bias.accel_mps2[i];
    }
  }
  s.message = r.message;
  return s;
}

std::string navigationMode(const VoConfig& config) {
  if (config.imu.enabled)
    return config.altimeter.enabled ? VoStatus::MODE_VISION_IMU_ALTIMETER : VoStatus::MODE_VISION_IMU;
  return config.altimeter.enabled ? VoStatus::MODE_VISION_ALTIMETER : VoStatus::MODE_VISION;
}

VoStatus badInputStatus(const std::string& why, const std_msgs::Header& header) {
  VoStatus s;
  s.header = header;
  s.state = VoStatus::STATE_BAD_INPUT;
  s.state_name = "bad_input";
  s.processed = false;
  s.message = why;
  return s;
}

nav_msgs::Odometry toOdometry(const FrameResult& result, const Pose& T_world_child, const Pose& T_world_prev,
                              double dt_s, const std_msgs::Header& header, const std::string& child_frame_id,
                              const OdometrySigma& sigma) {
  nav_msgs::Odometry odom;
  odom.header = header;
  odom.child_frame_id = child_frame_id;
  odom.pose.pose = toPoseMsg(T_world_child);
  double factor = sigma.lost_factor;
  if (result.hasPoseEstimate())
    factor = std::sqrt(double(sigma.reference_inliers) / double(std::max(1, result.num_inliers)));
  const double var_p = std::pow(sigma.position_m * factor, 2),
               var_r = std::pow(sigma.orientation_rad * factor, 2);
  for (int i = 0; i < 3; ++i) {
    odom.pose.covariance[i * 7] = var_p;
    odom.pose.covariance[(i + 3) * 7] = var_r;
  }
  if (dt_s > 0.0) {
    // Body-frame twist: T_prev_child = T_world_prev^-1 T_world_child over dt, expressed in the child frame.
    const Pose T_prev_child = T_world_prev.inverse() * T_world_child;
    const Eigen::Vector3d v_child = T_world_child.rotation().transpose() *
                                    (T_world_child.translation() - T_world_prev.translation()) / dt_s;
    const Eigen::AngleAxisd aa(T_prev_child.rotation());
    const Eigen::Vector3d w_child = aa.axis() * aa.angle() / dt_s;
    setTwist(v_child, w_child, &odom.twist.twist);
    for (int i = 0; i < 3; ++i) {
      odom.twist.covariance[i * 7] = 2.0 * var_p / (dt_s * dt_s);
      odom.twist.covariance[(i + 3) * 7] = 2.0 * var_r / (dt_s * dt_s);
    }
  } else {
    for (int i = 0; i < 6; ++i) odom.twist.covariance[i * 7] = 1e6;  // unknown
  }
  return odom;
}

Eigen::Matrix<double, 9, 9> navCovariance(const FrameResult& result, const OdometrySigma& sigma,
                                          double velocity_sigma_mps) {
  const bool confident = result.hasPoseEstimate() || result.inertial;
  if (result.has_covariance && result.covariance.allFinite()) {
    const double inflation = confident ? 1.0 : sigma.lost_factor * sigma.lost_factor;
    return result.covariance * inflation;
  }
  double factor = sigma.lost_factor;
  if (result.hasPoseEstimate())
    factor = std::sqrt(double(sigma.reference_inliers) / double(std::max(1, result.num_inliers)));
  Eigen::Matrix<double, 9, 9> cov = Eigen::Matrix<double, 9, 9>::Zero();
  cov.diagonal().segment<3>(0).setConstant(std::pow(sigma.position_m * factor, 2));
  cov.diagonal().segment<3>(3).setConstant(std::pow(sigma.orientation_rad * factor, 2));
  cov.diagonal().segment<3>(6).setConstant(std::pow(velocity_sigma_mps * factor, 2));
  return cov;
}

bool differentiatePoses(const Pose& T_world_prev, const Pose& T_world_cur, double dt_s,
                        Eigen::Vector3d* v_world, Eigen::Vector3d* w_body) {
  if (!(dt_s > 0.0)) return false;
  *v_world = (T_world_cur.translation() - T_world_prev.translation()) / dt_s;
  const Eigen::AngleAxisd aa(T_world_prev.rotation().transpose() * T_world_cur.rotation());
  *w_body = aa.axis() * aa.angle() / dt_s;
  return true;
}

nav_msgs::Odometry toNavOdometry(const NavSolution& s, const Pose& T_cam_imu, const Pose& T_cam_child,
                                 const std_msgs::Header& header, const std::string& child_frame_id) {
  nav_msgs::Odometry odom;
  odom.header = header;
  odom.child_frame_id = child_frame_id;
  const Pose T_world_child = s.T_world_cam * T_cam_child;
  const Pose T_world_body = s.T_world_cam * T_cam_imu;
  odom.pose.pose = toPoseMsg(T_world_child);
  const Eigen::Matrix3d R_world_child = T_world_child.rotation();
  const Eigen::Matrix3d R_world_body = T_world_body.rotation();
  const Eigen::Matrix3d R_child_body = R_world_child.transpose() * R_world_body;
  // Rigid body: the child origin moves with the body's velocity plus w x (lever arm), all in the world.
  const Eigen::Vector3d w_world = R_world_body * s.w_body_radps;
  const Eigen::Vector3d v_world_child =
      s.v_world_mps + w_world.cross(T_world_child.translation() - T_world_body.translation());
  const Eigen::Vector3d v_child = R_world_child.transpose() * v_world_child;
  const Eigen::Vector3d w_child = R_child_body * s.w_body_radps;
  setTwist(v_child, w_child, &odom.twist.twist);
  // Pose covariance of the child: position error dp_child = dp_cam - [R_world_cam t_cam_child]x dtheta for a
  // world-frame attitude error dtheta, which the child shares.
  Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Identity();
  J.block<3, 3>(0, 3) = -skew(s.T_world_cam.rotation() * T_cam_child.translation());
  const Eigen::Matrix<double, 6, 6> pose_cov = J * s.covariance.topLeftCorner<6, 6>() * J.transpose();
  Eigen::Matrix<double, 6, 6> twist_cov = Eigen::Matrix<double, 6, 6>::Zero();
  twist_cov.topLeftCorner<3, 3>() =
      R_world_child.transpose() * s.covariance.bottomRightCorner<3, 3>() * R_world_child;
  twist_cov.bottomRightCorner<3, 3>() = R_child_body * s.w_covariance * R_child_body.transpose();
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) {
      odom.pose.covariance[r * 6 + c] = pose_cov(r, c);
      odom.twist.covariance[r * 6 + c] = twist_cov(r, c);
    }
  return odom;
}

sensor_msgs::PointCloud2 toPointCloud(const std::vector<MapPointView>& points, const std_msgs::Header& header,
                                      const Sim3Transform& S_frame_world) {
  sensor_msgs::PointCloud2 cloud;
  cloud.header = header;
  sensor_msgs::PointCloud2Modifier modifier(cloud);
  modifier.setPointCloud2Fields(4, "x", 1, sensor_msgs::PointField::FLOAT32, "y", 1,
                                sensor_msgs::PointField::FLOAT32, "z", 1, sensor_msgs::PointField::FLOAT32,
                                "observations", 1, sensor_msgs::PointField::UINT32);
  modifier.resize(points.size());
  cloud.height = 1;
  cloud.width = static_cast<uint32_t>(points.size());
  cloud.is_dense = true;
  // No iterator over an empty cloud: its constructor takes data.front() of an empty vector (a reference
  // bound to a null pointer; UBSan in the sanitizer stage, issue 12, on the first frames with an empty map).
  if (points.empty()) return cloud;
  sensor_msgs::PointCloud2Iterator<float> x(cloud, "x"), y(cloud, "y"), z(cloud, "z");
  sensor_msgs::PointCloud2Iterator<uint32_t> n(cloud, "observations");
  for (const MapPointView& p : points) {
    const Eigen::Vector3d q = S_frame_world.transformPoint(p.p_world);
    *x = static_cast<float>(q.x());
    *y = static_cast<float>(q.y());
    *z = static_cast<float>(q.z());
    *n = static_cast<uint32_t>(std::max(0, p.num_observations));
    ++x, ++y, ++z, ++n;
  }
  return cloud;
}

sensor_msgs::ImagePtr drawTracks(const cv::Mat& gray, const std::vector<FeatureTrack>& tracks,
                                 const FrameResult& result, const std_msgs::Header& header) {
  cv::Mat bgr;
  cv::cvtColor(gray, bgr, cv::COLOR_GRAY2BGR);
  const int radius = std::max(2, gray.cols / 256);
  for (const FeatureTrack& t : tracks) {
    const double age = std::min(1.0, t.age_frames / 20.0);
    const cv::Scalar colour(0, 255 * age, 255 * (1.0 - age));
    cv::line(bgr, t.prev_px, t.px, colour, 1, cv::LINE_AA);
    cv::circle(bgr, t.px, radius, colour, -1, cv::LINE_AA);
  }
  const std::string text = std::string(toString(result.state)) + "  tracks " + std::to_string(tracks.size()) +
                           "  inliers " + std::to_string(result.num_inliers);
  const double font = std::max(0.4, gray.cols / 800.0);
  cv::putText(bgr, text, cv::Point(8, int(20 * font / 0.5)), cv::FONT_HERSHEY_SIMPLEX, font,
              cv::Scalar(0, 255, 255), 1, cv::LINE_AA);
  return cv_bridge::CvImage(header, sensor_msgs::image_encodings::BGR8, bgr).toImageMsg();
}

}  // namespace planetary_vo::ros_io
