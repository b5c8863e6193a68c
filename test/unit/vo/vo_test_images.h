#pragma once
/// Synthetic images with known answers for the vo stage tests: band-limited noise texture (many FAST corners,
/// smooth enough that sub-pixel warps are interpolated accurately) and known warps of it.

#include <cmath>
#include <cstdint>
#include <vector>

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

/// Two views of an analytic texture: `first` shows it directly, `second` after it moved by the affine map A
/// (2x3): a point p of `first` appears at A * [p; 1] in `second`. The texture is a sum of random plane waves
/// (wavelengths 8-40 px), evaluated exactly at every pixel of both views, so the known motion carries no
/// interpolation error (cv::warpAffine's cubic kernel biases sub-pixel shifts by ~0.03 px, as much as LK's
/// own error). Both images are rounded to 8 bits, as a camera's are.
struct ViewPair {
  cv::Mat first, second;
  cv::Matx23d A;
  cv::Point2f map(const cv::Point2f& p) const {
    return cv::Point2f(static_cast<float>(A(0, 0) * p.x + A(0, 1) * p.y + A(0, 2)),
                       static_cast<float>(A(1, 0) * p.x + A(1, 1) * p.y + A(1, 2)));
  }
};

/// The plane-wave texture seen through `B`: pixel q shows the texture at B * [q; 1].
inline cv::Mat planeWaveTexture(const cv::Size& size, uint64_t seed, const cv::Matx23d& B,
                                double contrast = 45.0) {
  constexpr int kWaves = 60;
  cv::RNG rng(seed);
  cv::Mat out(size, CV_32F, cv::Scalar(128.0));
  std::vector<double> cx(size.width), sx(size.width);
  const double amplitude = contrast * std::sqrt(2.0 / kWaves);
  for (int k = 0; k < kWaves; ++k) {
    const double wavelength_px = rng.uniform(8.0, 40.0), direction = rng.uniform(0.0, 2 * CV_PI);
    const double phase = rng.uniform(0.0, 2 * CV_PI);
    const double a = 2 * CV_PI / wavelength_px * std::cos(direction),
                 b = 2 * CV_PI / wavelength_px * std::sin(direction);
    // a*u + b*v with (u, v) = B * [x; y; 1] is again a plane wave in (x, y): separable per row and column.
    const double wx = a * B(0, 0) + b * B(1, 0), wy = a * B(0, 1) + b * B(1, 1),
                 w0 = a * B(0, 2) + b * B(1, 2) + phase;
    for (int x = 0; x < size.width; ++x) cx[x] = std::cos(wx * x), sx[x] = std::sin(wx * x);
    for (int y = 0; y < size.height; ++y) {
      const double cy = amplitude * std::cos(wy * y + w0), sy = amplitude * std::sin(wy * y + w0);
      float* row = out.ptr<float>(y);
      for (int x = 0; x < size.width; ++x) row[x] += static_cast<float>(cx[x] * cy - sx[x] * sy);
    }
  }
  return out;
}

inline ViewPair warpedPair(const cv::Size& size, const cv::Matx23d& A, uint64_t seed) {
  // Pixel q of the second view shows the texture point p = A^-1 q.
  cv::Matx23d A_inv;
  cv::invertAffineTransform(A, A_inv);
  return ViewPair{toGray(planeWaveTexture(size, seed, cv::Matx23d(1, 0, 0, 0, 1, 0))),
                  toGray(planeWaveTexture(size, seed, A_inv)), A};
}

inline cv::Matx23d translation(double dx_px, double dy_px) { return cv::Matx23d(1, 0, dx_px, 0, 1, dy_px); }

}  // namespace planetary_vo::test
