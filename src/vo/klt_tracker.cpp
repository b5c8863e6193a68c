/// @file klt_tracker.cpp
/// Pyramidal LK with forward-backward check, persistent ids and grid replenishment.

#include "planetary_vo/vo/klt_tracker.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "planetary_vo/geometry/median.h"

namespace planetary_vo {
namespace {

double msSince(int64 start_ticks) {
  return 1e3 * static_cast<double>(cv::getTickCount() - start_ticks) / cv::getTickFrequency();
}

}  // namespace

KltTracker::KltTracker(const TrackerConfig& config, const DetectorConfig& detector_config)
    : config_(config), detector_(detector_config) {
  setConfig(config);  // the LK criteria and window (no previous image yet: nothing else to do)
}

void KltTracker::setConfig(const TrackerConfig& config) {
  const bool pyramid_changed =
      config.window_size_px != config_.window_size_px || config.pyramid_levels != config_.pyramid_levels;
  config_ = config;
  criteria_ = cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, config.max_iterations,
                               config.epsilon_px);
  win_size_ = cv::Size(config.window_size_px, config.window_size_px);
  if (config.method != TrackingMethod::kAuto) active_ = config.method;
  if (!usesAnchors()) anchors_.clear();
  // The previous pyramid was padded for the old window and has the old number of levels; LK asserts a padding
  // of at least the window. Level 0 is the previous image itself.
  if (pyramid_changed && has_previous_ && !prev_pyramid_.empty()) {
    const cv::Mat previous = prev_pyramid_[0].clone();
    buildPyramid(previous, prev_plain_, &prev_pyramid_);
  }
}

void KltTracker::reset() {
  tracks_.clear();
  prediction_error_px_ = -1.0;
  planar_frames_ = non_planar_frames_ = 0;
  if (config_.method == TrackingMethod::kAuto) active_ = TrackingMethod::kKlt;
  homographies_.clear();
  anchors_.clear();
  has_previous_ = false;
}

int KltTracker::removeTracks(const std::vector<uint64_t>& ids) {
  if (ids.empty()) return 0;
  std::vector<uint64_t> sorted(ids);
  std::sort(sorted.begin(), sorted.end());
  const size_t before = tracks_.size();
  size_t kept = 0;
  for (size_t i = 0; i < tracks_.size(); ++i) {
    if (std::binary_search(sorted.begin(), sorted.end(), tracks_[i].id)) continue;
    if (kept != i) {
      tracks_[kept] = tracks_[i];
      if (!anchors_.empty()) anchors_[kept] = std::move(anchors_[i]);
    }
    ++kept;
  }
  tracks_.resize(kept);
  if (!anchors_.empty()) anchors_.resize(kept);
  return static_cast<int>(before - kept);
}

void KltTracker::buildPyramid(const cv::Mat& gray, bool plain, std::vector<cv::Mat>* pyramid) const {
  if (plain) {
    // A plain 2:1 pyramid: the patches carry their own gradients, so no derivative images are needed. Each
    // level is the 2x2 mean of the one below (INTER_AREA at exactly half the size): the patches are cut from
    // and aligned in the same kind of pyramid, and it is several times cheaper than pyrDown's 5x5 Gaussian.
    // The levels' buffers are reused frame after frame (same size).
    const size_t levels = static_cast<size_t>(config_.pyramid_levels) + 1;
    pyramid->resize(levels);
    gray.copyTo((*pyramid)[0]);
    for (size_t l = 1; l < levels; ++l) {
      if ((*pyramid)[l - 1].cols < 2 || (*pyramid)[l - 1].rows < 2) {
        pyramid->resize(l);
        break;
      }
      const cv::Mat& below = (*pyramid)[l - 1];
      cv::resize(below, (*pyramid)[l], cv::Size((below.cols + 1) / 2, (below.rows + 1) / 2), 0.0, 0.0,
                 cv::INTER_AREA);
    }
    return;
  }
  // withDerivatives: LK then reuses the Scharr derivatives instead of recomputing them in both passes.
  // tryReuseInputImage = false: the pyramid owns a copy, so the caller may overwrite its image buffer.
  cv::buildOpticalFlowPyramid(gray, *pyramid, win_size_, config_.pyramid_levels, true, cv::BORDER_REFLECT_101,
                              cv::BORDER_CONSTANT, false);
}

