// Laser altimeter error model against its specification (include/planetary_vo/sensors/altimeter_model.h,
// docs/sensors/altimeter.md), with synthetic ray casters: planes, a step, a sphere. No renderer.
//
// Statistical checks use 4-sigma bounds (a correct model fails one of them with probability < 1e-4 each);
// the seeds are fixed, so the outcome is deterministic.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>
#include <Eigen/Geometry>

#include "planetary_vo/sensors/altimeter_model.h"

namespace planetary_vo::sensors {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
const Eigen::Vector3d kNadir(0, 0, -1);
const Eigen::Vector3d kUp(0, 1, 0);

// ---------------------------------------------------------------------------------------------------------------
// Synthetic ray casters honouring the RayCaster contract (start_range_m; a hit at start when the start point
// is under the surface).

/// Half-space below the plane n . x = n . point (n: unit outward normal).
RayCaster planeCaster(const Eigen::Vector3d& normal, const Eigen::Vector3d& point) {
  const Eigen::Vector3d n = normal.normalized();
  const double offset = n.dot(point);
  return [n, offset](const Eigen::Vector3d& o, const Eigen::Vector3d& u, double start,
                     double max_range) -> std::optional<RayHit> {
    const double s = n.dot(o + start * u) - offset;  // height above the plane at the start
    if (s <= 0.0) return RayHit{start, n};
    const double closing = -n.dot(u);
    if (closing <= 0.0) return std::nullopt;
    const double t = start + s / closing;
    if (t > max_range) return std::nullopt;
    return RayHit{t, n};
  };
}

/// Heightfield z = 0 for x < edge_x, z = height for x >= edge_x (a raised block with a vertical wall).
RayCaster stepCaster(double edge_x, double height) {
  return [edge_x, height](const Eigen::Vector3d& o, const Eigen::Vector3d& u, double start,
                          double max_range) -> std::optional<RayHit> {
    auto ground = [&](double x) { return x >= edge_x ? height : 0.0; };
    const Eigen::Vector3d p = o + start * u;
    if (p.z() <= ground(p.x())) return RayHit{start, Eigen::Vector3d::UnitZ()};
    double best = kInf;
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
    if (u.z() < 0.0) {
      for (double level : {0.0, height}) {
        const double t = (level - o.z()) / u.z();
        const double x = o.x() + t * u.x();
        if (t >= start && ground(x) == level && t < best) best = t, normal = Eigen::Vector3d::UnitZ();
      }
    }
    if (u.x() != 0.0) {  // the wall x = edge_x, 0 <= z <= height, seen from the low side
      const double t = (edge_x - o.x()) / u.x();
      const double z = o.z() + t * u.z();
      if (u.x() > 0.0 && t >= start && z >= 0.0 && z <= height && t < best)
        best = t, normal = -Eigen::Vector3d::UnitX();
    }
    if (best > max_range) return std::nullopt;
    return RayHit{best, normal};
  };
}

/// Outside of a sphere.
RayCaster sphereCaster(const Eigen::Vector3d& centre, double radius) {
  return [centre, radius](const Eigen::Vector3d& o, const Eigen::Vector3d& u, double start,
                          double max_range) -> std::optional<RayHit> {
    const Eigen::Vector3d p = o + start * u;
    if ((p - centre).norm() <= radius) return RayHit{start, (p - centre).normalized()};
    const Eigen::Vector3d oc = p - centre;
    const double b = oc.dot(u), c = oc.squaredNorm() - radius * radius;
    const double disc = b * b - c;
    if (disc < 0.0) return std::nullopt;
    const double t = -b - std::sqrt(disc);
    if (t < 0.0 || start + t > max_range) return std::nullopt;
    return RayHit{start + t, (p + t * u - centre).normalized()};
  };
}

RayCaster nothingCaster() {
  return [](const Eigen::Vector3d&, const Eigen::Vector3d&, double, double) -> std::optional<RayHit> {
    return std::nullopt;
  };
}

/// A noiseless, bias-free, outlier-free enabled instrument (each test switches on what it checks).
AltimeterParams cleanParams() {
  AltimeterParams p;
  p.enabled = true;
  p.range_noise_floor_m = 0.0;
  p.range_noise_fraction = 0.0;
  p.bias_sigma_m = 0.0;
  p.outlier_probability = 0.0;
  p.quantization_m = 0.0;
  return p;
}

struct Stats {
  double mean = 0.0, std = 0.0;
  size_t n = 0;
};
Stats stats(const std::vector<double>& v) {
  Stats s;
  s.n = v.size();
  for (double x : v) s.mean += x;
  s.mean /= v.size();
  for (double x : v) s.std += (x - s.mean) * (x - s.mean);
  s.std = std::sqrt(s.std / (v.size() - 1));
  return s;
}

/// Direction of a footprint ray as documented: azimuth 0 along up's part orthogonal to the boresight, 90 deg
/// along boresight x up.
Eigen::Vector3d rayDirection(const FootprintRay& ray, const Eigen::Vector3d& boresight,
                             const Eigen::Vector3d& up) {
  const Eigen::Vector3d b = boresight.normalized();
  const Eigen::Vector3d e1 = (up - up.dot(b) * b).normalized();
  const Eigen::Vector3d e2 = b.cross(e1);
  return std::cos(ray.offset_rad) * b +
         std::sin(ray.offset_rad) * (std::cos(ray.azimuth_rad) * e1 + std::sin(ray.azimuth_rad) * e2);
}

/// Continuous energy-weighted centroid of the Gaussian beam (sigma = divergence / 4) on the plane through
/// `point` with unit normal `n`, seen from the origin along `boresight`: a ray at incidence i hits at
/// h / cos i and returns energy ~ cos^3 i / h^2, so the centroid is h * int f cos^2 i / int f cos^3 i. Polar
/// grid: Simpson in the offset (0 .. 8 sigma), uniform in azimuth (periodic: spectrally accurate).
double continuousPlaneCentroid(const Eigen::Vector3d& n, const Eigen::Vector3d& point,
                               const Eigen::Vector3d& origin, const Eigen::Vector3d& boresight,
                               const Eigen::Vector3d& up, double divergence) {
  const double sigma = divergence / 4.0;
  const double h = n.dot(origin - point);
  const int na = 800, nphi = 256;
  double num = 0.0, den = 0.0;
  for (int ia = 0; ia <= na; ++ia) {
    const double a = 8.0 * sigma * ia / na;
    const double simpson = (ia == 0 || ia == na) ? 1.0 : (ia % 2 ? 4.0 : 2.0);
    const double radial = simpson * std::exp(-a * a / (2 * sigma * sigma)) * a;
    for (int ip = 0; ip < nphi; ++ip) {
      const FootprintRay ray{a, 2 * kPi * ip / nphi, 1.0};
      const double cos_i = -n.dot(rayDirection(ray, boresight, up));
      num += radial * cos_i * cos_i;
      den += radial * cos_i * cos_i * cos_i;
    }
  }
  return h * num / den;
}

// ---------------------------------------------------------------------------------------------------------------

TEST(AltimeterFootprintPattern, SamplesTheGaussianBeam) {
  const double divergence = 0.5e-3, sigma = divergence / 4.0;
  for (int rays : {1, 7, 19, 37, 61, 91, 127}) {
    const auto pattern = footprintPattern(rays, divergence);
    ASSERT_EQ(static_cast<int>(pattern.size()), rays);
    EXPECT_EQ(pattern[0].offset_rad, 0.0);
    double w = 0, mx = 0, my = 0, m2 = 0, mxx = 0, myy = 0, mxy = 0;
    for (const auto& r : pattern) {
      const double x = r.offset_rad * std::cos(r.azimuth_rad), y = r.offset_rad * std::sin(r.azimuth_rad);
      w += r.weight, mx += r.weight * x, my += r.weight * y, m2 += r.weight * r.offset_rad * r.offset_rad;
      mxx += r.weight * x * x, myy += r.weight * y * y, mxy += r.weight * x * y;
      EXPECT_DOUBLE_EQ(r.weight, 1.0 / rays);  // equal-energy cells
    }
    EXPECT_NEAR(w, 1.0, 1e-12);
    // First moments vanish (no pointing bias), the second moment is the beam's: isotropic, 2 sigma^2.
    EXPECT_NEAR(mx, 0.0, 1e-12 * sigma);
    EXPECT_NEAR(my, 0.0, 1e-12 * sigma);
    if (rays == 1) continue;
    EXPECT_NEAR(m2, 2 * sigma * sigma, 1e-12 * sigma * sigma) << rays;
    EXPECT_NEAR(mxx, sigma * sigma, 1e-12 * sigma * sigma) << rays;
    EXPECT_NEAR(myy, sigma * sigma, 1e-12 * sigma * sigma) << rays;
    EXPECT_NEAR(mxy, 0.0, 1e-12 * sigma * sigma) << rays;
    // Each ring lies inside its equal-energy annulus: ring k spans the cumulative energies
    // [(1 + 3k(k-1)) / N, (1 + 3k(k+1)) / N], i.e. offsets sigma * sqrt(-2 ln(1 - F)).
    size_t index = 1;
    for (int k = 1; index < pattern.size(); ++k) {
      const double f_in = (1.0 + 3.0 * k * (k - 1)) / rays, f_out = (1.0 + 3.0 * k * (k + 1)) / rays;
      const double r_in = sigma * std::sqrt(-2 * std::log1p(-f_in));
      const double r_out = f_out >= 1.0 ? kInf : sigma * std::sqrt(-2 * std::log1p(-f_out));
      for (int j = 0; j < 6 * k; ++j, ++index) {
        EXPECT_GT(pattern[index].offset_rad, r_in) << rays << " ring " << k;
        EXPECT_LT(pattern[index].offset_rad, r_out) << rays << " ring " << k;
      }
    }
  }
  EXPECT_THROW(footprintPattern(5, divergence), std::invalid_argument);
  EXPECT_THROW(footprintPattern(7, -1e-3), std::invalid_argument);
}

TEST(AltimeterModel, IdealInstrumentReturnsTheExactBoresightRange) {
  // Every error switched to a large value: the disabled model must ignore them all.
  AltimeterParams p;
  p.enabled = false;
  p.range_noise_floor_m = 5.0, p.range_noise_fraction = 0.01, p.bias_sigma_m = 10.0;
  p.outlier_probability = 1.0, p.max_incidence_deg = 10.0, p.min_range_m = 500.0, p.quantization_m = 1.0;
  const AltimeterModel model(p, 3);
  EXPECT_EQ(model.biasM(), 0.0);
  // Sphere seen at incidence 89 deg, plane at 85 deg, at ranges below min_range_m and up to max_range_m.
  const double radius = 1000.0;
  const Eigen::Vector3d centre(radius * std::sin(89.0 * kPi / 180), 0, -1200.0);
  const auto sphere = model.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp, sphereCaster(centre, radius));
  const double sphere_range = 1200.0 - radius * std::cos(89.0 * kPi / 180);
  EXPECT_TRUE(sphere.returned);
  EXPECT_NEAR(sphere.true_range_m, sphere_range, 1e-9);
  EXPECT_EQ(sphere.range_m, sphere.true_range_m);
  EXPECT_NEAR(sphere.incidence_deg, 89.0, 1e-6);
  EXPECT_FALSE(sphere.outlier);
  EXPECT_EQ(sphere.ray_casts, 1);
  for (double range : {1.0, 120.0, 1999.0}) {
    const double tilt = 85.0 * kPi / 180;
    const auto r = model.measure(0.1, Eigen::Vector3d::Zero(), kNadir, kUp,
                                 planeCaster({std::sin(tilt), 0, std::cos(tilt)}, {0, 0, -range}));
    EXPECT_TRUE(r.returned) << range;
    EXPECT_NEAR(r.range_m, range, 1e-9 * range);
    EXPECT_EQ(r.range_m, r.true_range_m);
  }
  // No terrain within max range: no return (+inf), whatever the outlier probability.
  const auto far = model.measure(0.2, Eigen::Vector3d::Zero(), kNadir, kUp,
                                 planeCaster(Eigen::Vector3d::UnitZ(), {0, 0, -2001.0}));
  EXPECT_FALSE(far.returned);
  EXPECT_EQ(far.range_m, kInf);
  EXPECT_EQ(far.true_range_m, kInf);
  EXPECT_EQ(model.measure(0.3, Eigen::Vector3d::Zero(), kNadir, kUp, nothingCaster()).range_m, kInf);
}

