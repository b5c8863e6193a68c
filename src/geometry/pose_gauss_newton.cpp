#include "planetary_vo/geometry/pose_gauss_newton.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

namespace planetary_vo {
namespace {

using Loss = PoseGaussNewtonOptions::Loss;

/// rho(s) of Ceres' loss functions, s = squared pixel error.
double rho(double s, Loss loss, double a) {
  switch (loss) {
    case Loss::kHuber:
      return s <= a * a ? s : 2.0 * a * std::sqrt(s) - a * a;
    case Loss::kCauchy:
      return a * a * std::log1p(s / (a * a));
    case Loss::kNone:
      break;
  }
  return s;
}

/// rho'(s): the weight of a residual in the reweighted normal equations.
double weight(double s, Loss loss, double a) {
  switch (loss) {
    case Loss::kHuber:
      return s <= a * a ? 1.0 : a / std::sqrt(s);
    case Loss::kCauchy:
      return 1.0 / (1.0 + s / (a * a));
    case Loss::kNone:
      break;
  }
  return 1.0;
}

struct Problem {
  const std::vector<Eigen::Vector3d>* p_world;
  const std::vector<Eigen::Vector2d>* px;
  const std::vector<int>& used;  ///< points in front of the camera at the start
  Eigen::Matrix3d K;
  Loss loss;
  double a;

  /// Robust cost at T; infinite when a used point is behind the camera.
  double cost(const Pose& T) const {
    double c = 0.0;
    for (int i : used) {
      const Eigen::Vector3d p = T * (*p_world)[i];
      if (!(p.z() > 0.0)) return std::numeric_limits<double>::infinity();
      const Eigen::Vector3d u = K * p;
      const Eigen::Vector2d e(u.x() / u.z() - (*px)[i].x(), u.y() / u.z() - (*px)[i].y());
      c += rho(e.squaredNorm(), loss, a);
    }
    return 0.5 * c;
  }

  /// Reweighted normal equations at T; translation columns scaled by `depth`.
  void normalEquations(const Pose& T, double depth, Eigen::Matrix<double, 6, 6>* H,
                       Eigen::Matrix<double, 6, 1>* g) const {
    H->setZero();
    g->setZero();
    for (int i : used) {
      const Eigen::Vector3d p = T * (*p_world)[i];
      const double inv_z = 1.0 / p.z();
      const Eigen::Vector3d u = K * p;
      const double ux = u.x() * inv_z, uy = u.y() * inv_z;
      const Eigen::Vector2d e(ux - (*px)[i].x(), uy - (*px)[i].y());
      const double w = weight(e.squaredNorm(), loss, a);
      // d(pixel)/d(p_cam): rows of K minus the pixel times the third row, over depth.
      Eigen::Matrix<double, 2, 3> d_px_d_p;
      d_px_d_p.row(0) = (K.row(0) - ux * K.row(2)) * inv_z;
      d_px_d_p.row(1) = (K.row(1) - uy * K.row(2)) * inv_z;
      // d(p_cam)/d(xi) for p_cam <- exp(xi) p_cam: [-[p]x, depth * I].
      Eigen::Matrix<double, 3, 6> d_p_d_xi;
      d_p_d_xi << 0.0, p.z(), -p.y(), depth, 0.0, 0.0,  //
          -p.z(), 0.0, p.x(), 0.0, depth, 0.0,          //
          p.y(), -p.x(), 0.0, 0.0, 0.0, depth;
      const Eigen::Matrix<double, 2, 6> J = d_px_d_p * d_p_d_xi;
      H->noalias() += w * J.transpose() * J;
      g->noalias() += w * J.transpose() * e;
    }
  }
};

Pose applyStep(const Pose& T, const Eigen::Matrix<double, 6, 1>& xi, double depth) {
  const Eigen::Vector3d w = xi.head<3>();
  const double angle = w.norm();
  const Eigen::Matrix3d dR =
      angle > 0.0 ? Eigen::AngleAxisd(angle, w / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  Pose out;
  out.linear() = dR * T.linear();
  out.translation() = dR * T.translation() + depth * xi.tail<3>();
  return out;
}

}  // namespace

PoseGaussNewtonSummary refinePoseGaussNewton(Pose* T_cam_world, const std::vector<Eigen::Vector3d>& p_world,
                                            const std::vector<Eigen::Vector2d>& px, const Eigen::Matrix3d& K,
                                            const PoseGaussNewtonOptions& options,
                                            PoseGaussNewtonScratch* scratch) {
  if (T_cam_world == nullptr) throw std::invalid_argument("refinePoseGaussNewton: null pose");
  if (p_world.size() != px.size()) {
    throw std::invalid_argument("refinePoseGaussNewton: " + std::to_string(p_world.size()) + " points but " +
                                std::to_string(px.size()) + " pixels");
  }
  PoseGaussNewtonSummary summary;
  PoseGaussNewtonScratch local;
  PoseGaussNewtonScratch& buffers = scratch != nullptr ? *scratch : local;
  std::vector<int>& used = buffers.used;
  std::vector<double>& depths = buffers.depths;
  used.clear();
  depths.clear();
  for (size_t i = 0; i < p_world.size(); ++i) {
    const double z = (*T_cam_world * p_world[i]).z();
    if (!(z > 0.0) || !std::isfinite(z) || !px[i].allFinite()) continue;
    used.push_back(static_cast<int>(i));
    depths.push_back(z);
  }
  summary.num_residuals = static_cast<int>(used.size());
  if (used.size() < 3) return summary;
  const Problem problem{&p_world, &px, used, K, options.loss, options.loss_scale_px};
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  const double depth = depths[depths.size() / 2];

  Pose T = *T_cam_world;
  double cost = problem.cost(T);
  summary.initial_cost = cost;
  double lambda = 1e-4;
  Eigen::Matrix<double, 6, 6> H;
  Eigen::Matrix<double, 6, 1> g;
  bool need_equations = true;
  while (summary.iterations < options.max_iterations) {
    if (cost == 0.0) {
      summary.converged = true;
      break;
    }
    if (need_equations) problem.normalEquations(T, depth, &H, &g);
    ++summary.iterations;
    Eigen::Matrix<double, 6, 6> A = H;
    A.diagonal() += lambda * H.diagonal().cwiseMax(1e-12);
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(A);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) break;
    const Eigen::Matrix<double, 6, 1> xi = ldlt.solve(-g);
    if (!xi.allFinite()) break;
    const Pose candidate = applyStep(T, xi, depth);
    const double new_cost = problem.cost(candidate);
    if (new_cost < cost) {
      const double decrease = (cost - new_cost) / cost;
      T = candidate;
      cost = new_cost;
      lambda = std::max(lambda / 10.0, 1e-12);
      need_equations = true;
      if (decrease < options.function_tolerance || xi.norm() < options.parameter_tolerance) {
        summary.converged = true;
        break;
      }
    } else {
      // A rejected step at the tolerance means the minimum is reached to within it.
      if (xi.norm() < options.parameter_tolerance) {
        summary.converged = true;
        break;
      }
      lambda *= 10.0;
      need_equations = false;
      if (lambda > 1e12) break;
    }
  }
  summary.final_cost = cost;
  if (cost < summary.initial_cost && T.matrix().allFinite()) *T_cam_world = T;
  return summary;
}

}  // namespace planetary_vo