void KltTracker::predictPositions() {
  // A track with a history is expected where its own last motion takes it. A feature detected in the last
  // frame has none: it is expected to move like its nearest tracks that have one (the median of their last
  // motions), since the image motion varies across the view (a camera looking ahead sees the near ground move
  // faster than the far ground, a descent expands the view): one median for the whole image missed new
  // features by several pixels there, beyond the alignment's basin (docs/visual_core.md, step 23).
  constexpr size_t kNeighbours = 8;
  moving_.clear();
  for (size_t i = 0; i < tracks_.size(); ++i)
    if (tracks_[i].age_frames > 0) moving_.push_back(i);
  const float x_max = static_cast<float>(image_size_.width - 1);
  const float y_max = static_cast<float>(image_size_.height - 1);
  guess_px_.resize(tracks_.size());
  std::vector<std::pair<float, size_t>>& nearest = nearest_scratch_;
  auto motion = [this](size_t j) { return tracks_[j].px - tracks_[j].prev_px; };
  for (size_t i = 0; i < tracks_.size(); ++i) {
    const FeatureTrack& t = tracks_[i];
    cv::Point2f flow(0.f, 0.f);
    if (t.age_frames > 0) {
      flow = motion(i);
    } else if (!moving_.empty()) {
      nearest.clear();
      for (const size_t j : moving_) {
        const cv::Point2f d = tracks_[j].px - t.px;
        nearest.emplace_back(d.dot(d), j);
      }
      const size_t k = std::min(kNeighbours, nearest.size());
      std::partial_sort(nearest.begin(), nearest.begin() + static_cast<std::ptrdiff_t>(k), nearest.end());
      flow_scratch_.clear();
      for (size_t m = 0; m < k; ++m) flow_scratch_.push_back(motion(nearest[m].second).x);
      flow.x = medianInPlace(&flow_scratch_);
      flow_scratch_.clear();
      for (size_t m = 0; m < k; ++m) flow_scratch_.push_back(motion(nearest[m].second).y);
      flow.y = medianInPlace(&flow_scratch_);
    }
    // A guess outside the image would start LK on padding; the border check drops tracks that really leave.
    guess_px_[i] = cv::Point2f(std::min(std::max(t.px.x + flow.x, 0.f), x_max),
                               std::min(std::max(t.px.y + flow.y, 0.f), y_max));
  }
}

void KltTracker::trackPoints(const std::vector<cv::Point2f>& prev_px,
                             const std::vector<cv::Point2f>* guess_px, TrackingResult* result) {
  const size_t n = prev_px.size();
  keep_.assign(n, 0);
  if (n == 0) return;
  int flags = 0;
  if (guess_px != nullptr) {
    curr_px_ = *guess_px;
    flags = cv::OPTFLOW_USE_INITIAL_FLOW;
  }
  cv::calcOpticalFlowPyrLK(prev_pyramid_, curr_pyramid_, prev_px, curr_px_, lk_status_, lk_error_, win_size_,
                           config_.pyramid_levels, criteria_, flags, config_.min_eigen_threshold);
  const bool fb_check = config_.fb_max_error_px > 0.0;
  if (fb_check) {
    // Backward pass from the forward result, started where the forward pass ended minus the guessed motion
    // (not at the original position: started there, LK on an unmatched window barely moves and "comes
    // back" by construction; LK's own refinement away from the guess is what is checked). A point that LK
    // dragged onto a different structure (occlusion, shadow change, repeated texture) does not return.
    if (guess_px != nullptr) {
      back_px_.resize(n);
      for (size_t i = 0; i < n; ++i) back_px_[i] = curr_px_[i] - ((*guess_px)[i] - prev_px[i]);
    }
    cv::calcOpticalFlowPyrLK(curr_pyramid_, prev_pyramid_, curr_px_, back_px_, back_status_, lk_error_,
                             win_size_, config_.pyramid_levels, criteria_, flags,
                             config_.min_eigen_threshold);
  }
  const float border = static_cast<float>(config_.border_px);
  const float x_max = static_cast<float>(image_size_.width - 1) - border;
  const float y_max = static_cast<float>(image_size_.height - 1) - border;
  const double fb_max2 = config_.fb_max_error_px * config_.fb_max_error_px;
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f& p = curr_px_[i];
    if (!lk_status_[i]) {
      ++result->num_lost_lk;
    } else if (!(p.x >= border && p.y >= border && p.x <= x_max && p.y <= y_max)) {
      ++result->num_lost_border;
    } else if (fb_check) {
      const double dx = back_px_[i].x - prev_px[i].x, dy = back_px_[i].y - prev_px[i].y;
      if (!back_status_[i] || dx * dx + dy * dy > fb_max2)
        ++result->num_lost_fb;
      else
        keep_[i] = 1;
    } else {
      keep_[i] = 1;
    }
  }
}

