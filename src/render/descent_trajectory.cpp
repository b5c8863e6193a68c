#include "planetary_vo/render/descent_trajectory.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include <Eigen/Dense>

#include "noise.h"

namespace planetary_vo::render {

const char* toString(TrajectoryPhase phase) {
  return phase == TrajectoryPhase::kMainBrake ? "main_brake" : "approach";
}

const char* toString(CameraMode mode) {
  switch (mode) {
    case CameraMode::kDownward:
      return "downward";
    case CameraMode::kForward30:
      return "forward_30deg";
    case CameraMode::kPitchDownTo30:
      return "pitch_downward_to_30deg";
    case CameraMode::kNozzle:
      return "nozzle_pointing";
  }
  return "?";
}

const std::vector<SequenceSpec>& lunarSequences() {
  static const std::vector<SequenceSpec> kSequences = {
      {"main_brake_down", TrajectoryPhase::kMainBrake, CameraMode::kDownward},
      {"main_brake_30deg", TrajectoryPhase::kMainBrake, CameraMode::kForward30},
      {"main_brake_pitch", TrajectoryPhase::kMainBrake, CameraMode::kPitchDownTo30},
      {"approach_down", TrajectoryPhase::kApproach, CameraMode::kDownward},
      {"approach_30deg", TrajectoryPhase::kApproach, CameraMode::kForward30},
      {"approach_nozzle", TrajectoryPhase::kApproach, CameraMode::kNozzle},
  };
  return kSequences;
}

const SequenceSpec& findSequence(const std::string& name) {
  std::string names;
  for (const SequenceSpec& s : lunarSequences()) {
    if (s.name == name) return s;
    names += " " + s.name;
  }
  throw std::invalid_argument("unknown sequence '" + name + "'; valid:" + names);
}

Pose TrajectoryState::T_world_cam() const {
  Pose T = Pose::Identity();
  T.linear() = R_world_cam;
  T.translation() = position;
  return T;
}

Eigen::Vector3d TrajectoryState::specificForceCam() const {
  return R_world_cam.transpose() * (acceleration - Eigen::Vector3d(0, 0, -kLunarGravity));
}

namespace {
// Quintic per axis meeting position, velocity and acceleration at both ends: continuous acceleration, and the
// thrust (hence the nozzle attitude) changes smoothly.
Eigen::Matrix<double, 1, 6> quintic(double p0, double v0, double a0, double p1, double v1, double a1,
                                    double T) {
  Eigen::Matrix<double, 1, 6> c;
  c << p0, v0, 0.5 * a0, 0, 0, 0;
  Eigen::Matrix3d A;
  A << std::pow(T, 3), std::pow(T, 4), std::pow(T, 5),    //
      3 * T * T, 4 * std::pow(T, 3), 5 * std::pow(T, 4),  //
      6 * T, 12 * T * T, 20 * std::pow(T, 3);
  const Eigen::Vector3d b(p1 - (p0 + v0 * T + 0.5 * a0 * T * T), v1 - (v0 + a0 * T), a1 - a0);
  const Eigen::Vector3d x = A.colPivHouseholderQr().solve(b);
  c(3) = x(0), c(4) = x(1), c(5) = x(2);
  return c;
}
}  // namespace

DescentTrajectory::DescentTrajectory(TrajectoryPhase phase, CameraMode mode) : phase_(phase), mode_(mode) {
  if (phase == TrajectoryPhase::kMainBrake) {
    if (mode == CameraMode::kNozzle)
      throw std::invalid_argument("Main Brake has no nozzle-pointing sequence");
    // Constant-thrust horizontal brake (thesis Table 4.2: 35049 m x 6507 m in 114 s, 2 m/px at 1024 px, i.e.
    // about 1.4-1.8 km up): constant deceleration along track from 515 m/s to 100 m/s, a constant crossrange
    // acceleration building 6.5 km of crossrange, constant altitude, then a steeper final descent.
    duration_ = 114.0;
    const double downrange = 35049.0, crossrange = 6507.0, v_end = 100.0;
    const double v0 = 2.0 * downrange / duration_ - v_end;
    const double decel = (v0 - v_end) / duration_;
    poly_.c(0, 2) = crossrange / (duration_ * duration_);
    poly_.c(1, 0) =
        -4000.0 - downrange;  // the brake ends 4 km before the landing site, where Approach begins
    poly_.c(1, 1) = v0;
    poly_.c(1, 2) = -0.5 * decel;
    poly_.c(2, 0) = 1400.0;
    descent_start_s_ = 70.0;
    descent_drop_m_ = 750.0;
  } else {
    if (mode == CameraMode::kPitchDownTo30)
      throw std::invalid_argument("Approach has no pitch-manoeuvre sequence");
    // Variable-thrust approach (thesis Table 4.3: 55 s, 0.49 m/px at 1024 px, i.e. starting ~450-650 m up):
    // steep descent from 650 m to the 100 m low gate, 2.3 km of decelerating forward motion, a little
    // crossrange.
    duration_ = 55.0;
    const Eigen::Vector3d p0(-250, -2400, 650), v0(6, 75, -14), a0(0, -1.3, 0.2);
    const Eigen::Vector3d p1(0, -100, 100), v1(0, 4, -4), a1(0, -0.1, 0.1);
    for (int axis = 0; axis < 3; ++axis)
      poly_.c.row(axis) = quintic(p0(axis), v0(axis), a0(axis), p1(axis), v1(axis), a1(axis), duration_);
  }
  Eigen::Vector3d track = position(duration_) - position(0.0);
  track.z() = 0.0;
  forward_ = track.normalized();
}

Eigen::Vector3d DescentTrajectory::position(double t) const {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int k = 5; k >= 0; --k) p = p * t + poly_.c.col(k);
  if (descent_drop_m_ > 0 && t > descent_start_s_) {
    const double u = (t - descent_start_s_) / (duration_ - descent_start_s_);
    p.z() -= descent_drop_m_ * u * u * u;
  }
  return p;
}

