#pragma once
/// @file navigation_metrics.h
/// The errors guidance cares about beside ATE and RPE (see docs/evaluation.md for the equations): velocity
/// from position differences, tilt (error of the gravity direction seen in the body frame, which is what a
/// lander's attitude control and the hazard-detection geometry depend on), scale error over a sliding window
/// (the scale drift of a monocular estimate), and NEES (whether a reported covariance matches the actual
/// errors) with its chi-square bounds.

#include <limits>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/eval/trajectory_alignment.h"

namespace planetary_vo {

/// Median of the differences of consecutive stamps (the nominal sample period) [s]; 0 with fewer than 2
/// stamps.
double medianPeriod(const std::vector<double>& stamps_s);

/// Velocity at every stamp by differentiating `positions` (units per second): the derivative at t_k of the
/// parabola through three neighbouring samples. Interior samples use k-1, k, k+1 (on evenly spaced stamps
/// exactly the central difference (p_k+1 - p_k-1) / (t_k+1 - t_k-1)); the ends, and samples beside a gap, use
/// the one-sided three-point parabola (k, k+1, k+2 or k-2, k-1, k); the two-point difference when only one
/// neighbour is connected. Two samples are connected when their stamps differ by at most gap_factor x the
/// median period. A sample with no connected neighbour gets NaN. Stamps strictly increasing.
std::vector<Eigen::Vector3d> differentiatePositions(const std::vector<double>& stamps_s,
                                                    const std::vector<Eigen::Vector3d>& positions,
                                                    double gap_factor);

/// Linear interpolation of stamped vectors at each of `query_stamps_s` (stamps strictly increasing). NaN
/// outside the span of the stamps (1 us tolerance) or between two samples more than gap_factor x the median
/// period apart.
std::vector<Eigen::Vector3d> interpolateVectors(const std::vector<double>& stamps_s,
                                                const std::vector<Eigen::Vector3d>& values,
                                                const std::vector<double>& query_stamps_s, double gap_factor);
/// interpolateVectors() at one stamp.
Eigen::Vector3d interpolateVector(const std::vector<double>& stamps_s,
                                  const std::vector<Eigen::Vector3d>& values, double timestamp_s,
                                  double gap_factor);

/// Tilt error [deg]: angle between the up direction seen in the true body frame and in the estimated one,
/// angle(R_world_body_gt^T up_world, R_world_body_est^T up_world). Zero for any error about the up axis.
double tiltErrorDeg(const Eigen::Matrix3d& R_world_body_gt, const Eigen::Matrix3d& R_world_body_est,
                    const Eigen::Vector3d& up_world);

/// Scale error over a trailing window [%]: for sample k, 100 (L_est / L_gt - 1) with L the path length of the
/// positions from the first sample at or after t_k - window_s to sample k. NaN while the window is not full
/// (t_k - window_s < t_0), or when the ground truth did not move within it (L_gt <= 1e-9 m).
std::vector<double> windowedScaleErrorPercent(const std::vector<double>& stamps_s,
                                              const std::vector<Eigen::Vector3d>& positions_gt,
                                              const std::vector<Eigen::Vector3d>& positions_est,
                                              double window_s);

/// Quantile of the chi-square distribution with `dof` degrees of freedom: x with P(X <= x) = probability
/// (exact, through the regularised incomplete gamma function; relative accuracy ~1e-12). probability in (0,
/// 1).
double chiSquareQuantile(double probability, double dof);

/// Consistency of a reported covariance from the per-pose NEES values of one error (position, attitude or
/// pose).
struct NeesStatistics {
  int dof = 0;                                             ///< degrees of freedom of one NEES value (3 or 6)
  size_t count = 0;                                        ///< poses with a NEES value
  double mean = std::numeric_limits<double>::quiet_NaN();  ///< mean NEES (dof for a consistent estimator)
  double median = std::numeric_limits<double>::quiet_NaN();  ///< median NEES
  double max = std::numeric_limits<double>::quiet_NaN();     ///< largest NEES
  /// Two-sided 95 % bounds of the mean of `count` consistent NEES values: chi-square quantiles 0.025 and
  /// 0.975 with count x dof degrees of freedom, divided by count.
  double mean_lower_95 = std::numeric_limits<double>::quiet_NaN();
  double mean_upper_95 = std::numeric_limits<double>::quiet_NaN();
  /// Two-sided 95 % bounds of one NEES value: chi-square quantiles 0.025 and 0.975 with dof degrees of
  /// freedom.
  double pose_lower_95 = std::numeric_limits<double>::quiet_NaN();
  double pose_upper_95 = std::numeric_limits<double>::quiet_NaN();
  double fraction_inside_95 =
      std::numeric_limits<double>::quiet_NaN();  ///< share of poses within the pose bounds
  /// "consistent" (mean within its bounds), "optimistic" (above: the covariance is too small) or
  /// "pessimistic" (below: too large); empty without values.
  const char* verdict() const;
};
/// Statistics of per-pose NEES values with `dof` degrees of freedom; NaN values (poses without a covariance)
/// are left out.
NeesStatistics computeNeesStatistics(const std::vector<double>& nees, int dof);

/// A 3x3 (position) or 6x6 ([position; orientation]) covariance of the estimate mapped into the ground-truth
/// world by the alignment: J P J^T with J = diag(s R, R) (position scaled and rotated, small-angle
/// orientation rotated).
Eigen::MatrixXd transformCovariance(const Eigen::MatrixXd& covariance, const Sim3Transform& alignment);

/// NEES of one pose against the truth. Errors e_p = p_gt - p_est and delta = Log(R_gt R_est^T) (world frame,
/// so R_gt = Exp(delta) R_est), covariance in the same world (see transformCovariance). position = e_p^T
/// P_pp^-1 e_p; with a 6x6 covariance also attitude = delta^T P_rr^-1 delta and pose = [e_p; delta]^T P^-1
/// [e_p; delta] (NaN otherwise). Throws EvalError if the covariance is not positive definite.
struct PoseNees {
  double position = std::numeric_limits<double>::quiet_NaN();
  double attitude = std::numeric_limits<double>::quiet_NaN();
  double pose = std::numeric_limits<double>::quiet_NaN();
};
PoseNees computePoseNees(const Pose& T_world_cam_gt, const Pose& T_world_cam_est,
                         const Eigen::MatrixXd& covariance_world);

}  // namespace planetary_vo
