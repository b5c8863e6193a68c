#include "planetary_vo/vo/initializer.h"

#include <algorithm>

#include "planetary_vo/geometry/model_selection.h"
#include "planetary_vo/geometry/triangulation.h"
#include "planetary_vo/geometry/two_view_geometry.h"

namespace planetary_vo {
namespace {

MotionEstimate toMotionEstimate(TwoViewModel model) {
  switch (model) {
    case TwoViewModel::kEssential:
      return MotionEstimate::kEssential;
    case TwoViewModel::kFundamental:
      return MotionEstimate::kFundamental;
    case TwoViewModel::kHomography:
      return MotionEstimate::kHomography;
  }
  return MotionEstimate::kNone;
}

RelativeMotion fromTwoView(const TwoViewResult& r) {
  RelativeMotion m;
  m.valid = r.valid;
  m.reason = r.valid ? std::string() : std::string(toString(r.model)) + ": " + r.reason;
  m.model = toMotionEstimate(r.model);
  m.T_c2_c1_unit = r.T_c2_c1_unit();
  m.inlier_mask = r.inlier_mask;
  m.num_inliers = r.num_inliers;
  m.median_parallax_deg = r.quality.median_parallax_deg;
  m.resolved_by_prior = r.resolved_by_prior;
  return m;
}

}  // namespace

Initializer::Initializer(const MotionConfig& motion, const MapConfig& map,
                         const Eigen::Vector3d& prior_plane_normal_c1)
    : motion_(motion), map_(map), prior_normal_c1_(prior_plane_normal_c1) {}

TwoViewOptions Initializer::twoViewOptions() const {
  TwoViewOptions options;
  options.ransac.confidence = motion_.ransac_confidence;
  options.ransac.threshold_px = motion_.ransac_threshold_px;
  options.ransac.max_iterations = motion_.ransac_max_iterations;
  options.quality.min_inliers = motion_.min_inliers;
  options.quality.min_median_parallax_deg = motion_.min_parallax_deg;
  options.prior_plane_normal_c1 = prior_normal_c1_;
  return options;
}

RelativeMotion Initializer::estimateMotion(const std::vector<cv::Point2d>& px1,
                                           const std::vector<cv::Point2d>& px2,
                                           const Eigen::Matrix3d& K) const {
  if (px1.size() != px2.size() || static_cast<int>(px1.size()) < std::max(8, motion_.min_inliers)) {
    RelativeMotion m;
    m.reason = "too few correspondences (" + std::to_string(px1.size()) + ")";
    return m;
  }
  const TwoViewOptions options = twoViewOptions();
  switch (motion_.model) {
    case MotionModel::kFundamental:
      return fromTwoView(estimateFundamental(px1, px2, K, options));
    case MotionModel::kEssential:
      return fromTwoView(estimateEssential(px1, px2, K, options));
    case MotionModel::kHomography:
      return fromTwoView(estimateHomography(px1, px2, K, options));
    case MotionModel::kAuto:
      break;
  }
  const ModelSelection selection = selectTwoViewModel(px1, px2, K, options, motion_.homography_score_ratio);
  const TwoViewResult& chosen = selection.chosen();
  if (chosen.valid) return fromTwoView(chosen);
  // The score preferred a model that its own checks reject (typically an ambiguous homography, or E on a
  // plane at tiny parallax). The other model is only used if it passes all of its checks.
  const TwoViewResult& other = selection.homography_chosen ? selection.essential : selection.homography;
  if (other.valid) return fromTwoView(other);
  RelativeMotion m = fromTwoView(chosen);
  m.reason += "; " + fromTwoView(other).reason;
  return m;
}

Initialization Initializer::initialize(const std::vector<uint64_t>& track_ids,
                                       const std::vector<cv::Point2d>& px1,
                                       const std::vector<cv::Point2d>& px2, const Eigen::Matrix3d& K) const {
  Initialization init;
  init.motion = estimateMotion(px1, px2, K);
  if (!init.motion.valid) {
    init.reason = init.motion.reason;
    return init;
  }
  std::vector<cv::Point2d> in1, in2;
  std::vector<uint64_t> in_ids;
  for (size_t i = 0; i < px1.size(); ++i) {
    if (i < init.motion.inlier_mask.size() && init.motion.inlier_mask[i] == 0) continue;
    in1.push_back(px1[i]);
    in2.push_back(px2[i]);
    in_ids.push_back(track_ids[i]);
  }
  TriangulationOptions tri_options;
  tri_options.max_reprojection_error_px = map_.max_reprojection_error_px;
  tri_options.min_parallax_deg = map_.min_triangulation_parallax_deg;
  const TriangulationResult tri = triangulatePoints(in1, in2, K, init.motion.T_c2_c1_unit, tri_options);
  std::vector<double> depths;
  for (size_t i = 0; i < in1.size(); ++i) {
    if (!tri.valid[i]) continue;
    init.track_ids.push_back(in_ids[i]);
    init.points_c1.push_back(tri.points_c1[i]);
    init.px1.emplace_back(in1[i].x, in1[i].y);
    init.px2.emplace_back(in2[i].x, in2[i].y);
    depths.push_back(tri.points_c1[i].z());
  }
  if (static_cast<int>(init.points_c1.size()) < motion_.min_inliers) {
    init.reason = "only " + std::to_string(init.points_c1.size()) + " of " + std::to_string(in1.size()) +
                  " inliers triangulated (parallax " + std::to_string(init.motion.median_parallax_deg) +
                  " deg)";
    return init;
  }
  std::nth_element(depths.begin(), depths.begin() + static_cast<std::ptrdiff_t>(depths.size() / 2),
                   depths.end());
  init.median_depth = depths[depths.size() / 2];
  init.valid = true;
  return init;
}

}  // namespace planetary_vo
