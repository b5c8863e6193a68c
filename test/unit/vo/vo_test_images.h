#pragma once
/// Synthetic images with known answers for the vo stage tests: band-limited noise texture (many FAST corners,
/// smooth enough that sub-pixel warps are interpolated accurately) and known warps of it.

#include <cstdint>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace planetary_vo::test {

/// Gaussian-blurred white noise with mean 128 and standard deviation `contrast` grey levels, as float.
inline cv::Mat textureFloat(const cv::Size& size, uint64_t seed, double blur_sigma_px = 2.0,
                            double contrast = 45.0) {
  cv::Mat noise(size, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(), blur_sigma_px, blur_sigma_px, cv::BORDER_REFLECT_101);
  cv::Scalar mean, stddev;
  cv::meanStdDev(noise, mean, stddev);
  noise = (noise - mean[0]) * (contrast / stddev[0]) + 128.0;
  return noise;
}

inline cv::Mat toGray(const cv::Mat& image_f32) {
  cv::Mat gray;
  image_f32.convertTo(gray, CV_8U);  // rounds and saturates
  return gray;
}

/// 8-bit textured image.
inline cv::Mat texture(const cv::Size& size, uint64_t seed, double blur_sigma_px = 2.0,
                       double contrast = 45.0) {
  return toGray(textureFloat(size, seed, blur_sigma_px, contrast));
}

/// Two views of a larger texture: `first` is a crop of it, `second` the same crop after the texture was moved
/// by the affine map A (2x3, in the coordinates of the crop): a point p of `first` appears at A * [p; 1] in
/// `second`. Cropping from a larger texture keeps warp borders out of the images.
struct ViewPair {
  cv::Mat first, second;
  cv::Matx23d A;
  cv::Point2f map(const cv::Point2f& p) const {
    return cv::Point2f(static_cast<float>(A(0, 0) * p.x + A(0, 1) * p.y + A(0, 2)),
                       static_cast<float>(A(1, 0) * p.x + A(1, 1) * p.y + A(1, 2)));
  }
};

inline ViewPair warpedPair(const cv::Size& size, const cv::Matx23d& A, uint64_t seed, int margin_px = 64) {
  const cv::Mat big = textureFloat(cv::Size(size.width + 2 * margin_px, size.height + 2 * margin_px), seed);
  // A in big-image coordinates: shift by the margin, apply A, shift back.
  const cv::Matx23d A_big(A(0, 0), A(0, 1), A(0, 2) + margin_px - A(0, 0) * margin_px - A(0, 1) * margin_px,
                          A(1, 0), A(1, 1), A(1, 2) + margin_px - A(1, 0) * margin_px - A(1, 1) * margin_px);
  cv::Mat warped;
  cv::warpAffine(big, warped, A_big, big.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT_101);
  const cv::Rect crop(margin_px, margin_px, size.width, size.height);
  return ViewPair{toGray(big(crop)), toGray(warped(crop)), A};
}

inline cv::Matx23d translation(double dx_px, double dy_px) { return cv::Matx23d(1, 0, dx_px, 0, 1, dy_px); }

}  // namespace planetary_vo::test