TEST(AltimeterModel, NoiseStdIsFloorPlusFractionOfRangeAndMeanIsTheBias) {
  AltimeterParams p = cleanParams();
  p.range_noise_floor_m = 0.2;
  p.range_noise_fraction = 1.0e-3;
  p.bias_sigma_m = 0.5;
  // The first seed from 11 whose bias is well above the tolerance of the mean below (0.04 m at 100 m), so
  // that a bias left out fails.
  uint64_t seed = 11;
  while (std::abs(AltimeterModel(p, seed).biasM()) < 0.3) ++seed;
  const AltimeterModel model(p, seed);
  const int n = 4000;
  for (double d : {100.0, 500.0, 1000.0, 1900.0}) {
    const auto plane = planeCaster(Eigen::Vector3d::UnitZ(), {0, 0, -d});
    std::vector<double> errors;
    for (int i = 0; i < n; ++i) {
      const auto r = model.measure(0.05 * i + d, Eigen::Vector3d::Zero(), kNadir, kUp, plane);
      ASSERT_TRUE(r.returned);
      EXPECT_EQ(r.bias_m, model.biasM());
      errors.push_back(r.range_m - d);
    }
    const Stats s = stats(errors);
    const double sigma = 0.2 + 1.0e-3 * d;
    // Sample std of n Gaussian draws: relative standard error 1 / sqrt(2 (n - 1)) = 1.1 %; 4 sigma = 4.5 %.
    EXPECT_NEAR(s.std, sigma, 4.0 * sigma / std::sqrt(2.0 * (n - 1))) << "range " << d;
    // Mean = bias within 4 standard errors (the footprint offset on a perpendicular plane, d * 1.6e-8, is
    // negligible).
    EXPECT_NEAR(s.mean, model.biasM(), 4.0 * sigma / std::sqrt(n)) << "range " << d;
    std::printf("noise at %6.0f m: std %.4f m (expected %.4f), mean error %.4f m (bias %.4f)\n", d, s.std,
                sigma, s.mean, model.biasM());
  }
}

