#pragma once
/// @file allan_deviation.h
/// Overlapping Allan deviation (IEEE Std 952-1997, Annex C; IEEE Std 1554) of a uniformly sampled rate
/// signal (gyro rad/s, accelerometer m/s^2): the tool that reads white noise (slope -1/2), bias instability
/// (flat) and rate random walk (slope +1/2) off a static IMU record. Used to check the IMU error model
/// against its specification and to characterise a dataset's imu.txt.

#include <cstddef>
#include <vector>

namespace planetary_vo::sensors {

struct AllanPoint {
  double tau_s = 0.0;       ///< averaging time m * dt_s
  double deviation = 0.0;   ///< Allan deviation, same unit as the samples
  size_t num_clusters = 0;  ///< number of (overlapping) second differences averaged: N - 2m + 1
};

/// Overlapping Allan deviation of `samples` (rate, spaced dt_s), with theta_k = dt * sum_{i<k} y_i:
///   sigma^2(tau = m dt) = 1 / (2 tau^2 (N - 2m + 1)) * sum_{k=0}^{N-2m} (theta_{k+2m} - 2 theta_{k+m} +
///   theta_k)^2
/// for cluster sizes m log-spaced with `points_per_decade` per decade (distinct integers, m = 1 first) up to
/// m = floor(N / 2). The mean is removed first (the result does not depend on it; this keeps the cumulative
/// sum small). Fewer than 2 samples give an empty result. Throws std::invalid_argument for dt_s <= 0 or
/// points_per_decade < 1.
std::vector<AllanPoint> overlappingAllanDeviation(const std::vector<double>& samples, double dt_s,
                                                  int points_per_decade = 10);

/// The same estimator at one cluster size m (1 <= m <= N/2); throws std::invalid_argument otherwise.
AllanPoint overlappingAllanDeviationAt(const std::vector<double>& samples, double dt_s, size_t m);

}  // namespace planetary_vo::sensors
