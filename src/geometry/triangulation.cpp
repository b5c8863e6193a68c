#include "planetary_vo/geometry/triangulation.h"

#include <cmath>
#include <limits>

#include <Eigen/LU>
#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>

namespace planetary_vo {

Eigen::Vector3d triangulateDlt(const Eigen::Matrix<double, 3, 4>& P1, const Eigen::Matrix<double, 3, 4>& P2,
                               const Eigen::Vector2d& x1, const Eigen::Vector2d& x2) {
  Eigen::Matrix4d A;
  A.row(0) = x1.x() * P1.row(2) - P1.row(0);
  A.row(1) = x1.y() * P1.row(2) - P1.row(1);
  A.row(2) = x2.x() * P2.row(2) - P2.row(0);
  A.row(3) = x2.y() * P2.row(2) - P2.row(1);
  // Equal row weights matter for the SVD: normalise each equation.
  for (int r = 0; r < 4; ++r) {
    const double n = A.row(r).norm();
    if (n > 0.0) A.row(r) /= n;
  }
  const Eigen::Vector4d X = Eigen::JacobiSVD<Eigen::Matrix4d>(A, Eigen::ComputeFullV).matrixV().col(3);
  if (std::abs(X(3)) < 1e-12 * X.head<3>().norm())
    return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  return X.head<3>() / X(3);
}

TriangulationResult triangulatePoints(const std::vector<cv::Point2d>& px1,
                                      const std::vector<cv::Point2d>& px2, const Eigen::Matrix3d& K,
                                      const Pose& T_c2_c1, const TriangulationOptions& options) {
  TriangulationResult out;
  const std::size_t n = std::min(px1.size(), px2.size());
  out.points_c1.resize(n);
  out.reprojection_error_px.resize(n);
  out.parallax_deg.resize(n);
  out.valid.assign(n, 0);
  if (n == 0) return out;

  const Eigen::Matrix3d R = T_c2_c1.linear();
  const Eigen::Vector3d t = T_c2_c1.translation();
  Eigen::Matrix<double, 3, 4> P1, P2;
  P1 << K, Eigen::Vector3d::Zero();
  P2 << K * R, K * t;

  std::vector<cv::Point2d> c1 = px1, c2 = px2;
  if (options.optimal_correction && t.norm() > 0.0) {
    // F of the known motion in pixels; correctMatches moves each pair to the nearest epipolar-consistent pair
    // (Hartley-Sturm, minimal squared image distance), which is the ML estimate under Gaussian noise.
    Eigen::Matrix3d tx;
    tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
    const Eigen::Matrix3d K_inv = K.inverse();
    const Eigen::Matrix3d F = K_inv.transpose() * tx * R * K_inv;
    cv::Matx33d Fcv;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) Fcv(r, c) = F(r, c);
    cv::Mat in1(1, static_cast<int>(n), CV_64FC2, const_cast<cv::Point2d*>(px1.data()));
    cv::Mat in2(1, static_cast<int>(n), CV_64FC2, const_cast<cv::Point2d*>(px2.data()));
    cv::Mat out1(1, static_cast<int>(n), CV_64FC2, c1.data()),
        out2(1, static_cast<int>(n), CV_64FC2, c2.data());
    cv::correctMatches(cv::Mat(Fcv), in1, in2, out1, out2);
  }

  const Eigen::Vector3d centre2_c1 = -R.transpose() * t;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d X = triangulateDlt(P1, P2, {c1[i].x, c1[i].y}, {c2[i].x, c2[i].y});
    out.points_c1[i] = X;
    if (!X.allFinite()) {
      out.reprojection_error_px[i] = std::numeric_limits<double>::infinity();
      out.parallax_deg[i] = 0.0;
      continue;
    }
    const Eigen::Vector3d X2 = R * X + t;
    const Eigen::Vector3d u1 = K * X, u2 = K * X2;
    const double e1 = std::hypot(u1.x() / u1.z() - px1[i].x, u1.y() / u1.z() - px1[i].y);
    const double e2 = std::hypot(u2.x() / u2.z() - px2[i].x, u2.y() / u2.z() - px2[i].y);
    out.reprojection_error_px[i] = std::max(e1, e2);
    const Eigen::Vector3d ray1 = X, ray2 = X - centre2_c1;
    out.parallax_deg[i] = std::atan2(ray1.cross(ray2).norm(), ray1.dot(ray2)) * 180.0 / M_PI;
    const bool ok = X.z() > 0.0 && X2.z() > 0.0 &&
                    out.reprojection_error_px[i] <= options.max_reprojection_error_px &&
                    out.parallax_deg[i] >= options.min_parallax_deg;
    out.valid[i] = ok;
    out.num_valid += ok;
  }
  return out;
}

}  // namespace planetary_vo