TEST(AltimeterModel, BiasSpreadOverSeedsIsBiasSigma) {
  AltimeterParams p = cleanParams();
  p.bias_sigma_m = 0.7;
  std::vector<double> biases;
  const int n = 4000;
  for (int seed = 0; seed < n; ++seed) biases.push_back(AltimeterModel(p, 1000 + seed).biasM());
  const Stats s = stats(biases);
  EXPECT_NEAR(s.std, 0.7, 4.0 * 0.7 / std::sqrt(2.0 * (n - 1)));
  EXPECT_NEAR(s.mean, 0.0, 4.0 * 0.7 / std::sqrt(n));
  std::printf("bias over %d seeds: std %.4f m (expected 0.7), mean %.4f m\n", n, s.std, s.mean);
}

TEST(AltimeterModel, MaxRangeShrinksAsSqrtCosIncidence) {
  AltimeterParams p = cleanParams();
  p.max_range_m = 2000.0;
  p.max_incidence_deg = 60.0;
  const AltimeterModel model(p, 5);
  for (double incidence_deg : {0.0, 30.0, 50.0, 59.0}) {
    const double tilt = incidence_deg * kPi / 180;
    const double limit = p.max_range_m * std::sqrt(std::cos(tilt));
    for (double factor : {0.5, 1.0 - 1e-4, 1.0 + 1e-4}) {
      const double range = factor * limit;
      const auto r = model.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp,
                                   planeCaster({std::sin(tilt), 0, std::cos(tilt)}, {0, 0, -range}));
      if (range <= p.max_range_m) {  // else beyond the range gate: no terrain found at all
        EXPECT_NEAR(r.true_range_m, range, 1e-9 * range);
        EXPECT_NEAR(r.incidence_deg, incidence_deg, 1e-6);
        // Energy over threshold = cos(i) (R / r)^2 up to the footprint's O(divergence^2) = 1e-8 terms.
        EXPECT_NEAR(r.energy_ratio, std::cos(tilt) * std::pow(p.max_range_m / range, 2), 1e-6);
      } else {
        EXPECT_EQ(r.true_range_m, kInf);
      }
      EXPECT_EQ(r.returned, factor < 1.0) << "incidence " << incidence_deg << " range " << range;
      EXPECT_EQ(r.range_m == kInf, factor > 1.0);
    }
  }
  // Beyond max range at normal incidence, nothing is hit within the range gate.
  const auto far = model.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp,
                                 planeCaster(Eigen::Vector3d::UnitZ(), {0, 0, -2500.0}));
  EXPECT_FALSE(far.returned);
  EXPECT_EQ(far.true_range_m, kInf);
}

