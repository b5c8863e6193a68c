#include "planetary_vo/terrain/shadow_map.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <opencv2/imgproc.hpp>

namespace planetary_vo::terrain {

ShadowMap::ShadowMap(const PinholeCamera& camera, const ShadowMapConfig& config)
    : camera_(camera), config_(config) {
  std::string why;
  if (!camera_.isValid(&why)) throw std::invalid_argument("ShadowMap: invalid camera: " + why);
  if (!(config_.dark_fraction_of_bright > 0.0 && config_.dark_fraction_of_bright < 1.0) ||
      !(config_.max_pixel_footprint_m > 0.0 && std::isfinite(config_.max_pixel_footprint_m)) ||
      config_.max_keyframes < 1)
    throw std::invalid_argument(
        "ShadowMap: invalid configuration (dark_fraction_of_bright in (0, 1), max_pixel_footprint_m > 0, "
        "max_keyframes >= 1)");
  words_per_row_ = (camera_.width() + 63) / 64;
}

cv::Mat ShadowMap::darkMask(const cv::Mat& gray) const {
  checkKeyframeImage(camera_, gray, "ShadowMap");
  // The 90th percentile from the histogram.
  int histogram[256] = {0};
  for (int row = 0; row < gray.rows; ++row) {
    const uint8_t* p = gray.ptr<uint8_t>(row);
    for (int col = 0; col < gray.cols; ++col) ++histogram[p[col]];
  }
  const long rank = static_cast<long>(std::ceil(0.9 * static_cast<double>(gray.total())));
  long seen = 0;
  int bright = 0;
  for (; bright < 255; ++bright) {
    seen += histogram[bright];
    if (seen >= rank) break;
  }
  // Dark: strictly below the fraction of it (a black image has nothing dark: nothing to compare).
  const double limit = config_.dark_fraction_of_bright * bright;
  cv::Mat mask;
  cv::compare(gray, cv::Scalar(limit), mask, cv::CMP_LT);
  return mask;
}

void ShadowMap::addKeyframe(const Pose& T_world_cam, const cv::Mat& gray) {
  const cv::Mat mask = darkMask(gray);
  View view;
  view.pose = KeyframeView(T_world_cam);
  view.bits.assign(static_cast<size_t>(words_per_row_) * mask.rows, 0);
  for (int row = 0; row < mask.rows; ++row) {
    const uint8_t* m = mask.ptr<uint8_t>(row);
    uint64_t* w = view.bits.data() + static_cast<size_t>(row) * words_per_row_;
    for (int col = 0; col < mask.cols; ++col)
      if (m[col]) w[col / 64] |= uint64_t{1} << (col % 64);
  }
  views_.push_back(std::move(view));
  while (views_.size() > static_cast<size_t>(config_.max_keyframes)) views_.pop_front();
}

cv::Mat ShadowMap::shadowFraction(const GridGeometry& geometry, const cv::Mat& elevation_m,
                                  ShadowStats* stats, cv::Mat* views_out, double shadowed_above) const {
  if (elevation_m.type() != CV_32FC1 || elevation_m.rows != geometry.rows ||
      elevation_m.cols != geometry.cols)
    throw std::invalid_argument("ShadowMap::shadowFraction: the elevation is not a CV_32F layer of the grid");
  cv::Mat fraction = geometry.newLayer();
  cv::Mat views = geometry.newLayer(0.0f);
  ShadowStats s;
  for (int row = 0; row < geometry.rows; ++row) {
    const float* z = elevation_m.ptr<float>(row);
    float* f = fraction.ptr<float>(row);
    float* v = views.ptr<float>(row);
    for (int col = 0; col < geometry.cols; ++col) {
      if (!std::isfinite(z[col])) continue;
      const Eigen::Vector3d p(geometry.x_m(col), geometry.y_m(row), z[col]);
      int n = 0, dark = 0;
      for (const View& view : views_) {
        Eigen::Vector2d px;
        if (!resolvedPixel(camera_, view.pose, p, config_.max_pixel_footprint_m, &px)) continue;
        const int c = static_cast<int>(std::lround(px.x())), r = static_cast<int>(std::lround(px.y()));
        if (c < 0 || r < 0 || c >= camera_.width() || r >= camera_.height()) continue;
        ++n;
        if ((view.bits[static_cast<size_t>(r) * words_per_row_ + c / 64] >> (c % 64)) & 1u) ++dark;
      }
      v[col] = static_cast<float>(n);
      if (n == 0) continue;
      f[col] = static_cast<float>(double(dark) / n);
      ++s.cells_seen;
      if (f[col] > shadowed_above) ++s.cells_shadowed;
    }
  }
  if (stats) *stats = s;
  if (views_out) *views_out = views;
  return fraction;
}

}  // namespace planetary_vo::terrain
