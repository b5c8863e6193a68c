#pragma once
/// @file map_events.h
/// What changed in the VO's windowed map during one frame (FrameResult::map_events), for consumers that build
/// their own persistent products from it (the terrain and hazard map, terrain/): the VO does not know them,
/// and they never look into the VO's map.
///
/// Semantics, per frame (Map::takeEvents()):
/// - points_added: points triangulated this frame, with their state at the end of the frame;
/// - points_updated: points that already existed and moved or gained observations (bundle adjustment, a new
///   keyframe's observation, the map scaled to metres or turned gravity-aligned);
/// - points_retired: points that left the VO (their keyframes left the window, or the map was restarted)
///   with their last state: final, still valid estimates of the terrain;
/// - points_removed: ids of points the VO rejected (bundle-adjustment outliers, points PnP keeps rejecting):
///   a consumer should forget them;
/// - keyframes_added: keyframes inserted this frame, with their pose at insertion;
/// - keyframes_retired: keyframes that left the window (or the map, on a restart) with their last pose: the
///   final estimate after every bundle adjustment they took part in (the keyframe trajectory that DSO's
///   result.txt and ORB-SLAM's KeyFrameTrajectory.txt report). In the world frame of the frame they left in.
/// A point appears at most once per frame, in the last category that applies (added then removed in the
/// same frame: not reported at all). Positions are in the VO world frame of that frame (metres when
/// FrameResult::metric_scale, else the map's unit; gravity-aligned when the initial pose was handed over or
/// the visual-inertial alignment made it so).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/geometry/pose.h"

namespace planetary_vo {

struct MapPointState {
  uint64_t id = 0;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();
  /// Triangulation covariance (world, squared map units) from the point's keyframe observations with the
  /// keyframe poses taken as exact and 1 px of noise per observation. With fewer than two observations or
  /// nearly parallel rays the depth is unconstrained and the variance along the ray is large (capped at
  /// 1e12).
  Eigen::Matrix3d covariance_world = Eigen::Matrix3d::Identity();
  int num_observations = 0;  ///< keyframes of the window that observe it
};

struct MapKeyframeState {
  uint64_t id = 0;
  double timestamp_s = 0.0;
  Pose T_world_cam = Pose::Identity();
};

struct MapEvents {
  std::vector<MapKeyframeState> keyframes_added;
  std::vector<MapKeyframeState> keyframes_retired;
  std::vector<MapPointState> points_added;
  std::vector<MapPointState> points_updated;
  std::vector<MapPointState> points_retired;
  std::vector<uint64_t> points_removed;
  /// The VO started a new map this frame (first initialisation, re-initialisation or recovery); the points
  /// of the old one were retired. Ids never repeat across maps.
  bool map_restarted = false;

  bool empty() const {
    return keyframes_added.empty() && keyframes_retired.empty() && points_added.empty() &&
           points_updated.empty() && points_retired.empty() && points_removed.empty() && !map_restarted;
  }
};

}  // namespace planetary_vo