void KltTracker::addTracks(const std::vector<cv::KeyPoint>& keypoints, int64_t frame) {
  for (const cv::KeyPoint& kp : keypoints) {
    FeatureTrack t;
    t.id = next_id_++;
    t.px = kp.pt;
    t.prev_px = kp.pt;
    t.first_frame = frame;
    t.age_frames = 0;
    tracks_.push_back(t);
  }
}

void KltTracker::cutAnchor(const cv::Mat& image, const std::vector<cv::Mat>* plain_pyramid,
                           const cv::Point2f& px, int64_t frame, Anchor* anchor) const {
  anchor->patch = makeAnchorPatch(image, px, config_.anchor_patch_px);
  anchor->coarse.clear();
  if (plain_pyramid != nullptr) {
    float scale = 1.f;
    for (size_t l = 1; l < plain_pyramid->size(); ++l) {
      scale *= 0.5f;
      anchor->coarse.push_back(makeAnchorPatch((*plain_pyramid)[l], px * scale, config_.anchor_patch_px));
    }
  }
  anchor->frame = frame;
  anchor->px = px;
}

void KltTracker::reanchor(const cv::Mat& gray, size_t i) {
  // With anchor alignment curr_pyramid_ is the plain pyramid of `gray` here (track() swaps the pyramids only
  // at its end); LK's pyramid interleaves derivative images, and the refinement needs level 0 only.
  cutAnchor(gray, anchorAlignment() ? &curr_pyramid_ : nullptr, tracks_[i].px, frame_index_, &anchors_[i]);
}

cv::Matx22f KltTracker::chainedWarp(int64_t frame, const cv::Point2f& px) const {
  for (const FrameHomography& h : homographies_) {
    if (h.frame != frame) continue;
    cv::Matx22f warp;
    if (homographyWarp(h.H_to_last, px, &warp)) return warp;
    break;
  }
  return anchorWarp(frame);
}

double KltTracker::updateHomographyChain() {
  fit_from_.clear();
  fit_to_.clear();
  for (const FeatureTrack& t : tracks_) {
    if (t.age_frames == 0) continue;
    fit_from_.push_back(t.prev_px);
    fit_to_.push_back(t.px);
  }
  cv::Matx33d H_prev_to_this;
  bool ok = false;
  double share = -1.0;
  if (fit_from_.size() >= 12) {
    const cv::Mat H = cv::findHomography(fit_from_, fit_to_, cv::RANSAC, 1.0, fit_mask_, 200, 0.99);
    if (!H.empty()) {
      int inliers = 0;
      for (const uchar m : fit_mask_) inliers += m ? 1 : 0;
      // Half the tracks on one homography: the view is close enough to a plane for its Jacobian to be the
      // patches' warp. A 3D scene (a car's street) fails this and keeps the per-anchor-frame linear maps.
      share = static_cast<double>(inliers) / static_cast<double>(fit_from_.size());
      ok = share >= kAutoPlaneShare;
      H.convertTo(cv::Mat(3, 3, CV_64F, H_prev_to_this.val), CV_64F);
    }
  }
  if (!ok) {
    homographies_.clear();
  } else {
    // Keep the frames some anchor still refers to.
    size_t kept = 0;
    for (size_t k = 0; k < homographies_.size(); ++k) {
      bool used = false;
      for (const Anchor& a : anchors_)
        if (a.frame == homographies_[k].frame) {
          used = true;
          break;
        }
      if (!used) continue;
      homographies_[kept] = homographies_[k];
      homographies_[kept].H_to_last = H_prev_to_this * homographies_[k].H_to_last;
      ++kept;
    }
    homographies_.resize(kept);
  }
  return share;
}

