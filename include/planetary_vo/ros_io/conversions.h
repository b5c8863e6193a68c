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
#include <nav_msgs/Odometry.h>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Range.h>
#include <std_msgs/Header.h>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo::ros_io {

/// Stamp of a dataset time: `epoch + t`, with t converted on its own (ros::Duration::fromSec) so that a
/// dataset time of 0.1 s gives exactly 100000000 ns after the epoch, whatever the size of the epoch.
ros::Time toStamp(const ros::Time& epoch, double dataset_time_s);
/// Seconds of a stamp relative to `epoch` (the inverse of toStamp up to nanosecond rounding), for any two
/// valid stamps (= secondsBetween(stamp, epoch)).
double toDatasetTime(const ros::Time& epoch, const ros::Time& stamp);
/// `later - earlier` in seconds, from the nanosecond counts: defined for any two valid stamps, where
/// ros::Time's own difference throws beyond the 32-bit range of ros::Duration (a stamp decades off).
double secondsBetween(const ros::Time& later, const ros::Time& earlier);

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

// ---------------------------------------------------------------------------------------------------------------
// Sensor messages -> core samples (the nodelet's inputs). Times are seconds since `epoch` (toDatasetTime),
// the clock the nodelet gives the pipeline. None of these throws: a message that cannot be used gives false
// (or kInvalid) and the reason in *why.

/// @brief sensor_msgs/Imu -> ImuSample (angular velocity and linear acceleration = specific force, in the IMU
/// frame; the orientation is ignored).
/// @return false, with *why, for a zero stamp, a non-finite angular velocity or linear acceleration, or a
/// message that says it carries no angular velocity or no linear acceleration (covariance[0] = -1, REP-145).
bool fromImu(const sensor_msgs::Imu& msg, const ros::Time& epoch, ImuSample* sample, std::string* why);

/// What a sensor_msgs/Range reading says (REP-117 and the Range message's limits).
enum class RangeReading {
  kRange,    ///< a finite range within [min_range, max_range]: sample->slant_range_m = range
  kNoRange,  ///< a valid reading without a range: +Inf (no return), -Inf (too close to measure), or a finite
             ///< range outside [min_range, max_range]; sample->slant_range_m = +Inf (the pipeline's "no
             ///< return")
  kInvalid,  ///< NaN, a negative range, or a zero stamp: *why says which
};
/// "range", "no_range", "invalid".
const char* toString(RangeReading reading);
/// @brief sensor_msgs/Range -> AltimeterSample. The limits are applied only when the message gives usable
/// ones (finite, 0 <= min_range < max_range); a driver that leaves them 0 is not second-guessed.
/// @param why set for kNoRange (what kind) and kInvalid.
RangeReading fromRange(const sensor_msgs::Range& msg, const ros::Time& epoch, AltimeterSample* sample,
                       std::string* why);

/// The state guidance hands over (nav/initial_state), as the pipeline takes it.
struct InitialState {
  Pose T_world_cam = Pose::Identity();                        ///< camera optical frame in the world
  Eigen::Vector3d v_world_imu_mps = Eigen::Vector3d::Zero();  ///< IMU body velocity, world frame
};

/// @brief nav/initial_state (nav_msgs/Odometry) -> InitialState. Convention (docs/ros_interface.md): pose =
/// T_world_cam of the camera optical frame in the world frame (header.frame_id: gravity-aligned, z up);
/// twist.twist.linear = velocity of the camera optical frame's origin in the WORLD frame (not the child frame
/// as REP-105's odometry has it); twist.twist.angular = angular velocity in the world frame (zero when
/// unknown), used only to move the velocity to the IMU: v_imu = v_cam + w x (R_world_cam * t_cam_imu).
/// @return false, with *why, for a non-finite pose or velocity or a quaternion whose norm is not 1 +- 1e-3
/// (it is normalised otherwise).
bool fromInitialStateMsg(const nav_msgs::Odometry& msg, const Pose& T_cam_imu, InitialState* state,
                         std::string* why);
/// The inverse, for a handover source (the player): header.frame_id = the world frame, child_frame_id = the
/// camera optical frame, twist.linear = v_world_cam_mps (world frame), twist.angular = 0, covariances 0.
nav_msgs::Odometry toInitialStateMsg(const Pose& T_world_cam, const Eigen::Vector3d& v_world_cam_mps,
                                     const std_msgs::Header& header, const std::string& camera_frame);

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
/// @param mono16_bits significant bits of a mono16 pixel (8..16): 16 for left-aligned data (the full range,
///        the convention of most drivers), 10 or 12 for a sensor that writes its samples right-aligned
///        (0..1023, 0..4095); the top `mono16_bits` are mapped to 0..255 (brighter values saturate).
bool toGray8(const sensor_msgs::ImageConstPtr& msg, cv::Mat* gray, std::string* why, int mono16_bits = 16);

}  // namespace planetary_vo::ros_io
