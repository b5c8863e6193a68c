#include "planetary_vo/terrain/hazard.h"

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

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
  for (const auto& [layer, name] :
       {std::pair<const cv::Mat&, const char*>{shadow_fraction, "shadow fraction"},
        std::pair<const cv::Mat&, const char*>{shading_slope_deg, "shading slope"}})
    if (!layer.empty() && (layer.type() != CV_32FC1 || layer.size() != slope_deg.size()))
      throw std::invalid_argument(std::string("hazardMask: the ") + name +
                                  " must be a CV_32F layer of the slope's size");
  cv::Mat mask = hazardMask(slopeWithShading(slope_deg, shading_slope_deg, thresholds.shading_slope_weight),
                            roughness_m, thresholds);
  for (int row = 0; row < mask.rows; ++row) {
    const float* f = shadow_fraction.empty() ? nullptr : shadow_fraction.ptr<float>(row);
    const float* s = shading_slope_deg.empty() ? nullptr : shading_slope_deg.ptr<float>(row);
    uint8_t* m = mask.ptr<uint8_t>(row);
    for (int col = 0; col < mask.cols; ++col) {
      // Seen in shadow: relief unseen, unknown whatever else says. Else shading relief above the limit: a
      // hazard.
      if (f && std::isfinite(f[col]) && f[col] > thresholds.max_shadow_fraction)
        m[col] = kUnknown;
      else if (s && m[col] == kSafe && std::isfinite(s[col]) && s[col] > thresholds.max_shading_slope_deg)
        m[col] = kHazard;
    }
  }
  return mask;
}

}  // namespace planetary_vo::terrain