TEST(AltimeterModel, NoReturnAtGrazingIncidence) {
  AltimeterParams p = cleanParams();
  p.max_incidence_deg = 60.0;
  const AltimeterModel model(p, 5);
  // Sphere of radius 1000 m whose centre is 1200 m below: the boresight meets it at incidence asin(x / 1000),
  // at ranges up to 858 m (70 deg), within the energy limit R sqrt(cos i) (1170 m at 70 deg).
  const double radius = 1000.0;
  for (double incidence_deg : {20.0, 55.0, 59.5, 60.5, 65.0, 70.0}) {
    const double i = incidence_deg * kPi / 180;
    const Eigen::Vector3d centre(radius * std::sin(i), 0, -1200.0);
    const auto r = model.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp, sphereCaster(centre, radius));
    EXPECT_NEAR(r.incidence_deg, incidence_deg, 1e-6);
    EXPECT_NEAR(r.true_range_m, 1200.0 - radius * std::cos(i), 1e-6);
    EXPECT_GT(r.energy_ratio, 1.0) << incidence_deg;  // enough energy: only the incidence decides
    EXPECT_EQ(r.returned, incidence_deg < 60.0) << incidence_deg;
  }
}

TEST(AltimeterModel, MinRangeIsABlindZone) {
  AltimeterParams p = cleanParams();
  p.min_range_m = 10.0;
  const AltimeterModel model(p, 5);
  for (double d : {5.0, 9.99, 10.01, 15.0}) {
    const auto r = model.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp,
                                 planeCaster(Eigen::Vector3d::UnitZ(), {0, 0, -d}));
    EXPECT_EQ(r.returned, d >= 10.0) << d;
  }
}

