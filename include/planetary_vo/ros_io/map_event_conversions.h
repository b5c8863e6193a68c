#pragma once
/// @file map_event_conversions.h
/// planetary_vo::MapEvents (FrameResult::map_events, vo/map_events.h) <-> the message
/// planetary_vo/VoMapEvents of the topic vo/map_events, the feed of the terrain and hazard map. The message
/// is named VoMapEvents: the generated C++ type planetary_vo::MapEvents would collide with the core struct.
/// No node handle: unit-tested in test/ros/test_map_event_conversions.cpp without a master.
///
/// Round trip (fromMsg(toMsg(e))): ids, point positions, covariances, observation counts and the flags are
/// exact; keyframe poses go through a quaternion (translation exact, rotation to ~1e-16); keyframe stamps go
/// through ros::Time (nanoseconds: exact for times on a nanosecond, else to 1 ns).

#include <stdexcept>

#include <ros/time.h>
#include <std_msgs/Header.h>

#include <opencv2/core.hpp>

#include "planetary_vo/VoMapEvents.h"
#include "planetary_vo/vo/map_events.h"

namespace planetary_vo::ros_io {

/// @brief One frame's map events as a message.
/// @param events the pipeline's events of the frame
/// @param metric_scale FrameResult::metric_scale of the frame
/// @param header stamp of the image, frame_id the VO world frame (the frame the events' positions are in)
/// @param epoch the pipeline's clock origin: a keyframe at timestamp_s gets the stamp toStamp(epoch, t)
/// @param keyframe_gray the 8-bit image the pipeline was given this frame (CV_8UC1), or nullptr; attached as
///        keyframe_image (mono8, copied) only when a keyframe was added
/// @param image_header header of keyframe_image (the camera image's stamp and frame_id)
/// @throws std::invalid_argument when keyframe_gray is given, a keyframe was added and it is not CV_8UC1
VoMapEvents toMsg(const MapEvents& events, bool metric_scale, const std_msgs::Header& header,
                  const ros::Time& epoch, const cv::Mat* keyframe_gray = nullptr,
                  const std_msgs::Header& image_header = std_msgs::Header());

/// @brief The events of a message, checked.
/// @param epoch the consumer's clock origin: keyframe timestamp_s = seconds from epoch to the keyframe's
/// stamp
/// @param keyframe_image if not null: the keyframe image (a CV_8UC1 copy of keyframe_image), empty when the
///        message has none
/// @throws std::invalid_argument (saying which field and index) when the keyframe arrays or a point group's
///         ids / positions (3 per point) / covariances (9 per point) / num_observations lengths disagree, a
///         number is not finite, an observation count is negative, a keyframe quaternion is not unit length,
///         or keyframe_image is not mono8, inconsistent in size, or present without a keyframe added
MapEvents fromMsg(const VoMapEvents& msg, const ros::Time& epoch, cv::Mat* keyframe_image = nullptr);

}  // namespace planetary_vo::ros_io
