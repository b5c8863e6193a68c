/// @file map_event_conversions.cpp
/// MapEvents <-> planetary_vo/VoMapEvents (see map_event_conversions.h).

#include "planetary_vo/ros_io/map_event_conversions.h"

#include <cmath>
#include <string>

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>

#include "planetary_vo/ros_io/conversions.h"

namespace planetary_vo::ros_io {
namespace {

/// The arrays of one point group of the message.
struct PointGroup {
  std::vector<uint64_t>* ids;
  std::vector<double>* positions;
  std::vector<double>* covariances;
  std::vector<int32_t>* num_observations;
};

struct ConstPointGroup {
  const char* name;
  const std::vector<uint64_t>& ids;
  const std::vector<double>& positions;
  const std::vector<double>& covariances;
  const std::vector<int32_t>& num_observations;
};

void fillGroup(const std::vector<MapPointState>& points, const PointGroup& group) {
  const size_t n = points.size();
  group.ids->resize(n);
  group.positions->resize(3 * n);
  group.covariances->resize(9 * n);
  group.num_observations->resize(n);
  for (size_t i = 0; i < n; ++i) {
    const MapPointState& p = points[i];
    (*group.ids)[i] = p.id;
    for (int r = 0; r < 3; ++r) {
      (*group.positions)[3 * i + r] = p.p_world[r];
      for (int c = 0; c < 3; ++c) (*group.covariances)[9 * i + 3 * r + c] = p.covariance_world(r, c);
    }
    (*group.num_observations)[i] = static_cast<int32_t>(p.num_observations);
  }
}

[[noreturn]] void fail(const std::string& what) {
  throw std::invalid_argument("VoMapEvents rejected: " + what);
}

std::vector<MapPointState> readGroup(const ConstPointGroup& g) {
  const size_t n = g.ids.size();
  const std::string name(g.name);
  if (g.positions.size() != 3 * n)
    fail(name + "_positions has " + std::to_string(g.positions.size()) + " values, expected 3 x " +
         std::to_string(n) + " (" + name + "_ids)");
  if (g.covariances.size() != 9 * n)
    fail(name + "_covariances has " + std::to_string(g.covariances.size()) + " values, expected 9 x " +
         std::to_string(n) + " (" + name + "_ids)");
  if (g.num_observations.size() != n)
    fail(name + "_num_observations has " + std::to_string(g.num_observations.size()) + " values, expected " +
         std::to_string(n) + " (" + name + "_ids)");
  std::vector<MapPointState> points(n);
  for (size_t i = 0; i < n; ++i) {
    MapPointState& p = points[i];
    p.id = g.ids[i];
    for (int r = 0; r < 3; ++r) {
      p.p_world[r] = g.positions[3 * i + r];
      for (int c = 0; c < 3; ++c) p.covariance_world(r, c) = g.covariances[9 * i + 3 * r + c];
    }
    if (!p.p_world.allFinite())
      fail(name + " point " + std::to_string(i) + " (id " + std::to_string(p.id) + "): position not finite");
    if (!p.covariance_world.allFinite())
      fail(name + " point " + std::to_string(i) + " (id " + std::to_string(p.id) +
           "): covariance not finite");
    if (g.num_observations[i] < 0)
      fail(name + " point " + std::to_string(i) + " (id " + std::to_string(p.id) +
           "): negative num_observations " + std::to_string(g.num_observations[i]));
    p.num_observations = g.num_observations[i];
  }
  return points;
}

void fillKeyframes(const std::vector<MapKeyframeState>& keyframes, const ros::Time& epoch,
                   std::vector<uint64_t>* ids, std::vector<ros::Time>* stamps,
                   std::vector<geometry_msgs::Pose>* poses) {
  ids->resize(keyframes.size());
  stamps->resize(keyframes.size());
  poses->resize(keyframes.size());
  for (size_t i = 0; i < keyframes.size(); ++i) {
    (*ids)[i] = keyframes[i].id;
    (*stamps)[i] = toStamp(epoch, keyframes[i].timestamp_s);
    (*poses)[i] = toPoseMsg(keyframes[i].T_world_cam);
  }
}

/// One keyframe group of the message (`name`: the arrays' prefix, for the errors), checked: arrays of one
/// length, finite poses, unit quaternions.
std::vector<MapKeyframeState> readKeyframes(const std::string& name, const std::vector<uint64_t>& ids,
                                            const std::vector<ros::Time>& stamps,
                                            const std::vector<geometry_msgs::Pose>& poses,
                                            const ros::Time& epoch) {
  const size_t k = ids.size();
  if (stamps.size() != k || poses.size() != k)
    fail(name + " arrays disagree: " + std::to_string(k) + " " + name + "_ids, " +
         std::to_string(stamps.size()) + " " + name + "_stamps, " + std::to_string(poses.size()) + " " +
         name + "_T_world_cam");
  std::vector<MapKeyframeState> keyframes(k);
  for (size_t i = 0; i < k; ++i) {
    const geometry_msgs::Pose& pose = poses[i];
    const double values[] = {pose.position.x,    pose.position.y,    pose.position.z,   pose.orientation.x,
                             pose.orientation.y, pose.orientation.z, pose.orientation.w};
    for (double v : values)
      if (!std::isfinite(v)) fail(name + " " + std::to_string(i) + ": pose not finite");
    const double norm =
        std::sqrt(pose.orientation.x * pose.orientation.x + pose.orientation.y * pose.orientation.y +
                  pose.orientation.z * pose.orientation.z + pose.orientation.w * pose.orientation.w);
    if (std::abs(norm - 1.0) > 1e-6)
      fail(name + " " + std::to_string(i) + ": orientation is not a unit quaternion (norm " +
           std::to_string(norm) + ")");
    keyframes[i].id = ids[i];
    keyframes[i].timestamp_s = toDatasetTime(epoch, stamps[i]);
    keyframes[i].T_world_cam = fromPoseMsg(pose);
  }
  return keyframes;
}

}  // namespace

VoMapEvents toMsg(const MapEvents& events, bool metric_scale, const std_msgs::Header& header,
                  const ros::Time& epoch, const cv::Mat* keyframe_gray,
                  const std_msgs::Header& image_header) {
  VoMapEvents msg;
  msg.header = header;
  msg.metric_scale = metric_scale;
  msg.map_restarted = events.map_restarted;
  const size_t k = events.keyframes_added.size();
  fillKeyframes(events.keyframes_added, epoch, &msg.keyframe_ids, &msg.keyframe_stamps,
                &msg.keyframe_T_world_cam);
  fillKeyframes(events.keyframes_retired, epoch, &msg.retired_keyframe_ids, &msg.retired_keyframe_stamps,
                &msg.retired_keyframe_T_world_cam);
  fillGroup(events.points_added,
            {&msg.added_ids, &msg.added_positions, &msg.added_covariances, &msg.added_num_observations});
  fillGroup(events.points_updated, {&msg.updated_ids, &msg.updated_positions, &msg.updated_covariances,
                                    &msg.updated_num_observations});
  fillGroup(events.points_retired, {&msg.retired_ids, &msg.retired_positions, &msg.retired_covariances,
                                    &msg.retired_num_observations});
  msg.removed_ids = events.points_removed;
  if (keyframe_gray && k > 0 && !keyframe_gray->empty()) {
    if (keyframe_gray->type() != CV_8UC1)
      throw std::invalid_argument("toMsg: the keyframe image must be 8-bit single-channel (CV_8UC1)");
    cv_bridge::CvImage(image_header, sensor_msgs::image_encodings::MONO8, *keyframe_gray)
        .toImageMsg(msg.keyframe_image);
  }
  return msg;
}

MapEvents fromMsg(const VoMapEvents& msg, const ros::Time& epoch, cv::Mat* keyframe_image) {
  MapEvents events;
  events.map_restarted = msg.map_restarted;
  const size_t k = msg.keyframe_ids.size();
  events.keyframes_added =
      readKeyframes("keyframe", msg.keyframe_ids, msg.keyframe_stamps, msg.keyframe_T_world_cam, epoch);
  events.keyframes_retired =
      readKeyframes("retired_keyframe", msg.retired_keyframe_ids, msg.retired_keyframe_stamps,
                    msg.retired_keyframe_T_world_cam, epoch);
  events.points_added = readGroup(
      {"added", msg.added_ids, msg.added_positions, msg.added_covariances, msg.added_num_observations});
  events.points_updated = readGroup({"updated", msg.updated_ids, msg.updated_positions,
                                     msg.updated_covariances, msg.updated_num_observations});
  events.points_retired = readGroup({"retired", msg.retired_ids, msg.retired_positions,
                                     msg.retired_covariances, msg.retired_num_observations});
  events.points_removed = msg.removed_ids;

  const sensor_msgs::Image& image = msg.keyframe_image;
  const bool has_image = !image.data.empty() || image.width > 0 || image.height > 0;
  if (has_image) {
    if (k == 0) fail("keyframe_image present but no keyframe was added");
    if (image.encoding != sensor_msgs::image_encodings::MONO8)
      fail("keyframe_image encoding '" + image.encoding + "', expected mono8");
    if (image.width == 0 || image.height == 0 || image.step < image.width ||
        image.data.size() != size_t(image.step) * image.height)
      fail("keyframe_image of " + std::to_string(image.width) + "x" + std::to_string(image.height) +
           ", step " + std::to_string(image.step) + " does not hold " + std::to_string(image.data.size()) +
           " bytes");
  }
  if (keyframe_image) {
    if (has_image)
      *keyframe_image = cv::Mat(int(image.height), int(image.width), CV_8UC1,
                                const_cast<uint8_t*>(image.data.data()), image.step)
                            .clone();
    else
      *keyframe_image = cv::Mat();
  }
  return events;
}

}  // namespace planetary_vo::ros_io