TEST(AltimeterModel, OutlierRateAndValues) {
  AltimeterParams p = cleanParams();
  p.outlier_probability = 0.05;
  p.range_noise_floor_m = 0.3;
  p.min_range_m = 10.0, p.max_range_m = 2000.0;
  const AltimeterModel model(p, 21);
  const double d = 800.0;
  const int n = 20000;
  const auto plane = planeCaster(Eigen::Vector3d::UnitZ(), {0, 0, -d});
  std::vector<double> outliers;
  for (int i = 0; i < n; ++i) {
    const auto r = model.measure(0.05 * i, Eigen::Vector3d::Zero(), kNadir, kUp, plane);
    ASSERT_TRUE(r.returned);
    if (r.outlier) {
      outliers.push_back(r.range_m);
      EXPECT_GE(r.range_m, p.min_range_m);
      EXPECT_LE(r.range_m, p.max_range_m);
    } else {
      EXPECT_NEAR(r.range_m, d, 6 * 0.3);  // a true echo: within 6 sigma of the noise
    }
  }
  // Binomial count: sd sqrt(n p (1 - p)) = 30.8, 4 sigma = 123 around 1000.
  const double expected = n * p.outlier_probability;
  EXPECT_NEAR(outliers.size(), expected, 4.0 * std::sqrt(expected * (1 - p.outlier_probability)));
  // Uniform in [min, max]: mean (min + max) / 2 within 4 sigma of the mean of n_out uniforms.
  const Stats s = stats(outliers);
  EXPECT_NEAR(s.mean, 1005.0, 4.0 * (1990.0 / std::sqrt(12.0)) / std::sqrt(outliers.size()));
  EXPECT_NEAR(s.std, 1990.0 / std::sqrt(12.0), 0.05 * 1990.0 / std::sqrt(12.0));
  std::printf("outliers: %zu of %d (expected %.0f), mean %.1f m, std %.1f m\n", outliers.size(), n, expected,
              s.mean, s.std);

  // Without any echo (nothing within range) the false ranges still occur at the same rate: the output is
  // finite exactly for the outliers.
  int false_alarms = 0;
  for (int i = 0; i < n; ++i) {
    const auto r = model.measure(0.05 * i, Eigen::Vector3d::Zero(), kNadir, kUp, nothingCaster());
    EXPECT_EQ(r.returned, r.outlier);
    EXPECT_FALSE(r.echo_detected);
    false_alarms += r.outlier;
  }
  EXPECT_NEAR(false_alarms, expected, 4.0 * std::sqrt(expected * (1 - p.outlier_probability)));
}

TEST(AltimeterModel, QuantisationRoundsToTheResolution) {
  AltimeterParams p = cleanParams();
  p.quantization_m = 0.25;
  const AltimeterModel model(p, 5);
  for (double d : {100.0, 100.1, 100.13, 100.37, 731.9}) {
    const auto r = model.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp,
                                 planeCaster(Eigen::Vector3d::UnitZ(), {0, 0, -d}));
    EXPECT_DOUBLE_EQ(r.range_m, 0.25 * std::round(d / 0.25)) << d;
  }
  p.range_noise_floor_m = 0.4;  // with noise too, every output is a multiple of the resolution
  const AltimeterModel noisy(p, 6);
  for (int i = 0; i < 200; ++i) {
    const auto r = noisy.measure(0.05 * i, Eigen::Vector3d::Zero(), kNadir, kUp,
                                 planeCaster(Eigen::Vector3d::UnitZ(), {0, 0, -321.123}));
    EXPECT_NEAR(r.range_m / 0.25, std::round(r.range_m / 0.25), 1e-9);
  }
}

TEST(AltimeterModel, FootprintOnAPerpendicularPlaneIsUnbiased) {
  // Flight-like beam (0.5 mrad): the footprint-averaged range is the plane distance to 0.1 mm (the physical
  // excess d * E[a^2] / 2 is 1.6e-5 m at 1000 m), whatever the pattern's orientation.
  AltimeterParams p = cleanParams();
  p.beam_divergence_rad = 0.5e-3;
  p.footprint_rays = 19;
  const AltimeterModel model(p, 5);
  const auto plane = planeCaster(Eigen::Vector3d::UnitZ(), {0, 0, -1000.0});
  const auto r = model.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp, plane);
  EXPECT_NEAR(r.footprint_range_m, 1000.0, 1e-4);
  EXPECT_NEAR(r.range_m, 1000.0, 1e-4);
  // Wide beam (0.05 rad, sigma 12.5 mrad): the excess, 0.156 m here, matches the continuous Gaussian integral
  // h int f cos^2 / int f cos^3. The pattern has the beam's exact second moment, so the two differ only by
  // fourth-order terms, ~ h * sigma^4 = 2.4e-5 m (2e-5 m measured): tolerance 2e-4 m.
  p.beam_divergence_rad = 0.05;
  p.footprint_rays = 37;
  const AltimeterModel wide(p, 5);
  const double expected = continuousPlaneCentroid(
      Eigen::Vector3d::UnitZ(), {0, 0, -1000.0}, Eigen::Vector3d::Zero(), kNadir, kUp, p.beam_divergence_rad);
  EXPECT_GT(expected - 1000.0, 0.1);
  for (const Eigen::Vector3d& up :
       {Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 0.3, 0), Eigen::Vector3d(-1, 2, 5)}) {
    const auto w = wide.measure(0.0, Eigen::Vector3d::Zero(), kNadir, up, plane);
    EXPECT_NEAR(w.footprint_range_m, expected, 2e-4);
    std::printf("perpendicular plane at 1000 m, divergence 0.05 rad: %.5f m (continuous %.5f m)\n",
                w.footprint_range_m, expected);
  }
}