PatchAlignment KltTracker::alignCoarseToFine(const AnchorPatch& fine_patch,
                                             const std::vector<AnchorPatch>& coarse_patches,
                                             const cv::Matx22f& warp, cv::Point2f px,
                                             size_t top_level) const {
  // Coarse levels only need to bring the feature into the next level's basin.
  const double coarse_epsilon_px = std::max(config_.epsilon_px, 0.05);
  // Gauss-Newton may walk far on a texture that repeats; a level may move the feature by at most half a
  // patch (in that level's pixels), as LK's window bounds its own reach. Farther is not a convergence.
  const float max_move2 = 0.25f * static_cast<float>(config_.anchor_patch_px * config_.anchor_patch_px);
  for (size_t l = std::min({top_level, coarse_patches.size(), curr_pyramid_.size() - 1}); l >= 1; --l) {
    const AnchorPatch& patch = coarse_patches[l - 1];
    if (!patch.valid()) continue;  // too flat at this resolution: the finer level starts from here
    const float scale = static_cast<float>(1 << l);
    const cv::Point2f start = px / scale;
    const PatchAlignment coarse =
        alignPatch(patch, curr_pyramid_[l], start, config_.max_iterations, coarse_epsilon_px, warp);
    const cv::Point2f moved = coarse.px - start;
    if (coarse.converged && moved.dot(moved) <= max_move2) px = coarse.px * scale;
  }
  PatchAlignment fine =
      alignPatch(fine_patch, curr_pyramid_[0], px, config_.max_iterations, config_.epsilon_px, warp);
  const cv::Point2f moved = fine.px - px;
  if (moved.dot(moved) > max_move2) {
    fine.converged = false;
    fine.px = px;
  }
  return fine;
}

void KltTracker::usePreviousLkPyramid() {
  if (!prev_plain_) return;
  const cv::Mat previous = prev_pyramid_[0].clone();
  buildPyramid(previous, false, &prev_pyramid_);
  prev_plain_ = false;
}

void KltTracker::trackAllWithLk(TrackingResult* result) {
  prev_px_.clear();
  for (const FeatureTrack& t : tracks_) prev_px_.push_back(t.px);
  if (config_.predict_flow) predictPositions();
  trackPoints(prev_px_, config_.predict_flow ? &guess_px_ : nullptr, result);
}

void KltTracker::lkRescue(const cv::Mat& gray, TrackingResult* result) {
  result->lk_rescue = true;
  result->num_lost_lk = result->num_lost_border = result->num_lost_fb = result->num_lost_residual = 0;
  result->num_realigned = 0;
  // LK's pyramids of both images; the plain pyramid of this image is kept for the anchors and the next frame.
  std::swap(curr_pyramid_, rescue_plain_);
  usePreviousLkPyramid();
  buildPyramid(gray, false, &curr_pyramid_);
  trackAllWithLk(result);
  std::swap(curr_pyramid_, rescue_plain_);
}