Eigen::Vector3d DescentTrajectory::velocity(double t) const {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  for (int k = 5; k >= 1; --k) v = v * t + k * poly_.c.col(k);
  if (descent_drop_m_ > 0 && t > descent_start_s_) {
    const double span = duration_ - descent_start_s_, u = (t - descent_start_s_) / span;
    v.z() -= descent_drop_m_ * 3 * u * u / span;
  }
  return v;
}

Eigen::Vector3d DescentTrajectory::acceleration(double t) const {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  for (int k = 5; k >= 2; --k) a = a * t + k * (k - 1) * poly_.c.col(k);
  if (descent_drop_m_ > 0 && t > descent_start_s_) {
    const double span = duration_ - descent_start_s_, u = (t - descent_start_s_) / span;
    a.z() -= descent_drop_m_ * 6 * u / (span * span);
  }
  return a;
}

double DescentTrajectory::pitchAngle(double t) const {
  constexpr double k30 = 30.0 * M_PI / 180.0;
  switch (mode_) {
    case CameraMode::kDownward:
      return 0.0;
    case CameraMode::kForward30:
      return k30;
    case CameraMode::kPitchDownTo30: {
      // 10 s manoeuvre during the constant-altitude part, smootherstep so the rate and angular acceleration
      // start and end at zero (peak ~5.6 deg/s: fast compared with the translation, as in the thesis).
      const double u = std::clamp((t - 40.0) / 10.0, 0.0, 1.0);
      return k30 * u * u * u * (u * (u * 6 - 15) + 10);
    }
    case CameraMode::kNozzle:
      return 0.0;
  }
  return 0.0;
}

