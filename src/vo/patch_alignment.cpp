/// @file patch_alignment.cpp
/// Translation + affine-brightness alignment of an anchor patch (Gauss-Newton, fixed Jacobian).

#include "planetary_vo/vo/patch_alignment.h"

#include <algorithm>
#include <cmath>

namespace planetary_vo {
namespace {

/// Bilinear sample of an 8-bit image; the caller guarantees 0 <= x < cols - 1 and 0 <= y < rows - 1.
inline float sample(const cv::Mat& gray, float x, float y) {
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float ax = x - static_cast<float>(x0), ay = y - static_cast<float>(y0);
  const uchar* row0 = gray.ptr<uchar>(y0) + x0;
  const uchar* row1 = row0 + gray.step[0];
  return (1.f - ay) * ((1.f - ax) * row0[0] + ax * row0[1]) + ay * ((1.f - ax) * row1[0] + ax * row1[1]);
}

/// Whether every bilinear sample within `margin` px of a patch of half-size `half` around (x, y) is inside.
inline bool fits(const cv::Mat& gray, float x, float y, int half, int margin) {
  const float r = static_cast<float>(half + margin);
  return x - r >= 0.f && y - r >= 0.f && x + r < static_cast<float>(gray.cols - 1) &&
         y + r < static_cast<float>(gray.rows - 1);
}

}  // namespace

bool homographyWarp(const cv::Matx33d& H, const cv::Point2f& px, cv::Matx22f* warp) {
  const double x = px.x, y = px.y;
  const double w = H(2, 0) * x + H(2, 1) * y + H(2, 2);
  if (!(std::abs(w) > 1e-9)) return false;
  const double u = (H(0, 0) * x + H(0, 1) * y + H(0, 2)) / w;
  const double v = (H(1, 0) * x + H(1, 1) * y + H(1, 2)) / w;
  const cv::Matx22d J((H(0, 0) - u * H(2, 0)) / w, (H(0, 1) - u * H(2, 1)) / w, (H(1, 0) - v * H(2, 0)) / w,
                      (H(1, 1) - v * H(2, 1)) / w);
  const double det = cv::determinant(J);
  // A plausible image motion of a patch: no mirror, at most 4x zoom either way.
  if (!(det > 1.0 / 16.0 && det < 16.0)) return false;
  *warp = cv::Matx22f(J);
  return true;
}

AnchorPatch makeAnchorPatch(const cv::Mat& gray, const cv::Point2f& px, int size_px) {
  AnchorPatch patch;
  if (gray.empty() || gray.type() != CV_8UC1 || size_px < 3 || size_px % 2 == 0) return patch;
  const int half = size_px / 2;
  if (!(std::isfinite(px.x) && std::isfinite(px.y)) || !fits(gray, px.x, px.y, half, 1)) return patch;
  const size_t n = static_cast<size_t>(size_px) * static_cast<size_t>(size_px);
  patch.values.resize(n);
  patch.grad_x.resize(n);
  patch.grad_y.resize(n);
  double sum = 0.0;
  size_t k = 0;
  for (int dy = -half; dy <= half; ++dy) {
    for (int dx = -half; dx <= half; ++dx, ++k) {
      const float x = px.x + static_cast<float>(dx), y = px.y + static_cast<float>(dy);
      patch.values[k] = sample(gray, x, y);
      patch.grad_x[k] = 0.5f * (sample(gray, x + 1.f, y) - sample(gray, x - 1.f, y));
      patch.grad_y[k] = 0.5f * (sample(gray, x, y + 1.f) - sample(gray, x, y - 1.f));
      sum += patch.values[k];
    }
  }
  patch.mean = static_cast<float>(sum / static_cast<double>(n));
  double sum_d2 = 0.0;
  for (const float v : patch.values) sum_d2 += (v - patch.mean) * (v - patch.mean);
  patch.stddev = static_cast<float>(std::sqrt(sum_d2 / static_cast<double>(n)));
  // Normal matrix of the Jacobian rows [gx, gy, -(T - mean), -1].
  cv::Matx44d normal = cv::Matx44d::zeros();
  for (k = 0; k < n; ++k) {
    const cv::Vec4d j(patch.grad_x[k], patch.grad_y[k], -(patch.values[k] - patch.mean), -1.0);
    normal += j * j.t();
  }
  bool ok = false;
  patch.inverse_normal = normal.inv(cv::DECOMP_CHOLESKY, &ok);
  // A flat patch (no gradient, or gradient along one direction only: an edge) cannot fix both coordinates.
  // Its translation block must be well conditioned: the smaller eigenvalue of the 2x2 gradient matrix, per
  // sample, of at least 1 grey level^2 per px^2.
  const double a = normal(0, 0), b = normal(0, 1), c = normal(1, 1);
  const double min_eigen = 0.5 * (a + c - std::sqrt((a - c) * (a - c) + 4.0 * b * b));
  if (!ok || !(min_eigen >= static_cast<double>(n))) return AnchorPatch();
  patch.size_px = size_px;
  return patch;
}

PatchAlignment alignPatch(const AnchorPatch& patch, const cv::Mat& gray, const cv::Point2f& start_px,
                          int max_iterations, double epsilon_px, const cv::Matx22f& warp) {
  PatchAlignment result;
  result.px = start_px;
  if (!patch.valid() || gray.empty() || gray.type() != CV_8UC1) return result;
  const int patch_half = patch.size_px / 2;
  // The warped patch's reach in the new image (its corners move by warp * (+-half, +-half)).
  const float reach = static_cast<float>(patch_half) * std::max(std::abs(warp(0, 0)) + std::abs(warp(0, 1)),
                                                                std::abs(warp(1, 0)) + std::abs(warp(1, 1)));
  if (!(reach < 4.f * static_cast<float>(patch_half) + 1.f)) return result;  // not a plausible warp
  const int half = static_cast<int>(std::ceil(reach));

  float x = start_px.x, y = start_px.y, gain = 0.f, bias = 0.f;  // gain here is (factor - 1)
  const double eps2 = epsilon_px * epsilon_px;
  const float* values = patch.values.data();
  const float* grad_x = patch.grad_x.data();
  const float* grad_y = patch.grad_y.data();
  const size_t row_step = gray.step[0];
  for (int it = 0; it < max_iterations; ++it) {
    if (!(std::isfinite(x) && std::isfinite(y)) || !fits(gray, x, y, half, 0)) return result;
    // Sums in float per row (at most a few dozen samples), in double over the rows.
    cv::Vec4d jte(0.0, 0.0, 0.0, 0.0);
    double sum_e2 = 0.0;
    size_t k = 0;
    for (int dy = -patch_half; dy <= patch_half; ++dy) {
      // The row's first sample in the new image, then one warp column per step along the row.
      float sx = x - static_cast<float>(patch_half) * warp(0, 0) + static_cast<float>(dy) * warp(0, 1);
      float sy = y - static_cast<float>(patch_half) * warp(1, 0) + static_cast<float>(dy) * warp(1, 1);
      float r_gx = 0.f, r_gy = 0.f, r_t = 0.f, r_e = 0.f, r_e2 = 0.f;
      for (int dx = -patch_half; dx <= patch_half; ++dx, ++k, sx += warp(0, 0), sy += warp(1, 0)) {
        const int x0 = static_cast<int>(sx), y0 = static_cast<int>(sy);
        const float ax = sx - static_cast<float>(x0), ay = sy - static_cast<float>(y0);
        const uchar* row0 = gray.data + static_cast<size_t>(y0) * row_step + static_cast<size_t>(x0);
        const uchar* row1 = row0 + row_step;
        const float top = static_cast<float>(row0[0]) + ax * static_cast<float>(row0[1] - row0[0]);
        const float bottom = static_cast<float>(row1[0]) + ax * static_cast<float>(row1[1] - row1[0]);
        const float t = values[k] - patch.mean;
        const float e = top + ay * (bottom - top) - values[k] - gain * t - bias;
        r_gx += grad_x[k] * e;
        r_gy += grad_y[k] * e;
        r_t -= t * e;
        r_e -= e;
        r_e2 += e * e;
      }
      jte += cv::Vec4d(r_gx, r_gy, r_t, r_e);
      sum_e2 += r_e2;
    }
    const cv::Vec4d delta = -(patch.inverse_normal * jte);
    // The new image's gradient at a sample is the anchor's times the gain factor, through the warp
    // (grad I = warp^-T grad T): the step solved with the anchor's gradients maps to warp * step / factor.
    const double factor = std::max(0.1, 1.0 + gain);
    const double step_x = (warp(0, 0) * delta[0] + warp(0, 1) * delta[1]) / factor;
    const double step_y = (warp(1, 0) * delta[0] + warp(1, 1) * delta[1]) / factor;
    x += static_cast<float>(step_x);
    y += static_cast<float>(step_y);
    gain += static_cast<float>(delta[2]);
    bias += static_cast<float>(delta[3]);
    result.iterations = it + 1;
    result.rms_residual = std::sqrt(sum_e2 / static_cast<double>(patch.values.size()));
    if (step_x * step_x + step_y * step_y < eps2) {
      if (!(std::isfinite(x) && std::isfinite(y)) || !fits(gray, x, y, half, 0)) return result;
      result.converged = true;
      result.residual_ratio = result.rms_residual / std::max(1e-3, static_cast<double>(patch.stddev));
      result.px = cv::Point2f(x, y);
      result.gain = 1.f + gain;
      result.bias = bias;
      return result;
    }
  }
  return result;
}

}  // namespace planetary_vo
