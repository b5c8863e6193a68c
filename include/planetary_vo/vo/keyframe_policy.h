#pragma once
/// @file keyframe_policy.h
/// Stage 4: frame selection. Either every processed frame is a keyframe (the thesis' fixed rate), or a new
/// keyframe is taken when the view has changed enough for triangulation (rotation-compensated parallax), when
/// too few of the last keyframe's tracks survive (the map would starve), or after a maximum interval. So the
/// baseline follows the altitude instead of the frame rate.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/vo/config.h"

namespace planetary_vo {

/// What the policy sees of the current frame relative to the last keyframe.
struct KeyframeCandidate {
  int frames_since_keyframe = 0;     ///< processed frames since the last keyframe (1 for the next one)
  int tracks_at_keyframe = 0;        ///< live tracks when the last keyframe was taken
  int surviving_tracks = 0;          ///< of those, still alive now
  double median_parallax_deg = 0.0;  ///< rotation-compensated, over the surviving tracks
};

struct KeyframeDecision {
  bool is_keyframe = false;
  std::string reason;  ///< "fixed rate", "parallax", "track survival", "interval" or "" (no keyframe)
};

/// Stateless keyframe decision (the pipeline holds the last keyframe).
class KeyframePolicy {
 public:
  explicit KeyframePolicy(const KeyframeConfig& config);

  KeyframeDecision decide(const KeyframeCandidate& candidate) const;

  /// Median angle (deg) between the bearings of the same tracks in two views after removing the rotation:
  /// bearing_kf rotated into the current camera by R_cur_kf against bearing_cur. Pure rotation gives 0; this
  /// is the parallax that triangulation can use. Empty input gives 0. `scratch` avoids an allocation per
  /// call.
  static double medianParallaxDeg(const std::vector<Eigen::Vector3d>& bearings_kf,
                                  const std::vector<Eigen::Vector3d>& bearings_cur,
                                  const Eigen::Matrix3d& R_cur_kf, std::vector<double>* scratch);

  const KeyframeConfig& config() const { return config_; }

 private:
  KeyframeConfig config_;
};

}  // namespace planetary_vo
