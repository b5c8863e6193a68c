#include "planetary_vo/terrain/hazard.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "planetary_vo/terrain/surface_analysis.h"

namespace planetary_vo::terrain {

cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const HazardThresholds& thresholds) {
  if (slope_deg.type() != CV_32FC1 || roughness_m.type() != CV_32FC1 ||
      slope_deg.size() != roughness_m.size())
    throw std::invalid_argument("hazardMask: slope and roughness must be CV_32F layers of one size");
  cv::Mat mask(slope_deg.size(), CV_8U);
  for (int row = 0; row < mask.rows; ++row) {
    const float* s = slope_deg.ptr<float>(row);
    const float* r = roughness_m.ptr<float>(row);
    uint8_t* m = mask.ptr<uint8_t>(row);
    for (int col = 0; col < mask.cols; ++col) {
      if (!std::isfinite(s[col]) || !std::isfinite(r[col]))
        m[col] = kUnknown;
      else
        m[col] = (s[col] > thresholds.max_slope_deg || r[col] > thresholds.max_roughness_m) ? kHazard : kSafe;
    }
  }
  return mask;
}

cv::Mat shadingWithinMargin(const GridSet& grids, const HazardThresholds& thresholds) {
  const auto it = grids.layers.find("shading_slope_deg");
  if (it == grids.layers.end()) return cv::Mat();
  const cv::Mat& shading = it->second;
  const GridGeometry& g = grids.geometry;
  if (shading.type() != CV_32FC1 || shading.rows != g.rows || shading.cols != g.cols)
    throw std::invalid_argument("shadingWithinMargin: 'shading_slope_deg' is not a CV_32F layer of the grid");
  const double margin = thresholds.shading_margin_m;
  if (!(margin >= 0.0) || !std::isfinite(margin))
    throw std::invalid_argument("shadingWithinMargin: shading_margin_m must be finite and >= 0");
  if (!(g.cell_size_m > 0.0)) throw std::invalid_argument("shadingWithinMargin: non-positive cell size");
  if (margin < g.cell_size_m) return shading.clone();  // no neighbour's centre within it
  // The cells whose centres are within the margin: the footprint disc of that radius (surface_analysis.h).
  const std::vector<cv::Point> disc = footprintOffsets(g.cell_size_m, 2.0 * margin);
  int R = 0;
  for (const cv::Point& o : disc) R = std::max(R, o.x);
  cv::Mat kernel = cv::Mat::zeros(2 * R + 1, 2 * R + 1, CV_8U);
  for (const cv::Point& o : disc) kernel.at<uint8_t>(o.y + R, o.x + R) = 1;
  // An unmeasured cell (NaN) must not win the maximum.
  cv::Mat v = shading.clone(), out;
  constexpr float kNone = -std::numeric_limits<float>::infinity();
  cv::patchNaNs(v, kNone);
  cv::dilate(v, out, kernel, cv::Point(-1, -1), 1, cv::BORDER_CONSTANT, cv::Scalar(kNone));
  out.setTo(std::numeric_limits<float>::quiet_NaN(), out == kNone);
  return out;
}

cv::Mat slopeWithShading(const cv::Mat& slope_deg, const cv::Mat& shading_slope_deg, double weight) {
  if (!(weight >= 0.0) || !std::isfinite(weight))
    throw std::invalid_argument("slopeWithShading: the weight must be finite and >= 0");
  if (slope_deg.type() != CV_32FC1 ||
      (!shading_slope_deg.empty() &&
       (shading_slope_deg.type() != CV_32FC1 || shading_slope_deg.size() != slope_deg.size())))
    throw std::invalid_argument("slopeWithShading: slope and shading must be CV_32F layers of one size");
  cv::Mat out = slope_deg.clone();
  if (shading_slope_deg.empty() || weight == 0.0) return out;
  for (int row = 0; row < out.rows; ++row) {
    float* o = out.ptr<float>(row);
    const float* s = shading_slope_deg.ptr<float>(row);
    for (int col = 0; col < out.cols; ++col)
      if (std::isfinite(s[col])) o[col] = static_cast<float>(o[col] + weight * s[col]);
  }
  return out;
}

cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const cv::Mat& shadow_fraction,
                   const cv::Mat& shading_slope_deg, const HazardThresholds& thresholds) {
  return hazardMask(slope_deg, roughness_m, shadow_fraction, shading_slope_deg, shading_slope_deg, thresholds);
}

cv::Mat hazardMask(const cv::Mat& slope_deg, const cv::Mat& roughness_m, const cv::Mat& shadow_fraction,
                   const cv::Mat& shading_slope_deg, const cv::Mat& shading_near_deg,
                   const HazardThresholds& thresholds) {
  if (shading_near_deg.empty() != shading_slope_deg.empty())
    throw std::invalid_argument("hazardMask: the shading near a cell is given without its shading, or back");
  for (const auto& [layer, name] :
       {std::pair<const cv::Mat&, const char*>{shadow_fraction, "shadow fraction"},
        std::pair<const cv::Mat&, const char*>{shading_slope_deg, "shading slope"},
        std::pair<const cv::Mat&, const char*>{shading_near_deg, "shading near"}})
    if (!layer.empty() && (layer.type() != CV_32FC1 || layer.size() != slope_deg.size()))
      throw std::invalid_argument(std::string("hazardMask: the ") + name +
                                  " must be a CV_32F layer of the slope's size");
  cv::Mat mask = hazardMask(slopeWithShading(slope_deg, shading_slope_deg, thresholds.shading_slope_weight),
                            roughness_m, thresholds);
  for (int row = 0; row < mask.rows; ++row) {
    const float* f = shadow_fraction.empty() ? nullptr : shadow_fraction.ptr<float>(row);
    const float* s = shading_near_deg.empty() ? nullptr : shading_near_deg.ptr<float>(row);
    uint8_t* m = mask.ptr<uint8_t>(row);
    for (int col = 0; col < mask.cols; ++col) {
      // Seen in shadow: relief unseen, unknown whatever else says. Else shading relief above the limit
      // within the margin: a hazard.
      if (f && std::isfinite(f[col]) && f[col] > thresholds.max_shadow_fraction)
        m[col] = kUnknown;
      else if (s && m[col] == kSafe && std::isfinite(s[col]) && s[col] > thresholds.max_shading_slope_deg)
        m[col] = kHazard;
    }
  }
  return mask;
}

}  // namespace planetary_vo::terrain
