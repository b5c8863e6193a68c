#include "planetary_vo/geometry/pnp_solver.h"

#include <cmath>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

namespace planetary_vo {

PnpResult solvePnpRansac(const std::vector<Eigen::Vector3d>& p_world, const std::vector<cv::Point2d>& px,
                         const Eigen::Matrix3d& K, const PnpOptions& options) {
  PnpResult r;
  r.num_points = static_cast<int>(px.size());
  r.inlier_mask.assign(px.size(), 0);
  if (p_world.size() != px.size()) {
    r.reason = "p_world and px differ in size";
    return r;
  }
  if (px.size() < 6) {
    r.reason = "too few correspondences for EPnP in RANSAC: " + std::to_string(px.size());
    return r;
  }
  // The points normalised: relative to their centroid c, divided by their RMS distance s to it. OpenCV's
  // EPnP RANSAC and LM refinement work with single-precision copies and absolute tolerances, so a vision-only
  // map whose scale was bridged across many losses (1e-5 units wide, 170 units from the origin: soak
  // benchmark, issue 12) gave a wrong pose or none. A monocular map has no unit of its own: the pose is
  // solved in the normalised frame and moved back below (R unchanged, t = s t_n - R c).
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : p_world) centroid += p;
  centroid /= static_cast<double>(p_world.size());
  double scale = 0.0;
  for (const auto& p : p_world) scale += (p - centroid).squaredNorm();
  scale = std::sqrt(scale / static_cast<double>(p_world.size()));
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    r.reason = "the map points coincide or are not finite";
    return r;
  }
  std::vector<cv::Point3d> obj;
  obj.reserve(p_world.size());
  for (const auto& p : p_world) {
    const Eigen::Vector3d n = (p - centroid) / scale;
    obj.emplace_back(n.x(), n.y(), n.z());
  }
  cv::Matx33d Kcv;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Kcv(i, j) = K(i, j);

  cv::Mat rvec, tvec;
  std::vector<int> inliers;
  const bool found = cv::solvePnPRansac(
      obj, px, Kcv, cv::noArray(), rvec, tvec, false, options.ransac.max_iterations,
      static_cast<float>(options.ransac.threshold_px), options.ransac.confidence, inliers, cv::SOLVEPNP_EPNP);
  if (!found || inliers.size() < 4) {
    r.reason = "EPnP RANSAC found no pose";
    return r;
  }
  if (options.refine_lm) {
    std::vector<cv::Point3d> obj_in;
    std::vector<cv::Point2d> px_in;
    for (int i : inliers) {
      obj_in.push_back(obj[i]);
      px_in.push_back(px[i]);
    }
    cv::solvePnPRefineLM(obj_in, px_in, Kcv, cv::noArray(), rvec, tvec);
  }

  cv::Matx33d Rcv;
  cv::Rodrigues(rvec, Rcv);
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = Rcv(i, j);
  r.T_cam_world.linear() = R;
  r.T_cam_world.translation() =
      scale * Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)) - R * centroid;

  // Inliers re-selected with the refined pose, so that mask and RMS describe the pose we return.
  const double thr_sq = options.ransac.threshold_px * options.ransac.threshold_px;
  double sum_sq = 0.0;
  r.num_inliers = 0;
  for (std::size_t i = 0; i < px.size(); ++i) {
    const Eigen::Vector3d p_cam = r.T_cam_world * p_world[i];
    if (p_cam.z() <= 0.0) continue;
    const Eigen::Vector3d u = K * p_cam;
    const double dx = u.x() / u.z() - px[i].x, dy = u.y() / u.z() - px[i].y;
    const double e2 = dx * dx + dy * dy;
    if (e2 < thr_sq) {
      r.inlier_mask[i] = 1;
      ++r.num_inliers;
      sum_sq += e2;
    }
  }
  r.reprojection_rms_px = r.num_inliers > 0 ? std::sqrt(sum_sq / r.num_inliers) : 0.0;
  const double ratio = double(r.num_inliers) / r.num_points;
  if (r.num_inliers < options.min_inliers) {
    r.reason = "too few inliers: " + std::to_string(r.num_inliers);
  } else if (ratio < options.min_inlier_ratio) {
    r.reason = "inlier ratio " + std::to_string(ratio) + " < " + std::to_string(options.min_inlier_ratio);
  } else {
    r.valid = true;
  }
  return r;
}

}  // namespace planetary_vo
