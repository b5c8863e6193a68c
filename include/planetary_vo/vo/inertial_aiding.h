#pragma once
/// @file inertial_aiding.h
/// Stage of the camera + IMU mode: the IMU samples given to the pipeline, buffered by stamp on the camera's
/// clock, and what the pipeline asks of them: the preintegrated measurement between two keyframes (the
/// factor of the windowed bundle adjustment) and the propagation of a keyframe's navigation state to a later
/// time (the velocity of every frame, the pose while vision is lost, the baseline of a new map).
///
/// Frames (nav_state.h): body = the IMU; T_cam_imu from the configuration; the world is the gravity-aligned
/// frame of the handed-over initial state (z up), gravity (0, 0, -gravity_mps2). A keyframe's camera pose and
/// its body pose are related by T_world_body = T_world_cam * T_cam_imu.
///
/// Gaps: between two samples more than max_gap_s apart the IMU says nothing (no preintegration, no
/// propagation across it); an interval end up to max_gap_s beyond the newest sample is bridged by holding it.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "planetary_vo/fusion/imu_preintegration.h"
#include "planetary_vo/fusion/measurements.h"
#include "planetary_vo/fusion/nav_state.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/config.h"

namespace planetary_vo {

class InertialAiding {
 public:
  explicit InertialAiding(const ImuAidingConfig& config);

  /// Buffers a sample (stamped on the IMU clock; stored at stamp - time_offset_s). Throws
  /// std::invalid_argument for a non-finite stamp or value, an angular rate above kMaxAngularRateRadps or a
  /// specific force above kMaxSpecificForceMps2 (corrupt: beyond any IMU's range), or a stamp not after the
  /// newest buffered one (the caller reorders by stamp); the buffer is unchanged then. Samples older than
  /// kHistoryS before the newest are dropped (flat memory).
  void add(const ImuSample& sample);
  static constexpr double kMaxAngularRateRadps = 1e3;   ///< |angular rate| of a sample add() accepts
  static constexpr double kMaxSpecificForceMps2 = 1e4;  ///< |specific force| of a sample add() accepts

  /// Why [t0, t1] cannot be integrated ("" when it can): not covered by the buffer, or a gap.
  std::string coverageProblem(double t0_s, double t1_s) const;
  /// The preintegrated IMU over [t0, t1] at the linearisation bias, or nullptr when coverageProblem().
  std::shared_ptr<const ImuPreintegration> preintegrate(double t0_s, double t1_s, const ImuBias& bias) const;
  /// The body state moved on to t_s (>= state.timestamp_s) through the buffered samples, or nullopt when the
  /// span is not covered.
  std::optional<NavState> propagate(const NavState& state, double t_s) const;

  /// Body state of a camera pose with the body velocity and biases.
  NavState bodyState(double t_s, const Pose& T_world_cam, const Eigen::Vector3d& v_world_mps,
                     const ImuBias& bias) const;
  /// Camera pose of a body state.
  Pose cameraPose(const NavState& state) const { return state.T_world_body * T_cam_imu_.inverse(); }

  void clear() { samples_.clear(); }
  size_t size() const { return samples_.size(); }
  const Eigen::Vector3d& gravityWorld() const { return gravity_world_; }
  const Pose& T_cam_imu() const { return T_cam_imu_; }
  const ImuNoiseParams& noise() const { return noise_; }
  const ImuAidingConfig& config() const { return config_; }

  /// Keyframes of the bundle adjustment window lie within this of the newest sample.
  static constexpr double kHistoryS = 120.0;

 private:
  ImuAidingConfig config_;
  ImuNoiseParams noise_;
  Pose T_cam_imu_ = Pose::Identity();
  Eigen::Vector3d gravity_world_;
  std::vector<ImuSample> samples_;  // ascending stamps (camera clock)
  size_t first_ = 0;                // samples before this index are expired (erased in batches)
};

}  // namespace planetary_vo
