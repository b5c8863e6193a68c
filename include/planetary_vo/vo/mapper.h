#pragma once
/// @file mapper.h
/// Stage 5b: what happens to the map when a frame becomes a keyframe. The keyframe is appended with the ideal
/// pixels of all its live tracks (and of its map-only tracks, keyframe_tracker.h); the map points that PnP
/// confirmed in it gain an observation; every track without a point is triangulated against the oldest kept
/// keyframe that saw it (the widest baseline) and the new point is observed by every kept keyframe that
/// agrees with it; dead tracks are detached, the window is trimmed and bad points are culled. Bundle
/// adjustment of the result is the pipeline's next step.
///
/// Stateless apart from its settings; the map and the camera are passed in, so a camera change needs nothing
/// here.

#include <cstdint>
#include <utility>
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

/// A keyframe's map-only tracks (keyframe_tracker.h): parallel arrays, ids ascending and above every frame
/// track id, ideal pixels.
struct KeyframeTracks {
  std::vector<uint64_t> ids;
  std::vector<Eigen::Vector2d> px;
};

struct KeyframeInsertion {
  uint64_t keyframe_id = 0;
  int points_created = 0;
  int points_culled = 0;
  /// Map-only tracks whose point the keyframe now observes (they reproject within max_reprojection_error_px).
  int keyframe_track_observations = 0;
  /// Map-only tracks that reproject farther than that from their point: detached from it; the caller drops
  /// them from the keyframe tracker.
  std::vector<uint64_t> rejected_keyframe_tracks;
};

class Mapper {
 public:
  explicit Mapper(const MapConfig& config);

  /// Adds the frame as the newest keyframe of `map` and updates the map as described above.
  /// @param track_ids the frame's live tracks, ascending; @param px their ideal pixels.
  /// @param associations the frame's PnP associations (only the inliers gain an observation).
  /// @param keyframe_tracks the keyframe's map-only tracks, or nullptr: they join the keyframe like the frame
  ///        tracks (and are triangulated like them); one that carries a point gives it an observation when it
  ///        reprojects within max_reprojection_error_px of the keyframe's pose, else it is detached.
  /// @throws std::invalid_argument when the map-only ids do not ascend above the frame tracks' (the map is
  ///         unchanged).
  KeyframeInsertion insertKeyframe(double timestamp_s, const Pose& T_world_cam,
                                   const std::vector<uint64_t>& track_ids,
                                   const std::vector<Eigen::Vector2d>& px,
                                   const MapAssociations& associations, const PinholeCamera& camera, Map* map,
                                   const KeyframeTracks* keyframe_tracks = nullptr) const;

  /// The map-only tracks of the newest keyframe, found after it was inserted (the pipeline has them tracked
  /// in the background while the next image is processed): they join that keyframe as insertKeyframe()
  /// would have joined them (reprojection check against its pose, as it is now, observations, new points
  /// triangulated against the oldest kept keyframe that saw them), and map-only tracks not among them stop
  /// following their point. The window and the culling are left to the next insertKeyframe().
  /// @throws std::invalid_argument when `keyframe_id` is not the newest keyframe, or the ids do not ascend
  ///         from kFirstMapOnlyTrackId (the map is unchanged).
  KeyframeInsertion attachKeyframeTracks(uint64_t keyframe_id, const KeyframeTracks& keyframe_tracks,
                                         const PinholeCamera& camera, Map* map) const;

 private:
  /// Splits map-only tracks into those that join the keyframe (`kept`, with `observed` the (point id, pixel)
  /// of those carrying a point) and those off their point by more than max_reprojection_error_px.
  void checkKeyframeTracks(const KeyframeTracks& tracks, const Pose& T_world_cam, const PinholeCamera& camera,
                           const Map& map, KeyframeTracks* kept,
                           std::vector<std::pair<uint64_t, Eigen::Vector2d>>* observed,
                           std::vector<uint64_t>* rejected) const;
  int triangulateNewPoints(uint64_t new_keyframe_id, const std::vector<uint64_t>& track_ids,
                           const std::vector<Eigen::Vector2d>& px, const PinholeCamera& camera,
                           Map* map) const;

  MapConfig config_;
};

}  // namespace planetary_vo
