#include "planetary_vo/geometry/pose_recovery.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>

#include "planetary_vo/geometry/median.h"

namespace planetary_vo {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

bool selected(const std::vector<std::uint8_t>& mask, std::size_t i) { return mask.empty() || mask[i]; }

// In-front count of one motion hypothesis over the selected points; optionally collects parallax angles.
int countInFront(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, const std::vector<Eigen::Vector2d>& xn1,
                 const std::vector<Eigen::Vector2d>& xn2, const std::vector<std::uint8_t>& mask,
                 std::vector<double>* parallax_deg) {
  int count = 0;
  for (std::size_t i = 0; i < xn1.size(); ++i) {
    if (!selected(mask, i)) continue;
    double z1, z2;
    if (!twoRayDepths(R, t, xn1[i], xn2[i], &z1, &z2)) continue;
    if (z1 > 0.0 && z2 > 0.0) {
      ++count;
      if (parallax_deg) parallax_deg->push_back(parallaxAngleDeg(R, xn1[i], xn2[i]));
    }
  }
  return count;
}

}  // namespace

bool twoRayDepths(const Eigen::Matrix3d& R_c2_c1, const Eigen::Vector3d& t_c2_c1, const Eigen::Vector2d& xn1,
                  const Eigen::Vector2d& xn2, double* z1, double* z2) {
  // z1 * (R a) - z2 * b = -t, least squares in (z1, z2): the linear two-ray triangulation, ~10x cheaper than
  // a 4x4 SVD per point, which matters because every E candidate triangulates every inlier.
  const Eigen::Vector3d u = R_c2_c1 * Eigen::Vector3d(xn1.x(), xn1.y(), 1.0);
  const Eigen::Vector3d b(xn2.x(), xn2.y(), 1.0);
  const double uu = u.dot(u), bb = b.dot(b), ub = u.dot(b), ut = u.dot(t_c2_c1), bt = b.dot(t_c2_c1);
  const double det = uu * bb - ub * ub;  // = |u x b|^2
  if (det <= 1e-18 * uu * bb) return false;
  *z1 = (-ut * bb + ub * bt) / det;
  *z2 = (uu * bt - ub * ut) / det;
  return true;
}

double parallaxAngleDeg(const Eigen::Matrix3d& R_c2_c1, const Eigen::Vector2d& xn1,
                        const Eigen::Vector2d& xn2) {
  const Eigen::Vector3d r1(xn1.x(), xn1.y(), 1.0);
  const Eigen::Vector3d r2_in_c1 = R_c2_c1.transpose() * Eigen::Vector3d(xn2.x(), xn2.y(), 1.0);
  return std::atan2(r1.cross(r2_in_c1).norm(), r1.dot(r2_in_c1)) * kRadToDeg;
}

PoseRecovery recoverPoseFromEssential(const Eigen::Matrix3d& E, const std::vector<Eigen::Vector2d>& xn1,
                                      const std::vector<Eigen::Vector2d>& xn2,
                                      const std::vector<std::uint8_t>& mask) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  // E is defined up to sign, so U and V may be flipped to proper rotations without changing the solutions.
  if (U.determinant() < 0) U.col(2) *= -1.0;
  if (V.determinant() < 0) V.col(2) *= -1.0;
  Eigen::Matrix3d W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d Ra = U * W * V.transpose();
  const Eigen::Matrix3d Rb = U * W.transpose() * V.transpose();
  const Eigen::Vector3d t = U.col(2).normalized();
  const std::array<Eigen::Matrix3d, 4> Rs{Ra, Ra, Rb, Rb};
  const std::array<Eigen::Vector3d, 4> ts{t, -t, t, -t};

  std::array<int, 4> counts{};
  for (int k = 0; k < 4; ++k) counts[k] = countInFront(Rs[k], ts[k], xn1, xn2, mask, nullptr);
  std::array<int, 4> order{0, 1, 2, 3};
  std::sort(order.begin(), order.end(), [&](int a, int b) { return counts[a] > counts[b]; });

  PoseRecovery out;
  out.R_c2_c1 = Rs[order[0]];
  out.t_c2_c1_unit = ts[order[0]];
  out.num_in_front = counts[order[0]];
  out.num_in_front_second = counts[order[1]];
  std::vector<double> parallax;
  parallax.reserve(out.num_in_front);
  countInFront(out.R_c2_c1, out.t_c2_c1_unit, xn1, xn2, mask, &parallax);
  out.median_parallax_deg = medianInPlace(&parallax);
  return out;
}

