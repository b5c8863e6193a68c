#pragma once
/// @file input_check.h
/// Checks on an input image before the chain sees it, in the core so that vo_run and the nodelet share them.
///
/// FrozenFrameDetector: a stuck frame buffer (the same image repeated with fresh stamps) must not be tracked
/// as a zero-motion pose. The image is compared with the previous input image on a subsampled grid (every
/// kStepPx-th pixel in both directions); a mean absolute difference below the threshold
/// (pipeline.frozen_frame_max_mean_abs_diff, gray levels) marks the image as frozen, unless more than
/// pipeline.frozen_frame_max_moved_ratio of the sampled pixels changed by more than kMovedLevel gray levels.
/// A real camera's noise alone keeps consecutive frames above a fraction of a gray level; a noiseless camera
/// moving slowly over mostly flat ground does not (approach_nozzle, 512 ideal, Sun 9.6 deg: mean difference
/// 0.17-0.49 over 26 frames while the lander moved 0.6-1 m a frame), but there the edges that moved change
/// by tens of gray levels (0.46-1.3 % of the samples by more than 8), where a repeated buffer changes none.
/// So the default flags only identical or near-identical frames; frozen_frame_max_mean_abs_diff = 0 switches
/// the check off.
///
/// checkExposure: a black, blank or saturated image has nothing to track (pipeline.min_exposure_stddev,
/// pipeline.max_saturated_ratio).
///
/// ExposureCompensator: KLT compares raw intensities, so a sudden exposure or gain step (a 0.3x drop lost
/// 12 frames on a Lunar descent) breaks every track although the scene did not change. A step of the mean
/// brightness between consecutive images by at least pipeline.exposure_step_ratio (either way) is taken as
/// such a change, and the images are scaled back to the brightness before the step for tracking. Slow changes
/// (the scene, the Sun) stay below the ratio and are left to KLT; without a step the image is passed through
/// untouched.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace planetary_vo {

class FrozenFrameDetector {
 public:
  static constexpr int kStepPx = 4;
  /// A sampled pixel whose value changed by more than this (gray levels) has moved: noise and
  /// re-quantisation change a pixel by a few levels, a moving edge by tens.
  static constexpr int kMovedLevel = 8;

  /// The comparison of an image with the previous one.
  struct Difference {
    double mean_abs_diff = 0.0;  ///< mean absolute difference of the sampled pixels, gray levels
    double moved_ratio = 0.0;    ///< fraction of the sampled pixels that changed by more than kMovedLevel
  };

  /// @param max_mean_abs_diff frames whose mean absolute difference to the previous one is below this are
  /// frozen; <= 0 switches the check off.
  /// @param max_moved_ratio ... unless more than this fraction of the sampled pixels moved (>= 1: the mean
  /// difference alone decides).
  explicit FrozenFrameDetector(double max_mean_abs_diff = 0.0, double max_moved_ratio = 1.0)
      : threshold_(max_mean_abs_diff), max_moved_ratio_(max_moved_ratio) {}

  /// @brief Compares `gray` (8UC1) with the previous image given, then keeps it as the previous image.
  /// @param difference out (may be null): the comparison, NaN without a previous image of the same size.
  /// @return true when the image is frozen (never for the first image, or after reset() or a size change).
  bool check(const cv::Mat& gray, Difference* difference = nullptr);

  double threshold() const { return threshold_; }
  /// Forgets the previous image.
  void reset() { previous_.clear(); }

 private:
  double threshold_;
  double max_moved_ratio_;
  int cols_ = 0, rows_ = 0;
  std::vector<uint8_t> previous_, current_;
};

/// @brief Why `gray` (8UC1) cannot be tracked, or "" when it can: more than max_saturated_ratio of its pixels
/// at 255 ("saturated frame"), or a gray-level standard deviation below min_stddev ("black frame" when the
/// mean is below 10, else "blank frame"). Every pixel of every kExposureRowStep-th row is counted: a quarter of
/// the image gives the same figures to well within these coarse thresholds, at a quarter of the cost of this
/// check that runs on every frame (docs/visual_core.md, step 3).
std::string checkExposure(const cv::Mat& gray, double min_stddev, double max_saturated_ratio);
constexpr int kExposureRowStep = 4;

class ExposureCompensator {
 public:
  static constexpr int kStepPx = 4;  ///< the mean brightness is taken on every kStepPx-th pixel

  /// @param step_ratio a brightness step between consecutive images by at least this factor is compensated;
  /// 0 (or <= 1) switches the compensation off.
  explicit ExposureCompensator(double step_ratio = 0.0) : step_ratio_(step_ratio) {}

  /// @brief The image to track: `gray` (8UC1) itself while the accumulated gain is 1, else `gray` scaled by
  /// the gain into *buffer (saturating), which is returned.
  const cv::Mat& apply(const cv::Mat& gray, cv::Mat* buffer);

  /// The factor the last image was scaled by (1: untouched).
  double gain() const { return gain_; }
  void setStepRatio(double step_ratio) { step_ratio_ = step_ratio; }
  /// Forgets the previous image and sets the gain back to 1 (with the tracks: nothing to compare to).
  void reset() {
    gain_ = 1.0;
    previous_mean_ = 0.0;
  }

 private:
  double step_ratio_;
  double gain_ = 1.0;
  double previous_mean_ = 0.0;  ///< raw mean brightness of the previous image, 0: none
};

}  // namespace planetary_vo
