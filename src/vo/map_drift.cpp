#include "planetary_vo/vo/map_drift.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "planetary_vo/geometry/pose.h"  // skew()

namespace planetary_vo {
namespace {

/// The velocity error's Jacobian on [theta, s]: dv = s v + theta x v.
Eigen::Matrix<double, 3, 4> velocityJacobian(const Eigen::Vector3d& v) {
  Eigen::Matrix<double, 3, 4> J;
  J.leftCols<3>() = -skew(v);
  J.col(3) = v;
  return J;
}

}  // namespace

MapDrift::MapDrift(double attitude_drift_rad_per_sqrt_keyframe, int scale_window_keyframes) {
  if (!(attitude_drift_rad_per_sqrt_keyframe >= 0.0) || !std::isfinite(attitude_drift_rad_per_sqrt_keyframe))
    throw std::invalid_argument("MapDrift: the attitude drift must be finite and >= 0");
  if (scale_window_keyframes < 1) throw std::invalid_argument("MapDrift: the scale window must be >= 1");
  attitude_q_rad2_ = attitude_drift_rad_per_sqrt_keyframe * attitude_drift_rad_per_sqrt_keyframe;
  scale_correlation_ = std::exp(-1.0 / scale_window_keyframes);
}

void MapDrift::reset() {
  running_ = false;
  P_.setZero();
}

void MapDrift::start(const Eigen::Vector3d& c_start_world_m, const Eigen::Vector3d& c_world_m,
                     int keyframes_so_far, double relative_scale_sigma, const Matrix6d& start_covariance) {
  P_.setZero();
  P_.topLeftCorner<6, 6>() = start_covariance;
  P_.block<3, 3>(3, 3).diagonal().array() += attitude_q_rad2_ * std::max(0, keyframes_so_far);
  P_(6, 6) = relative_scale_sigma * relative_scale_sigma;
  running_ = true;
  c_last_ = c_start_world_m;
  moveTo(c_world_m);
}

void MapDrift::setScaleSigma(double relative_scale_sigma) {
  if (!running_ || !(relative_scale_sigma >= 0.0)) return;
  const double old_sigma = std::sqrt(P_(6, 6));
  const double ratio = old_sigma > 0.0 ? relative_scale_sigma / old_sigma : 0.0;
  P_.block<6, 1>(0, 6) *= ratio;
  P_.block<1, 6>(6, 0) *= ratio;
  P_(6, 6) = relative_scale_sigma * relative_scale_sigma;
}

void MapDrift::addKeyframe() {
  if (!running_) return;
  P_.block<3, 3>(3, 3).diagonal().array() += attitude_q_rad2_;
  // s <- a s + w, Var(w) = (1 - a^2) Var(s): the same variance, a correlation of a with the past.
  const double a = scale_correlation_;
  P_.block<6, 1>(0, 6) *= a;
  P_.block<1, 6>(6, 0) *= a;
}

void MapDrift::moveTo(const Eigen::Vector3d& c_world_m) {
  if (!running_) return;
  const Eigen::Vector3d d = c_world_m - c_last_;
  c_last_ = c_world_m;
  Matrix7d F = Matrix7d::Identity();
  F.block<3, 3>(0, 3) = -skew(d);
  F.block<3, 1>(0, 6) = d;
  P_ = F * P_ * F.transpose();
  P_ = 0.5 * (P_ + P_.transpose()).eval();
}

MapDrift::Matrix6d MapDrift::poseCovariance() const { return P_.topLeftCorner<6, 6>(); }

Eigen::Matrix3d MapDrift::velocityCovariance(const Eigen::Vector3d& v_world_mps) const {
  const Eigen::Matrix<double, 3, 4> J = velocityJacobian(v_world_mps);
  return J * P_.bottomRightCorner<4, 4>() * J.transpose();
}

Eigen::Matrix<double, 3, 6> MapDrift::velocityPoseCovariance(const Eigen::Vector3d& v_world_mps) const {
  return velocityJacobian(v_world_mps) * P_.block<4, 6>(3, 0);
}

void MapDrift::addTo(Eigen::Matrix<double, 9, 9>* covariance, const Eigen::Vector3d* v_world_mps) const {
  covariance->topLeftCorner<6, 6>() += poseCovariance();
  if (v_world_mps == nullptr) return;
  covariance->bottomRightCorner<3, 3>() += velocityCovariance(*v_world_mps);
  const Eigen::Matrix<double, 3, 6> cross = velocityPoseCovariance(*v_world_mps);
  covariance->block<3, 6>(6, 0) += cross;
  covariance->block<6, 3>(0, 6) += cross.transpose();
}

double MapDrift::relativeScaleSigma() const { return std::sqrt(P_(6, 6)); }

double MapDrift::attitudeSigmaRad() const { return std::sqrt(P_.block<3, 3>(3, 3).trace() / 3.0); }

}  // namespace planetary_vo