PoseRecovery recoverPoseFromHomography(const Eigen::Matrix3d& H_normalized,
                                       const std::vector<Eigen::Vector2d>& xn1,
                                       const std::vector<Eigen::Vector2d>& xn2,
                                       const std::vector<std::uint8_t>& mask,
                                       const Eigen::Vector3d& prior_normal_c1, double min_margin) {
  PoseRecovery out;
  std::vector<cv::Mat> Rs, ts, ns;
  // OpenCV's analytic decomposition takes square roots of differences that round-off can make slightly
  // negative for an exact pure translation (measured: all-NaN solutions for a noise-free sideways step over a
  // plane). A relative perturbation far below any noise (1e-9) moves it off that knife edge.
  for (double eps : {0.0, 1e-9, 1e-7}) {
    cv::Matx33d Hcv;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) Hcv(r, c) = H_normalized(r, c) + (r == c ? eps * (r + 1) : 0.0);
    cv::decomposeHomographyMat(Hcv, cv::Matx33d::eye(), Rs, ts, ns);
    bool finite = !Rs.empty();
    for (std::size_t k = 0; k < Rs.size(); ++k)
      finite = finite && cv::checkRange(Rs[k]) && cv::checkRange(ts[k]) && cv::checkRange(ns[k]);
    if (finite) break;
    Rs.clear();
  }

  const bool has_prior = prior_normal_c1.squaredNorm() > 0.0;
  std::vector<HomographyCandidate> candidates;
  for (std::size_t k = 0; k < Rs.size(); ++k) {
    HomographyCandidate c;
    for (int r = 0; r < 3; ++r) {
      for (int col = 0; col < 3; ++col) c.R_c2_c1(r, col) = Rs[k].at<double>(r, col);
      c.normal_c1(r) = ns[k].at<double>(r);
    }
    const Eigen::Vector3d t_over_d(ts[k].at<double>(0), ts[k].at<double>(1), ts[k].at<double>(2));
    c.normal_c1.normalize();
    // With the plane n . p = d (d = 1 after OpenCV's normalisation), a point on ray 1 is p_c1 = a / (n . a):
    // n . a > 0 is the plane being in front of camera 1 and facing it; then the depth in camera 2 must be >
    // 0.
    for (std::size_t i = 0; i < xn1.size(); ++i) {
      if (!selected(mask, i)) continue;
      const Eigen::Vector3d a(xn1[i].x(), xn1[i].y(), 1.0);
      const double na = c.normal_c1.dot(a);
      if (na <= 0.0) continue;
      const Eigen::Vector3d p_c2 = c.R_c2_c1 * (a / na) + t_over_d;
      if (p_c2.z() > 0.0) ++c.num_in_front;
    }
    if (c.num_in_front == 0) continue;
    c.translation_over_distance = t_over_d.norm();
    c.t_c2_c1_unit = c.translation_over_distance > 1e-12
                         ? Eigen::Vector3d(t_over_d / c.translation_over_distance)
                         : Eigen::Vector3d::Zero();
    if (has_prior) c.prior_normal_angle_deg = angleBetweenDeg(c.normal_c1, prior_normal_c1);
    candidates.push_back(c);
  }
  if (candidates.empty()) return out;
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const HomographyCandidate& a, const HomographyCandidate& b) {
                     return a.num_in_front > b.num_in_front;
                   });
  if (candidates.size() >= 2 && has_prior) {
    const double margin = static_cast<double>(candidates[0].num_in_front - candidates[1].num_in_front) /
                          candidates[0].num_in_front;
    // The points cannot separate the two: let the expected plane orientation decide (ORB-SLAM's failure mode
    // on planar descents was to wait forever for the points to decide).
    if (margin < min_margin && candidates[1].prior_normal_angle_deg < candidates[0].prior_normal_angle_deg) {
      std::swap(candidates[0], candidates[1]);
      out.resolved_by_prior = true;
    } else if (margin < min_margin) {
      out.resolved_by_prior = true;
    }
  }
  out.R_c2_c1 = candidates[0].R_c2_c1;
  out.t_c2_c1_unit = candidates[0].t_c2_c1_unit;
  out.num_in_front = candidates[0].num_in_front;
  out.num_in_front_second = candidates.size() >= 2 ? candidates[1].num_in_front : 0;
  std::vector<double> parallax;
  for (std::size_t i = 0; i < xn1.size(); ++i)
    if (selected(mask, i)) parallax.push_back(parallaxAngleDeg(out.R_c2_c1, xn1[i], xn2[i]));
  out.median_parallax_deg = medianInPlace(&parallax);
  out.homography_candidates = std::move(candidates);
  return out;
}

}  // namespace planetary_vo