TEST(AltimeterModel, FootprintOnATiltedPlaneIsTheEnergyWeightedCentroid) {
  // Divergence 0.02 rad (sigma 5 mrad) so that the footprint term is well resolved: at incidence 30-60 deg
  // it shifts the range by +8 mm to -125 mm (the near side of the footprint returns more energy), against a
  // quadrature error of the 37-ray pattern of fourth order, ~ range * tan^4(i) * sigma^4 = 5.6e-6 m at 60 deg
  // (3e-6 m measured): tolerance 1e-4 m.
  AltimeterParams p = cleanParams();
  p.beam_divergence_rad = 0.02;
  p.footprint_rays = 37;
  p.max_range_m = 5000.0;
  const AltimeterModel model(p, 5);
  for (double incidence_deg : {30.0, 45.0, 60.0}) {
    for (double tilt_azimuth_deg : {0.0, 90.0, 33.0}) {
      const double i = incidence_deg * kPi / 180, az = tilt_azimuth_deg * kPi / 180;
      const Eigen::Vector3d n(std::sin(i) * std::cos(az), std::sin(i) * std::sin(az), std::cos(i));
      const Eigen::Vector3d point(0, 0, -1000.0);
      const auto r = model.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp, planeCaster(n, point));
      const double expected = continuousPlaneCentroid(n, point, Eigen::Vector3d::Zero(), kNadir, kUp, 0.02);
      EXPECT_NEAR(r.true_range_m, 1000.0, 1e-9);
      EXPECT_GT(std::abs(expected - 1000.0), 0.005);  // the effect is there
      EXPECT_NEAR(r.footprint_range_m, expected, 1e-4) << incidence_deg << " " << tilt_azimuth_deg;
      std::printf("tilted plane, incidence %2.0f deg, tilt azimuth %2.0f deg: %.6f m (continuous %.6f m)\n",
                  incidence_deg, tilt_azimuth_deg, r.footprint_range_m, expected);
    }
  }
  // One ray: the boresight range.
  p.footprint_rays = 1;
  const AltimeterModel single(p, 5);
  const Eigen::Vector3d n(std::sin(1.0), 0, std::cos(1.0));
  EXPECT_NEAR(single.measure(0.0, Eigen::Vector3d::Zero(), kNadir, kUp, planeCaster(n, {0, 0, -1000.0}))
                  .footprint_range_m,
              1000.0, 1e-9);
}

