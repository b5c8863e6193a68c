/// Overlapping Allan deviation: the estimator formula on a hand-checked series, and its statistics on white
/// noise (sigma(tau) = N / sqrt(tau)) and on a random walk (sigma(tau) = K sqrt(tau / 3)).

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/sensors/allan_deviation.h"

namespace planetary_vo::sensors {
namespace {

/// Direct evaluation of the overlapping estimator from its definition (cluster averages, no cumulative sum).
double bruteForceAllanDeviation(const std::vector<double>& y, double dt, size_t m) {
  const size_t n = y.size();
  double sum = 0.0;
  size_t terms = 0;
  for (size_t k = 0; k + 2 * m <= n; ++k) {
    double first = 0.0, second = 0.0;
    for (size_t i = 0; i < m; ++i) first += y[k + i], second += y[k + m + i];
    const double diff = (second - first) / static_cast<double>(m);
    sum += diff * diff;
    ++terms;
  }
  (void)dt;
  return std::sqrt(sum / (2.0 * static_cast<double>(terms)));
}

TEST(AllanDeviation, MatchesTheDefinitionOnASmallSeries) {
  const std::vector<double> y = {0.3, -1.2, 2.5, 0.7, 0.1, -0.4, 1.9, -2.2, 0.8, 0.05, 1.1};
  const double dt = 0.5;
  const std::vector<AllanPoint> points = overlappingAllanDeviation(y, dt, 10);
  ASSERT_EQ(points.size(), 5u);  // m = 1..5 = floor(11 / 2), each a distinct integer
  for (size_t j = 0; j < points.size(); ++j) {
    const size_t m = j + 1;
    EXPECT_DOUBLE_EQ(points[j].tau_s, m * dt);
    EXPECT_EQ(points[j].num_clusters, y.size() - 2 * m + 1);
    EXPECT_NEAR(points[j].deviation, bruteForceAllanDeviation(y, dt, m), 1e-12) << "m = " << m;
  }
  // m = 1 by hand: successive differences of the samples.
  double sum = 0.0;
  for (size_t k = 0; k + 1 < y.size(); ++k) sum += (y[k + 1] - y[k]) * (y[k + 1] - y[k]);
  EXPECT_NEAR(points[0].deviation, std::sqrt(sum / (2.0 * (y.size() - 1))), 1e-12);
  EXPECT_NEAR(overlappingAllanDeviationAt(y, dt, 3).deviation, points[2].deviation, 1e-15);
}

TEST(AllanDeviation, IndependentOfAConstantOffsetAndLogSpaced) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal;
  std::vector<double> y(20000), shifted(20000);
  for (size_t i = 0; i < y.size(); ++i) y[i] = normal(rng), shifted[i] = y[i] + 9.80665e3;
  const std::vector<AllanPoint> a = overlappingAllanDeviation(y, 0.01, 5);
  const std::vector<AllanPoint> b = overlappingAllanDeviation(shifted, 0.01, 5);
  ASSERT_EQ(a.size(), b.size());
  for (size_t j = 0; j < a.size(); ++j) EXPECT_NEAR(a[j].deviation, b[j].deviation, 1e-9 * a[j].deviation);
  // 5 points per decade up to m = 10000: m = 1, 2, 3, 4, 6, 10, 16, ... strictly increasing.
  for (size_t j = 1; j < a.size(); ++j) EXPECT_GT(a[j].tau_s, a[j - 1].tau_s);
  EXPECT_DOUBLE_EQ(a.front().tau_s, 0.01);
  EXPECT_EQ(a.size(), 21u);  // m = 10^(i/5), i = 0..20 (m = 10000 = N / 2 included)
  EXPECT_DOUBLE_EQ(a.back().tau_s, 100.0);
}

TEST(AllanDeviation, WhiteNoiseFollowsMinusOneHalfSlope) {
  // Rate white noise of density N sampled at 100 Hz for 1 h: per-sample sigma N sqrt(rate).
  const double rate = 100.0, dt = 1.0 / rate, density = 3e-4;
  const size_t n = 360000;
  std::mt19937_64 rng(2024);
  std::normal_distribution<double> normal(0.0, density * std::sqrt(rate));
  std::vector<double> y(n);
  for (double& v : y) v = normal(rng);
  for (size_t m : {1u, 10u, 100u, 1000u}) {
    const AllanPoint p = overlappingAllanDeviationAt(y, dt, m);
    // Equivalent degrees of freedom of the overlapping estimator for this noise (Howe, Allan & Barnes 1981,
    // white FM): edf = (3 (N-1) / 2m - 2 (N-2) / N) 4m^2 / (4m^2 + 5); relative sigma of the deviation
    // = 1 / sqrt(2 edf) (0.2 % at m = 1, 4.3 % at m = 1000). Bound: 4 sigma.
    const double nn = static_cast<double>(n), mm = static_cast<double>(m);
    const double edf = (3.0 * (nn - 1) / (2 * mm) - 2.0 * (nn - 2) / nn) * 4 * mm * mm / (4 * mm * mm + 5);
    const double expected = density / std::sqrt(p.tau_s);
    EXPECT_NEAR(p.deviation / expected, 1.0, 4.0 / std::sqrt(2.0 * edf)) << "tau = " << p.tau_s;
  }
}

TEST(AllanDeviation, RandomWalkFollowsPlusOneHalfSlope) {
  // Rate random walk K: r_{k+1} = r_k + K sqrt(dt) n_k; sigma(tau) = K sqrt(tau / 3) for tau >> dt. The
  // estimator scatter of a random walk is large, so 16 independent records of 1 h at 100 Hz are averaged
  // (in variance); scatter of this average over 50 seeds: 0.32 % at tau = 1 s, 0.82 % at 10 s. Bound 4 %
  // (> 4.8 sigma).
  const double rate = 100.0, dt = 1.0 / rate, k = 2e-5;
  const size_t n = 360000;
  std::mt19937_64 rng(77);
  std::normal_distribution<double> normal(0.0, k * std::sqrt(dt));
  std::vector<double> variance_sum(2, 0.0);
  const size_t ms[2] = {100, 1000};
  const int records = 16;
  std::vector<double> y(n);
  for (int r = 0; r < records; ++r) {
    double walk = 0.0;
    for (double& v : y) v = walk, walk += normal(rng);
    for (int j = 0; j < 2; ++j)
      variance_sum[j] += std::pow(overlappingAllanDeviationAt(y, dt, ms[j]).deviation, 2);
  }
  for (int j = 0; j < 2; ++j) {
    const double tau = ms[j] * dt;
    const double measured = std::sqrt(variance_sum[j] / records);
    EXPECT_NEAR(measured / (k * std::sqrt(tau / 3.0)), 1.0, 0.04) << "tau = " << tau;
  }
}

TEST(AllanDeviation, RejectsBadArguments) {
  const std::vector<double> y(10, 1.0);
  EXPECT_THROW(overlappingAllanDeviation(y, 0.0), std::invalid_argument);
  EXPECT_THROW(overlappingAllanDeviation(y, 0.01, 0), std::invalid_argument);
  EXPECT_THROW(overlappingAllanDeviationAt(y, 0.01, 6), std::invalid_argument);
  EXPECT_THROW(overlappingAllanDeviationAt(y, 0.01, 0), std::invalid_argument);
  EXPECT_TRUE(overlappingAllanDeviation(std::vector<double>{1.0}, 0.01).empty());
}

}  // namespace
}  // namespace planetary_vo::sensors

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
