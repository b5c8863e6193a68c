#pragma once
/// @file altimeter_model.h
/// Error model of the laser altimeter (a pulsed time-of-flight rangefinder along the camera boresight) of the
/// flight-like benchmark. The instrument outputs only what it measures: a slant range, or +inf when no echo
/// is detected (REP-117 convention of sensor_msgs/Range). Everything derived from ground truth (the exact
/// range, the incidence, the altitude) belongs to the ground-truth files.
///
/// The model (docs/sensors/altimeter.md gives the equations, the default values and their sources):
///  1. Footprint: the beam is Gaussian with full divergence `beam_divergence_rad` (1/e^2). It is sampled by
///     `footprint_rays` rays (centre + rings of 6, 12, 18 ... rays, a fixed pattern) that each carry the beam
///     energy of one cell of equal energy (footprintPattern()). Each ray is cast on the terrain.
///  2. Return: a ray hitting at range r with incidence i returns energy w cos(i) / r^2 (Lambertian target of
///     the nominal albedo). The measured range is the energy-weighted mean range of the returns (the centroid
///     of the return pulse). An echo is detected if the total energy is at least that of a plane
///     perpendicular to the boresight at `max_range_m` (so the reach shrinks as sqrt(cos i) at oblique
///     incidence), the boresight incidence is at most `max_incidence_deg` and the range is at least
///     `min_range_m`.
///  3. Errors: a constant bias per run (drawn once from the seed), Gaussian noise of 1-sigma
///     floor + fraction * range, outliers (a false range, uniform in [min_range_m, max_range_m], with
///     probability `outlier_probability` per sample, whether an echo was detected or not), quantisation.
///
/// Cost: the boresight ray is cast from the instrument to at most max_range_m; the other rays of the
/// footprint start `footprint_search_margin_m` before the boresight hit (RayCaster's start_range_m), so a
/// sample costs one full ray plus (footprint_rays - 1) short ones (AltimeterReading::ray_casts counts them).
///
/// Randomness: the bias is drawn from the seed; each sample's draws come from a hash of (seed, timestamp), so
/// a reading depends only on the seed, its timestamp and its geometry, not on the order of the calls.

#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <vector>

#include <yaml-cpp/yaml.h>
#include <Eigen/Core>