Eigen::Matrix3d DescentTrajectory::rotation(double t) const {
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d right = forward_.cross(up);  // world +x for a +y forward direction
  Eigen::Vector3d z;
  if (mode_ == CameraMode::kNozzle) {
    // Boresight along the exhaust: opposite to the thrust acceleration a - g.
    z = -(acceleration(t) + Eigen::Vector3d(0, 0, kLunarGravity)).normalized();
  } else {
    const double theta = pitchAngle(t);
    z = -std::cos(theta) * up + std::sin(theta) * forward_;
  }
  // Image x stays along the crossrange axis (no roll): the top of the image looks downrange.
  const Eigen::Vector3d x = (right - right.dot(z) * z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x, R.col(1) = y, R.col(2) = z;
  return R;
}

TrajectoryState DescentTrajectory::state(double t) const {
  TrajectoryState s;
  s.t = t;
  s.position = position(t);
  s.velocity = velocity(t);
  s.acceleration = acceleration(t);
  s.R_world_cam = rotation(t);
  // Body rate from the attitude itself (central difference of the rotation), so gyro and poses agree exactly.
  constexpr double h = 1e-4;
  const Eigen::AngleAxisd delta(rotation(t - h).transpose() * rotation(t + h));
  s.angular_velocity_cam = delta.axis() * delta.angle() / (2 * h);
  return s;
}

ImuSample DescentTrajectory::imu(double t) const {
  const TrajectoryState s = state(t);
  ImuSample imu;
  imu.timestamp_s = t;
  imu.angular_velocity_radps = s.angular_velocity_cam;
  imu.specific_force_mps2 = s.specificForceCam();
  return imu;
}

std::string DescentTrajectory::describeYaml(int indent) const {
  const std::string pad(indent, ' ');
  std::ostringstream os;
  os.precision(10);
  const Eigen::Vector3d p0 = position(0), p1 = position(duration_), v0 = velocity(0),
                        v1 = velocity(duration_);
  os << pad << "phase: " << toString(phase_) << "\n"
     << pad << "camera_mode: " << toString(mode_) << "\n"
     << pad << "duration_s: " << duration_ << "\n"
     << pad << "start_position_m: [" << p0.x() << ", " << p0.y() << ", " << p0.z() << "]\n"
     << pad << "end_position_m: [" << p1.x() << ", " << p1.y() << ", " << p1.z() << "]\n"
     << pad << "start_velocity_mps: [" << v0.x() << ", " << v0.y() << ", " << v0.z() << "]\n"
     << pad << "end_velocity_mps: [" << v1.x() << ", " << v1.y() << ", " << v1.z() << "]\n"
     << pad << "gravity_mps2: " << kLunarGravity << "\n";
  return os.str();
}

DemPlacement placeTrajectoryOnDem(const LunarDem& dem, const DescentTrajectory& trajectory, int rank) {
  if (rank < 0) throw std::invalid_argument("placement rank must be >= 0");
  constexpr int kSamples = 40, kHeadings = 12;
  constexpr double kGridStep = 2000.0, kMargin = 5000.0;
  std::vector<Eigen::Vector3d> track;
  for (int i = 0; i < kSamples; ++i)
    track.push_back(trajectory.position(trajectory.duration() * i / (kSamples - 1)));
  // Probe points around each track sample, at the scale of the image footprint.
  const Eigen::Vector2d probes[5] = {{0, 0}, {1, 0}, {-1, 0}, {0, 1}, {0, -1}};

  // Every placement that keeps clear of the terrain, with its score (search order = deterministic tie order).
  std::vector<std::pair<double, DemPlacement>> fits;
  for (int hi = 0; hi < kHeadings; ++hi) {
    const double heading = 2.0 * M_PI * hi / kHeadings;
    for (double e0 = -dem.halfWidthEastM(); e0 <= dem.halfWidthEastM(); e0 += kGridStep) {
      for (double n0 = -dem.halfHeightNorthM(); n0 <= dem.halfHeightNorthM(); n0 += kGridStep) {
        DemPlacement pl;
        pl.origin_east_m = e0, pl.origin_north_m = n0, pl.heading_rad = heading;
        bool inside = true;
        for (const Eigen::Vector3d& p : track) {
          const Eigen::Vector2d en = pl.worldToDem(p.x(), p.y());
          inside = inside && std::abs(en.x()) < dem.halfWidthEastM() - kMargin &&
                   std::abs(en.y()) < dem.halfHeightNorthM() - kMargin;
        }
        if (!inside) continue;
        pl.datum_m = dem.height(e0, n0);
        double score = 0.0;
        bool ok = true;
        for (size_t i = 0; i < track.size() && ok; ++i) {
          const Eigen::Vector3d& p = track[i];
          const double r = 0.6 * p.z();
          double hmin = 1e9, hmax = -1e9;
          for (const Eigen::Vector2d& d : probes) {
            const Eigen::Vector2d en = pl.worldToDem(p.x() + r * d.x(), p.y() + r * d.y());
            const double h = dem.height(en.x(), en.y()) - pl.datum_m;
            hmin = std::min(hmin, h), hmax = std::max(hmax, h);
          }
          // Keep the large-scale slope gentle (< ~8 deg): a low Sun would otherwise saturate or black out
          // frames.
          ok = hmax <= 0.4 * p.z() && hmin >= -0.8 * p.z() && (hmax - hmin) <= 0.3 * r;
          score += (hmax - hmin) / p.z();
        }
        if (ok) fits.push_back({score, pl});
      }
    }
  }
  if (fits.empty())
    throw std::runtime_error("no placement of the trajectory on DEM " + dem.name() +
                             " keeps clear of the terrain");
  // Best first; equal scores keep the search order (so rank 0 is the placement of renderer 1.2).
  std::stable_sort(fits.begin(), fits.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<DemPlacement> chosen;
  for (const auto& [score, pl] : fits) {
    bool distinct = true;
    for (const DemPlacement& c : chosen) {
      const double d = std::hypot(pl.origin_east_m - c.origin_east_m, pl.origin_north_m - c.origin_north_m);
      double dh = std::abs(std::remainder(pl.heading_rad - c.heading_rad, 2.0 * M_PI));
      distinct = distinct && (d >= 6000.0 || dh >= 60.0 * M_PI / 180.0 - 1e-9);
    }
    if (!distinct) continue;
    chosen.push_back(pl);
    if (static_cast<int>(chosen.size()) > rank) return chosen.back();
  }
  throw std::runtime_error("placement rank " + std::to_string(rank) + " asked, but only " +
                           std::to_string(chosen.size()) + " distinct placements on DEM " + dem.name() +
                           " keep clear of the terrain");
}

}  // namespace planetary_vo::render
