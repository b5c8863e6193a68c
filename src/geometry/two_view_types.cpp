#include "planetary_vo/geometry/two_view_types.h"

namespace planetary_vo {

const char* toString(TwoViewModel model) {
  switch (model) {
    case TwoViewModel::kEssential:
      return "E";
    case TwoViewModel::kFundamental:
      return "F";
    case TwoViewModel::kHomography:
      return "H";
  }
  return "?";
}

Pose TwoViewResult::T_c2_c1_unit() const {
  Pose T = Pose::Identity();
  T.linear() = R_c2_c1;
  T.translation() = t_c2_c1_unit;
  return T;
}

std::vector<cv::Point2d> normalizedToVirtualPixels(const std::vector<cv::Point2d>& normalized,
                                                   double focal_px) {
  std::vector<cv::Point2d> px;
  px.reserve(normalized.size());
  for (const auto& p : normalized) px.emplace_back(focal_px * p.x, focal_px * p.y);
  return px;
}

Eigen::Matrix3d virtualK(double focal_px) {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  K(0, 0) = K(1, 1) = focal_px;
  return K;
}

}  // namespace planetary_vo
