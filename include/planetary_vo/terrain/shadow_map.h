#pragma once
/// @file shadow_map.h
/// Where the landing area lies in shadow, from the keyframe images (issue 11: the sub-resolution relief).
///
/// On an airless body at low Sun, shadows are black and hard. A cast shadow marks what casts it (a rock,
/// a crater rim) or a slope turned away from the Sun by more than the Sun's elevation; either way the ground
/// in it is unseen: no texture, no points, so the terrain model's plane fit runs over it (terrain_map.h)
/// and cannot see a rock smaller than its support. A rock 0.3 m high casts a shadow 1.4 m long at 12 deg,
/// a few pixels at the last hundred metres of an approach, where the plane fit smooths it away. In the
/// true terrain of the rendered landing area (Sun 12 deg), 76 % of the cells in shadow are hazardous
/// against 20 % of all cells (docs/terrain/README.md).
///
/// A keyframe's image gives a dark mask: the pixels darker than dark_fraction_of_bright times the
/// image's 90th percentile (lit ground, even when most of the image is in shadow at a very low Sun). The
/// masks of the last max_keyframes keyframes are kept (1 bit per pixel) with their poses. shadowFraction()
/// projects every cell of a known elevation into each of them and counts the views that see the cell with a
/// pixel covering at most max_pixel_footprint_m of ground (range / focal length, stretched by the incidence
/// on a level cell), and how many of those saw it dark. The cells are projected at the time of the query,
/// with the elevation known then, so a cell mapped after the keyframe was taken is still seen by it.
///
/// Frames: the world of the poses (gravity-aligned, z up, metres: as the densifier, used only once the
/// navigation is metric). The images are the 8-bit keyframes as the VO was given them (distorted).

#include <cstdint>
#include <deque>
#include <vector>

#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/terrain/grid.h"
#include "planetary_vo/terrain/keyframe_view.h"

namespace planetary_vo::terrain {

struct ShadowMapConfig {
  bool enabled = true;
  /// A pixel is in shadow when darker than this fraction of its image's 90th percentile. approach_down
  /// at 100 m, flight camera (8-bit as the VO gets it): Sun 12 deg, 90th percentile 91, shadows 4 (the
  /// black level and the noise), 20th percentile 14 (dim lit ground); Sun 25 deg: 125, lit ground from 49;
  /// Sun 45 deg: 152, lit from 110.
  double dark_fraction_of_bright = 0.1;
  /// A view counts for a cell only when one pixel covers at most this much ground there (m): coarser, a
  /// shadow of a rock is thinner than a pixel. The cell size of the landing area by default.
  double max_pixel_footprint_m = 0.5;
  /// The last N keyframes are kept (in a descent, the nearest views); 1 bit per pixel each.
  int max_keyframes = 30;
};

struct ShadowStats {
  int cells_seen = 0;      ///< cells with at least one view at the resolution
  int cells_shadowed = 0;  ///< ... of which dark in more than `shadowed_above` of them
};

class ShadowMap {
 public:
  /// Throws std::invalid_argument on an invalid camera or config (fraction outside (0, 1), footprint <= 0,
  /// max_keyframes < 1).
  ShadowMap(const PinholeCamera& camera, const ShadowMapConfig& config = ShadowMapConfig());

  /// Keeps the dark mask of a keyframe's image (CV_8UC1 of the camera's size, else std::invalid_argument)
  /// and its pose; the oldest is dropped beyond max_keyframes.
  void addKeyframe(const Pose& T_world_cam, const cv::Mat& gray);
  void clear() { views_.clear(); }
  size_t numKeyframes() const { return views_.size(); }

  /// Per cell of `elevation_m` (CV_32F on `geometry`, NaN = unknown): the fraction of the views at the
  /// resolution that saw the cell dark, NaN where the elevation is unknown or no view qualifies.
  /// `views_out` (optional): the number of those views per cell (CV_32F). `shadowed_above`: the fraction
  /// above which stats counts a cell as in shadow (the hazard map's thresholds.max_shadow_fraction).
  cv::Mat shadowFraction(const GridGeometry& geometry, const cv::Mat& elevation_m,
                         ShadowStats* stats = nullptr, cv::Mat* views_out = nullptr,
                         double shadowed_above = 0.5) const;

  /// The dark mask of one image by the config's rule (CV_8U, 255 = dark): what addKeyframe keeps.
  cv::Mat darkMask(const cv::Mat& gray) const;

 private:
  struct View {
    KeyframeView pose;
    std::vector<uint64_t> bits;  ///< row-major, bit (col % 64) of word (row * words_per_row + col / 64)
  };
  PinholeCamera camera_;
  ShadowMapConfig config_;
  int words_per_row_ = 0;
  std::deque<View> views_;
};

}  // namespace planetary_vo::terrain
