#pragma once
/// @file map_drift.h
/// Stage 5c: the drift of a metric map built without gravity (vision + altimeter), as the covariance of the
/// navigation it gives (docs/visual_core.md step 20).
///
/// Each frame is posed against the map, so the frame's own covariance (the motion filter's) says how well it
/// sits in the map, not how well the map sits in the world. Two errors of the map pass into the navigation:
/// - its attitude: vision has no gravity, and every keyframe's new points carry a little rotation of the
///   ones before, a random walk of `attitude_drift_rad_per_sqrt_keyframe` per axis per keyframe;
/// - its scale: the altimeter's range factors hold it to a relative 1-sigma (setScaleSigma()), but the
///   window that holds it moves on, so a scale error is correlated over about a window of keyframes
///   (a first-order Gauss-Markov process with a correlation of exp(-1/window) per keyframe).
/// A displacement dp of the published pose is then off by s dp + theta x dp (s the relative scale error,
/// theta the map's attitude error), and the position error is the sum of those over the path: the state
/// [position error, attitude error, scale error] is propagated along the published positions.
///
/// Error convention: estimate = truth + e_p and R_est = Exp(theta) R_true (world frame). The covariance of
/// (-e_p, -theta), the convention of vo_eval (truth minus estimate), is the same matrix.
///
/// The class holds only this covariance; the caller feeds it the events (start at the metric fix,
/// keyframes, the scale's sigma, the published positions).

#include <Eigen/Core>

namespace planetary_vo {

class MapDrift {
 public:
  using Matrix6d = Eigen::Matrix<double, 6, 6>;

  /// @param attitude_drift_rad_per_sqrt_keyframe >= 0. @param scale_window_keyframes >= 1.
  /// Throws std::invalid_argument otherwise.
  MapDrift(double attitude_drift_rad_per_sqrt_keyframe, int scale_window_keyframes);

  /// Not running: no covariance until start().
  void reset();
  /// The map became metric with the pose at `c_world_m` (the path from `c_start_world_m`, where the
  /// trajectory started, was scaled by the fix, so its length carries the scale's error too), after
  /// `keyframes_so_far` keyframes. `start_covariance`: of [position, attitude] of the handed-over start.
  void start(const Eigen::Vector3d& c_start_world_m, const Eigen::Vector3d& c_world_m, int keyframes_so_far,
             double relative_scale_sigma, const Matrix6d& start_covariance);
  bool running() const { return running_; }

  /// The map's scale is now known to this relative 1-sigma (a new fix or the range factors of a window): the
  /// scale error keeps its correlation with the position error.
  void setScaleSigma(double relative_scale_sigma);
  /// A keyframe joined the map: the attitude's random walk steps, the scale error decorrelates by one
  /// keyframe of the window.
  void addKeyframe();
  /// The published camera centre of a metric frame; the displacement from the last one carries the map's
  /// errors into the position error.
  void moveTo(const Eigen::Vector3d& c_world_m);

  /// Covariance of [position (m), attitude (rad)] that the map's drift gives the published pose.
  Matrix6d poseCovariance() const;
  /// What the drift adds to a velocity `v_world_mps` measured against the map: with an isotropic attitude
  /// sigma_theta and the scale's sigma_s, sigma_s^2 v v^T + sigma_theta^2 (|v|^2 I - v v^T).
  Eigen::Matrix3d velocityCovariance(const Eigen::Vector3d& v_world_mps) const;
  /// Cross-covariance of that velocity error with the pose error [position, attitude] (3x6).
  Eigen::Matrix<double, 3, 6> velocityPoseCovariance(const Eigen::Vector3d& v_world_mps) const;
  /// Adds the drift to a navigation covariance [position, attitude, velocity] (9x9): the pose's, and with a
  /// velocity `v_world_mps` (nullptr: none) the velocity's and its cross-covariance with the pose.
  void addTo(Eigen::Matrix<double, 9, 9>* covariance, const Eigen::Vector3d* v_world_mps) const;
  double relativeScaleSigma() const;
  double attitudeSigmaRad() const;

 private:
  using Matrix7d = Eigen::Matrix<double, 7, 7>;
  double attitude_q_rad2_ = 0.0;    ///< variance per axis per keyframe
  double scale_correlation_ = 0.0;  ///< per keyframe
  bool running_ = false;
  Eigen::Vector3d c_last_ = Eigen::Vector3d::Zero();
  Matrix7d P_ = Matrix7d::Zero();  ///< [e_p, theta, s]
};

}  // namespace planetary_vo
