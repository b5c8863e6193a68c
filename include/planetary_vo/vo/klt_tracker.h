#pragma once
/// @file klt_tracker.h
/// Stage 2 of the chain: pyramidal Lucas-Kanade tracking of grid features from frame to frame (thesis 4.4.3,
/// Table 4.7), with a forward-backward consistency check and the Phase-1 replenishment of thesis 5.1
/// (surviving tracks are kept and new features are detected only where the grid has become empty).

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/feature_tracks.h"
#include "planetary_vo/vo/grid_detector.h"
#include "planetary_vo/vo/patch_alignment.h"

namespace planetary_vo {

/// What one KltTracker::track() call did.
struct TrackingResult {
  int64_t frame_index = -1;  ///< 0 for the first image given to the tracker
  int num_tracked = 0;       ///< tracks carried over from the previous frame (= correspondences.size())
  int num_lost_lk = 0;       ///< LK did not converge or the window was too flat (min eigenvalue)
  int num_lost_border = 0;   ///< tracked to within border_px of the image edge or beyond
  int num_lost_fb = 0;       ///< forward-backward round trip off by more than fb_max_error_px
  int num_new = 0;           ///< features added this frame (replenishment, first frame or restart)
  bool restarted = false;    ///< restart_below_min: all tracks were dropped and detection started afresh
  int num_refined = 0;       ///< anchor refinement: tracks moved to their anchor patch's alignment
  int num_reanchored = 0;    ///< anchor refinement: alignment failed or was too far from KLT; new anchor
  FrameCorrespondences correspondences;  ///< previous -> current pixels of the tracks carried over
  double pyramid_ms = 0.0;               ///< building the LK pyramid of the new image
  double lk_ms = 0.0;                    ///< forward and backward LK
  double refine_ms = 0.0;                ///< anchor refinement (TrackerConfig::anchor_refinement)
  double detect_ms = 0.0;                ///< replenishment / restart detection
  double total_ms = 0.0;
};

/// @brief Frame-to-frame KLT tracker with persistent track ids and grid replenishment.
///
/// Each image's LK pyramid is built once (cv::buildOpticalFlowPyramid) and reused as the previous pyramid for
/// the next frame, for the forward and for the backward pass. The image is copied into the pyramid, so the
/// caller may reuse its buffer after track() returns. With TrackerConfig::anchor_refinement, each track keeps
/// the patch it had when anchored (patch_alignment.h) and the KLT position is refined against it.
///
/// Threading: not thread-safe; one instance per image stream.
class KltTracker {
 public:
  /// @param config LK, forward-backward and replenishment settings.
  /// @param detector_config the grid detector used for the first frame and for replenishment.
  KltTracker(const TrackerConfig& config, const DetectorConfig& detector_config);

  /// @brief Tracks the current features into `gray` and replenishes empty grid cells.
  /// @param gray 8-bit single-channel image, the same size for every call until reset().
  /// @throws std::invalid_argument on an empty, non-8UC1 image or a size change.
  TrackingResult track(const cv::Mat& gray);

  /// The live tracks after the last track() call, in the current frame.
  const std::vector<FeatureTrack>& tracks() const { return tracks_; }

  /// Drops tracks, e.g. the RANSAC outliers of the geometry stage (thesis 4.4.1: outliers are deleted). Their
  /// cells become eligible for replenishment on the next frame. Returns how many were found and removed.
  int removeTracks(const std::vector<uint64_t>& ids);

  /// Forgets all tracks and the previous image; the next track() starts like the first. Ids keep increasing.
  void reset();

  /// A new detector for the next detections (replenishment, restart, first frame); the live tracks stay.
  void setDetectorConfig(const DetectorConfig& detector_config) { detector_ = GridDetector(detector_config); }

  /// @brief A new tracker configuration for the next track() calls; the live tracks stay. A change of the LK
  /// window or pyramid levels rebuilds the previous image's pyramid for them; anchor_refinement off drops the
  /// anchors, on anchors the live tracks in the next image (CpuBudget's steps, Pipeline::reconfigure).
  void setConfig(const TrackerConfig& config);

  const TrackerConfig& config() const { return config_; }
  const GridDetector& detector() const { return detector_; }

 private:
  void buildPyramid(const cv::Mat& gray, std::vector<cv::Mat>* pyramid) const;
  /// Forward LK prev -> curr, then backward; fills status_ (true = keep) and curr_px_, counting the losses.
  /// With `guess_px`, LK starts there (and the backward pass at curr minus the guessed motion).
  void trackPoints(const std::vector<cv::Point2f>& prev_px, const std::vector<cv::Point2f>* guess_px,
                   TrackingResult* result);
  /// Where each live track is expected in the next image (TrackerConfig::predict_flow) into guess_px_.
  void predictPositions();
  void addTracks(const std::vector<cv::KeyPoint>& keypoints, int64_t frame);
  /// Anchor refinement of the tracks' positions in `gray` (their KLT positions); fills the counts.
  void refineToAnchors(const cv::Mat& gray, TrackingResult* result);
  /// Fits warps_: per anchor frame, the linear part of the image motion since it (anchor_warp_min_tracks).
  void fitAnchorWarps();
  /// The fitted warp of an anchor frame; identity when it has none.
  cv::Matx22f anchorWarp(int64_t frame) const;
  /// Anchors the tracks appended since the last call (detection, restart) in `gray`.
  void anchorNewTracks(const cv::Mat& gray);
  /// A new anchor for track i at its current position in `gray`.
  void reanchor(const cv::Mat& gray, size_t i);

  TrackerConfig config_;
  GridDetector detector_;
  cv::TermCriteria criteria_;
  cv::Size win_size_;

  std::vector<FeatureTrack> tracks_;
  /// Parallel to tracks_ (anchor refinement): the anchor patch and the frame it was cut from.
  struct Anchor {
    AnchorPatch patch;
    int64_t frame = 0;
    cv::Point2f px;  ///< where the patch was cut
  };
  std::vector<Anchor> anchors_;
  /// fitAnchorWarps()' sums and result per anchor frame.
  struct AnchorWarp {
    int64_t frame = 0;
    cv::Point2d mean_anchor, mean_now;
    cv::Matx22d aa = cv::Matx22d::zeros(), da = cv::Matx22d::zeros();
    int n = 0;
    cv::Matx22f warp = cv::Matx22f::eye();
  };
  std::vector<AnchorWarp> warps_;
  uint64_t next_id_ = 0;
  int64_t frame_index_ = -1;
  bool has_previous_ = false;
  cv::Size image_size_;

  // Reused buffers: the pyramids swap roles every frame, so their levels are allocated once.
  std::vector<cv::Mat> prev_pyramid_, curr_pyramid_;
  std::vector<cv::Point2f> prev_px_, curr_px_, back_px_, existing_px_, guess_px_;
  std::vector<float> flow_scratch_;
  std::vector<uchar> lk_status_, back_status_, keep_;
  std::vector<float> lk_error_;
};

}  // namespace planetary_vo
