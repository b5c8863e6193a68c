#pragma once
/// @file altimeter_range.h
/// Laser-altimeter measurement model of the fusion (issue 10): what range the altimeter should measure given
/// the VO's sparse terrain map and the sensor pose, a Ceres factor comparing it with the measured range, and
/// the metric scale of a monocular map from the measured ranges. docs/fusion/altimeter.md gives the model,
/// the frames and the choices in full.
///
/// Frames and units:
/// - world: the frame of the map (the VO's world); map units are metres once the map is metric, an unknown
///   unit (the monocular scale) before. The body is the frame whose pose is estimated (the camera optical
///   frame for the Lunar sequences: z forward, x right, y down). T_world_body maps body into world.
/// - The altimeter's beam starts at `AltimeterMounting::origin_body_m` (metres, body frame) and points along
///   the unit `boresight_body`; the measured slant range is the distance along that ray to the terrain (m).
///
/// The model: the terrain under the beam is a plane fitted to the map points around the beam's hit point
/// (predictRange()); the predicted range is the ray-plane distance. Its 1-sigma combines the plane's fit
/// covariance and the residual roughness of the terrain about the plane, both propagated along the beam.
///
/// Contract (altimeter_range.cpp):
/// - Bad input is a caller bug and throws std::invalid_argument with a message naming it: a non-finite map
///   point, pose, mounting, sigma or range; a point-sigma vector whose size is neither 0 nor that of the
///   points, or a negative point sigma; a boresight that is not a unit vector (|norm - 1| > 1e-6); a pose
///   whose rotation is not orthonormal; options or noise parameters out of range (validate()).
/// - "No prediction possible" is a normal outcome, not an error: predictRange() returns a RangePrediction
///   whose status says why (too few points, degenerate support, grazing incidence, extrapolation, surface
///   behind the sensor). An empty map is such a case (kTooFewPoints).
/// - Altimeter samples without a return (+inf), or outside [min_range_m, max_range_m], never make a factor
///   or a scale sample (AltimeterNoise::accepts()).
/// - Deterministic: the robust fit's random sampling is seeded from the options, so equal inputs give equal
///   outputs.

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "planetary_vo/fusion/measurements.h"
#include "planetary_vo/geometry/pose.h"

namespace ceres {
class CostFunction;
class LossFunction;
}  // namespace ceres

namespace planetary_vo {

/// Where the altimeter sits on the body. The default is the Lunar datasets' instrument: co-located with the
/// camera and looking along its optical axis (+z).
struct AltimeterMounting {
  Eigen::Vector3d origin_body_m = Eigen::Vector3d::Zero();    ///< beam origin in the body frame (metres)
  Eigen::Vector3d boresight_body = Eigen::Vector3d::UnitZ();  ///< unit beam direction in the body frame
};
/// Throws std::invalid_argument for a non-finite origin or a boresight that is not a unit vector.
void validate(const AltimeterMounting& mounting);

/// The instrument's range noise and range gate as its data sheet (sensors.yaml) gives them. The noise is
/// Gaussian with 1-sigma floor + fraction * range (docs/sensors/altimeter.md); the constant bias of a run is
/// unknown to the user and not modelled here.
struct AltimeterNoise {
  double range_noise_floor_m = 0.3;
  double range_noise_fraction = 2.0e-4;
  double min_range_m = 10.0;    ///< blind zone: shorter readings are not trusted
  double max_range_m = 2000.0;  ///< range gate: longer readings are not trusted

