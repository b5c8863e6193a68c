#pragma once
/// @file klt_tracker.h
/// Stage 2 of the chain: pyramidal Lucas-Kanade tracking of grid features from frame to frame (thesis 4.4.3,
/// Table 4.7), with a forward-backward consistency check and the Phase-1 replenishment of thesis 5.1
/// (surviving tracks are kept and new features are detected only where the grid has become empty).

#include <cstdint>
#include <utility>
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
  /// anchor_alignment: the alignment converged but left more than alignment_max_residual_ratio of the
  /// patch's contrast (also from the previous image)
  int num_lost_residual = 0;
  /// anchor_alignment: tracks whose anchor failed, found again from their patch in the previous image
  int num_realigned = 0;
  /// anchor_alignment: the pyramid level the tracks' alignment started from (0 = full resolution alone),
  /// chosen from the last frame's prediction error; -1 when LK alone tracked the frame
  int alignment_start_level = -1;
  bool anchor_alignment =
      false;  ///< this frame was tracked by anchor alignment (the method, or auto's choice)
  /// auto: anchor alignment found fewer than half of the tracks (the image jumped beyond the patches' reach),
  /// so LK tracked them all again in this frame; the counts above are LK's.
  bool lk_rescue = false;
  /// Share of the tracks on one homography from the previous image (RANSAC, 1 px); -1 when not fitted
  /// (method klt, or too few tracks). auto uses anchor alignment while it is at least 0.5.
  double plane_share = -1.0;
  int num_new = 0;         ///< features added this frame (replenishment, first frame or restart)
  bool restarted = false;  ///< restart_below_min: all tracks were dropped and detection started afresh
  int num_refined = 0;     ///< anchor refinement: tracks moved to their anchor patch's alignment
  int num_reanchored = 0;  ///< anchor refinement: alignment failed or was too far from KLT; new anchor
  FrameCorrespondences correspondences;  ///< previous -> current pixels of the tracks carried over
  double pyramid_ms = 0.0;               ///< building the LK pyramid of the new image
  double lk_ms = 0.0;                    ///< forward and backward LK (anchor_alignment: the alignment)
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
/// With TrackingMethod::kAnchorAlignment there is no LK: the pyramid is a plain pyramid of 2x2 means (no
/// Scharr derivatives, no padding), each track's anchor patch is cut at every level when it is anchored, and
/// a track is found in a new image by aligning those patches coarse to fine from its predicted position,
/// starting at the coarsest level the last frame's prediction error needs (full resolution alone when the
/// prediction was good; TrackingResult::alignment_start_level).
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
  /// plain: a 2:1 image pyramid (anchor alignment); otherwise LK's, with derivatives and padding.
  void buildPyramid(const cv::Mat& gray, bool plain, std::vector<cv::Mat>* pyramid) const;
  /// Whether this frame is tracked by anchor alignment (the method, or auto's choice).
  bool anchorAlignment() const { return active_ == TrackingMethod::kAnchorAlignment; }
  /// Whether the frame-to-frame homographies are fitted: for anchor alignment's warps and auto's choice.
  bool keepsHomographyChain() const { return anchorAlignment() || config_.method == TrackingMethod::kAuto; }
  /// Whether the tracks keep anchor patches (refinement, or anchor alignment where they are the tracker).
  bool usesAnchors() const { return config_.anchor_refinement || config_.method != TrackingMethod::kKlt; }
  /// anchor_alignment: finds every live track in curr_pyramid_; fills keep_, curr_px_ and the losses.
  void alignToAnchors(TrackingResult* result);
  /// auto: tracks every live track again with LK (previous and current LK pyramids built for it); fills
  /// keep_, curr_px_ and the losses. curr_pyramid_ stays the plain pyramid.
  void lkRescue(const cv::Mat& gray, TrackingResult* result);
  /// LK from prev_pyramid_ to curr_pyramid_ for every live track, from its predicted position
  /// (predict_flow); fills keep_, curr_px_ and the losses.
  void trackAllWithLk(TrackingResult* result);
  /// Rebuilds prev_pyramid_ as LK's pyramid (derivatives, padding) when it is a plain one.
  void usePreviousLkPyramid();
  /// Aligns a patch given at full resolution and at levels 1, 2, ... in curr_pyramid_, coarse to fine from
  /// `px` (full-resolution pixels), starting at `top_level` (or the coarsest level there is).
  PatchAlignment alignCoarseToFine(const AnchorPatch& fine_patch,
                                   const std::vector<AnchorPatch>& coarse_patches, const cv::Matx22f& warp,
                                   cv::Point2f px, size_t top_level) const;
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
  /// The warp of the patch anchored at `px` in `frame` into the last image, the Jacobian
  /// of the chained frame-to-frame homographies there; anchorWarp(frame) when the chain does not reach it.
  cv::Matx22f chainedWarp(int64_t frame, const cv::Point2f& px) const;
  /// Fits the homography from the previous image to this one on the kept tracks and chains it onto every
  /// frame that still holds an anchor (the chain is dropped when the view is not close to a plane). Returns
  /// the share of the tracks on it, -1 when there were too few tracks to fit one.
  double updateHomographyChain();
  /// Anchors the tracks appended since the last call (detection, restart) in `gray`.
  void anchorNewTracks(const cv::Mat& gray);
  /// A new anchor for track i at its current position in `gray`.
  void reanchor(const cv::Mat& gray, size_t i);

  static constexpr double kAutoPlaneShare =
      0.5;                                     ///< share of the tracks on one homography: a plane-like view
  static constexpr int kAutoSwitchFrames = 3;  ///< auto switches after this many frames in a row

  TrackerConfig config_;
  TrackingMethod active_ = TrackingMethod::kKlt;   ///< the method of the frame being tracked
  int planar_frames_ = 0, non_planar_frames_ = 0;  ///< auto: frames in a row with / without a plane-like view
  bool prev_plain_ = false;                        ///< prev_pyramid_ is a plain pyramid (anchor alignment)
  GridDetector detector_;
  cv::TermCriteria criteria_;
  cv::Size win_size_;

  std::vector<FeatureTrack> tracks_;
  /// Parallel to tracks_ (anchor refinement): the anchor patch and the frame it was cut from.
  struct Anchor {
    AnchorPatch patch;
    std::vector<AnchorPatch> coarse;  ///< anchor_alignment: the patch at pyramid levels 1, 2, ...
    int64_t frame = 0;
    cv::Point2f px;  ///< where the patch was cut
  };
  std::vector<Anchor> anchors_;
  /// Cuts `anchor`'s patch at `px` (full-resolution pixels) from `image` and, with `plain_pyramid` (the plain
  /// pyramid of that image), its patches at levels 1, 2, ... for anchor alignment.
  void cutAnchor(const cv::Mat& image, const std::vector<cv::Mat>* plain_pyramid, const cv::Point2f& px,
                 int64_t frame, Anchor* anchor) const;
  /// fitAnchorWarps()' sums and result per anchor frame.
  struct AnchorWarp {
    int64_t frame = 0;
    cv::Point2d mean_anchor, mean_now;
    cv::Matx22d aa = cv::Matx22d::zeros(), da = cv::Matx22d::zeros();
    int n = 0;
    cv::Matx22f warp = cv::Matx22f::eye();
  };
  std::vector<AnchorWarp> warps_;
  /// anchor_alignment: per frame, the homography from that image to the last one (terrain seen from above is
  /// close to a plane, so its Jacobian is the local zoom, rotation and perspective foreshortening of a
  /// patch).
  struct FrameHomography {
    int64_t frame = 0;
    cv::Matx33d H_to_last = cv::Matx33d::eye();
  };
  std::vector<FrameHomography> homographies_;
  std::vector<cv::Point2f> fit_from_, fit_to_;
  std::vector<uchar> fit_mask_;
  uint64_t next_id_ = 0;
  int64_t frame_index_ = -1;
  bool has_previous_ = false;
  cv::Size image_size_;

  // Reused buffers: the pyramids swap roles every frame, so their levels are allocated once.
  std::vector<cv::Mat> prev_pyramid_, curr_pyramid_, rescue_plain_;
  std::vector<cv::Point2f> prev_px_, curr_px_, back_px_, existing_px_, guess_px_;
  std::vector<float> flow_scratch_, miss_px_;
  std::vector<size_t> moving_;                             ///< predictPositions(): tracks with a history
  std::vector<std::pair<float, size_t>> nearest_scratch_;  ///< predictPositions(): distances to them
  /// anchor_alignment: 90th percentile of the distance between predicted and aligned positions in the last
  /// frame (sets the coarsest pyramid level needed); -1 when unknown.
  double prediction_error_px_ = -1.0;
  std::vector<uchar> lk_status_, back_status_, keep_;
  std::vector<float> lk_error_;
};

}  // namespace planetary_vo
