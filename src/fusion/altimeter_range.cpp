/// @file altimeter_range.cpp
/// Altimeter range prediction from the sparse map (local robust plane fit), its Ceres factors and the
/// altimeter scale estimator. The model and its choices: docs/fusion/altimeter.md.

#include "planetary_vo/fusion/altimeter_range.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include <ceres/ceres.h>
#include <Eigen/Eigenvalues>

namespace planetary_vo {
namespace {

constexpr double kDegToRad = M_PI / 180.0;
constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kUnitTolerance = 1e-6;

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

bool finite(const Eigen::Vector3d& v) { return v.allFinite(); }

std::string str(double v) {
  std::ostringstream os;
  os.precision(4);
  os << v;
  return os.str();
}

void validatePose(const Pose& T_world_body) {
  require(T_world_body.matrix().allFinite(), "predictRange: T_world_body is not finite");
  const Eigen::Matrix3d R = T_world_body.linear();
  require((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < kUnitTolerance && R.determinant() > 0.0,
          "predictRange: the rotation of T_world_body is not orthonormal");
}

double median(std::vector<double> v) {
  const size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  if (v.size() % 2 == 1) return v[mid];
  const double upper = v[mid];
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + mid));
}

/// Outcome of the robust local plane fit.
struct PlaneFit {
  RangePredictionStatus status = RangePredictionStatus::kValid;
  std::string reason;
  LocalSurfacePlane plane;
  std::vector<size_t> inliers;  ///< indices into the map
};

/// Weighted total-least-squares plane through `inliers` with per-point variances var_i + roughness^2, the
/// normal oriented toward `viewpoint`; fills the plane (not its roughness) and returns false if the points
/// are collinear.
bool weightedPlane(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& point_var,
                   const std::vector<size_t>& inliers, double roughness2, double var_floor,
                   const Eigen::Vector3d& viewpoint, LocalSurfacePlane* plane) {
  double weight_sum = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (size_t i : inliers) {
    const double w = 1.0 / std::max(point_var[i] + roughness2, var_floor);
    weight_sum += w;
    centroid += w * points[i];
  }
  centroid /= weight_sum;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (size_t i : inliers) {
    const double w = 1.0 / std::max(point_var[i] + roughness2, var_floor);
    const Eigen::Vector3d d = points[i] - centroid;
    scatter += w * d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(scatter);
  const Eigen::Vector3d lambda = eig.eigenvalues();    // ascending
  if (!(lambda(1) > 1e-10 * lambda(2))) return false;  // all points on a line (or one point)
  Eigen::Vector3d normal = eig.eigenvectors().col(0).normalized();
  if (normal.dot(viewpoint - centroid) < 0.0) normal = -normal;
  const Eigen::Vector3d tangent1 = eig.eigenvectors().col(2).normalized();
  plane->centroid_world = centroid;
  plane->normal_world = normal;
  plane->tangent1_world = tangent1;
  plane->tangent2_world = normal.cross(tangent1);
  // Covariance of (offset, slope1, slope2): the inverse information of the linearised height regression.
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  for (size_t i : inliers) {
    const double w = 1.0 / std::max(point_var[i] + roughness2, var_floor);
    const Eigen::Vector3d d = points[i] - centroid;
    const Eigen::Vector3d g(1.0, plane->tangent1_world.dot(d), plane->tangent2_world.dot(d));
    information += w * g * g.transpose();
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(information);
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 0.0)) return false;
  plane->covariance = ldlt.solve(Eigen::Matrix3d::Identity());
  return true;
}

/// Roughness^2 (>= 0) such that the inliers' chi-square with variances var_i + roughness^2 equals its degrees
/// of freedom (n - 3); 0 when the point sigmas alone already explain the residuals.
double roughnessSquared(const std::vector<double>& residual2, const std::vector<double>& var) {
  const double dof = static_cast<double>(residual2.size()) - 3.0;
  auto chi2 = [&](double r2) {
    double sum = 0.0;
    for (size_t i = 0; i < residual2.size(); ++i) sum += residual2[i] / std::max(var[i] + r2, 1e-300);
    return sum;
  };
  const double sum_r2 = std::accumulate(residual2.begin(), residual2.end(), 0.0);
  if (dof <= 0.0 || sum_r2 <= 0.0) return 0.0;
  // No roughness unless the point sigmas alone leave a significant excess (chi-square beyond its mean + 1
  // sd): on a true plane the positive part of a noisy estimate would only inflate the sigma.
  if (chi2(0.0) <= dof + std::sqrt(2.0 * dof)) return 0.0;
  double lo = 0.0, hi = sum_r2 / dof;  // chi2(hi) <= sum_r2 / hi = dof
  for (int it = 0; it < 60; ++it) {
    const double mid = 0.5 * (lo + hi);
    (chi2(mid) > dof ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

/// Least median of squares over random 3-point planes, then the weighted refit of the inliers (re-selected
/// with the refitted plane and roughness until the set is stable).
PlaneFit fitPlaneRobust(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& point_var,
                        const std::vector<size_t>& support, const Eigen::Vector3d& viewpoint, double radius,
                        const RangePredictionOptions& options, std::mt19937_64* rng) {
  PlaneFit fit;
  const size_t n = support.size();
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  std::vector<double> residual2(n);
  double best_median2 = std::numeric_limits<double>::infinity();
  Eigen::Vector3d best_normal = Eigen::Vector3d::UnitZ(), best_point = Eigen::Vector3d::Zero();
  for (int h = 0; h < options.plane_hypotheses; ++h) {
    const size_t i = pick(*rng), j = pick(*rng), k = pick(*rng);
    if (i == j || j == k || i == k) continue;
    const Eigen::Vector3d& a = points[support[i]];
    const Eigen::Vector3d ab = points[support[j]] - a, ac = points[support[k]] - a;
    const Eigen::Vector3d cross = ab.cross(ac);
    if (!(cross.norm() > 1e-3 * ab.norm() * ac.norm())) continue;  // nearly collinear sample
    const Eigen::Vector3d normal = cross.normalized();
    for (size_t m = 0; m < n; ++m) residual2[m] = std::pow(normal.dot(points[support[m]] - a), 2);
    const double med = median(residual2);
    if (med < best_median2) {
      best_median2 = med;
      best_normal = normal;
      best_point = a;
    }
  }
  if (!std::isfinite(best_median2)) {
    fit.status = RangePredictionStatus::kDegenerateSupport;
    fit.reason = "the " + std::to_string(n) + " points around the hit are (nearly) collinear";
    return fit;
  }
  // Robust scale of the LMedS residuals (Rousseeuw's small-sample correction).
  const double lmeds_sigma =
      1.4826 * (1.0 + 5.0 / std::max(1.0, static_cast<double>(n) - 3.0)) * std::sqrt(best_median2);
  const double var_floor = std::pow(1e-9 * radius, 2);
  const double threshold2 = options.inlier_threshold_sigmas * options.inlier_threshold_sigmas;
  for (size_t m : support)
    if (std::pow(best_normal.dot(points[m] - best_point), 2) <=
        std::max(threshold2 * lmeds_sigma * lmeds_sigma, var_floor))
      fit.inliers.push_back(m);

  // Start value of the roughness: the LMedS scale beyond the points' own (median) noise.
  std::vector<double> support_var;
  for (size_t m : support) support_var.push_back(point_var[m]);
  double roughness2 = std::max(0.0, lmeds_sigma * lmeds_sigma - median(support_var));
  // The weighted plane of the current inliers; false (with status and reason set) when too few remain or they
  // are collinear.
  auto fitInliers = [&]() {
    if (fit.inliers.size() < static_cast<size_t>(options.min_support_points)) {
      fit.status = RangePredictionStatus::kTooFewPoints;
      fit.reason = "only " + std::to_string(fit.inliers.size()) + " of the " + std::to_string(n) +
                   " points around the hit fit a plane, need " + std::to_string(options.min_support_points);
      return false;
    }
    if (!weightedPlane(points, point_var, fit.inliers, roughness2, var_floor, viewpoint, &fit.plane)) {
      fit.status = RangePredictionStatus::kDegenerateSupport;
      fit.reason = "the inliers around the hit are collinear";
      return false;
    }
    return true;
  };
  for (int iteration = 0; iteration < 10; ++iteration) {
    if (!fitInliers()) return fit;
    std::vector<double> r2, var;
    for (size_t m : fit.inliers) {
      r2.push_back(std::pow(fit.plane.normal_world.dot(points[m] - fit.plane.centroid_world), 2));
      var.push_back(point_var[m]);
    }
    const double new_roughness2 = roughnessSquared(r2, var);
    std::vector<size_t> inliers;
    for (size_t m : support) {
      const double e2 = std::pow(fit.plane.normal_world.dot(points[m] - fit.plane.centroid_world), 2);
      if (e2 <= std::max(threshold2 * (point_var[m] + new_roughness2), var_floor)) inliers.push_back(m);
    }
    const bool stable = inliers == fit.inliers &&
                        std::abs(new_roughness2 - roughness2) <= 1e-3 * std::max(roughness2, var_floor);
    roughness2 = new_roughness2;
    fit.plane.roughness = std::sqrt(roughness2);
    if (stable) break;
    fit.inliers = std::move(inliers);
  }
  // The plane and covariance must describe the final inlier set and roughness.
  if (!fitInliers()) return fit;
  fit.plane.roughness = std::sqrt(roughness2);
  return fit;
}

/// Largest empty sector (deg) of the points' azimuths around `hit` in the plane.
double largestAzimuthGapDeg(const std::vector<Eigen::Vector3d>& points, const std::vector<size_t>& indices,
                            const LocalSurfacePlane& plane, const Eigen::Vector3d& hit, double min_distance) {
  std::vector<double> azimuths;
  for (size_t i : indices) {
    const Eigen::Vector3d d = points[i] - hit;
    const double u = plane.tangent1_world.dot(d), v = plane.tangent2_world.dot(d);
    if (std::hypot(u, v) > min_distance) azimuths.push_back(std::atan2(v, u));
  }
  if (azimuths.size() < 2) return 360.0;
  std::sort(azimuths.begin(), azimuths.end());
  double gap = 2.0 * M_PI - (azimuths.back() - azimuths.front());
  for (size_t i = 1; i < azimuths.size(); ++i) gap = std::max(gap, azimuths[i] - azimuths[i - 1]);
  return gap * kRadToDeg;
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// Parameters
// ---------------------------------------------------------------------------------------------------------

void validate(const AltimeterMounting& mounting) {
  require(finite(mounting.origin_body_m), "AltimeterMounting: origin_body_m is not finite");
  require(finite(mounting.boresight_body) && std::abs(mounting.boresight_body.norm() - 1.0) <= kUnitTolerance,
          "AltimeterMounting: boresight_body must be a finite unit vector");
}

void validate(const AltimeterNoise& noise) {
  require(std::isfinite(noise.range_noise_floor_m) && noise.range_noise_floor_m >= 0.0,
          "AltimeterNoise: range_noise_floor_m must be finite and >= 0");
  require(std::isfinite(noise.range_noise_fraction) && noise.range_noise_fraction >= 0.0,
          "AltimeterNoise: range_noise_fraction must be finite and >= 0");
  require(std::isfinite(noise.min_range_m) && std::isfinite(noise.max_range_m) && noise.min_range_m >= 0.0 &&
              noise.max_range_m > noise.min_range_m,
          "AltimeterNoise: need finite 0 <= min_range_m < max_range_m");
}

bool AltimeterNoise::accepts(const AltimeterSample& sample) const {
  require(std::isfinite(sample.timestamp_s), "AltimeterSample: timestamp is not finite");
  require(!std::isnan(sample.slant_range_m), "AltimeterSample: slant range is NaN (no return is +inf)");
  return sample.hasReturn() && std::isfinite(sample.slant_range_m) && sample.slant_range_m >= min_range_m &&
         sample.slant_range_m <= max_range_m;
}

void validate(const RangePredictionOptions& o) {
  require(std::isfinite(o.search_cone_half_angle_deg) && o.search_cone_half_angle_deg > 0.0 &&
              o.search_cone_half_angle_deg < 90.0,
          "RangePredictionOptions: search_cone_half_angle_deg must be in (0, 90)");
  require(o.min_cone_points >= 1, "RangePredictionOptions: min_cone_points must be >= 1");
  require(std::isfinite(o.support_radius_fraction) && o.support_radius_fraction > 0.0,
          "RangePredictionOptions: support_radius_fraction must be > 0");
  require(std::isfinite(o.beam_divergence_rad) && o.beam_divergence_rad >= 0.0,
          "RangePredictionOptions: beam_divergence_rad must be >= 0");
  require(o.target_support_points >= 1, "RangePredictionOptions: target_support_points must be >= 1");
  require(std::isfinite(o.max_support_radius_fraction) && o.max_support_radius_fraction > 0.0,
          "RangePredictionOptions: max_support_radius_fraction must be > 0");
  require(o.max_refinements >= 0, "RangePredictionOptions: max_refinements must be >= 0");
  require(o.min_support_points >= 4, "RangePredictionOptions: min_support_points must be >= 4");
  require(o.plane_hypotheses >= 1, "RangePredictionOptions: plane_hypotheses must be >= 1");
  require(std::isfinite(o.inlier_threshold_sigmas) && o.inlier_threshold_sigmas > 0.0,
          "RangePredictionOptions: inlier_threshold_sigmas must be > 0");
  require(std::isfinite(o.max_incidence_deg) && o.max_incidence_deg > 0.0 && o.max_incidence_deg < 90.0,
          "RangePredictionOptions: max_incidence_deg must be in (0, 90)");
  require(
      std::isfinite(o.max_azimuth_gap_deg) && o.max_azimuth_gap_deg > 0.0 && o.max_azimuth_gap_deg <= 360.0,
      "RangePredictionOptions: max_azimuth_gap_deg must be in (0, 360]");
  require(std::isfinite(o.metres_per_map_unit) && o.metres_per_map_unit > 0.0,
          "RangePredictionOptions: metres_per_map_unit must be > 0");
}

void validate(const ScaleEstimatorOptions& o) {
  require(o.min_samples >= 1, "ScaleEstimatorOptions: min_samples must be >= 1");
  require(std::isfinite(o.max_relative_sigma) && o.max_relative_sigma > 0.0,
          "ScaleEstimatorOptions: max_relative_sigma must be > 0");
  require(std::isfinite(o.rejection_sigmas) && o.rejection_sigmas > 0.0,
          "ScaleEstimatorOptions: rejection_sigmas must be > 0");
  require(std::isfinite(o.huber_sigmas) && o.huber_sigmas > 0.0,
          "ScaleEstimatorOptions: huber_sigmas must be > 0");
  require(o.max_iterations >= 1, "ScaleEstimatorOptions: max_iterations must be >= 1");
}

const char* toString(RangePredictionStatus status) {
  switch (status) {
    case RangePredictionStatus::kValid:
      return "valid";
    case RangePredictionStatus::kTooFewPoints:
      return "too_few_points";
    case RangePredictionStatus::kDegenerateSupport:
      return "degenerate_support";
    case RangePredictionStatus::kGrazingIncidence:
      return "grazing_incidence";
    case RangePredictionStatus::kExtrapolation:
      return "extrapolation";
    case RangePredictionStatus::kBehindSensor:
      return "behind_sensor";
  }
  return "unknown";
}

// ---------------------------------------------------------------------------------------------------------
// Plane and prediction
// ---------------------------------------------------------------------------------------------------------

double LocalSurfacePlane::heightSigmaAt(const Eigen::Vector3d& x_world) const {
  const Eigen::Vector3d d = x_world - centroid_world;
  const Eigen::Vector3d g(1.0, tangent1_world.dot(d), tangent2_world.dot(d));
  return std::sqrt(std::max(0.0, g.dot(covariance * g)));
}

double rangeToPlane(const LocalSurfacePlane& plane, const Eigen::Vector3d& origin_world,
                    const Eigen::Vector3d& unit_direction_world) {
  require(finite(origin_world) && finite(unit_direction_world), "rangeToPlane: non-finite ray");
  require(std::abs(unit_direction_world.norm() - 1.0) <= kUnitTolerance,
          "rangeToPlane: direction is not unit");
  const double toward = -plane.normal_world.dot(unit_direction_world);
  const double height = plane.normal_world.dot(origin_world - plane.centroid_world);
  // The ray meets the plane at t = height / toward; only t >= 0 with the ray not parallel counts.
  if (toward == 0.0 || height / toward < 0.0) return std::numeric_limits<double>::infinity();
  return height / toward;
}

RangePrediction predictRange(const std::vector<Eigen::Vector3d>& points_world,
                             const std::vector<double>& point_sigmas, const Pose& T_world_body,
                             const AltimeterMounting& mounting, const RangePredictionOptions& options) {
  validate(mounting);
  validate(options);
  validatePose(T_world_body);
  require(point_sigmas.empty() || point_sigmas.size() == points_world.size(),
          "predictRange: point_sigmas must be empty or one per point (" +
              std::to_string(point_sigmas.size()) + " sigmas for " + std::to_string(points_world.size()) +
              " points)");
  std::vector<double> point_var(points_world.size(), 0.0);
  for (size_t i = 0; i < points_world.size(); ++i) {
    require(finite(points_world[i]), "predictRange: map point " + std::to_string(i) + " is not finite");
    if (!point_sigmas.empty()) {
      require(std::isfinite(point_sigmas[i]) && point_sigmas[i] >= 0.0,
              "predictRange: sigma of map point " + std::to_string(i) + " must be finite and >= 0");
      point_var[i] = point_sigmas[i] * point_sigmas[i];
    }
  }

  RangePrediction out;
  const Eigen::Matrix3d R = T_world_body.linear();
  out.origin_world = T_world_body.translation() + R * mounting.origin_body_m / options.metres_per_map_unit;
  out.direction_world = (R * mounting.boresight_body).normalized();
  const Eigen::Vector3d& o = out.origin_world;
  const Eigen::Vector3d& d = out.direction_world;

  // (1) Rough hit: median depth of the points in the cone around the beam.
  const double tan_cone = std::tan(options.search_cone_half_angle_deg * kDegToRad);
  std::vector<double> depths;
  for (const Eigen::Vector3d& p : points_world) {
    const Eigen::Vector3d v = p - o;
    const double along = v.dot(d);
    if (along > 0.0 && (v - along * d).norm() <= along * tan_cone) depths.push_back(along);
  }
  out.cone_points = static_cast<int>(depths.size());
  if (out.cone_points < options.min_cone_points) {
    out.status = RangePredictionStatus::kTooFewPoints;
    out.reason = std::to_string(out.cone_points) + " map points within " +
                 str(options.search_cone_half_angle_deg) + " deg of the boresight, need " +
                 std::to_string(options.min_cone_points);
    return out;
  }
  double range = median(depths);

  // (2)-(4) Support around the hit, robust plane, ray-plane intersection; repeated around the new hit.
  std::mt19937_64 rng(options.seed);
  PlaneFit fit;
  double cos_incidence = 0.0;
  const double radius_per_range = options.support_radius_fraction + 0.5 * options.beam_divergence_rad;
  const double max_radius_per_range =
      std::max(options.max_support_radius_fraction, options.support_radius_fraction) +
      0.5 * options.beam_divergence_rad;
  for (int iteration = 0; iteration <= options.max_refinements; ++iteration) {
    const Eigen::Vector3d hit = o + range * d;
    std::vector<double> distance(points_world.size());
    for (size_t i = 0; i < points_world.size(); ++i) distance[i] = (points_world[i] - hit).norm();
    double radius = radius_per_range * range;
    const size_t target = static_cast<size_t>(options.target_support_points);
    if (distance.size() >= target) {
      std::vector<double> sorted = distance;
      std::nth_element(sorted.begin(), sorted.begin() + (target - 1), sorted.end());
      radius = std::max(radius, std::min(sorted[target - 1], max_radius_per_range * range));
    } else {
      radius = max_radius_per_range * range;
    }
    std::vector<size_t> support;
    for (size_t i = 0; i < points_world.size(); ++i)
      if (distance[i] <= radius) support.push_back(i);
    out.support_points = static_cast<int>(support.size());
    out.hit_world = hit;
    out.range = range;
    if (out.support_points < options.min_support_points) {
      out.status = RangePredictionStatus::kTooFewPoints;
      out.reason = std::to_string(out.support_points) + " map points within " + str(radius) +
                   " of the hit point, need " + std::to_string(options.min_support_points);
      return out;
    }
    fit = fitPlaneRobust(points_world, point_var, support, o, radius, options, &rng);
    out.inliers = static_cast<int>(fit.inliers.size());
    out.plane = fit.plane;
    if (fit.status != RangePredictionStatus::kValid) {
      out.status = fit.status;
      out.reason = fit.reason;
      return out;
    }
    cos_incidence = -fit.plane.normal_world.dot(d);
    out.incidence_deg = std::acos(std::clamp(cos_incidence, -1.0, 1.0)) * kRadToDeg;
    const double height = fit.plane.normal_world.dot(o - fit.plane.centroid_world);
    if (!(cos_incidence > AltimeterRangeFactor::kMinCosIncidence) || !(height > 0.0)) {
      out.status = RangePredictionStatus::kBehindSensor;
      out.reason =
          "the beam points away from the fitted surface (incidence " + str(out.incidence_deg) + " deg)";
      return out;
    }
    const double new_range = height / cos_incidence;
    const double moved = std::abs(new_range - range);
    range = new_range;
    if (moved < 0.01 * radius) break;
  }

  // (5) The prediction and its checks.
  out.range = range;
  out.hit_world = o + range * d;
  const double fit_var = std::pow(fit.plane.heightSigmaAt(out.hit_world), 2);
  out.sigma_fit = std::sqrt(fit_var) / cos_incidence;
  out.sigma = std::sqrt(fit_var + fit.plane.roughness * fit.plane.roughness) / cos_incidence;
  if (out.incidence_deg > options.max_incidence_deg) {
    out.status = RangePredictionStatus::kGrazingIncidence;
    out.reason =
        "incidence " + str(out.incidence_deg) + " deg beyond " + str(options.max_incidence_deg) + " deg";
    return out;
  }
  const double gap_deg = largestAzimuthGapDeg(points_world, fit.inliers, fit.plane, out.hit_world,
                                              1e-9 * radius_per_range * range);
  if (gap_deg > options.max_azimuth_gap_deg) {
    out.status = RangePredictionStatus::kExtrapolation;
    out.reason = "the inliers leave a " + str(gap_deg) + " deg sector around the hit empty (limit " +
                 str(options.max_azimuth_gap_deg) + " deg): the plane is extrapolated";
    return out;
  }
  out.status = RangePredictionStatus::kValid;
  out.reason.clear();
  return out;
}

double altimeterResidualSigmaM(const AltimeterNoise& noise, double measured_range_m,
                               const RangePrediction& prediction, double metres_per_map_unit) {
  validate(noise);
  require(std::isfinite(measured_range_m) && measured_range_m > 0.0,
          "altimeterResidualSigmaM: the measured range must be finite and > 0");
  require(std::isfinite(metres_per_map_unit) && metres_per_map_unit > 0.0,
          "altimeterResidualSigmaM: metres_per_map_unit must be finite and > 0");
  require(std::isfinite(prediction.sigma) && prediction.sigma >= 0.0,
          "altimeterResidualSigmaM: the prediction has no sigma (is it valid?)");
  return std::hypot(noise.sigmaM(measured_range_m), metres_per_map_unit * prediction.sigma);
}

// ---------------------------------------------------------------------------------------------------------
// Factors
// ---------------------------------------------------------------------------------------------------------

namespace {
void validateFactorInput(const LocalSurfacePlane& plane, const AltimeterMounting& mounting,
                         double measured_range_m, double sigma_m) {
  validate(mounting);
  require(finite(plane.centroid_world) && finite(plane.normal_world) &&
              std::abs(plane.normal_world.norm() - 1.0) <= kUnitTolerance,
          "altimeter factor: the plane needs a finite centroid and a unit normal");
  require(std::isfinite(measured_range_m) && measured_range_m > 0.0,
          "altimeter factor: the measured range must be finite and > 0 (no-return samples make no factor)");
  require(std::isfinite(sigma_m) && sigma_m > 0.0, "altimeter factor: sigma must be finite and > 0");
}
}  // namespace

AltimeterRangeFactor::AltimeterRangeFactor(const LocalSurfacePlane& plane, const AltimeterMounting& mounting,
                                           double measured_range_m, double sigma_m)
    : centroid_(plane.centroid_world),
      normal_(plane.normal_world),
      origin_(mounting.origin_body_m),
      boresight_(mounting.boresight_body),
      measured_range_m_(measured_range_m),
      sigma_m_(sigma_m) {
  validateFactorInput(plane, mounting, measured_range_m, sigma_m);
}

ceres::CostFunction* AltimeterRangeFactor::create(const LocalSurfacePlane& plane,
                                                  const AltimeterMounting& mounting, double measured_range_m,
                                                  double sigma_m) {
  return new ceres::AutoDiffCostFunction<AltimeterRangeFactor, 1, 4, 3>(
      new AltimeterRangeFactor(plane, mounting, measured_range_m, sigma_m));
}

AltimeterScaledRangeFactor::AltimeterScaledRangeFactor(const LocalSurfacePlane& plane,
                                                       const AltimeterMounting& mounting,
                                                       double measured_range_m, double sigma_m)
    : centroid_(plane.centroid_world),
      normal_(plane.normal_world),
      origin_m_(mounting.origin_body_m),
      boresight_(mounting.boresight_body),
      measured_range_m_(measured_range_m),
      sigma_m_(sigma_m) {
  validateFactorInput(plane, mounting, measured_range_m, sigma_m);
}

ceres::CostFunction* AltimeterScaledRangeFactor::create(const LocalSurfacePlane& plane,
                                                        const AltimeterMounting& mounting,
                                                        double measured_range_m, double sigma_m) {
  return new ceres::AutoDiffCostFunction<AltimeterScaledRangeFactor, 1, 4, 3, 1>(
      new AltimeterScaledRangeFactor(plane, mounting, measured_range_m, sigma_m));
}

ceres::LossFunction* makeAltimeterLoss(double scale_sigmas) {
  require(std::isfinite(scale_sigmas) && scale_sigmas > 0.0, "makeAltimeterLoss: scale must be > 0");
  return new ceres::CauchyLoss(scale_sigmas);
}

// ---------------------------------------------------------------------------------------------------------
// Scale
// ---------------------------------------------------------------------------------------------------------

AltimeterScaleEstimator::AltimeterScaleEstimator(const ScaleEstimatorOptions& options) : options_(options) {
  validate(options_);
}

void AltimeterScaleEstimator::add(const AltimeterScaleSample& s) {
  require(std::isfinite(s.timestamp_s), "AltimeterScaleEstimator: non-finite timestamp");
  require(std::isfinite(s.predicted_range) && s.predicted_range > 0.0,
          "AltimeterScaleEstimator: the predicted range must be finite and > 0");
  require(std::isfinite(s.measured_range_m) && s.measured_range_m > 0.0,
          "AltimeterScaleEstimator: the measured range must be finite and > 0");
  require(std::isfinite(s.predicted_sigma) && s.predicted_sigma >= 0.0 && std::isfinite(s.measured_sigma_m) &&
              s.measured_sigma_m >= 0.0,
          "AltimeterScaleEstimator: sigmas must be finite and >= 0");
  samples_.push_back(s);
}

bool AltimeterScaleEstimator::add(const RangePrediction& prediction, const AltimeterSample& reading,
                                  const AltimeterNoise& noise) {
  validate(noise);
  if (!noise.accepts(reading) || !prediction.valid()) return false;
  add({reading.timestamp_s, prediction.range, prediction.sigma, reading.slant_range_m,
       noise.sigmaM(reading.slant_range_m)});
  return true;
}

ScaleEstimate AltimeterScaleEstimator::estimate() const {
  ScaleEstimate e;
  const size_t n = samples_.size();
  e.samples = static_cast<int>(n);
  if (n == 0) {
    e.reason = "no samples";
    return e;
  }
  // Model: measured_i = s * predicted_i + noise, var_i(s) = measured_sigma_i^2 + s^2 predicted_sigma_i^2. The
  // residuals live in metres, so a false return's weight does not depend on its own (wrong) value.
  std::vector<double> ratio(n);
  for (size_t i = 0; i < n; ++i) ratio[i] = samples_[i].measured_range_m / samples_[i].predicted_range;
  double scale = median(ratio);  // breakdown point 50 %, no weights that outliers could steer
  std::vector<double> normalised(n), variance(n);
  auto residuals = [&](double s) {
    for (size_t i = 0; i < n; ++i) {
      const AltimeterScaleSample& x = samples_[i];
      variance[i] =
          std::max(x.measured_sigma_m * x.measured_sigma_m + s * s * x.predicted_sigma * x.predicted_sigma,
                   std::pow(1e-12 * x.measured_range_m, 2));
      normalised[i] = (x.measured_range_m - s * x.predicted_range) / std::sqrt(variance[i]);
    }
  };
  // Robust spread of the normalised residuals about the median: > 1 when the sigmas are too optimistic.
  residuals(scale);
  std::vector<double> abs_normalised(n);
  for (size_t i = 0; i < n; ++i) abs_normalised[i] = std::abs(normalised[i]);
  const double spread = std::max(1.0, 1.4826 * median(abs_normalised));

  std::vector<double> huber(n, 1.0);
  auto reweight = [&](double s) {
    residuals(s);
    for (size_t i = 0; i < n; ++i) {
      const double a = std::abs(normalised[i]) / spread;
      huber[i] = a > options_.rejection_sigmas
                     ? 0.0
                     : (a <= options_.huber_sigmas ? 1.0 : options_.huber_sigmas / a);
    }
  };
  for (int it = 0; it < options_.max_iterations; ++it) {
    reweight(scale);
    double num = 0.0, den = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const AltimeterScaleSample& x = samples_[i];
      num += huber[i] * x.predicted_range * x.measured_range_m / variance[i];
      den += huber[i] * x.predicted_range * x.predicted_range / variance[i];
    }
    if (!(den > 0.0)) break;
    const double next = num / den;
    const bool converged = std::abs(next - scale) <= 1e-12 * std::abs(scale);
    scale = next;
    if (converged) break;
  }
  reweight(scale);
  double information = 0.0, chi2 = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (huber[i] == 0.0) {
      ++e.rejected;
      continue;
    }
    ++e.inliers;
    information += huber[i] * std::pow(samples_[i].predicted_range, 2) / variance[i];
    chi2 += normalised[i] * normalised[i];
  }
  e.metres_per_map_unit = scale;
  if (e.inliers > 1) e.chi2_per_dof = chi2 / (e.inliers - 1);
  if (information > 0.0) {
    const double inflation = e.inliers > 1 ? std::max(1.0, std::sqrt(e.chi2_per_dof)) : 1.0;
    e.sigma = inflation / std::sqrt(information);
    e.relative_sigma = e.sigma / scale;
  }
  if (e.inliers < options_.min_samples) {
    e.reason = std::to_string(e.inliers) + " inlier samples, need " + std::to_string(options_.min_samples);
  } else if (!(e.relative_sigma <= options_.max_relative_sigma)) {
    e.reason = "relative sigma " + str(e.relative_sigma) + " above " + str(options_.max_relative_sigma);
  } else {
    e.ready = true;
  }
  return e;
}

}  // namespace planetary_vo