  /// 1-sigma range noise (m) of a reading of `range_m`.
  double sigmaM(double range_m) const { return range_noise_floor_m + range_noise_fraction * range_m; }
  /// A usable reading: a return (finite range) inside [min_range_m, max_range_m]. A non-finite timestamp or a
  /// NaN range throws std::invalid_argument (+inf is the regular "no return").
  bool accepts(const AltimeterSample& sample) const;
};
/// Throws std::invalid_argument for negative or non-finite noise terms or an empty / non-finite range gate.
void validate(const AltimeterNoise& noise);

/// The local surface fitted around the beam's hit point, in world coordinates and map units.
/// The plane is {x : normal . (x - centroid) = 0}. Its uncertainty is the covariance of three small
/// perturbations: the offset along the normal at the centroid (map units) and the slopes along tangent1 and
/// tangent2 (dimensionless): the perturbed plane's height over the point x is offset + slope1 * u + slope2 *
/// v with (u, v) the tangent coordinates of x - centroid.
struct LocalSurfacePlane {
  Eigen::Vector3d centroid_world = Eigen::Vector3d::Zero();  ///< weighted centroid of the inliers
  Eigen::Vector3d normal_world =
      Eigen::Vector3d::UnitZ();  ///< unit, on the side of the sensor that fitted it
  Eigen::Vector3d tangent1_world = Eigen::Vector3d::UnitX();  ///< (tangent1, tangent2, normal) right-handed
  Eigen::Vector3d tangent2_world = Eigen::Vector3d::UnitY();
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  ///< of (offset, slope1, slope2)
  /// RMS deviation (map units, along the normal) of the terrain from the plane beyond the points' own noise:
  /// relief the plane does not model. Estimated so that the inliers' chi-square equals its degrees of
  /// freedom, and 0 unless the point sigmas alone leave a significant excess (chi-square above its mean + 1
  /// sd). With no point sigmas given it includes the point noise too.
  double roughness = 0.0;

  /// 1-sigma (map units) of the plane's position along its normal at the point x (from `covariance` only).
  double heightSigmaAt(const Eigen::Vector3d& x_world) const;
};

/// Distance along the unit ray origin + t * direction to the plane; +inf if the ray runs parallel to the
/// plane or away from it (t would be negative or infinite). Throws std::invalid_argument for a non-unit
/// direction.
double rangeToPlane(const LocalSurfacePlane& plane, const Eigen::Vector3d& origin_world,
                    const Eigen::Vector3d& unit_direction_world);

enum class RangePredictionStatus {
  kValid,
  kTooFewPoints,       ///< not enough map points in the search cone or around the hit (or after the fit)
  kDegenerateSupport,  ///< the points around the hit do not span a plane (collinear)
  kGrazingIncidence,   ///< the beam meets the fitted plane beyond max_incidence_deg
  kExtrapolation,      ///< the support points do not surround the hit (an azimuth gap > max_azimuth_gap_deg)
  kBehindSensor,       ///< the beam points away from the fitted surface (or the surface is behind the origin)
};
const char* toString(RangePredictionStatus status);

/// Tuning of predictRange(). Lengths are relative to the range (the map's unit is unknown before the scale
/// is), angles in degrees.
struct RangePredictionOptions {
  /// Rough hit: the median depth along the beam of the map points within this half-angle of the boresight.
  double search_cone_half_angle_deg = 10.0;
  int min_cone_points = 5;
  /// Support of the local fit: the points within (support_radius_fraction + beam_divergence_rad / 2) * range
  /// of the hit point (a sphere; re-centred on the new hit after each fit, at most max_refinements times).
  /// A sparse map may hold fewer than target_support_points there: the sphere then grows to the distance of
  /// the target_support_points-th nearest point, up to max_support_radius_fraction * range.
  double support_radius_fraction = 0.12;
  int target_support_points = 40;
  double max_support_radius_fraction = 0.3;
  double beam_divergence_rad = 0.5e-3;  ///< full angle; the footprint only widens the support
  int max_refinements = 4;
  int min_support_points = 6;  ///< needed both before and after the outlier rejection
  /// Robust fit: least-median-of-squares over `plane_hypotheses` random 3-point planes, then a weighted
  /// least-squares refit of the points within inlier_threshold_sigmas of the plane (re-selected with the
  /// refitted plane and roughness, a few times).
  int plane_hypotheses = 200;
  double inlier_threshold_sigmas = 3.0;
  uint64_t seed = 1;
  double max_incidence_deg = 75.0;  ///< beyond: kGrazingIncidence (the range sigma grows as 1/cos)
  /// Largest empty sector (azimuth about the normal) of the inliers around the hit; beyond: kExtrapolation.
  double max_azimuth_gap_deg = 160.0;
  /// Converts the mounting's lever arm (metres) into map units: map units = metres / metres_per_map_unit.
  /// Leave 1 for a metric map; irrelevant for the co-located default mounting.
  double metres_per_map_unit = 1.0;
};
void validate(const RangePredictionOptions& options);

/// Result of predictRange(). When the status is not kValid, the fields computed before the failure are still
/// filled (for diagnostics); `reason` says what failed in words.
struct RangePrediction {
  RangePredictionStatus status = RangePredictionStatus::kTooFewPoints;
  std::string reason;
  bool valid() const { return status == RangePredictionStatus::kValid; }