TEST(AltimeterModel, FootprintOverAStepFollowsTheEnergySplit) {
  // Nadir view from 1000 m of a 5 m step at x = edge. Beam 2 mrad (footprint sigma 0.5 m at 1000 m), 61 rays.
  AltimeterParams p = cleanParams();
  p.beam_divergence_rad = 2e-3;
  p.footprint_rays = 61;
  const AltimeterModel model(p, 5);
  const Eigen::Vector3d origin(0, 0, 1000.0);
  const double height = 5.0, sigma_fp = 1000.0 * p.beam_divergence_rad / 4;
  const auto pattern = footprintPattern(p.footprint_rays, p.beam_divergence_rad);
  double previous = 0.0, worst_split_error = 0.0;
  for (double edge : {-1.5, -0.75, -0.4, -0.15, 0.05, 0.2, 0.45, 0.8, 1.5}) {
    const auto caster = stepCaster(edge, height);
    const auto r = model.measure(0.0, origin, kNadir, kUp, caster);
    ASSERT_TRUE(r.returned);
    // The boresight sees one level; the footprint range lies between the two levels.
    EXPECT_DOUBLE_EQ(r.true_range_m, edge <= 0.0 ? 1000.0 - height : 1000.0);
    EXPECT_GT(r.footprint_range_m, 1000.0 - height - 1e-9);
    EXPECT_LT(r.footprint_range_m, 1000.0 + 1e-3);
    EXPECT_GE(r.footprint_range_m, previous);  // moves away from the high level as the edge recedes
    previous = r.footprint_range_m;
    // Exactly the energy-weighted mean over the documented pattern (computed here independently).
    double e_sum = 0.0, er_sum = 0.0, e_high = 0.0;
    for (const auto& ray : pattern) {
      const Eigen::Vector3d u = rayDirection(ray, kNadir, kUp);
      const auto h = caster(origin, u, 0.0, p.max_range_m);
      ASSERT_TRUE(h);
      const double e = ray.weight * std::max(0.0, -u.dot(h->normal_world)) / (h->range_m * h->range_m);
      e_sum += e, er_sum += e * h->range_m;
      if ((origin + h->range_m * u).x() >= edge) e_high += ray.weight;
    }
    EXPECT_NEAR(r.footprint_range_m, er_sum / e_sum, 1e-9);
    // Against the continuous beam: the share of the energy on the high side is Phi(-edge / sigma_fp); the
    // 61-ray pattern resolves it to about one ray per ring it cuts (measured: at most 0.031 of the energy,
    // 0.16 m of range): tolerance 0.06 of the energy, 0.3 m. A boresight-only range is off by up to 2.5 m.
    const double share = 0.5 * std::erfc(edge / sigma_fp / std::sqrt(2.0));
    const double r_high = 1000.0 - height, r_low = 1000.0;
    const double e_h = share / (r_high * r_high), e_l = (1 - share) / (r_low * r_low);
    const double continuous = (e_h * r_high + e_l * r_low) / (e_h + e_l);
    worst_split_error = std::max(worst_split_error, std::abs(e_high - share));
    EXPECT_NEAR(r.footprint_range_m, continuous, 0.06 * height) << "edge " << edge;
    std::printf("step edge at %+5.2f m: range %.4f m, continuous %.4f m (high-side energy %.3f vs %.3f)\n",
                edge, r.footprint_range_m, continuous, e_high, share);
  }
  EXPECT_LT(worst_split_error, 0.06);
  // One ray: the boresight range, whichever side.
  p.footprint_rays = 1;
  const AltimeterModel single(p, 5);
  EXPECT_DOUBLE_EQ(single.measure(0.0, origin, kNadir, kUp, stepCaster(0.05, height)).range_m, 1000.0);
  EXPECT_DOUBLE_EQ(single.measure(0.0, origin, kNadir, kUp, stepCaster(-0.05, height)).range_m, 995.0);
}

TEST(AltimeterModel, OuterRaysStartNearTheBoresightHit) {
  AltimeterParams p = cleanParams();
  p.beam_divergence_rad = 2e-3;
  p.footprint_rays = 19;
  p.footprint_search_margin_m = 50.0;
  const AltimeterModel model(p, 5);
  const Eigen::Vector3d origin(0, 0, 1000.0);
  // Flat ground: one full cast and 18 casts starting at (range - margin).
  std::vector<double> starts;
  const auto flat = stepCaster(1e9, 0.0);
  const RayCaster recording = [&](const Eigen::Vector3d& o, const Eigen::Vector3d& u, double start,
                                  double max) {
    starts.push_back(start);
    return flat(o, u, start, max);
  };
  const auto r = model.measure(0.0, origin, kNadir, kUp, recording);
  EXPECT_EQ(r.ray_casts, 19);
  ASSERT_EQ(starts.size(), 19u);
  EXPECT_EQ(starts[0], 0.0);
  for (size_t k = 1; k < starts.size(); ++k) EXPECT_DOUBLE_EQ(starts[k], 950.0);
  // A 100 m block (taller than the margin) inside the footprint: its rays start under the block top, are
  // recast from the instrument, and the result is that of full casts.
  p.footprint_search_margin_m = 1e4;
  const AltimeterModel full(p, 5);
  for (double edge : {-0.3, 0.1, 0.4}) {
    const auto tall = stepCaster(edge, 100.0);
    const auto a = model.measure(0.0, origin, kNadir, kUp, tall);
    const auto b = full.measure(0.0, origin, kNadir, kUp, tall);
    EXPECT_NEAR(a.footprint_range_m, b.footprint_range_m, 1e-9) << edge;
    EXPECT_EQ(b.ray_casts, 19);
    if (edge > 0.0) {
      EXPECT_GT(a.ray_casts, 19) << edge;  // rays on the block were recast
    }
    std::printf("100 m block, edge %+.1f m: %d casts (19 without recasts), range %.4f m\n", edge, a.ray_casts,
                a.footprint_range_m);
  }
}

TEST(AltimeterModel, DeterministicPerSeedAndIndependentOfCallOrder) {
  AltimeterParams p = cleanParams();
  p.range_noise_floor_m = 0.3, p.range_noise_fraction = 2e-4, p.bias_sigma_m = 0.2;
  p.outlier_probability = 0.1, p.quantization_m = 0.0;
  const auto plane = planeCaster(Eigen::Vector3d(0.1, 0.2, 1.0), {0, 0, -700.0});
  auto run = [&](uint64_t seed, bool reverse) {
    const AltimeterModel model(p, seed);
    std::vector<double> out(200);
    for (int k = 0; k < 200; ++k) {
      const int i = reverse ? 199 - k : k;
      out[i] = model.measure(0.05 * i, Eigen::Vector3d::Zero(), kNadir, kUp, plane).range_m;
    }
    return out;
  };
  const auto a = run(42, false), b = run(42, false), c = run(42, true), d = run(43, false);
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(double)));  // bit-identical
  EXPECT_EQ(0, std::memcmp(a.data(), c.data(), a.size() * sizeof(double)));  // whatever the order
  int same = 0;
  for (size_t i = 0; i < a.size(); ++i) same += a[i] == d[i];
  EXPECT_LT(same, 5);  // another seed, other draws
}

