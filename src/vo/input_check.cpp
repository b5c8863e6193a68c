#include "planetary_vo/vo/input_check.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

#include <opencv2/core.hpp>

namespace planetary_vo {

bool FrozenFrameDetector::check(const cv::Mat& gray, Difference* difference) {
  if (difference) {
    difference->mean_abs_diff = std::numeric_limits<double>::quiet_NaN();
    difference->moved_ratio = std::numeric_limits<double>::quiet_NaN();
  }
  if (gray.empty() || gray.type() != CV_8UC1)
    throw std::invalid_argument(
        "FrozenFrameDetector::check: expected a non-empty 8-bit single-channel image");
  current_.clear();
  current_.reserve(static_cast<size_t>((gray.rows / kStepPx + 1) * (gray.cols / kStepPx + 1)));
  for (int r = 0; r < gray.rows; r += kStepPx) {
    const uint8_t* row = gray.ptr<uint8_t>(r);
    for (int c = 0; c < gray.cols; c += kStepPx) current_.push_back(row[c]);
  }
  const bool comparable =
      !previous_.empty() && cols_ == gray.cols && rows_ == gray.rows && previous_.size() == current_.size();
  bool frozen = false;
  if (comparable) {
    uint64_t sum = 0, moved = 0;
    for (size_t i = 0; i < current_.size(); ++i) {
      const int d = std::abs(int(current_[i]) - int(previous_[i]));
      sum += static_cast<uint64_t>(d);
      moved += d > kMovedLevel;
    }
    const double n = static_cast<double>(current_.size());
    const double mad = static_cast<double>(sum) / n;
    const double moved_ratio = static_cast<double>(moved) / n;
    if (difference) *difference = {mad, moved_ratio};
    frozen = threshold_ > 0.0 && mad < threshold_ && moved_ratio <= max_moved_ratio_;
  }
  previous_.swap(current_);
  cols_ = gray.cols;
  rows_ = gray.rows;
  return frozen;
}

std::string checkExposure(const cv::Mat& gray, double min_stddev, double max_saturated_ratio) {
  if (gray.empty() || gray.type() != CV_8UC1)
    throw std::invalid_argument("checkExposure: expected a non-empty 8-bit single-channel image");
  // One pass: sum, sum of squares and the count of saturated pixels.
  uint64_t sum = 0, sum_sq = 0, saturated = 0, count = 0;
  for (int r = 0; r < gray.rows; r += kExposureRowStep) {
    const uint8_t* row = gray.ptr<uint8_t>(r);
    uint32_t row_sum = 0, row_saturated = 0;
    uint64_t row_sq = 0;
    for (int c = 0; c < gray.cols; ++c) {
      const uint32_t v = row[c];
      row_sum += v;
      row_sq += v * v;
      row_saturated += v == 255;
    }
    sum += row_sum;
    sum_sq += row_sq;
    saturated += row_saturated;
    count += static_cast<uint64_t>(gray.cols);
  }
  const double n = static_cast<double>(count);
  const double mean = static_cast<double>(sum) / n;
  const double stddev = std::sqrt(std::max(0.0, static_cast<double>(sum_sq) / n - mean * mean));
  const double saturated_ratio = static_cast<double>(saturated) / n;
  if (saturated_ratio > max_saturated_ratio)
    return "saturated frame: " + std::to_string(int(100.0 * saturated_ratio)) + " % of the pixels at 255";
  if (stddev < min_stddev)
    return std::string(mean < 10.0 ? "black" : "blank") + " frame: grey-level mean " + std::to_string(mean) +
           ", stddev " + std::to_string(stddev) + " (no texture to track)";
  return "";
}

const cv::Mat& ExposureCompensator::apply(const cv::Mat& gray, cv::Mat* buffer) {
  if (gray.empty() || gray.type() != CV_8UC1)
    throw std::invalid_argument(
        "ExposureCompensator::apply: expected a non-empty 8-bit single-channel image");
  if (!(step_ratio_ > 1.0)) {
    gain_ = 1.0;
    return gray;
  }
  uint64_t sum = 0, count = 0;
  for (int r = 0; r < gray.rows; r += kStepPx) {
    const uint8_t* row = gray.ptr<uint8_t>(r);
    for (int c = 0; c < gray.cols; c += kStepPx, ++count) sum += row[c];
  }
  const double mean = std::max(1.0, static_cast<double>(sum) / static_cast<double>(count));
  if (previous_mean_ > 0.0) {
    const double ratio = previous_mean_ / mean;
    if (ratio >= step_ratio_ || 1.0 / ratio >= step_ratio_) {
      gain_ = std::min(64.0, std::max(1.0 / 64.0, gain_ * ratio));
      // Back where it started (the exposure returned): pass the images through untouched again.
      if (std::abs(gain_ - 1.0) < 0.5 * (step_ratio_ - 1.0)) gain_ = 1.0;
    }
  }
  previous_mean_ = mean;
  if (gain_ == 1.0) return gray;
  gray.convertTo(*buffer, CV_8U, gain_);
  return *buffer;
}

}  // namespace planetary_vo
