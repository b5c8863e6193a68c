/// @file keyframe_tracker.cpp
/// Map-only features followed from keyframe to keyframe (LK from a homography prediction, anchor alignment).

#include "planetary_vo/vo/keyframe_tracker.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/video/tracking.hpp>

namespace planetary_vo {
namespace {

cv::Point2f applyHomography(const cv::Matx33d& H, const cv::Point2f& p) {
  const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1.0);
  if (std::abs(q[2]) < 1e-12) return p;
  return cv::Point2f(static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2]));
}

bool inside(const cv::Point2f& p, const cv::Size& size, float border) {
  return std::isfinite(p.x) && std::isfinite(p.y) && p.x >= border && p.y >= border &&
         p.x <= static_cast<float>(size.width) - 1.f - border &&
         p.y <= static_cast<float>(size.height) - 1.f - border;
}

/// The detector of the keyframes: the frame tracks' budget plus the map-only features, so that its grid
/// leaves room for both.
DetectorConfig withMapOnlyFeatures(const DetectorConfig& detector, int num_features) {
  DetectorConfig d = detector;
  d.num_features = detector.num_features + num_features;
  return d;
}

}  // namespace

KeyframeTracker::KeyframeTracker(int num_features, int anchor_max_age, const TrackerConfig& tracker,
                                 const DetectorConfig& detector)
    : num_features_(num_features),
      anchor_max_age_(std::max(1, anchor_max_age)),
      config_(tracker),
      detector_config_(detector),
      detector_(withMapOnlyFeatures(detector, num_features)),
      win_size_(tracker.window_size_px, tracker.window_size_px),
      criteria_(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, tracker.max_iterations, tracker.epsilon_px) {
}

void KeyframeTracker::reset() {
  prev_pyramid_.clear();
  prev_live_.clear();
  ids_.clear();
  px_.clear();
  anchors_.clear();
  chains_.clear();
}

void KeyframeTracker::setNumFeatures(int num_features) {
  reset();
  num_features_ = num_features;
  detector_ = GridDetector(withMapOnlyFeatures(detector_config_, num_features));
}

int KeyframeTracker::removeTracks(const std::vector<uint64_t>& ids) {
  if (ids.empty()) return 0;
  std::vector<uint64_t> sorted = ids;
  std::sort(sorted.begin(), sorted.end());
  size_t kept = 0;
  int removed = 0;
  for (size_t i = 0; i < ids_.size(); ++i) {
    if (std::binary_search(sorted.begin(), sorted.end(), ids_[i])) {
      ++removed;
      continue;
    }
    ids_[kept] = ids_[i];
    px_[kept] = px_[i];
    if (kept != i) anchors_[kept] = std::move(anchors_[i]);  // no self-move: it would empty the patch
    ++kept;
  }
  ids_.resize(kept);
  px_.resize(kept);
  anchors_.resize(kept);
  return removed;
}

