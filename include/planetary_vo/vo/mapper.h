#pragma once
/// @file mapper.h
/// Stage 5b: what happens to the map when a frame becomes a keyframe. The keyframe is appended with the ideal
/// pixels of all its live tracks; the map points that PnP confirmed in it gain an observation; every track
/// without a point is triangulated against the oldest kept keyframe that saw it (the widest baseline) and the
/// new point is observed by every kept keyframe that agrees with it; dead tracks are detached, the window is
/// trimmed and bad points are culled. Bundle adjustment of the result is the pipeline's next step.
///
/// Stateless apart from its settings; the map and the camera are passed in, so a camera change needs nothing
/// here.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/map.h"

namespace planetary_vo {

/// The current frame's live tracks that carry a map point, as given to PnP (parallel arrays; `inlier` is
/// PnP's verdict).
struct MapAssociations {
  std::vector<Eigen::Vector3d> p_world;
  std::vector<Eigen::Vector2d> px;  ///< ideal pixels
  std::vector<uint64_t> track_ids;
  std::vector<uint64_t> point_ids;
  std::vector<uint8_t> inlier;
  void clear();
  size_t size() const { return point_ids.size(); }
};

struct KeyframeInsertion {
  uint64_t keyframe_id = 0;
  int points_created = 0;
  int points_culled = 0;
};

class Mapper {
 public:
  explicit Mapper(const MapConfig& config);

  /// Adds the frame as the newest keyframe of `map` and updates the map as described above.
  /// @param track_ids the frame's live tracks, ascending; @param px their ideal pixels.
  /// @param associations the frame's PnP associations (only the inliers gain an observation).
  KeyframeInsertion insertKeyframe(double timestamp_s, const Pose& T_world_cam,
                                   const std::vector<uint64_t>& track_ids,
                                   const std::vector<Eigen::Vector2d>& px,
                                   const MapAssociations& associations, const PinholeCamera& camera,
                                   Map* map) const;

 private:
  int triangulateNewPoints(uint64_t new_keyframe_id, const std::vector<uint64_t>& track_ids,
                           const std::vector<Eigen::Vector2d>& px, const PinholeCamera& camera,
                           Map* map) const;

  MapConfig config_;
};

}  // namespace planetary_vo
