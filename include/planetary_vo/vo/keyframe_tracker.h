#pragma once
/// @file keyframe_tracker.h
/// Stage 5c: map-only features, followed from keyframe to keyframe only.
///
/// The map and its bundle adjustment gain from more points than the per-frame pose needs (issue 13, session
/// 18: 800 features instead of 300 made 26 of 30 five-start runs more accurate, and posing each frame from
/// 3/8 of them kept the gain), but tracking them in every image doubles the tracking time. These features
/// are looked for only when a keyframe is taken: from the previous keyframe's image to the new one, by
/// pyramidal LK started at the position predicted by the homography that the frame tracker's own tracks
/// give between the two keyframes, checked forward-backward, and then aligned against their anchor patch
/// (patch_alignment.h, warped by the homography chained since it was cut), so that their error does not grow
/// from keyframe to keyframe; a track whose alignment fails or disagrees with LK is lost. The anchor is cut
/// again every few keyframes: an anchor kept for good made the map worse on the flight renders (the ground's
/// appearance changes with the view). New ones are detected where the grid has room, away from the frame
/// tracker's tracks. The mapper triangulates them like any track (mapper.h), and they enter the bundle
/// adjustment but never the per-frame PnP.
///
/// Pixels are distorted (as the frame tracker's). Track ids start at kFirstId, far above the frame tracker's.
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/grid_detector.h"
#include "planetary_vo/vo/map.h"
#include "planetary_vo/vo/patch_alignment.h"

namespace planetary_vo {

/// What one KeyframeTracker::track() call did.
struct KeyframeTrackingResult {
  int num_tracked = 0;                   ///< carried over from the previous keyframe
  int num_lost = 0;                      ///< LK failed, left the image or failed the forward-backward check
  int num_aligned = 0;                   ///< of the tracked: moved to their anchor patch's alignment
  int num_new = 0;                       ///< detected in this keyframe
  bool predicted_by_homography = false;  ///< enough frame tracks for the homography prediction
  double ms = 0.0;
};

class KeyframeTracker {
 public:
  static constexpr uint64_t kFirstId = kFirstMapOnlyTrackId;  ///< map.h

  /// @param num_features the map-only features wanted per keyframe (on top of the frame tracker's).
  /// @param anchor_max_age a track's anchor patch is cut again after this many keyframes (>= 1; 1: each
  ///        keyframe aligns the patch of the previous one).
  /// @param tracker LK window, levels, criteria, forward-backward and border checks, anchor patch settings.
  /// @param detector grid and FAST settings (its num_features is the frame tracker's budget).
  KeyframeTracker(int num_features, int anchor_max_age, const TrackerConfig& tracker,
                  const DetectorConfig& detector);

  /// A new keyframe: follows the map-only tracks from the previous keyframe into `gray`, then detects new
  /// ones. @param live_ids, live_px the frame tracker's tracks in this image (distorted pixels): their motion
  /// since the previous keyframe predicts the map-only tracks', and new features keep clear of them.
  KeyframeTrackingResult track(const cv::Mat& gray, const std::vector<uint64_t>& live_ids,
                               const std::vector<cv::Point2f>& live_px);
  /// The map-only tracks of the last keyframe, ids ascending, and their distorted pixels.
  const std::vector<uint64_t>& ids() const { return ids_; }
  const std::vector<cv::Point2f>& px() const { return px_; }
  /// Drops tracks (e.g. the mapper found them off their point). Returns how many were found.
  int removeTracks(const std::vector<uint64_t>& ids);
  /// Forgets the previous keyframe and every track (a new map); ids keep increasing.
  void reset();
  /// A new number of map-only features per keyframe (0: none); forgets every track as reset() does.
  void setNumFeatures(int num_features);

 private:
  struct Anchor {
    AnchorPatch patch;
    cv::Point2f px;  ///< where it was cut
    int chain = -1;  ///< index into chains_: the homography from its keyframe to the last one
    int age = 0;     ///< keyframes since it was cut
  };
  int num_features_;
  int anchor_max_age_;
  TrackerConfig config_;
  DetectorConfig detector_config_;
  GridDetector detector_;
  cv::Size win_size_;
  cv::TermCriteria criteria_;
  std::vector<cv::Mat> prev_pyramid_;
  std::unordered_map<uint64_t, cv::Point2f> prev_live_;  ///< frame tracks at the previous keyframe
  std::vector<uint64_t> ids_;
  std::vector<cv::Point2f> px_;
  std::vector<Anchor> anchors_;  ///< parallel to ids_
  /// Homography from an anchor keyframe to the last keyframe (distorted pixels), one per keyframe that still
  /// anchors a track; identity for the last one.
  std::vector<cv::Matx33d> chains_;
  uint64_t next_id_ = kFirstId;
};

}  // namespace planetary_vo