void KltTracker::alignToAnchors(TrackingResult* result) {
  const size_t n = tracks_.size();
  keep_.assign(n, 0);
  curr_px_.resize(n);
  if (config_.predict_flow) {
    predictPositions();
  } else {
    guess_px_.resize(n);
    for (size_t i = 0; i < n; ++i) guess_px_[i] = tracks_[i].px;
  }
  // Fallback warps (anchor frames the homography chain does not reach): the linear maps fitted to the tracks'
  // positions in the previous image.
  warps_.clear();
  if (config_.anchor_warp_min_tracks > 0) fitAnchorWarps();
  const float border = static_cast<float>(config_.border_px);
  const float x_max = static_cast<float>(image_size_.width - 1) - border;
  const float y_max = static_cast<float>(image_size_.height - 1) - border;
  const bool can_realign =
      config_.alignment_previous_fallback && prev_plain_ && prev_pyramid_.size() == curr_pyramid_.size();
  auto usable = [&](const PatchAlignment& a) {
    return a.converged && a.residual_ratio <= config_.alignment_max_residual_ratio;
  };
  // The coarsest level needed: the prediction missed by prediction_error_px_ (90th percentile, last frame);
  // twice that must lie within a level's basin of about a quarter patch (2.75 px for 11 px) times its scale.
  // Full resolution alone when the prediction is that good; all levels when nothing is known yet. A track
  // that fails from there is tried again from the top level before anything else.
  const size_t top_level = curr_pyramid_.size() - 1;
  size_t start_level = top_level;
  if (prediction_error_px_ >= 0.0) {
    const double basin_px = std::max(1.0, 0.25 * config_.anchor_patch_px);
    start_level = 0;
    while (start_level < top_level && basin_px * (1 << start_level) < 2.0 * prediction_error_px_)
      ++start_level;
    start_level = std::min(start_level, top_level);
  }
  result->alignment_start_level = static_cast<int>(start_level);
  miss_px_.clear();
  for (size_t i = 0; i < n; ++i) {
    Anchor& anchor = anchors_[i];
    PatchAlignment found;
    if (anchor.patch.valid()) {
      const cv::Matx22f warp = chainedWarp(anchor.frame, anchor.px);
      found = alignCoarseToFine(anchor.patch, anchor.coarse, warp, guess_px_[i], start_level);
      if (!usable(found) && start_level < top_level)
        found = alignCoarseToFine(anchor.patch, anchor.coarse, warp, guess_px_[i], top_level);
    }
    if (!usable(found) && can_realign) {
      // The anchor no longer matches (its view changed too much, or it was too flat): cut the track's patch
      // in the previous image, where it was found last, and align that one (frame to frame, like LK). On
      // success it becomes the track's anchor.
      Anchor previous;
      cutAnchor(prev_pyramid_[0], &prev_pyramid_, tracks_[i].px, frame_index_ - 1, &previous);
      if (previous.patch.valid()) {
        const PatchAlignment again =
            alignCoarseToFine(previous.patch, previous.coarse, cv::Matx22f::eye(), guess_px_[i], top_level);
        if (usable(again)) {
          anchor = std::move(previous);
          found = again;
          ++result->num_realigned;
        }
      }
    }
    curr_px_[i] = found.px;
    if (!found.converged) {
      ++result->num_lost_lk;
    } else if (!(found.px.x >= border && found.px.y >= border && found.px.x <= x_max &&
                 found.px.y <= y_max)) {
      ++result->num_lost_border;
    } else if (!usable(found)) {
      ++result->num_lost_residual;
    } else {
      keep_[i] = 1;
      miss_px_.push_back(static_cast<float>(cv::norm(found.px - guess_px_[i])));
    }
  }
  if (miss_px_.size() >= 10) {
    const size_t k90 = miss_px_.size() * 9 / 10;
    std::nth_element(miss_px_.begin(), miss_px_.begin() + k90, miss_px_.end());
    prediction_error_px_ = miss_px_[k90];
  } else {
    prediction_error_px_ = -1.0;
  }
}

void KltTracker::fitAnchorWarps() {
  // Per anchor frame: the least-squares linear map from the anchor positions to the current ones of the
  // tracks anchored there, about their centroids (the image's rotation and zoom since that frame). warps_ is
  // a member so that its storage is reused frame after frame (a few dozen anchor frames at most).
  warps_.clear();
  auto warpOf = [this](int64_t frame) -> AnchorWarp& {
    for (AnchorWarp& w : warps_)
      if (w.frame == frame) return w;
    warps_.emplace_back();
    warps_.back().frame = frame;
    return warps_.back();
  };
  for (size_t i = 0; i < anchors_.size(); ++i) {
    if (!anchors_[i].patch.valid() || anchors_[i].frame == frame_index_) continue;
    AnchorWarp& w = warpOf(anchors_[i].frame);
    w.mean_anchor += cv::Point2d(anchors_[i].px);
    w.mean_now += cv::Point2d(tracks_[i].px);
    ++w.n;
  }
  for (AnchorWarp& w : warps_) {
    w.mean_anchor /= w.n;
    w.mean_now /= w.n;
  }
  for (size_t i = 0; i < anchors_.size(); ++i) {
    if (!anchors_[i].patch.valid() || anchors_[i].frame == frame_index_) continue;
    AnchorWarp& w = warpOf(anchors_[i].frame);
    const cv::Vec2d a(anchors_[i].px.x - w.mean_anchor.x, anchors_[i].px.y - w.mean_anchor.y);
    const cv::Vec2d d(tracks_[i].px.x - w.mean_now.x, tracks_[i].px.y - w.mean_now.y);
    w.aa += a * a.t();
    w.da += d * a.t();
  }
  for (AnchorWarp& w : warps_) {
    // Enough tracks, spread in two directions (the anchor positions' spread matrix well conditioned).
    const double trace = w.aa(0, 0) + w.aa(1, 1), det = cv::determinant(w.aa);
    if (w.n >= config_.anchor_warp_min_tracks && det > 1e-3 * trace * trace) {
      const cv::Matx22d m = w.da * w.aa.inv();
      if (std::isfinite(m(0, 0)) && std::isfinite(m(0, 1)) && std::isfinite(m(1, 0)) &&
          std::isfinite(m(1, 1)))
        w.warp = cv::Matx22f(m);
    }
  }
}

