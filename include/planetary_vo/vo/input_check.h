#pragma once
/// @file input_check.h
/// Checks on an input image before the chain sees it, in the core so that vo_run and the nodelet share them.
///
/// FrozenFrameDetector: a stuck frame buffer (the same image repeated with fresh stamps) must not be tracked
/// as a zero-motion pose. The image is compared with the previous input image on a subsampled grid (every
/// kStepPx-th pixel in both directions); a mean absolute difference below the threshold
/// (pipeline.frozen_frame_max_mean_abs_diff, gray levels) marks the image as frozen. A real camera's noise
/// alone keeps consecutive frames above a fraction of a gray level, so the default flags only identical or
/// near-identical frames; 0 switches the check off.

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

namespace planetary_vo {

class FrozenFrameDetector {
 public:
  static constexpr int kStepPx = 4;

  /// @param max_mean_abs_diff frames whose mean absolute difference to the previous one is below this are
  /// frozen; <= 0 switches the check off.
  explicit FrozenFrameDetector(double max_mean_abs_diff = 0.0) : threshold_(max_mean_abs_diff) {}

  /// @brief Compares `gray` (8UC1) with the previous image given, then keeps it as the previous image.
  /// @param mean_abs_diff out (may be null): the mean absolute difference, NaN without a previous image of
  /// the same size.
  /// @return true when the image is frozen (never for the first image, or after reset() or a size change).
  bool check(const cv::Mat& gray, double* mean_abs_diff = nullptr);

  void setThreshold(double max_mean_abs_diff) { threshold_ = max_mean_abs_diff; }
  double threshold() const { return threshold_; }
  /// Forgets the previous image.
  void reset() { previous_.clear(); }

 private:
  double threshold_;
  int cols_ = 0, rows_ = 0;
  std::vector<uint8_t> previous_, current_;
};

}  // namespace planetary_vo
