#pragma once
/// @file descent_trajectory.h
/// The six Lunar descent sequences of the thesis benchmark (section 4.2, Table 4.4) as smooth, physically
/// plausible trajectories: pose, velocity, acceleration, angular rate at any time, so that camera, IMU and
/// altimeter streams are mutually consistent.
///
/// World frame = landing-site frame of thesis 4.2.2: origin at the landing site, z up (altitude), x
/// crossrange, y downrange (the vehicle flies toward +y and its y is negative). Camera = body = REP-103
/// optical frame.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/render/dem.h"

namespace planetary_vo::render {

constexpr double kLunarGravity = 1.62;  ///< m/s^2

enum class TrajectoryPhase { kMainBrake, kApproach };
/// Attitude modes: fixed nadir; fixed 30 deg forward of nadir; pitch manoeuvre nadir -> 30 deg forward
/// (Main Brake); boresight along the thrust axis, i.e. looking through the nozzle direction (Approach).
enum class CameraMode { kDownward, kForward30, kPitchDownTo30, kNozzle };

const char* toString(TrajectoryPhase phase);
const char* toString(CameraMode mode);

struct SequenceSpec {
  std::string name;
  TrajectoryPhase phase;
  CameraMode mode;
};
/// main_brake_down, main_brake_30deg, main_brake_pitch, approach_down, approach_30deg, approach_nozzle.
const std::vector<SequenceSpec>& lunarSequences();
/// Throws std::invalid_argument listing the valid names.
const SequenceSpec& findSequence(const std::string& name);

struct TrajectoryState {
  double t = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      ///< camera centre, world
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      ///< world
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();  ///< world, including gravity's effect
  Eigen::Matrix3d R_world_cam = Eigen::Matrix3d::Identity();
  Eigen::Vector3d angular_velocity_cam = Eigen::Vector3d::Zero();  ///< body rate in the camera frame

  Pose T_world_cam() const;
  /// What an accelerometer measures: non-gravitational acceleration in the camera frame, R^T (a - g).
  Eigen::Vector3d specificForceCam() const;
};

/// A descent trajectory. Translation is polynomial in time (continuous acceleration); attitude is a smooth
/// function of time; angular rate is the exact derivative of the attitude (numerically, to ~1e-9 rad/s).
class DescentTrajectory {
 public:
  DescentTrajectory(TrajectoryPhase phase, CameraMode mode);
  static DescentTrajectory fromSequence(const SequenceSpec& spec) { return {spec.phase, spec.mode}; }

  TrajectoryPhase phase() const { return phase_; }
  CameraMode mode() const { return mode_; }
  double duration() const { return duration_; }

  Eigen::Vector3d position(double t) const;
  Eigen::Vector3d velocity(double t) const;
  Eigen::Vector3d acceleration(double t) const;
  Eigen::Matrix3d rotation(double t) const;  ///< R_world_cam
  TrajectoryState state(double t) const;
  ImuSample imu(double t) const;

  /// Horizontal flight direction used to orient fixed attitudes (unit, world, z = 0).
  const Eigen::Vector3d& forward() const { return forward_; }
  /// Planned altitude above the landing-site datum (world z) at t; the DEM placement keeps the terrain below.
  double plannedAltitude(double t) const { return position(t).z(); }
  /// Key numbers for sequence.yaml (YAML mapping text, indented by `indent` spaces).
  std::string describeYaml(int indent) const;

 private:
  struct Poly {  // p(t) = sum c_k t^k per axis
    Eigen::Matrix<double, 3, 6> c = Eigen::Matrix<double, 3, 6>::Zero();
  };
  double pitchAngle(double t) const;

  TrajectoryPhase phase_;
  CameraMode mode_;
  double duration_ = 0.0;
  Poly poly_;
  // Main Brake final descent: z -= drop * max(0, (t - t1) / (T - t1))^3 (C2 at t1).
  double descent_start_s_ = 0.0, descent_drop_m_ = 0.0;
  Eigen::Vector3d forward_ = Eigen::Vector3d::UnitY();
};

/// Chooses where the landing-site frame sits on the DEM: searches origins and headings so that the
/// trajectory's ground track crosses as much relief as possible while the terrain stays below 40 % of the
/// planned altitude (and not deeper than 80 % of it), everywhere along the track and around it.
/// Deterministic. `rank` 0 is the best placement; rank k > 0 the k-th next best that is distinct from all
/// better ones (origin at least 6 km away, or heading at least 60 deg different): another track over other
/// relief. Throws std::runtime_error if no (or not rank + 1 distinct) placement fits.
DemPlacement placeTrajectoryOnDem(const LunarDem& dem, const DescentTrajectory& trajectory, int rank = 0);

}  // namespace planetary_vo::render
