#include "planetary_vo/vo/input_check.h"

#include <cmath>
#include <cstdlib>
#include <limits>
#include <stdexcept>

namespace planetary_vo {

bool FrozenFrameDetector::check(const cv::Mat& gray, double* mean_abs_diff) {
  if (mean_abs_diff) *mean_abs_diff = std::numeric_limits<double>::quiet_NaN();
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
    uint64_t sum = 0;
    for (size_t i = 0; i < current_.size(); ++i)
      sum += static_cast<uint64_t>(std::abs(int(current_[i]) - int(previous_[i])));
    const double mad = static_cast<double>(sum) / static_cast<double>(current_.size());
    if (mean_abs_diff) *mean_abs_diff = mad;
    frozen = threshold_ > 0.0 && mad < threshold_;
  }
  previous_.swap(current_);
  cols_ = gray.cols;
  rows_ = gray.rows;
  return frozen;
}

}  // namespace planetary_vo
