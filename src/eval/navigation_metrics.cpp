/// @file navigation_metrics.cpp
/// Velocity by differentiation, interpolation, tilt, windowed scale error, NEES and chi-square quantiles.

#include "planetary_vo/eval/navigation_metrics.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

namespace planetary_vo {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const Eigen::Vector3d kNaNVector = Eigen::Vector3d::Constant(kNaN);

/// Derivative at t of the parabola through (t0, p0), (t1, p1), (t2, p2) (Lagrange form).
Eigen::Vector3d parabolaDerivative(double t, double t0, double t1, double t2, const Eigen::Vector3d& p0,
                                   const Eigen::Vector3d& p1, const Eigen::Vector3d& p2) {
  return p0 * ((t - t1) + (t - t2)) / ((t0 - t1) * (t0 - t2)) +
         p1 * ((t - t0) + (t - t2)) / ((t1 - t0) * (t1 - t2)) +
         p2 * ((t - t0) + (t - t1)) / ((t2 - t0) * (t2 - t1));
}

/// Regularised lower incomplete gamma function P(a, x) (Numerical Recipes 6.2: series below a + 1, Lentz's
/// continued fraction for Q = 1 - P above).
double regularisedGammaP(double a, double x) {
  if (x <= 0.0) return 0.0;
  const double log_prefix = a * std::log(x) - x - std::lgamma(a);
  if (x < a + 1.0) {
    double ap = a, term = 1.0 / a, sum = term;
    for (int n = 0; n < 1000000; ++n) {
      ap += 1.0;
      term *= x / ap;
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return sum * std::exp(log_prefix);
  }
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return 1.0 - std::exp(log_prefix) * h;
}

}  // namespace

double medianPeriod(const std::vector<double>& stamps_s) {
  if (stamps_s.size() < 2) return 0.0;
  std::vector<double> dt;
  dt.reserve(stamps_s.size() - 1);
  for (size_t k = 1; k < stamps_s.size(); ++k) dt.push_back(stamps_s[k] - stamps_s[k - 1]);
  const size_t mid = dt.size() / 2;
  std::nth_element(dt.begin(), dt.begin() + mid, dt.end());
  if (dt.size() % 2) return dt[mid];
  const double upper = dt[mid];
  return 0.5 * (upper + *std::max_element(dt.begin(), dt.begin() + mid));
}

std::vector<Eigen::Vector3d> differentiatePositions(const std::vector<double>& stamps_s,
                                                    const std::vector<Eigen::Vector3d>& positions,
                                                    double gap_factor) {
  const size_t n = std::min(stamps_s.size(), positions.size());
  std::vector<Eigen::Vector3d> velocity(n, kNaNVector);
  const double max_step_s = gap_factor * medianPeriod(stamps_s);
  // connected(i): samples i and i + 1 are close enough in time to be differentiated together.
  const auto connected = [&](size_t i) {
    const double dt = stamps_s[i + 1] - stamps_s[i];
    return dt > 0.0 && dt <= max_step_s;
  };
  const std::vector<double>& t = stamps_s;
  const std::vector<Eigen::Vector3d>& p = positions;
  for (size_t k = 0; k < n; ++k) {
    const bool left = k > 0 && connected(k - 1);
    const bool right = k + 1 < n && connected(k);
    if (left && right) {
      velocity[k] = parabolaDerivative(t[k], t[k - 1], t[k], t[k + 1], p[k - 1], p[k], p[k + 1]);
    } else if (right) {
      velocity[k] = k + 2 < n && connected(k + 1)
                        ? parabolaDerivative(t[k], t[k], t[k + 1], t[k + 2], p[k], p[k + 1], p[k + 2])
                        : Eigen::Vector3d((p[k + 1] - p[k]) / (t[k + 1] - t[k]));
    } else if (left) {
      velocity[k] = k >= 2 && connected(k - 2)
                        ? parabolaDerivative(t[k], t[k - 2], t[k - 1], t[k], p[k - 2], p[k - 1], p[k])
                        : Eigen::Vector3d((p[k] - p[k - 1]) / (t[k] - t[k - 1]));
    }
  }
  return velocity;
}

namespace {

/// Linear interpolation at one stamp, with the largest interpolated step given.
Eigen::Vector3d interpolateAt(const std::vector<double>& stamps_s, const std::vector<Eigen::Vector3d>& values,
                              size_t n, double timestamp_s, double max_step_s) {
  constexpr double kTolerance_s = 1e-6;
  if (n == 0 || timestamp_s < stamps_s.front() - kTolerance_s || timestamp_s > stamps_s[n - 1] + kTolerance_s)
    return kNaNVector;
  const size_t hi = static_cast<size_t>(
      std::upper_bound(stamps_s.begin(), stamps_s.begin() + n, timestamp_s) - stamps_s.begin());
  if (hi > 0 && timestamp_s - stamps_s[hi - 1] <= kTolerance_s) return values[hi - 1];  // on a sample
  if (hi < n && stamps_s[hi] - timestamp_s <= kTolerance_s) return values[hi];
  if (hi == 0 || hi >= n) return kNaNVector;
  const size_t lo = hi - 1;
  const double span = stamps_s[hi] - stamps_s[lo];
  if (span > max_step_s) return kNaNVector;
  const double alpha = (timestamp_s - stamps_s[lo]) / span;
  return (1.0 - alpha) * values[lo] + alpha * values[hi];
}

}  // namespace

std::vector<Eigen::Vector3d> interpolateVectors(const std::vector<double>& stamps_s,
                                                const std::vector<Eigen::Vector3d>& values,
                                                const std::vector<double>& query_stamps_s,
                                                double gap_factor) {
  const size_t n = std::min(stamps_s.size(), values.size());
  const double max_step_s = gap_factor * medianPeriod(stamps_s);
  std::vector<Eigen::Vector3d> result;
  result.reserve(query_stamps_s.size());
  for (double t : query_stamps_s) result.push_back(interpolateAt(stamps_s, values, n, t, max_step_s));
  return result;
}

Eigen::Vector3d interpolateVector(const std::vector<double>& stamps_s,
                                  const std::vector<Eigen::Vector3d>& values, double timestamp_s,
                                  double gap_factor) {
  return interpolateVectors(stamps_s, values, {timestamp_s}, gap_factor).front();
}

double tiltErrorDeg(const Eigen::Matrix3d& R_world_body_gt, const Eigen::Matrix3d& R_world_body_est,
                    const Eigen::Vector3d& up_world) {
  return angleBetweenDeg(R_world_body_gt.transpose() * up_world, R_world_body_est.transpose() * up_world);
}

std::vector<double> windowedScaleErrorPercent(const std::vector<double>& stamps_s,
                                              const std::vector<Eigen::Vector3d>& positions_gt,
                                              const std::vector<Eigen::Vector3d>& positions_est,
                                              double window_s) {
  constexpr double kTolerance_s = 1e-6;  // stamps on a grid: t_k - window lands on a sample up to rounding
  const size_t n = std::min({stamps_s.size(), positions_gt.size(), positions_est.size()});
  std::vector<double> error(n, kNaN);
  if (n == 0 || !(window_s > 0.0)) return error;
  std::vector<double> length_gt(n, 0.0), length_est(n, 0.0);
  for (size_t k = 1; k < n; ++k) {
    length_gt[k] = length_gt[k - 1] + (positions_gt[k] - positions_gt[k - 1]).norm();
    length_est[k] = length_est[k - 1] + (positions_est[k] - positions_est[k - 1]).norm();
  }
  size_t start = 0;
  for (size_t k = 0; k < n; ++k) {
    const double window_start_s = stamps_s[k] - window_s;
    if (window_start_s < stamps_s.front() - kTolerance_s) continue;  // window not full yet
    while (start < k && stamps_s[start] < window_start_s - kTolerance_s) ++start;
    const double gt_m = length_gt[k] - length_gt[start];
    if (!(gt_m > 1e-9)) continue;
    error[k] = 100.0 * ((length_est[k] - length_est[start]) / gt_m - 1.0);
  }
  return error;
}

double chiSquareQuantile(double probability, double dof) {
  if (!(probability > 0.0 && probability < 1.0) || !(dof > 0.0))
    throw EvalError("chi-square quantile needs 0 < p < 1 and dof > 0");
  const auto cdf = [dof](double x) { return regularisedGammaP(0.5 * dof, 0.5 * x); };
  double lo = 0.0, hi = dof + 10.0 * std::sqrt(2.0 * dof) + 10.0;
  while (cdf(hi) < probability) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-13 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (cdf(mid) < probability ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

const char* NeesStatistics::verdict() const {
  if (count == 0) return "";
  if (mean > mean_upper_95) return "optimistic";
  if (mean < mean_lower_95) return "pessimistic";
  return "consistent";
}

NeesStatistics computeNeesStatistics(const std::vector<double>& nees, int dof) {
  NeesStatistics s;
  s.dof = dof;
  std::vector<double> values;
  for (double v : nees)
    if (std::isfinite(v)) values.push_back(v);
  s.count = values.size();
  s.pose_lower_95 = chiSquareQuantile(0.025, dof);
  s.pose_upper_95 = chiSquareQuantile(0.975, dof);
  if (values.empty()) return s;
  const double n = static_cast<double>(values.size());
  double sum = 0.0;
  size_t inside = 0;
  for (double v : values) {
    sum += v;
    if (v >= s.pose_lower_95 && v <= s.pose_upper_95) ++inside;
  }
  s.mean = sum / n;
  s.fraction_inside_95 = static_cast<double>(inside) / n;
  s.mean_lower_95 = chiSquareQuantile(0.025, n * dof) / n;
  s.mean_upper_95 = chiSquareQuantile(0.975, n * dof) / n;
  std::sort(values.begin(), values.end());
  const size_t mid = values.size() / 2;
  s.median = values.size() % 2 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
  s.max = values.back();
  return s;
}

Eigen::MatrixXd transformCovariance(const Eigen::MatrixXd& covariance, const Sim3Transform& alignment) {
  const Eigen::Index n = covariance.rows();
  if (covariance.cols() != n || (n != 3 && n != 6))
    throw EvalError("a covariance must be 3x3 or 6x6, got " + std::to_string(covariance.rows()) + "x" +
                    std::to_string(covariance.cols()));
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(n, n);
  J.topLeftCorner<3, 3>() = alignment.scale * alignment.R_gt_est;
  if (n == 6) J.bottomRightCorner<3, 3>() = alignment.R_gt_est;
  return J * covariance * J.transpose();
}

PoseNees computePoseNees(const Pose& T_world_cam_gt, const Pose& T_world_cam_est,
                         const Eigen::MatrixXd& covariance_world) {
  const Eigen::Index n = covariance_world.rows();
  if (covariance_world.cols() != n || (n != 3 && n != 6)) throw EvalError("a covariance must be 3x3 or 6x6");
  const auto quadratic = [](const Eigen::MatrixXd& P, const Eigen::VectorXd& e) {
    const Eigen::LLT<Eigen::MatrixXd> llt(P);
    if (llt.info() != Eigen::Success) throw EvalError("a covariance is not positive definite");
    return e.dot(llt.solve(e));
  };
  Eigen::VectorXd e(6);
  e.head<3>() = T_world_cam_gt.translation() - T_world_cam_est.translation();
  const Eigen::AngleAxisd delta(T_world_cam_gt.rotation() * T_world_cam_est.rotation().transpose());
  e.tail<3>() = delta.angle() * delta.axis();
  PoseNees nees;
  nees.position = quadratic(covariance_world.topLeftCorner(3, 3), e.head<3>());
  if (n == 6) {
    nees.attitude = quadratic(covariance_world.bottomRightCorner(3, 3), e.tail<3>());
    nees.pose = quadratic(covariance_world, e);
  }
  return nees;
}

}  // namespace planetary_vo