namespace planetary_vo::sensors {

/// Parameters of the laser altimeter. The defaults describe a lander-class pulsed laser rangefinder; each is
/// sourced (or labelled typical) in docs/sensors/altimeter.md.
struct AltimeterParams {
  /// false: the perfect instrument (the "ideal" preset): the exact boresight range, returned wherever the
  /// boresight hits the terrain within max_range_m, whatever the incidence; the other fields are ignored
  /// except max_range_m. true: the error model below.
  bool enabled = false;
  double range_noise_floor_m = 0.3;      ///< 1-sigma range noise at zero range (m)
  double range_noise_fraction = 2.0e-4;  ///< 1-sigma range noise per metre of range (dimensionless)
  double bias_sigma_m = 0.2;             ///< 1-sigma of the constant range bias drawn once per run (m)
  /// Maximum range (m) on a plane perpendicular to the boresight of the nominal lunar albedo; also the range
  /// gate: no ray is searched beyond it, and the exact boresight range is +inf beyond it.
  double max_range_m = 2000.0;
  double min_range_m = 10.0;  ///< blind zone: no echo closer than this (m); lower bound of the outliers
  /// No echo when the angle between the boresight and the surface normal at its hit exceeds this (deg).
  double max_incidence_deg = 60.0;
  double outlier_probability = 1.0e-3;  ///< per sample: the output is a false range, uniform in [min, max]
  double beam_divergence_rad = 0.5e-3;  ///< full angle of the Gaussian beam at 1/e^2 intensity (rad)
  /// Rays sampling the footprint: 1 (boresight only), 7, 19, 37, 61, 91 or 127 (centre + rings of 6k rays).
  int footprint_rays = 7;
  /// The footprint rays other than the boresight start this far (m) before the boresight hit. Safe as long as
  /// the terrain inside the footprint does not rise this much above the boresight hit and fall back again
  /// along one ray; a ray that starts under the terrain is recast from the instrument (see RayCaster).
  double footprint_search_margin_m = 50.0;
  double quantization_m = 0.1;  ///< range resolution of the output (m), 0 = none
};

/// Throws std::invalid_argument naming the first field that is out of range (or not finite).
void validate(const AltimeterParams& params);
/// Overrides the fields whose keys (= field names) are present in the map `node`, then validates. Throws
/// std::invalid_argument naming the key for an unknown key, a non-scalar or unparsable value, or an invalid
/// value. A null node changes nothing.
void readYaml(const YAML::Node& node, AltimeterParams* params);
/// Every field, keyed by its name.
YAML::Node toYaml(const AltimeterParams& params);

/// Hit of a ray on the terrain.
struct RayHit {
  double range_m = 0.0;  ///< distance from the ray origin along the unit ray
  Eigen::Vector3d normal_world = Eigen::Vector3d::UnitZ();  ///< unit surface normal at the hit (outward)
};

/// Casts the ray origin + t * unit_direction for t in [start_range_m, max_range_m] and returns the first
/// crossing of the terrain surface, or nothing if there is none in that interval. The caller guarantees that
/// the ray is above the terrain on [0, start_range_m) as far as it knows; if the point at start_range_m is
/// already under the surface, the caster must return a hit with range_m <= start_range_m (e.g. exactly
/// start_range_m): the model then recasts that ray from 0 (a hit at or before start 0 is taken as a hit at
/// range 0). Example over the render module's terrain:
///
///   auto cast = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& d, double start,
///                   double max) -> std::optional<RayHit> {
///     const Eigen::Vector3d p = o + start * d;
///     if (p.z() <= terrain.height(p.x(), p.y(), lod_m)) return RayHit{start, {0, 0, 1}};  // under it
///     const auto t = castRayOnTerrain(terrain, p, d, lod_m, max - start);
///     if (!t) return std::nullopt;
///     const Eigen::Vector3d h = p + *t * d;
///     return RayHit{start + *t, terrain.normal(h.x(), h.y(), lod_m)};
///   };
using RayCaster = std::function<std::optional<RayHit>(const Eigen::Vector3d& origin_world,
                                                      const Eigen::Vector3d& unit_direction_world,
                                                      double start_range_m, double max_range_m)>;

/// One ray of the footprint pattern: its angular offset from the boresight and its share of the beam energy.
struct FootprintRay {
  double offset_rad = 0.0;   ///< angle between the ray and the boresight
  double azimuth_rad = 0.0;  ///< direction of the offset, from the pattern's reference axis (up) toward
                             ///< boresight x up
  double weight = 1.0;       ///< share of the beam energy (the weights sum to 1)
};

/// The deterministic footprint pattern: ray 0 is the boresight; ring k (k = 1..K) has 6k rays at one offset.
/// The beam's Gaussian angular profile is cut into footprint_rays cells of equal energy (the centre disc and
/// the sectors of annuli); each ray carries its cell's energy, 1/footprint_rays. The ring offsets are the rms
/// offsets of their annuli, scaled so that the pattern's second moment equals the beam's
/// (sum w * offset^2 = 2 sigma^2 with sigma = beam_divergence_rad / 4). Throws std::invalid_argument for an
/// invalid footprint_rays or divergence.
std::vector<FootprintRay> footprintPattern(int footprint_rays, double beam_divergence_rad);

/// One altimeter sample. `range_m` is the instrument output; everything else is ground truth or diagnostics,
/// to be written to the ground-truth files only.
struct AltimeterReading {
  double timestamp_s = 0.0;
  /// What the instrument outputs: the measured slant range along the boresight (m), +inf when no return.
  double range_m = std::numeric_limits<double>::infinity();
  // Ground truth of this sample:
  /// Exact range along the boresight to the terrain (m); +inf if the terrain is not hit within max_range_m.
  double true_range_m = std::numeric_limits<double>::infinity();
  /// Energy-weighted mean range of the footprint before the errors (m); +inf if the boresight misses.
  double footprint_range_m = std::numeric_limits<double>::infinity();
  /// Angle between the boresight and the surface normal at the boresight hit (deg); NaN if no hit.
  double incidence_deg = std::numeric_limits<double>::quiet_NaN();
  /// Return energy over the detection threshold (>= 1: enough energy); NaN if not computed (ideal
  /// instrument, or no boresight hit).
  double energy_ratio = std::numeric_limits<double>::quiet_NaN();
  bool echo_detected = false;  ///< a true echo passed detection (energy, incidence, min range)
  bool outlier = false;        ///< range_m is a false range
  bool returned = false;       ///< range_m is finite (echo_detected || outlier)
  double bias_m = 0.0;         ///< the run's range bias (m)
  int ray_casts = 0;           ///< calls of the ray caster for this sample (cost diagnostics)
};

class AltimeterModel {
 public:
  /// Validates `params` (std::invalid_argument) and draws the run's bias from `seed`.
  AltimeterModel(const AltimeterParams& params, uint64_t seed);

  /// One measurement at `timestamp_s` from `origin_world` along `boresight_world` (normalised here).
  /// `up_world`, any vector not parallel to the boresight, orients the footprint pattern (azimuth 0).
  AltimeterReading measure(double timestamp_s, const Eigen::Vector3d& origin_world,
                           const Eigen::Vector3d& boresight_world, const Eigen::Vector3d& up_world,
                           const RayCaster& cast) const;

  const AltimeterParams& params() const { return params_; }
  double biasM() const { return bias_m_; }  ///< the run's range bias (0 for the ideal instrument)

 private:
  AltimeterParams params_;
  uint64_t seed_;
  double bias_m_ = 0.0;
  std::vector<FootprintRay> pattern_;
  double reference_energy_ = 0.0;  ///< pattern energy * max_range^2 of a perpendicular plane at max range
};

}  // namespace planetary_vo::sensors
