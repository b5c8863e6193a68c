#pragma once
/// Ground texture for rendered test scenes: octaves of smooth noise (uniform noise on a coarse lattice,
/// cubic-upsampled), from `first_cells` to `last_cells` lattice cells across, each octave's weight
/// `decay` times the previous one, contrast-normalised to 20..235 grey levels (8-bit).

#include <cstdint>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace planetary_vo::test {

inline cv::Mat octaveNoiseTexture(int size_px, uint64_t seed, int first_cells, int last_cells, double decay) {
  cv::RNG rng(seed);
  cv::Mat acc = cv::Mat::zeros(size_px, size_px, CV_32F);
  double weight = 1.0;
  for (int cells = first_cells; cells <= last_cells; cells *= 2, weight *= decay) {
    cv::Mat coarse(cells, cells, CV_32F), fine;
    rng.fill(coarse, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::resize(coarse, fine, acc.size(), 0, 0, cv::INTER_CUBIC);
    acc += weight * fine;
  }
  cv::Mat out;
  cv::normalize(acc, acc, 20, 235, cv::NORM_MINMAX);
  acc.convertTo(out, CV_8U);
  return out;
}

}  // namespace planetary_vo::test