cv::Matx22f KltTracker::anchorWarp(int64_t frame) const {
  for (const AnchorWarp& w : warps_)
    if (w.frame == frame) return w.warp;
  return cv::Matx22f::eye();
}

void KltTracker::anchorNewTracks(const cv::Mat& gray) {
  // anchors_ is parallel to tracks_, and new tracks are appended: the tail without an anchor is new.
  const size_t old_count = anchors_.size();
  anchors_.resize(tracks_.size());
  for (size_t i = old_count; i < tracks_.size(); ++i) reanchor(gray, i);
}

void KltTracker::refineToAnchors(const cv::Mat& gray, TrackingResult* result) {
  // Every live track has its anchor (anchorNewTracks() at the end of each track() call, and removeTracks()
  // keeps anchors_ parallel), except right after the refinement was switched on: those get one now.
  const size_t old_count = anchors_.size();
  anchorNewTracks(gray);
  const double max_shift2 = config_.anchor_max_shift_px * config_.anchor_max_shift_px;
  warps_.clear();
  if (config_.anchor_warp_min_tracks > 0) fitAnchorWarps();
  for (size_t i = 0; i < old_count; ++i) {
    FeatureTrack& t = tracks_[i];
    Anchor& anchor = anchors_[i];
    if (anchor.frame == frame_index_) continue;  // anchored in this very image: nothing to refine
    bool used = false;
    if (anchor.patch.valid()) {
      const PatchAlignment aligned = alignPatch(anchor.patch, gray, t.px, config_.max_iterations,
                                                config_.epsilon_px, anchorWarp(anchor.frame));
      const cv::Point2f shift = aligned.px - t.px;
      if (aligned.converged && shift.dot(shift) <= max_shift2 &&
          aligned.residual_ratio <= config_.anchor_max_residual_ratio) {
        t.px = aligned.px;
        used = true;
        ++result->num_refined;
      }
    }
    if (!used) {
      ++result->num_reanchored;
      reanchor(gray, i);
    } else if (frame_index_ - anchor.frame >= config_.anchor_max_age_frames) {
      reanchor(gray, i);
    }
  }
}