TEST(AltimeterParamsYaml, RoundTripAndErrors) {
  AltimeterParams p;
  p.enabled = true;
  p.range_noise_floor_m = 0.123456789012345;
  p.range_noise_fraction = 3.3e-4;
  p.bias_sigma_m = 0.77;
  p.max_range_m = 1750.5;
  p.min_range_m = 3.25;
  p.max_incidence_deg = 71.0;
  p.outlier_probability = 0.0125;
  p.beam_divergence_rad = 1.1e-3;
  p.footprint_rays = 37;
  p.footprint_search_margin_m = 33.0;
  p.quantization_m = 0.05;
  const YAML::Node node = YAML::Load(YAML::Dump(toYaml(p)));
  EXPECT_EQ(node.size(), 12u);  // every field
  AltimeterParams q;
  readYaml(node, &q);
  EXPECT_EQ(q.enabled, p.enabled);
  EXPECT_EQ(q.range_noise_floor_m, p.range_noise_floor_m);
  EXPECT_EQ(q.range_noise_fraction, p.range_noise_fraction);
  EXPECT_EQ(q.bias_sigma_m, p.bias_sigma_m);
  EXPECT_EQ(q.max_range_m, p.max_range_m);
  EXPECT_EQ(q.min_range_m, p.min_range_m);
  EXPECT_EQ(q.max_incidence_deg, p.max_incidence_deg);
  EXPECT_EQ(q.outlier_probability, p.outlier_probability);
  EXPECT_EQ(q.beam_divergence_rad, p.beam_divergence_rad);
  EXPECT_EQ(q.footprint_rays, p.footprint_rays);
  EXPECT_EQ(q.footprint_search_margin_m, p.footprint_search_margin_m);
  EXPECT_EQ(q.quantization_m, p.quantization_m);

  // Only the keys present change.
  AltimeterParams partial;
  readYaml(YAML::Load("{max_range_m: 1500, footprint_rays: 19}"), &partial);
  EXPECT_EQ(partial.max_range_m, 1500.0);
  EXPECT_EQ(partial.footprint_rays, 19);
  EXPECT_EQ(partial.range_noise_floor_m, AltimeterParams().range_noise_floor_m);
  readYaml(YAML::Node(), &partial);  // null: nothing changes
  EXPECT_EQ(partial.max_range_m, 1500.0);

  auto expectError = [](const std::string& yaml, const std::string& key) {
    AltimeterParams r;
    const AltimeterParams before = r;
    try {
      readYaml(YAML::Load(yaml), &r);
      ADD_FAILURE() << "accepted: " << yaml;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
    EXPECT_EQ(r.max_range_m, before.max_range_m);  // untouched on error
  };
  expectError("{max_rnage_m: 100}", "max_rnage_m");
  expectError("{max_range_m: [1, 2]}", "max_range_m");
  expectError("{max_range_m: far}", "max_range_m");
  expectError("{enabled: maybe}", "enabled");
  expectError("{footprint_rays: 5}", "footprint_rays");
  expectError("{footprint_rays: 7.5}", "footprint_rays");
  expectError("{range_noise_floor_m: -0.1}", "range_noise_floor_m");
  expectError("{range_noise_fraction: 1.5}", "range_noise_fraction");
  expectError("{bias_sigma_m: .nan}", "bias_sigma_m");
  expectError("{max_range_m: .inf}", "max_range_m");
  expectError("{max_range_m: 0}", "max_range_m");
  expectError("{min_range_m: 3000}", "min_range_m");
  expectError("{max_incidence_deg: 95}", "max_incidence_deg");
  expectError("{max_incidence_deg: 0}", "max_incidence_deg");
  expectError("{outlier_probability: 1.01}", "outlier_probability");
  expectError("{beam_divergence_rad: -1e-3}", "beam_divergence_rad");
  expectError("{footprint_search_margin_m: 0}", "footprint_search_margin_m");
  expectError("{quantization_m: -0.01}", "quantization_m");
  EXPECT_THROW(readYaml(YAML::Load("[1, 2]"), &p), std::invalid_argument);

  AltimeterParams bad;
  bad.min_range_m = -1.0;
  EXPECT_THROW(AltimeterModel(bad, 1), std::invalid_argument);
}

}  // namespace
}  // namespace planetary_vo::sensors

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