KeyframeTrackingResult KeyframeTracker::track(const cv::Mat& gray, const std::vector<uint64_t>& live_ids,
                                              const std::vector<cv::Point2f>& live_px) {
  const auto start = std::chrono::steady_clock::now();
  KeyframeTrackingResult result;
  std::vector<cv::Mat> pyramid;
  cv::buildOpticalFlowPyramid(gray, pyramid, win_size_, config_.pyramid_levels, true, cv::BORDER_REFLECT_101,
                              cv::BORDER_CONSTANT, false);
  const float border = static_cast<float>(std::max(config_.border_px, 0));

  if (!ids_.empty() && !prev_pyramid_.empty()) {
    // The image motion since the previous keyframe, from the frame tracker's tracks seen in both.
    std::vector<cv::Point2f> from, to;
    for (size_t i = 0; i < live_ids.size() && i < live_px.size(); ++i) {
      auto it = prev_live_.find(live_ids[i]);
      if (it == prev_live_.end()) continue;
      from.push_back(it->second);
      to.push_back(live_px[i]);
    }
    cv::Matx33d H = cv::Matx33d::eye();
    if (from.size() >= 8) {
      const cv::Mat h = cv::findHomography(from, to, cv::RANSAC, 2.0);
      if (!h.empty()) {
        h.convertTo(h, CV_64F);
        H = cv::Matx33d(h.ptr<double>());
        result.predicted_by_homography = true;
      }
    }
    if (!result.predicted_by_homography && !from.empty()) {
      // Too few for a homography: the median translation.
      std::vector<float> dx, dy;
      for (size_t i = 0; i < from.size(); ++i) {
        dx.push_back(to[i].x - from[i].x);
        dy.push_back(to[i].y - from[i].y);
      }
      std::nth_element(dx.begin(), dx.begin() + static_cast<long>(dx.size() / 2), dx.end());
      std::nth_element(dy.begin(), dy.begin() + static_cast<long>(dy.size() / 2), dy.end());
      H(0, 2) = dx[dx.size() / 2];
      H(1, 2) = dy[dy.size() / 2];
    }
    for (cv::Matx33d& chain : chains_) chain = H * chain;

    std::vector<cv::Point2f> guess(px_.size()), back;
    for (size_t i = 0; i < px_.size(); ++i) guess[i] = applyHomography(H, px_[i]);
    std::vector<uchar> status, back_status;
    std::vector<float> error;
    cv::calcOpticalFlowPyrLK(prev_pyramid_, pyramid, px_, guess, status, error, win_size_,
                             config_.pyramid_levels, criteria_, cv::OPTFLOW_USE_INITIAL_FLOW,
                             config_.min_eigen_threshold);
    back = px_;
    cv::calcOpticalFlowPyrLK(pyramid, prev_pyramid_, guess, back, back_status, error, win_size_,
                             config_.pyramid_levels, criteria_, cv::OPTFLOW_USE_INITIAL_FLOW,
                             config_.min_eigen_threshold);
    // The tracks re-anchored in this keyframe start a new chain (identity until the next keyframe).
    const int new_chain = static_cast<int>(chains_.size());
    chains_.push_back(cv::Matx33d::eye());
    size_t kept = 0;
    for (size_t i = 0; i < ids_.size(); ++i) {
      bool ok = status[i] && back_status[i] && inside(guess[i], gray.size(), border);
      if (ok && config_.fb_max_error_px > 0.0) ok = cv::norm(back[i] - px_[i]) <= config_.fb_max_error_px;
      if (!ok) {
        ++result.num_lost;
        continue;
      }
      cv::Point2f p = guess[i];
      const Anchor& a = anchors_[i];
      // The anchor patch, warped by the chained homography, aligned where LK found the track: a track
      // whose alignment fails, leaves too much of the patch's contrast or lands more than
      // anchor_max_shift_px from LK is lost (two methods that disagree).
      if (config_.anchor_refinement && a.patch.valid() && a.chain >= 0) {
        // An implausible chained warp (mirror, more than 4x zoom) leaves the patch unwarped.
        cv::Matx22f warp = cv::Matx22f::eye();
        homographyWarp(chains_[static_cast<size_t>(a.chain)], a.px, &warp);
        const PatchAlignment aligned = alignPatch(a.patch, gray, p, 10, 0.01, warp);
        if (aligned.converged && cv::norm(aligned.px - p) <= config_.anchor_max_shift_px &&
            aligned.residual_ratio <= config_.anchor_max_residual_ratio &&
            inside(aligned.px, gray.size(), border)) {
          p = aligned.px;
          ++result.num_aligned;
          // A new anchor after anchor_max_age keyframes: the ground's appearance changes with the view.
          Anchor& an = anchors_[i];
          if (++an.age >= anchor_max_age_) {
            AnchorPatch patch = makeAnchorPatch(gray, p, config_.anchor_patch_px);
            if (patch.valid()) {
              an.patch = std::move(patch);
              an.px = p;
              an.chain = new_chain;
              an.age = 0;
            }
          }
        } else {
          ++result.num_lost;
          continue;
        }
      }
      ids_[kept] = ids_[i];
      px_[kept] = p;
      if (kept != i) anchors_[kept] = std::move(anchors_[i]);
      ++kept;
    }
    ids_.resize(kept);
    px_.resize(kept);
    anchors_.resize(kept);
    result.num_tracked = static_cast<int>(kept);
  } else {
    ids_.clear();
    px_.clear();
    anchors_.clear();
    chains_.clear();
  }

  // New features where the grid has room, clear of the frame tracks and the surviving map-only tracks.
  std::vector<cv::Point2f> existing = live_px;
  existing.insert(existing.end(), px_.begin(), px_.end());
  const int cells = std::max(1, detector_config_.grid_cols * detector_config_.grid_rows);
  const int per_cell = (detector_config_.num_features + num_features_ + cells - 1) / cells;
  const std::vector<cv::KeyPoint> keypoints = detector_.detect(gray, existing, per_cell, 1);
  if (chains_.empty() || chains_.back() != cv::Matx33d::eye()) chains_.push_back(cv::Matx33d::eye());
  const int chain = static_cast<int>(chains_.size()) - 1;
  for (const cv::KeyPoint& k : keypoints) {
    if (!inside(k.pt, gray.size(), border)) continue;
    Anchor a;
    a.px = k.pt;
    a.chain = chain;
    if (config_.anchor_refinement) a.patch = makeAnchorPatch(gray, k.pt, config_.anchor_patch_px);
    ids_.push_back(next_id_++);
    px_.push_back(k.pt);
    anchors_.push_back(std::move(a));
    ++result.num_new;
  }
  // Drop the chains no track refers to any more.
  std::vector<int> remap(chains_.size(), -1);
  for (const Anchor& a : anchors_)
    if (a.chain >= 0) remap[static_cast<size_t>(a.chain)] = 0;
  std::vector<cv::Matx33d> chains;
  for (size_t c = 0; c < chains_.size(); ++c) {
    if (remap[c] < 0) continue;
    remap[c] = static_cast<int>(chains.size());
    chains.push_back(chains_[c]);
  }
  for (Anchor& a : anchors_)
    if (a.chain >= 0) a.chain = remap[static_cast<size_t>(a.chain)];
  chains_ = std::move(chains);

  prev_pyramid_ = std::move(pyramid);
  prev_live_.clear();
  for (size_t i = 0; i < live_ids.size() && i < live_px.size(); ++i)
    prev_live_.emplace(live_ids[i], live_px[i]);
  result.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace planetary_vo
