#include "planetary_vo/geometry/fundamental_ransac.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

namespace planetary_vo {
namespace {

// Hartley normalisation: centroid to the origin, mean distance sqrt(2). Without it the design matrix mixes
// entries of order 1 and 1e6 (pixels squared) and the eight-point solution is dominated by round-off.
Eigen::Matrix3d normalisingTransform(const std::vector<cv::Point2d>& px, const std::vector<int>& indices) {
  double cx = 0.0, cy = 0.0;
  for (int i : indices) {
    cx += px[i].x;
    cy += px[i].y;
  }
  cx /= indices.size();
  cy /= indices.size();
  double mean_dist = 0.0;
  for (int i : indices) mean_dist += std::hypot(px[i].x - cx, px[i].y - cy);
  mean_dist /= indices.size();
  const double s = mean_dist > 0.0 ? std::sqrt(2.0) / mean_dist : 1.0;
  Eigen::Matrix3d T;
  T << s, 0, -s * cx, 0, s, -s * cy, 0, 0, 1;
  return T;
}

}  // namespace

EightPointSolution fundamentalEightPoint(const std::vector<cv::Point2d>& px1,
                                         const std::vector<cv::Point2d>& px2,
                                         const std::vector<int>& indices) {
  EightPointSolution out;
  if (indices.size() < 8) return out;
  const Eigen::Matrix3d T1 = normalisingTransform(px1, indices);
  const Eigen::Matrix3d T2 = normalisingTransform(px2, indices);
  // Normal matrix A^T A of the design matrix: 9x9 whatever the number of points, so no per-call allocation
  // grows with N. Its eigenvalues are the squared singular values of A.
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (int i : indices) {
    const Eigen::Vector3d a = T1 * Eigen::Vector3d(px1[i].x, px1[i].y, 1.0);
    const Eigen::Vector3d b = T2 * Eigen::Vector3d(px2[i].x, px2[i].y, 1.0);
    Eigen::Matrix<double, 9, 1> row;
    row << b.x() * a.x(), b.x() * a.y(), b.x(), b.y() * a.x(), b.y() * a.y(), b.y(), a.x(), a.y(), 1.0;
    AtA.selfadjointView<Eigen::Lower>().rankUpdate(row);
  }
  AtA.triangularView<Eigen::StrictlyUpper>() = AtA.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(AtA);
  if (eig.info() != Eigen::Success) return out;
  const auto& ev = eig.eigenvalues();  // ascending
  out.conditioning = ev(8) > 0.0 ? std::sqrt(std::max(ev(2), 0.0) / ev(8)) : 0.0;
  out.null_space_gap =
      ev(0) > 0.0 ? std::sqrt(std::max(ev(2), 0.0) / ev(0)) : std::numeric_limits<double>::infinity();
  const Eigen::Matrix<double, 9, 1> f = eig.eigenvectors().col(0);
  Eigen::Matrix3d Fn;
  Fn << f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7), f(8);
  // Rank-2 constraint: every epipolar line passes through the epipole.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(Fn, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d s = svd.singularValues();
  s(2) = 0.0;
  Fn = svd.matrixU() * s.asDiagonal() * svd.matrixV().transpose();
  Eigen::Matrix3d F = T2.transpose() * Fn * T1;
  const double norm = F.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) return out;
  out.F = F / norm;
  out.ok = true;
  return out;
}

double sampsonDistanceSq(const Eigen::Matrix3d& F, const cv::Point2d& p1, const cv::Point2d& p2) {
  const Eigen::Vector3d x1(p1.x, p1.y, 1.0), x2(p2.x, p2.y, 1.0);
  const Eigen::Vector3d Fx1 = F * x1;
  const Eigen::Vector3d Ftx2 = F.transpose() * x2;
  const double e = x2.dot(Fx1);
  const double denom = Fx1(0) * Fx1(0) + Fx1(1) * Fx1(1) + Ftx2(0) * Ftx2(0) + Ftx2(1) * Ftx2(1);
  return denom > 0.0 ? e * e / denom : std::numeric_limits<double>::infinity();
}

FundamentalRansacResult fundamentalRansac(const std::vector<cv::Point2d>& px1,
                                          const std::vector<cv::Point2d>& px2, const RansacOptions& options) {
  FundamentalRansacResult out;
  const int n = static_cast<int>(std::min(px1.size(), px2.size()));
  out.inlier_mask.assign(n, 0);
  if (n < 8) return out;
  const double thr_sq = options.threshold_px * options.threshold_px;
  std::mt19937_64 rng(options.seed);
  std::vector<int> sample(8);
  std::vector<std::uint8_t> mask(n);
  int best_count = -1;
  Eigen::Matrix3d best_F = Eigen::Matrix3d::Zero();
  long needed = options.max_iterations;
  int it = 0;
  for (; it < needed && it < options.max_iterations; ++it) {
    // Eight distinct indices (partial Floyd sampling would be faster, but n >> 8 makes rejection cheap).
    for (int k = 0; k < 8; ++k) {
      int idx;
      do {
        idx = static_cast<int>(rng() % static_cast<std::uint64_t>(n));
      } while (std::find(sample.begin(), sample.begin() + k, idx) != sample.begin() + k);
      sample[k] = idx;
    }
    const EightPointSolution sol = fundamentalEightPoint(px1, px2, sample);
    if (!sol.ok) continue;
    int count = 0;
    for (int i = 0; i < n; ++i) count += sampsonDistanceSq(sol.F, px1[i], px2[i]) < thr_sq;
    if (count > best_count) {
      best_count = count;
      best_F = sol.F;
      // Adaptive stopping: iterations for `confidence` of drawing one all-inlier sample at this inlier ratio.
      const double w8 = std::pow(static_cast<double>(count) / n, 8);
      if (w8 >= 1.0) {
        needed = it + 1;
      } else if (w8 > 0.0) {
        needed = static_cast<long>(std::ceil(std::log(1.0 - options.confidence) / std::log(1.0 - w8)));
      }
    }
  }
  out.iterations = it;
  if (best_count < 8) return out;
  // Least-squares refit on the inliers, re-selecting the inliers of the refit each time.
  Eigen::Matrix3d F = best_F;
  std::vector<int> inliers;
  inliers.reserve(n);
  for (int round = 0; round < 2; ++round) {
    inliers.clear();
    for (int i = 0; i < n; ++i)
      if (sampsonDistanceSq(F, px1[i], px2[i]) < thr_sq) inliers.push_back(i);
    if (inliers.size() < 8) break;
    const EightPointSolution sol = fundamentalEightPoint(px1, px2, inliers);
    if (!sol.ok) break;
    out.solution = sol;
    F = sol.F;
  }
  if (!out.solution.ok) return out;
  out.num_inliers = 0;
  for (int i = 0; i < n; ++i) {
    out.inlier_mask[i] = sampsonDistanceSq(F, px1[i], px2[i]) < thr_sq;
    out.num_inliers += out.inlier_mask[i];
  }
  return out;
}

}  // namespace planetary_vo