  /// Beam origin -> fitted plane along the beam (map units).
  double range = std::numeric_limits<double>::quiet_NaN();
  /// 1-sigma of `range` (map units): sqrt(sigma_fit^2 + (roughness / cos(incidence))^2).
  double sigma = std::numeric_limits<double>::quiet_NaN();
  double sigma_fit = std::numeric_limits<double>::quiet_NaN();      ///< the plane covariance's part alone
  double incidence_deg = std::numeric_limits<double>::quiet_NaN();  ///< beam vs plane normal
  int cone_points = 0;                                              ///< map points in the search cone
  int support_points = 0;  ///< map points in the support sphere of the last fit
  int inliers = 0;         ///< of those, used by the final fit
  Eigen::Vector3d origin_world = Eigen::Vector3d::Zero();      ///< beam origin (map units)
  Eigen::Vector3d direction_world = Eigen::Vector3d::UnitZ();  ///< unit beam direction
  Eigen::Vector3d hit_world = Eigen::Vector3d::Zero();         ///< origin + range * direction
  LocalSurfacePlane plane;
};

/// Predicts the altimeter's range from the sparse map.
/// `points_world`: map points (world, map units); `point_sigmas`: empty (unknown) or one isotropic 1-sigma
/// position error per point (map units). `T_world_body`: the body pose in the world, in map units.
/// Steps: (1) rough hit = median depth of the points in the search cone around the beam; (2) support = the
/// points within the support radius of the hit; (3) robust plane fit (LMedS + weighted refit, the roughness
/// from the chi-square of the inliers); (4) ray-plane intersection; (2)-(4) repeat around the new hit until
/// it moves by less than 1 % of the support radius; (5) checks: enough inliers, incidence, inliers around the
/// hit. Cost: O(points) per refinement plus O(plane_hypotheses * support points).
RangePrediction predictRange(const std::vector<Eigen::Vector3d>& points_world,
                             const std::vector<double>& point_sigmas, const Pose& T_world_body,
                             const AltimeterMounting& mounting = {},
                             const RangePredictionOptions& options = {});

/// 1-sigma (m) of an altimeter residual: the instrument noise at `measured_range_m` and the prediction's
/// sigma (map units) converted to metres, combined in quadrature.
double altimeterResidualSigmaM(const AltimeterNoise& noise, double measured_range_m,
                               const RangePrediction& prediction, double metres_per_map_unit = 1.0);

/// The beam may meet a plane only up to this incidence: cos > 1e-3 (~89.94 deg).
constexpr double kAltimeterMinCosIncidence = 1e-3;

/// The geometry of every range residual: the distance along the altimeter beam of the body pose
/// (q_world_body, p_world_body) to the plane through `plane_point_world` with unit normal `normal_world` (on
/// the sensor's side). False when the beam does not point toward the plane (incidence beyond
/// kAltimeterMinCosIncidence), so that a Ceres evaluation fails and Levenberg-Marquardt rejects the step.
template <typename T>
bool beamRangeToPlane(const Eigen::Quaternion<T>& q_world_body, const Eigen::Matrix<T, 3, 1>& p_world_body,
                      const Eigen::Vector3d& origin_body_m, const Eigen::Vector3d& boresight_body,
                      const Eigen::Vector3d& normal_world, const Eigen::Matrix<T, 3, 1>& plane_point_world,
                      T* range) {
  const Eigen::Matrix<T, 3, 1> n = normal_world.cast<T>();
  const Eigen::Matrix<T, 3, 1> direction = q_world_body * boresight_body.cast<T>();
  const Eigen::Matrix<T, 3, 1> origin = p_world_body + q_world_body * origin_body_m.cast<T>();
  const T cos_incidence = -n.dot(direction);
  if (!(cos_incidence > T(kAltimeterMinCosIncidence))) return false;
  *range = n.dot(origin - plane_point_world) / cos_incidence;
  return true;
}

/// Altimeter factor of a METRIC map: residual = (range from the body pose along the beam to the fixed
/// plane - measured range) / sigma_m, dimensionless. Parameter blocks: q_world_body (4, Eigen order x, y, z,
/// w, to be used with ceres::EigenQuaternionManifold) and p_world_body (3, metres). The plane, the mounting,
/// the measurement and sigma are constants of the factor.
///
/// Why the plane is fixed: it summarises many map points for a 1-D residual; making it a function of all of
/// them would tie every altimeter factor to dozens of point blocks. Its uncertainty is in sigma instead. This
/// is right only where the map's scale is held by something else: in a window whose scale is free (the
/// vision + altimeter bundle adjustment fixes only its oldest keyframe), a plane frozen in the world makes
/// the scale diverge, and the bundle adjuster instead moves the plane with the mean of a few support points
/// (src/vo/bundle_adjuster.cpp, same geometry: beamRangeToPlane()). Refit it (predictRange())
/// when the map around the hit has moved (after each local bundle adjustment of those points, i.e. at each
/// new keyframe) or when the pose has moved the hit out of the support (|hit - centroid| beyond the support
/// radius); after a change of the map's gauge (e.g. the scale initialisation), transform it with the map.
///
/// Evaluation fails (returns false, so Levenberg-Marquardt rejects the step) when the beam does not point
/// toward the plane's side.
struct AltimeterRangeFactor {
  AltimeterRangeFactor(const LocalSurfacePlane& plane, const AltimeterMounting& mounting,
                       double measured_range_m, double sigma_m);
  /// Throws std::invalid_argument for a non-finite or non-positive range or sigma, or a bad mounting.
  static ceres::CostFunction* create(const LocalSurfacePlane& plane, const AltimeterMounting& mounting,
                                     double measured_range_m, double sigma_m);