TrackingResult KltTracker::track(const cv::Mat& gray) {
  if (gray.empty() || gray.type() != CV_8UC1)
    throw std::invalid_argument("KltTracker::track: expected a non-empty 8-bit single-channel image");
  if (has_previous_ && gray.size() != image_size_)
    throw std::invalid_argument("KltTracker::track: image size changed from " +
                                std::to_string(image_size_.width) + "x" + std::to_string(image_size_.height) +
                                " to " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                                "; call reset() first");
  const int64 t_start = cv::getTickCount();
  TrackingResult result;
  result.frame_index = ++frame_index_;
  image_size_ = gray.size();

  if (config_.method == TrackingMethod::kAuto) {
    // Anchor alignment while the view is close to a plane (its patches' warps are the homography's), LK in a
    // 3D scene. Three frames in a row decide, so that one odd frame pair does not flip the method.
    if (planar_frames_ >= kAutoSwitchFrames) active_ = TrackingMethod::kAnchorAlignment;
    if (non_planar_frames_ >= kAutoSwitchFrames) active_ = TrackingMethod::kKlt;
  }
  if (has_previous_ && !anchorAlignment()) usePreviousLkPyramid();
  buildPyramid(gray, anchorAlignment(), &curr_pyramid_);
  result.pyramid_ms = msSince(t_start);

  if (has_previous_ && !tracks_.empty()) {
    const int64 t_lk = cv::getTickCount();
    bool rescued = false;
    if (anchorAlignment()) {
      anchorNewTracks(gray);  // only after a switch of method: every track has its anchor otherwise
      alignToAnchors(&result);
      if (config_.method == TrackingMethod::kAuto && tracks_.size() >= 20) {
        size_t found = 0;
        for (const uchar k : keep_) found += k ? 1 : 0;
        // Most tracks lost at once (frames refused in between, a jolt): the image moved beyond the patches'
        // reach. LK with its larger window looks for all of them again in this frame.
        if (2 * found < tracks_.size()) {
          rescued = true;
          lkRescue(gray, &result);
        }
      }
    } else {
      trackAllWithLk(&result);
    }
    const bool anchored = !anchors_.empty();
    size_t kept = 0;
    for (size_t i = 0; i < tracks_.size(); ++i) {
      if (!keep_[i]) continue;
      if (anchored && kept != i) anchors_[kept] = std::move(anchors_[i]);
      FeatureTrack& t = tracks_[kept++];
      t = tracks_[i];
      t.prev_px = t.px;
      t.px = curr_px_[i];
      ++t.age_frames;
    }
    tracks_.resize(kept);
    if (anchored) anchors_.resize(kept);
    result.lk_ms = msSince(t_lk);
    if (anchorAlignment()) {
      // The aligned position is the refined one; the anchor is renewed when it is old (appearance changes).
      for (size_t i = 0; i < tracks_.size(); ++i)
        if (rescued || frame_index_ - anchors_[i].frame >= config_.anchor_max_age_frames) reanchor(gray, i);
    } else if (config_.anchor_refinement) {
      const int64 t_refine = cv::getTickCount();
      refineToAnchors(gray, &result);
      result.refine_ms = msSince(t_refine);
    }
    for (const FeatureTrack& t : tracks_) result.correspondences.push_back(t.id, t.prev_px, t.px);
    if (keepsHomographyChain()) {
      const int64 t_chain = cv::getTickCount();
      result.plane_share = updateHomographyChain();
      if (result.plane_share >= 0.0) {
        const bool planar = result.plane_share >= kAutoPlaneShare;
        planar_frames_ = planar ? planar_frames_ + 1 : 0;
        non_planar_frames_ = planar ? 0 : non_planar_frames_ + 1;
      }
      result.lk_ms += msSince(t_chain);
    }
  }
  result.anchor_alignment = anchorAlignment();

  const int64 t_detect = cv::getTickCount();
  if (config_.replenish_strategy == ReplenishStrategy::kRestartBelowMin) {
    if (has_previous_ && static_cast<int>(tracks_.size()) < config_.min_tracked_features) {
      // Thesis 4.4.1: drop everything, detect on the previous image and track the fresh features into this
      // one, so that this frame pair still yields correspondences.
      result.restarted = true;
      tracks_.clear();
      anchors_.clear();
      result.correspondences.clear();
      const std::vector<cv::KeyPoint> fresh = detector_.detect(prev_pyramid_[0]);
      prev_px_.clear();
      for (const cv::KeyPoint& kp : fresh) prev_px_.push_back(kp.pt);
      TrackingResult restart_losses;  // losses of the fresh features are not losses of tracks
      trackPoints(prev_px_, nullptr, &restart_losses);
      for (size_t i = 0; i < fresh.size(); ++i) {
        if (!keep_[i]) continue;
        FeatureTrack t;
        t.id = next_id_++;
        t.prev_px = prev_px_[i];
        t.px = curr_px_[i];
        t.first_frame = frame_index_ - 1;
        t.age_frames = 1;
        tracks_.push_back(t);
        result.correspondences.push_back(t.id, t.prev_px, t.px);
      }
      result.num_new = static_cast<int>(tracks_.size());
    } else if (!has_previous_) {
      const std::vector<cv::KeyPoint> fresh = detector_.detect(gray);
      addTracks(fresh, frame_index_);
      result.num_new = static_cast<int>(fresh.size());
    }
  } else {
    // Phase 1: keep the survivors; cells left with too few of them get new features, once at least
    // replenish_min_cells of them are (the first frame: all are).
    existing_px_.clear();
    for (const FeatureTrack& t : tracks_) existing_px_.push_back(t.px);
    const std::vector<cv::KeyPoint> fresh = detector_.detect(
        gray, existing_px_, config_.replenish_cell_min_features, config_.replenish_min_cells);
    addTracks(fresh, frame_index_);
    result.num_new = static_cast<int>(fresh.size());
  }
  result.detect_ms = msSince(t_detect);
  if (keepsHomographyChain()) homographies_.push_back(FrameHomography{frame_index_, cv::Matx33d::eye()});
  if (usesAnchors()) {
    anchorNewTracks(gray);  // they were detected in, or restarted into, this image
  } else {
    anchors_.clear();
  }
  result.num_tracked = static_cast<int>(result.correspondences.size());

  std::swap(prev_pyramid_, curr_pyramid_);
  prev_plain_ = anchorAlignment();
  has_previous_ = true;
  result.total_ms = msSince(t_start);
  return result;
}

}  // namespace planetary_vo
