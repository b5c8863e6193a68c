#pragma once
/// @file conversions.h
/// Free functions between the ROS-free core types (planetary_vo::PinholeCamera, Pose, ImuSample,
/// AltimeterSample, cv::Mat) and ROS messages. No node handle, no master: everything here is unit-tested in
/// test/ros/.
///
/// Conventions: poses are T_parent_child (see geometry/pose.h), so a Pose T_world_cam becomes a message whose
/// header.frame_id is the world frame and whose child is the camera frame. Frames follow REP-103 (optical
/// frame: z forward, x right, y down).

#include <string>

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Header.h>

#include <opencv2/core.hpp>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo::ros_io {

/// Stamp of a dataset time: `epoch + t`, with t converted on its own (ros::Duration::fromSec) so that a
/// dataset time of 0.1 s gives exactly 100000000 ns after the epoch, whatever the size of the epoch.
ros::Time toStamp(const ros::Time& epoch, double dataset_time_s);
/// Seconds of a stamp relative to `epoch` (the inverse of toStamp up to nanosecond rounding).
double toDatasetTime(const ros::Time& epoch, const ros::Time& stamp);

std_msgs::Header makeHeader(const ros::Time& stamp, const std::string& frame_id);

/// Intrinsics -> CameraInfo: K, R = I, P = [K | 0], size, distortion_model ("plumb_bob" when the camera has
/// none, with D = 5 zeros, as camera_calibration writes it) and D. header is copied as given.
sensor_msgs::CameraInfo toCameraInfo(const PinholeCamera& camera, const std_msgs::Header& header);
/// CameraInfo -> intrinsics (fx, fy, cx, cy from K, size, distortion model and D). "plumb_bob" with all-zero
/// D becomes a camera without distortion.
PinholeCamera fromCameraInfo(const sensor_msgs::CameraInfo& info);

geometry_msgs::Pose toPoseMsg(const Pose& T_parent_child);
/// Normalises the quaternion; a zero quaternion gives the identity rotation.
Pose fromPoseMsg(const geometry_msgs::Pose& msg);
/// header.frame_id is the parent frame (the world for T_world_cam).
geometry_msgs::PoseStamped toPoseStamped(const Pose& T_parent_child, const std_msgs::Header& header);
/// header.frame_id is the parent frame, child_frame_id the child frame.
geometry_msgs::TransformStamped toTransformStamped(const Pose& T_parent_child, const std_msgs::Header& header,
                                                   const std::string& child_frame_id);
Pose fromTransformMsg(const geometry_msgs::Transform& msg);

/// White-noise standard deviations of one IMU sample, for the message covariances (0: unknown).
struct ImuNoiseSpec {
  double gyro_sigma_radps = 0.0;
  double accel_sigma_mps2 = 0.0;
};
/// The per-sample noise of the IMU that sensors.yaml describes: noise density x sqrt(rate). Zero (unknown)
/// when the dataset does not describe its IMU.
ImuNoiseSpec imuNoiseSpec(const SensorSpecification& spec);

/// IMU sample -> sensor_msgs/Imu: angular velocity and specific force (linear_acceleration) in the header
/// frame, orientation unknown (orientation_covariance[0] = -1, as REP-145 asks); angular velocity and linear
/// acceleration covariances diagonal from `noise` (all 0 = unknown when noise is 0).
sensor_msgs::Imu toImu(const ImuSample& sample, const std_msgs::Header& header,
                       const ImuNoiseSpec& noise = ImuNoiseSpec());

/// Shape of the altimeter beam written into every Range message (the defaults when a dataset does not
/// describe its altimeter: see altimeterSpec()).
struct AltimeterSpec {
  double field_of_view_rad = 0.005;  ///< a laser beam: about 0.3 degree
  double min_range_m = 0.5;
  double max_range_m = 100000.0;
};
/// The Range limits of the altimeter that sensors.yaml describes (beam divergence, min and max range);
/// `fallback` when the dataset does not describe it.
AltimeterSpec altimeterSpec(const SensorSpecification& spec, const AltimeterSpec& fallback = AltimeterSpec());
/// Altimeter sample -> sensor_msgs/Range (INFRARED, i.e. laser): range = slant range along the camera
/// boresight. The altitude above the terrain has no field in Range and is not carried.
sensor_msgs::Range toRange(const AltimeterSample& sample, const std_msgs::Header& header,
                           const AltimeterSpec& spec = AltimeterSpec());

/// 8-bit gray -> mono8, 16-bit gray -> mono16 (the pixels are copied). Throws std::invalid_argument
/// otherwise.
sensor_msgs::ImagePtr toImageMsg(const cv::Mat& gray, const std_msgs::Header& header);

/// Image encodings toGray8() accepts: mono8, mono16, rgb8, bgr8, rgba8, bgra8.
bool isSupportedEncoding(const std::string& encoding);

/// @brief Any supported image -> 8-bit gray for the pipeline.
/// mono8 is shared without a copy (the returned Mat points into `msg`, which must outlive it); mono16 is
/// scaled by 1/256; colour images are converted with the ITU-R BT.601 weights (cv::cvtColor).
/// @param why set to the reason when the image cannot be converted (unsupported encoding, empty image, step
///        or data size inconsistent with width x height).
/// @return false, with *why set, instead of throwing.
bool toGray8(const sensor_msgs::ImageConstPtr& msg, cv::Mat* gray, std::string* why);

}  // namespace planetary_vo::ros_io