  template <typename T>
  bool operator()(const T* q_world_body, const T* p_world_body, T* residual) const {
    T range;
    if (!beamRangeToPlane(Eigen::Quaternion<T>(Eigen::Map<const Eigen::Quaternion<T>>(q_world_body)),
                          Eigen::Matrix<T, 3, 1>(Eigen::Map<const Eigen::Matrix<T, 3, 1>>(p_world_body)),
                          origin_, boresight_, normal_, Eigen::Matrix<T, 3, 1>(centroid_.cast<T>()), &range))
      return false;
    residual[0] = (range - T(measured_range_m_)) / T(sigma_m_);
    return true;
  }

  static constexpr double kMinCosIncidence = kAltimeterMinCosIncidence;
  Eigen::Vector3d centroid_, normal_, origin_, boresight_;
  double measured_range_m_, sigma_m_;
};

/// The same factor on a map of unknown scale, for the vision + altimeter scale initialisation: a third
/// parameter block s = `metres_per_map_unit` (1) converts the map-unit geometry to metres, the lever arm
/// staying in metres (beam origin in map units = p + R * origin_body_m / s):
///   range_m = (s * n.(p - c) + n.(R * origin_body_m)) / cos(incidence),  cos(incidence) = -n.(R *
///   boresight),
/// residual = (range_m - measured) / sigma_m. sigma_m is frozen at construction: compute it with
/// altimeterResidualSigmaM() at the current scale guess (leaving s inside the sigma would reward large
/// scales). The pose and plane are in map units.
struct AltimeterScaledRangeFactor {
  AltimeterScaledRangeFactor(const LocalSurfacePlane& plane, const AltimeterMounting& mounting,
                             double measured_range_m, double sigma_m);
  static ceres::CostFunction* create(const LocalSurfacePlane& plane, const AltimeterMounting& mounting,
                                     double measured_range_m, double sigma_m);

