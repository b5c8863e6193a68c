#pragma once
/// @file densifier.h
/// Densification of the landing area (issue 11): the VO's sparse map holds a few hundred points per image,
/// a few metres apart on the ground, too sparse for slopes and rocks at the lander's scale. At each VO
/// keyframe the densifier tracks a dense set of corners that see the landing area from an EARLIER keyframe
/// (one of the last `max_keyframe_gap`: the best overlap at enough parallax) into the new one, and
/// triangulates them with the two keyframes' VO poses. The points go to the terrain model
/// (terrain_map.h) like the VO's own points; every pair adds its own measurement of the same ground, which
/// the model's weighted plane fit averages.
///
/// Per pair: corners (cv::goodFeaturesToTrack, at most one per grid_step_px) in the old keyframe's image
/// where its rays meet the plane z = ground_z_m inside the landing area (plus support margin); their
/// position in the new image predicted through that plane (the homography it induces) and refined by
/// pyramidal Lucas-Kanade from the old image warped onto the new view by that homography (warp_partner: a
/// translation-only window is biased by the views' scale and rotation; on approach_down the slope error
/// fell from 4.6 to 3.1 deg RMS, docs/terrain/README.md), kept when the backward track returns within
/// max_forward_backward_px; then the two rays' midpoint, kept when the rays pass within 4 pixel sigmas, both
/// depths are positive and the ray angle is at least min_parallax_deg. The point's covariance is the two-ray
/// triangulation covariance at pixel_sigma_px (the keyframe poses taken as exact, like the VO's map events).
///
/// Ids: 2^63 + n, apart from the VO's point ids. Images: 8-bit gray, as the VO was given them (distorted;
/// the camera model undistorts the tracked corners).

#include <cstdint>
#include <deque>
#include <vector>

#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/terrain/landing_area.h"
#include "planetary_vo/vo/map_events.h"

namespace planetary_vo::terrain {

struct DensifierConfig {
  LandingAreaParams area;             ///< where to densify
  double area_margin_m = 8.0;         ///< ... plus this much around it (the support of the edge cells)
  int grid_step_px = 5;               ///< at most one corner per step x step pixels
  int max_corners = 20000;            ///< per pair
  double min_corner_quality = 0.002;  ///< goodFeaturesToTrack quality level (relative to the best corner)
  int max_keyframe_gap = 8;           ///< partner: one of the last N keyframes (see target_parallax_deg)
  /// The partner is the one whose overlap with the new keyframe over the area, times min(1, median
  /// parallax / target_parallax_deg), is largest.
  double target_parallax_deg = 5.0;
  /// Partners per keyframe, best first: each ground point is measured by that many pairs.
  int partners_per_keyframe = 1;
  /// Track from the partner image warped onto the new view by the ground plane's homography (fitted to the
  /// predicted positions), so that the windows differ only by the relief.
  bool warp_partner = true;
  int min_seeds = 50;             ///< a partner must offer at least this many corners
  double min_parallax_deg = 1.5;  ///< ray angle of a kept point
  double max_forward_backward_px = 0.5;
  double pixel_sigma_px = 0.5;  ///< KLT accuracy, for the points' covariance and the ray gap test
  int klt_window_px = 21;
  /// A point is kept only when the ground its tracking window covers (range x klt_window_px / fx, divided
  /// by the cosine of the incidence on level ground) is at most this in both views: a point seen from
  /// farther averages relief over a wider patch than the lander's footprint. 0 = no limit. Default: the
  /// 4 m footprint (campaign of docs/terrain/README.md: unsafe sites chosen 12 of 24 without, 3 of 16 with).
  double max_window_footprint_m = 4.0;
  int klt_levels = 4;
};

struct DensifierStats {
  int partner_gap = 0;  ///< keyframes between the best pair (0: no pair)
  int seeds = 0, tracked = 0, triangulated = 0;
};

class Densifier {
 public:
  /// Throws std::invalid_argument on an invalid camera or config.
  Densifier(const PinholeCamera& camera, const DensifierConfig& config = DensifierConfig());

  /// A new keyframe (its image and VO pose T_world_cam); ground_z_m: the height of the ground around the
  /// landing area as far as known (e.g. the median of the map's points there), for the prediction only.
  /// Returns the points triangulated against the partner keyframe (empty without one).
  std::vector<MapPointState> addKeyframe(double timestamp_s, const Pose& T_world_cam, const cv::Mat& gray,
                                         double ground_z_m, DensifierStats* stats = nullptr);

 private:
  struct StoredKeyframe {
    double timestamp_s = 0.0;
    Pose T_world_cam = Pose::Identity();
    cv::Mat gray;
  };
  PinholeCamera camera_;
  DensifierConfig config_;
  std::deque<StoredKeyframe> keyframes_;
  uint64_t next_id_ = uint64_t{1} << 63;
};

}  // namespace planetary_vo::terrain
