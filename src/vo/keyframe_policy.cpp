#include "planetary_vo/vo/keyframe_policy.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace planetary_vo {

KeyframePolicy::KeyframePolicy(const KeyframeConfig& config) : config_(config) {}

KeyframeDecision KeyframePolicy::decide(const KeyframeCandidate& c) const {
  KeyframeDecision d;
  if (config_.mode == KeyframeMode::kFixedRate) {
    d.is_keyframe = true;
    d.reason = "fixed rate";
    return d;
  }
  if (c.frames_since_keyframe <= 0) return d;
  if (c.median_parallax_deg >= config_.min_parallax_deg) {
    d.is_keyframe = true;
    d.reason = "parallax";
  } else if (c.tracks_at_keyframe > 0 &&
             c.surviving_tracks < config_.min_track_ratio * static_cast<double>(c.tracks_at_keyframe)) {
    d.is_keyframe = true;
    d.reason = "track survival";
  } else if (c.frames_since_keyframe >= config_.max_interval_frames) {
    d.is_keyframe = true;
    d.reason = "interval";
  }
  return d;
}

double KeyframePolicy::medianParallaxDeg(const std::vector<Eigen::Vector3d>& bearings_kf,
                                         const std::vector<Eigen::Vector3d>& bearings_cur,
                                         const Eigen::Matrix3d& R_cur_kf, std::vector<double>* scratch) {
  const size_t n = std::min(bearings_kf.size(), bearings_cur.size());
  if (n == 0) return 0.0;
  scratch->resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = (R_cur_kf * bearings_kf[i]).normalized();
    const Eigen::Vector3d b = bearings_cur[i].normalized();
    // atan2 of |a x b| and a.b stays accurate for the tiny angles that matter here (acos does not).
    (*scratch)[i] = std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
  }
  std::nth_element(scratch->begin(), scratch->begin() + static_cast<std::ptrdiff_t>(n / 2), scratch->end());
  return (*scratch)[n / 2];
}

}  // namespace planetary_vo