  template <typename T>
  bool operator()(const T* q_world_body, const T* p_world_body, const T* metres_per_map_unit,
                  T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_world_body);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(p_world_body);
    const Eigen::Matrix<T, 3, 1> n = normal_.cast<T>();
    const Eigen::Matrix<T, 3, 1> direction = q * boresight_.cast<T>();
    const T cos_incidence = -n.dot(direction);
    if (!(cos_incidence > T(AltimeterRangeFactor::kMinCosIncidence))) return false;
    const T height_m =
        metres_per_map_unit[0] * n.dot(p - centroid_.cast<T>()) + n.dot(q * origin_m_.cast<T>());
    residual[0] = (height_m / cos_incidence - T(measured_range_m_)) / T(sigma_m_);
    return true;
  }

  Eigen::Vector3d centroid_, normal_, origin_m_, boresight_;
  double measured_range_m_, sigma_m_;
};

/// The robust loss for altimeter factors (the residuals are already divided by sigma): Cauchy with scale
/// `scale_sigmas`. Redescending influence, so a false return (uniform in [min, max] range) pulls on the pose
/// with a force that vanishes with its size, while good samples (< 2 sigma) act almost quadratically.
/// Ownership goes to the caller (or to the ceres::Problem it is given to).
ceres::LossFunction* makeAltimeterLoss(double scale_sigmas = 2.5);

/// One pair (predicted range in map units, measured range in metres) for the scale.
struct AltimeterScaleSample {
  double timestamp_s = 0.0;
  double predicted_range = 0.0;   ///< map units, > 0
  double predicted_sigma = 0.0;   ///< map units, >= 0
  double measured_range_m = 0.0;  ///< > 0
  double measured_sigma_m = 0.0;  ///< >= 0
};

struct ScaleEstimatorOptions {
  int min_samples = 5;                ///< inliers needed before the estimate is ready
  double max_relative_sigma = 0.005;  ///< ready once sigma / scale is at most this
  /// Samples whose normalised residual (after the robust spread) exceeds this are rejected outright.
  double rejection_sigmas = 5.0;
  double huber_sigmas = 1.5;  ///< Huber threshold of the IRLS (normalised residuals)
  int max_iterations = 30;
};
void validate(const ScaleEstimatorOptions& options);

struct ScaleEstimate {
  bool ready = false;  ///< min_samples inliers and relative sigma within max_relative_sigma
  std::string reason;  ///< why not ready (empty when ready)
  double metres_per_map_unit = std::numeric_limits<double>::quiet_NaN();
  double sigma = std::numeric_limits<double>::infinity();  ///< 1-sigma of metres_per_map_unit
  double relative_sigma = std::numeric_limits<double>::infinity();
  int samples = 0;                                                 ///< accumulated
  int inliers = 0;                                                 ///< used by the final fit
  int rejected = 0;                                                ///< beyond rejection_sigmas
  double chi2_per_dof = std::numeric_limits<double>::quiet_NaN();  ///< of the inliers (1 if consistent)
};

/// Metric scale (metres per map unit) of a monocular map from altimeter readings: each sample gives the
/// ratio measured / predicted with a first-order sigma; the estimate is a robust weighted mean of the ratios:
/// weighted median start, outright rejection beyond rejection_sigmas (the normalised residuals being rescaled
/// by their robust spread 1.4826 MAD when that exceeds 1), Huber IRLS on the rest. Its sigma is the weighted
/// mean's, inflated by sqrt(chi2/dof) when the samples scatter more than their sigmas say.
/// Samples of keyframes close together share map points, so their errors correlate: the sigma is then
/// optimistic; the chi-square inflation only partly accounts for it.
class AltimeterScaleEstimator {
 public:
  explicit AltimeterScaleEstimator(const ScaleEstimatorOptions& options = {});

  /// Throws std::invalid_argument for non-finite values, non-positive ranges or negative sigmas.
  void add(const AltimeterScaleSample& sample);
  /// Adds the pair when usable: a valid prediction and an accepted reading (AltimeterNoise::accepts()).
  /// Returns whether it was added; unusable pairs are not an error.
  bool add(const RangePrediction& prediction, const AltimeterSample& reading, const AltimeterNoise& noise);

  ScaleEstimate estimate() const;
  const std::vector<AltimeterScaleSample>& samples() const { return samples_; }
  void clear() { samples_.clear(); }

 private:
  ScaleEstimatorOptions options_;
  std::vector<AltimeterScaleSample> samples_;
};

}  // namespace planetary_vo
