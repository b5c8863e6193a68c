/// @file allan_deviation.cpp
/// Overlapping Allan deviation from the cumulative sum (angle) of the rate samples.

#include "planetary_vo/sensors/allan_deviation.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace planetary_vo::sensors {
namespace {

/// theta_k = dt * sum_{i<k} (y_i - mean), k = 0..N, in long double so that a long record loses no digits.
std::vector<long double> cumulativeAngle(const std::vector<double>& samples, double dt_s) {
  long double mean = 0.0L;
  for (double y : samples) mean += y;
  mean /= static_cast<long double>(samples.size());
  std::vector<long double> theta(samples.size() + 1, 0.0L);
  for (size_t i = 0; i < samples.size(); ++i) theta[i + 1] = theta[i] + (samples[i] - mean) * dt_s;
  return theta;
}

AllanPoint pointAt(const std::vector<long double>& theta, double dt_s, size_t m) {
  const size_t n = theta.size() - 1;  // number of rate samples
  const size_t terms = n - 2 * m + 1;
  long double sum = 0.0L;
  for (size_t k = 0; k < terms; ++k) {
    const long double d = theta[k + 2 * m] - 2.0L * theta[k + m] + theta[k];
    sum += d * d;
  }
  const double tau = static_cast<double>(m) * dt_s;
  AllanPoint point;
  point.tau_s = tau;
  point.deviation =
      std::sqrt(static_cast<double>(sum / (2.0L * tau * tau * static_cast<long double>(terms))));
  point.num_clusters = terms;
  return point;
}

}  // namespace

std::vector<AllanPoint> overlappingAllanDeviation(const std::vector<double>& samples, double dt_s,
                                                  int points_per_decade) {
  if (!(dt_s > 0.0) || !std::isfinite(dt_s))
    throw std::invalid_argument("overlappingAllanDeviation: dt_s must be > 0, got " + std::to_string(dt_s));
  if (points_per_decade < 1)
    throw std::invalid_argument("overlappingAllanDeviation: points_per_decade must be >= 1");
  std::vector<AllanPoint> result;
  if (samples.size() < 2) return result;
  const std::vector<long double> theta = cumulativeAngle(samples, dt_s);
  const size_t m_max = samples.size() / 2;
  size_t last_m = 0;
  for (int i = 0;; ++i) {
    const size_t m =
        static_cast<size_t>(std::llround(std::pow(10.0, static_cast<double>(i) / points_per_decade)));
    if (m > m_max) break;
    if (m == last_m) continue;
    last_m = m;
    result.push_back(pointAt(theta, dt_s, m));
  }
  return result;
}

AllanPoint overlappingAllanDeviationAt(const std::vector<double>& samples, double dt_s, size_t m) {
  if (!(dt_s > 0.0) || !std::isfinite(dt_s))
    throw std::invalid_argument("overlappingAllanDeviationAt: dt_s must be > 0, got " + std::to_string(dt_s));
  if (m < 1 || 2 * m > samples.size())
    throw std::invalid_argument("overlappingAllanDeviationAt: cluster size " + std::to_string(m) +
                                " outside [1, N/2] for N = " + std::to_string(samples.size()));
  return pointAt(cumulativeAngle(samples, dt_s), dt_s, m);
}

}  // namespace planetary_vo::sensors
