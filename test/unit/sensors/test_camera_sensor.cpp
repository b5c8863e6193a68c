/// Checks each part of the camera error model against its specification (docs/sensors/camera.md): the photon
/// transfer curve, Poisson shot noise, full-well and ADC clipping, quantisation and bit depth, the PSF, the
/// vignetting law, pixel defects, the auto exposure's lag and limits, motion blur and image motion, the
/// calibration error, determinism and the YAML interface. Statistical tolerances state how many sigma they
/// allow.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <numeric>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "planetary_vo/sensors/camera_sensor.h"

namespace planetary_vo::sensors {
namespace {

/// A sensor with every error source off (no read noise, dark current, PRNU, vignetting, defects, PSF; fixed
/// exposure of 1 ms): tests switch on what they check.
CameraSensorParams quietParams() {
  CameraSensorParams p;
  p.enabled = true;
  p.read_noise_e = 0.0;
  p.dark_current_e_per_s = 0.0;
  p.prnu = 0.0;
  p.vignetting_corner = 1.0;
  p.hot_pixel_fraction = 0.0;
  p.dead_pixel_fraction = 0.0;
  p.psf = "none";
  p.ae_gain = 0.0;
  p.exposure_step_s = 0.0;
  return p;
}

/// I/F that gives `electrons` mean at the image centre with the sensor's current exposure.
float reflectanceFor(const CameraSensor& sensor, double electrons) {
  return static_cast<float>(electrons /
                            (electronRatePerUnitReflectance(sensor.params()) * sensor.exposureS()));
}

/// Temporal statistics per pixel over repeated frames, averaged over the pixels.
struct TemporalStats {
  double mean_dn = 0.0;      // mean over pixels of the per-pixel temporal mean
  double variance_dn = 0.0;  // mean over pixels of the per-pixel unbiased temporal variance
};

TemporalStats temporalStats(CameraSensor* sensor, const cv::Mat1f& scene, int frames, uint64_t first_frame) {
  const int n = scene.rows * scene.cols;
  std::vector<double> sum(n, 0.0), sum2(n, 0.0);
  for (int f = 0; f < frames; ++f) {
    const cv::Mat1w raw = sensor->expose(scene, first_frame + f);
    for (int i = 0; i < n; ++i) {
      const double v = raw(i / scene.cols, i % scene.cols);
      sum[i] += v;
      sum2[i] += v * v;
    }
  }
  TemporalStats s;
  for (int i = 0; i < n; ++i) {
    const double m = sum[i] / frames;
    s.mean_dn += m;
    s.variance_dn += (sum2[i] - frames * m * m) / (frames - 1);
  }
  s.mean_dn /= n;
  s.variance_dn /= n;
  return s;
}

// ------------------------------------------------------------------------------------------------------------
// Photon transfer

TEST(CameraSensor, PhotonTransferCurveMatchesGainAndReadNoise) {
  // The flight sensor (read noise, shot noise, dark current, PRNU, 12 bits) at 8 flat-field levels from dark
  // to 85 % of the full well: temporal variance = signal / gain + (read_noise / gain)^2 + 1/12 (DN^2).
  CameraSensorParams p;
  p.enabled = true;
  p.vignetting_corner = 1.0;
  p.hot_pixel_fraction = p.dead_pixel_fraction = 0.0;
  p.ae_gain = 0.0;
  CameraSensor sensor(p, 64, 64, 7);
  sensor.setExposure(1e-3);
  const double g = sensor.gainEPerDn(), black = p.black_level_dn;
  const std::vector<double> levels_e = {0, 300, 1000, 2000, 4000, 6000, 8500, 11500};
  std::vector<double> x, y;
  for (size_t l = 0; l < levels_e.size(); ++l) {
    const cv::Mat1f scene(64, 64, reflectanceFor(sensor, levels_e[l]));
    const TemporalStats s = temporalStats(&sensor, scene, 16, 1000 * l);
    x.push_back(s.mean_dn - black);
    y.push_back(s.variance_dn);
    // The mean signal is the expected electrons (+ dark current) over the gain: 1 % (PRNU averages out).
    const double expected = (levels_e[l] + p.dark_current_e_per_s * 1e-3) / g;
    EXPECT_NEAR(s.mean_dn - black, expected, 0.01 * expected + 0.05) << "level " << levels_e[l] << " e-";
  }
  // Least-squares line var = a + b * signal.
  const double n = static_cast<double>(x.size());
  const double mx = std::accumulate(x.begin(), x.end(), 0.0) / n,
               my = std::accumulate(y.begin(), y.end(), 0.0) / n;
  double sxy = 0.0, sxx = 0.0;
  for (size_t i = 0; i < x.size(); ++i) sxy += (x[i] - mx) * (y[i] - my), sxx += (x[i] - mx) * (x[i] - mx);
  const double slope = sxy / sxx, intercept = my - slope * mx;
  const double read_dn2 = p.read_noise_e * p.read_noise_e / (g * g) + 1.0 / 12.0;
  std::printf("PTC: slope %.5f (1/gain %.5f), intercept %.3f DN^2 (expected %.3f), dark variance %.3f\n",
              slope, 1.0 / g, intercept, read_dn2, y[0]);
  // Each level's variance has a relative error sqrt(2 / (4096 * 15)) = 0.6 %: 2 % on the slope is > 3 sigma.
  EXPECT_NEAR(slope, 1.0 / g, 0.02 / g);
  EXPECT_NEAR(intercept, read_dn2, 0.05 * read_dn2);
  // The dark level measures the read noise directly: 3 % = 5 sigma.
  EXPECT_NEAR(y[0], read_dn2 + p.dark_current_e_per_s * 1e-3 / (g * g), 0.03 * read_dn2);
}

TEST(CameraSensor, QuantisationAddsOneTwelfthDnSquared) {
  // Read noise of exactly 1 DN and no light: variance 1 + 1/12 (the ADC rounding), mean exactly the black
  // level.
  CameraSensorParams p = quietParams();
  p.gain_e_per_dn = 3.0;
  p.read_noise_e = 3.0;
  CameraSensor sensor(p, 64, 64, 3);
  const TemporalStats s = temporalStats(&sensor, cv::Mat1f(64, 64, 0.0f), 32, 0);
  // Relative error of the variance: sqrt(2 / (4096 * 31)) = 0.4 %; 1/12 is 7.7 %: 1.5 % is 3.7 sigma.
  std::printf("quantisation: dark variance %.4f DN^2 (1 + 1/12 = 1.0833), mean - black %.4f DN\n",
              s.variance_dn, s.mean_dn - p.black_level_dn);
  EXPECT_NEAR(s.variance_dn, 1.0 + 1.0 / 12.0, 0.015 * (1.0 + 1.0 / 12.0));
  EXPECT_NEAR(s.mean_dn, p.black_level_dn, 0.02);  // rounding to nearest, not truncation (that would be -0.5)
}

TEST(CameraSensor, ShotNoiseIsPoissonAtLowSignal) {
  // 1 e-/DN, no read noise: the DN above black count electrons. Poisson: variance = mean, P(0) = exp(-mean).
  CameraSensorParams p = quietParams();
  p.gain_e_per_dn = 1.0;
  p.black_level_dn = 10.0;
  CameraSensor sensor(p, 64, 64, 11);
  for (double mean_e : {0.5, 3.0, 12.0}) {
    const cv::Mat1f scene(64, 64, reflectanceFor(sensor, mean_e));
    double sum = 0.0, sum2 = 0.0, zeros = 0.0, count = 0.0;
    for (int f = 0; f < 8; ++f) {
      const cv::Mat1w raw = sensor.expose(scene, 100 + f);
      for (int i = 0; i < raw.rows * raw.cols; ++i) {
        const double e = raw(i / raw.cols, i % raw.cols) - p.black_level_dn;
        ASSERT_EQ(e, std::round(e));
        sum += e, sum2 += e * e, zeros += e == 0.0, count += 1.0;
      }
    }
    const double m = sum / count, var = sum2 / count - m * m;
    std::printf("Poisson: mean %.4f e- (set %.1f), variance / mean %.4f, P(0) %.4f (exp(-mean) %.4f)\n", m,
                mean_e, var / m, zeros / count, std::exp(-mean_e));
    // 32768 samples: relative sd of the variance sqrt((1/mean + 2) / n) <= 1.1 %, of the mean <= 0.8 %.
    EXPECT_NEAR(m, mean_e, 0.04 * mean_e) << mean_e;
    EXPECT_NEAR(var / m, 1.0, 0.05) << mean_e;
    // sd of the zero fraction < 0.3 %: 0.015 is 5 sigma (a rounded Gaussian gives 0.5 at mean 0.5, not 0.61).
    EXPECT_NEAR(zeros / count, std::exp(-mean_e), 0.015) << mean_e;
  }
}

TEST(CameraSensor, FullWellClipsTheSignal) {
  // Gain chosen so that the full well (13.5 ke-) maps to 3000 DN above black, below the ADC full scale: a
  // field at twice the full well reads black + 3000 with only read noise left.
  CameraSensorParams p = quietParams();
  p.gain_e_per_dn = p.full_well_e / 3000.0;
  p.read_noise_e = 13.0;
  CameraSensor sensor(p, 64, 64, 5);
  const cv::Mat1f scene(64, 64, reflectanceFor(sensor, 2.0 * p.full_well_e));
  FrameExposure info;
  const TemporalStats s = temporalStats(&sensor, scene, 8, 0);
  sensor.expose(scene, 99, &info);
  std::printf("full well: mean %.3f DN above black (3000), variance %.3f DN^2\n",
              s.mean_dn - p.black_level_dn, s.variance_dn);
  EXPECT_NEAR(s.mean_dn, p.black_level_dn + 3000.0, 0.5);
  const double read_dn2 = std::pow(p.read_noise_e / sensor.gainEPerDn(), 2) + 1.0 / 12.0;
  EXPECT_NEAR(s.variance_dn, read_dn2, 0.1 * read_dn2);  // no shot noise left (it would be 6000 DN^2)
  EXPECT_DOUBLE_EQ(info.saturated_fraction, 1.0);
}

TEST(CameraSensor, BitDepthAndPngAlignment) {
  // A ramp from dark to 1.5 x full well through a 12-bit and a 10-bit ADC (black level 64 and 16 DN).
  CameraSensorParams p12 = quietParams();
  p12.read_noise_e = 13.0;
  CameraSensorParams p10 = p12;
  p10.bit_depth = 10;
  p10.black_level_dn = 16.0;
  CameraSensor s12(p12, 256, 32, 1), s10(p10, 256, 32, 1);
  // Pixel i (row-major, 8192 of them) gets 1.5 * full well * i / 8191: two pixels per 12-bit DN.
  cv::Mat1f ramp(32, 256);
  const int unclipped = 5000;  // below the full well (i < 8191 / 1.5)
  for (int i = 0; i < 8192; ++i)
    ramp(i / 256, i % 256) = reflectanceFor(s12, 1.5 * p12.full_well_e * i / 8191.0);
  const cv::Mat1w r12 = s12.expose(ramp, 0), r10 = s10.expose(ramp, 0);
  double min12, max12, min10, max10;
  cv::minMaxLoc(r12, &min12, &max12);
  cv::minMaxLoc(r10, &min10, &max10);
  EXPECT_EQ(max12, 4095.0);
  EXPECT_EQ(max10, 1023.0);
  EXPECT_GE(min12, 0.0);
  EXPECT_GE(min10, 0.0);
  // Same electrons, 4x coarser steps: (13500 / 1007) / (13500 / 4031) = 4.003 between the signals.
  double sig12 = 0.0, sig10 = 0.0;
  for (int i = 100; i < unclipped; ++i)
    sig12 += r12(i / 256, i % 256) - 64.0, sig10 += r10(i / 256, i % 256) - 16.0;
  EXPECT_NEAR(sig12 / sig10, s10.gainEPerDn() / s12.gainEPerDn(), 0.01 * 4.0);
  EXPECT_NEAR(s10.gainEPerDn() / s12.gainEPerDn(), 4.003, 0.001);
  // The ADC resolves single DN: the 12-bit frame (1.35 pixels per DN) uses > 2500 distinct values, the 10-bit
  // one > 750.
  auto distinct = [](const cv::Mat1w& m, int levels) {
    std::vector<bool> seen(levels, false);
    for (int i = 0; i < m.rows * m.cols; ++i) seen[m(i / m.cols, i % m.cols)] = true;
    return std::count(seen.begin(), seen.end(), true);
  };
  EXPECT_GT(distinct(r12, 4096), 2500);
  EXPECT_GT(distinct(r10, 1024), 750);
  // 16-bit PNG: MSB-aligned, so full scale reads 255 in 8 bits (value / 257).
  const cv::Mat1w png12 = s12.toPng16(r12), png10 = s10.toPng16(r10);
  for (int i = 0; i < r12.rows * r12.cols; ++i) {
    ASSERT_EQ(png12(i / 256, i % 256), r12(i / 256, i % 256) << 4);
    ASSERT_EQ(png10(i / 256, i % 256), r10(i / 256, i % 256) << 6);
  }
  EXPECT_EQ(s12.toPng16(cv::Mat1w(1, 1, uint16_t{4095}))(0, 0), 65520);
  EXPECT_EQ(std::lround(65520 / 257.0), 255);
}

// ------------------------------------------------------------------------------------------------------------
// Optics

double kernelSecondMoment(const cv::Mat1d& k) {
  const int c = k.cols / 2;
  double m = 0.0, s = 0.0;
  for (int r = 0; r < k.rows; ++r)
    for (int j = 0; j < k.cols; ++j) m += (j - c) * (j - c) * k(r, j), s += k(r, j);
  return m / s;
}

TEST(CameraSensor, GaussianPsfKernelHasTheConfiguredSecondMoment) {
  CameraSensorParams p;
  for (double sigma : {0.2, 0.45, 0.6, 1.0, 2.5}) {
    p.psf_sigma_px = sigma;
    const cv::Mat1d k = psfKernel(p);
    EXPECT_NEAR(cv::sum(k)[0], 1.0, 1e-12);
    EXPECT_NEAR(kernelSecondMoment(k), sigma * sigma, 1e-9) << sigma;
  }
}

TEST(CameraSensor, AiryPsfHasItsFirstDarkRingAt122LambdaN) {
  // sigma 4 px: optics core sigma sqrt(16 - 1/12) = 0.42 lambda N -> first dark ring at 1.2197 lambda N.
  CameraSensorParams p;
  p.psf = "airy";
  p.psf_sigma_px = 4.0;
  const cv::Mat1d k = psfKernel(p);
  const int c = k.cols / 2;
  const double lambda_n = std::sqrt(16.0 - 1.0 / 12.0) / 0.42;
  const double ring_px = 3.8317059702 / M_PI * lambda_n;  // 11.59 px
  EXPECT_NEAR(cv::sum(k)[0], 1.0, 1e-12);
  int argmin = 0;
  for (int j = 6; j <= 16; ++j)
    if (k(c, c + j) < k(c, c + argmin) || argmin == 0) argmin = j;
  EXPECT_EQ(argmin, static_cast<int>(std::lround(ring_px)));
  EXPECT_LT(k(c, c + argmin), 2e-3 * k(c, c));  // dark (pixel-integrated across the zero)
  // The second bright ring (x = 5.136, r = 15.5 px) is brighter than the dark ring.
  EXPECT_GT(k(c, c + 15), 3.0 * k(c, c + argmin));
  // The core: within the first ring the profile falls monotonically.
  for (int j = 1; j < argmin; ++j) EXPECT_LT(k(c, c + j), k(c, c + j - 1));
}

TEST(CameraSensor, PointSourceImageHasThePsfSecondMoment) {
  // A point source through expose(): the DN above black have the second moment sigma^2 = 0.36 px^2 per axis.
  CameraSensorParams p = quietParams();
  p.psf = "gaussian";
  p.psf_sigma_px = 0.6;
  CameraSensor sensor(p, 33, 33, 2);
  cv::Mat1f scene(33, 33, 0.0f);
  scene(16, 16) = reflectanceFor(sensor, 1.8 * p.full_well_e);  // the centre pixel gets 43 %: below full well
  double m0 = 0.0, mx = 0.0, mxx = 0.0, myy = 0.0;
  for (int f = 0; f < 8; ++f) {
    const cv::Mat1w raw = sensor.expose(scene, f);
    for (int r = 0; r < 33; ++r)
      for (int c = 0; c < 33; ++c) {
        const double v = raw(r, c) - p.black_level_dn;
        m0 += v, mx += v * (c - 16), mxx += v * (c - 16) * (c - 16), myy += v * (r - 16) * (r - 16);
      }
  }
  std::printf("point source: second moments %.4f, %.4f px^2 (sigma^2 = 0.36)\n", mxx / m0, myy / m0);
  EXPECT_NEAR(mx / m0, 0.0, 0.01);
  // Shot noise and rounding of the wings move the moment by < 1 %: 3 %.
  EXPECT_NEAR(mxx / m0, 0.36, 0.03 * 0.36);
  EXPECT_NEAR(myy / m0, 0.36, 0.03 * 0.36);
}

TEST(CameraSensor, VignettingCornerToCentreRatio) {
  CameraSensorParams p = quietParams();
  p.vignetting_corner = 0.95;
  const cv::Mat1f v = vignettingMap(p, 101, 81);
  EXPECT_FLOAT_EQ(v(40, 50), 1.0f);
  for (auto [r, c] : std::vector<std::pair<int, int>>{{0, 0}, {0, 100}, {80, 0}, {80, 100}})
    EXPECT_NEAR(v(r, c), 0.95f, 1e-6);
  EXPECT_NEAR(v(40, 0), 1.0 - 0.05 * 50 * 50 / (50.0 * 50 + 40 * 40), 1e-6);  // quadratic in the radius
  // Through expose(): flat field of 10000 e- at the centre.
  CameraSensor sensor(p, 101, 81, 4);
  const cv::Mat1f scene(81, 101, reflectanceFor(sensor, 10000.0));
  double centre = 0.0, corners = 0.0;
  for (int f = 0; f < 16; ++f) {
    const cv::Mat1w raw = sensor.expose(scene, f);
    centre += raw(40, 50) - p.black_level_dn;
    corners += 0.25 * (raw(0, 0) + raw(0, 100) + raw(80, 0) + raw(80, 100) - 4 * p.black_level_dn);
  }
  // Shot noise: 1 % per pixel -> 0.3 % on the ratio of these sums: 1.5 % is 5 sigma (vignetting is 5 %).
  std::printf("vignetting: corner / centre %.4f (set 0.95)\n", corners / centre);
  EXPECT_NEAR(corners / centre, 0.95, 0.015);
}

// ------------------------------------------------------------------------------------------------------------
// Defects

TEST(CameraSensor, HotAndDeadPixelsMatchTheirFractionsAndStayPut) {
  CameraSensorParams p;
  p.enabled = true;
  p.hot_pixel_fraction = 2e-3;
  p.dead_pixel_fraction = 1e-3;
  p.ae_gain = 0.0;
  p.psf = "none";
  const int W = 256, H = 256;
  CameraSensor sensor(p, W, H, 21);
  const cv::Mat1b& d = sensor.defectMap();
  const double n = W * H;
  const int hot = cv::countNonZero(d == CameraSensor::kHot),
            dead = cv::countNonZero(d == CameraSensor::kDead);
  std::printf("defects: %d hot (expected 131 +- 11), %d dead (65.5 +- 8)\n", hot, dead);
  // Binomial: 131 +- 11.4 and 65.5 +- 8.1; 4.5 sigma.
  EXPECT_NEAR(hot, n * 2e-3, 4.5 * std::sqrt(n * 2e-3));
  EXPECT_NEAR(dead, n * 1e-3, 4.5 * std::sqrt(n * 1e-3));
  // Another seed puts them elsewhere; the same seed in the same place.
  CameraSensor same(p, W, H, 21), other(p, W, H, 22);
  EXPECT_EQ(cv::countNonZero(same.defectMap() != d), 0);
  EXPECT_GT(cv::countNonZero(other.defectMap() != d), hot);

  // Dead pixels read the black level in every frame, even in a bright field.
  sensor.setExposure(1e-3);
  const cv::Mat1f bright(H, W, reflectanceFor(sensor, 8000.0));
  for (uint64_t f = 0; f < 3; ++f) {
    const cv::Mat1w raw = sensor.expose(bright, f);
    for (int r = 0; r < H; ++r)
      for (int c = 0; c < W; ++c)
        if (d(r, c) == CameraSensor::kDead) {
          ASSERT_EQ(raw(r, c), std::lround(p.black_level_dn));
        }
  }
  // Hot pixels in the dark: brighter with a longer exposure (mean dark current 2e5 e-/s: ~400 e- at 2 ms).
  const cv::Mat1f dark(H, W, 0.0f);
  sensor.setExposure(2e-3);
  const cv::Mat1w short_raw = sensor.expose(dark, 10);
  sensor.setExposure(8e-3);
  const cv::Mat1w long_raw = sensor.expose(dark, 11);
  double sum_short = 0.0, sum_long = 0.0;
  int brighter = 0, detected = 0, false_detections = 0;
  const double threshold = p.black_level_dn + 10.0 * p.read_noise_e / sensor.gainEPerDn();
  for (int r = 0; r < H; ++r)
    for (int c = 0; c < W; ++c) {
      if (d(r, c) == CameraSensor::kHot) {
        sum_short += short_raw(r, c) - p.black_level_dn, sum_long += long_raw(r, c) - p.black_level_dn;
        brighter += long_raw(r, c) > short_raw(r, c);
        detected += long_raw(r, c) > threshold;
      } else {
        false_detections += long_raw(r, c) > threshold;
      }
    }
  std::printf(
      "hot pixels: 8 ms / 2 ms signal %.3f, %d of %d brighter, %d detected above 10 sigma, %d false\n",
      sum_long / sum_short, brighter, hot, detected, false_detections);
  EXPECT_NEAR(sum_long / sum_short, 4.0, 0.4);  // dark charge grows with the exposure (clipping aside)
  EXPECT_GE(brighter, 0.9 * hot);
  EXPECT_GE(detected,
            0.8 * hot);  // exponential currents: 7.8 +- 2.4 % are below 10 sigma of read noise at 8 ms
  EXPECT_EQ(false_detections, 0);
}

// ------------------------------------------------------------------------------------------------------------
// Auto exposure

/// A horizontal ramp of I/F from 0 to `peak` (a scene whose percentile does not depend on the noise).
cv::Mat1f rampScene(int w, int h, double peak) {
  cv::Mat1f s(h, w);
  for (int c = 0; c < w; ++c) s.col(c).setTo(peak * c / (w - 1));
  return s;
}

CameraSensorParams aeParams() {
  CameraSensorParams p;
  p.enabled = true;
  p.exposure_step_s = 1e-6;
  p.hot_pixel_fraction = p.dead_pixel_fraction = 0.0;
  return p;
}

TEST(CameraSensor, SettledExposurePutsTheMeteredPercentileAtTarget) {
  const CameraSensorParams p = aeParams();
  CameraSensor sensor(p, 128, 128, 8);
  const cv::Mat1f scene = rampScene(128, 128, 0.06);
  sensor.settleExposure(scene);
  FrameExposure info;
  sensor.expose(scene, 0, &info);
  const double target = p.ae_target_fraction * (sensor.maxDn() - p.black_level_dn);
  // Noise (1 %) and the exposure step (0.1 %) move the metered percentile by ~1 %: 2.5 %.
  EXPECT_NEAR(info.metered_dn / target, 1.0, 0.025);
  std::printf("settled exposure %.4f ms, metered %.1f DN, target %.1f DN\n", info.exposure_s * 1e3,
              info.metered_dn, target);
}

TEST(CameraSensor, FlightCameraNeedsAFewMillisecondsOnFlatTerrainAt12DegreeSun) {
  // The radiometric budget of docs/sensors/camera.md: flat average terrain (albedo 0.12) from nadir with the
  // Sun 12 deg high has I/F 0.0298 (McEwen lunar-Lambert); the settled exposure must be 1-3 ms.
  CameraSensorParams p;
  p.enabled = true;
  CameraSensor sensor(p, 256, 256, 1);
  sensor.settleExposure(cv::Mat1f(256, 256, 0.0298f));
  std::printf("flight: %.4g e-/s per unit I/F, gain %.4f e-/DN, settled exposure %.3f ms\n",
              electronRatePerUnitReflectance(p), sensor.gainEPerDn(), sensor.exposureS() * 1e3);
  EXPECT_GT(sensor.exposureS(), 1e-3);
  EXPECT_LT(sensor.exposureS(), 3e-3);
  // Scaling laws of the rate: f-number^-2 and distance^-2.
  CameraSensorParams q = p;
  q.f_number *= 2.0;
  q.heliocentric_distance_au = 2.0;
  EXPECT_NEAR(electronRatePerUnitReflectance(q) * 16.0, electronRatePerUnitReflectance(p),
              1e-12 * electronRatePerUnitReflectance(p));
}

/// Exposure settled for `scene` by a fresh sensor (the ideal exposure of that scene).
double idealExposure(const CameraSensorParams& p, const cv::Mat1f& scene) {
  CameraSensor s(p, scene.cols, scene.rows, 8);
  s.settleExposure(scene);
  return s.exposureS();
}

TEST(CameraSensor, AutoExposureConvergesWithTheConfiguredLag) {
  CameraSensorParams p = aeParams();
  p.ae_gain = 0.3;
  p.ae_max_step_ratio = 100.0;
  const cv::Mat1f before = rampScene(128, 128, 0.06), after = rampScene(128, 128, 0.015);  // 4x darker
  CameraSensor sensor(p, 128, 128, 8);
  sensor.settleExposure(before);
  const double t_star = idealExposure(p, after);
  double e0 = 0.0;
  for (int n = 0; n <= 10; ++n) {
    FrameExposure info;
    sensor.expose(after, n, &info);
    const double e = std::log(t_star / info.exposure_s);
    if (n == 0) e0 = e;
    // Metering noise (~1 %) and quantisation (0.1 %): 0.03 in log exposure.
    EXPECT_NEAR(e, std::pow(1.0 - p.ae_gain, n) * e0, 0.03) << "frame " << n;
  }
  EXPECT_NEAR(e0, std::log(4.0), 0.03);
}

TEST(CameraSensor, AutoExposureRespectsTheMaxStepRatio) {
  CameraSensorParams p = aeParams();
  p.ae_gain = 1.0;
  p.ae_max_step_ratio = 1.25;
  const cv::Mat1f before = rampScene(128, 128, 0.06), after = rampScene(128, 128, 0.015);
  CameraSensor sensor(p, 128, 128, 8);
  sensor.settleExposure(before);
  std::vector<double> t;
  for (int n = 0; n < 10; ++n) {
    FrameExposure info;
    sensor.expose(after, n, &info);
    t.push_back(info.exposure_s);
  }
  // ln 4 / ln 1.25 = 6.2: six full steps, then the remainder.
  for (int n = 1; n <= 6; ++n) EXPECT_NEAR(t[n] / t[n - 1], 1.25, 0.003) << n;
  EXPECT_NEAR(t.back(), idealExposure(p, after), 0.03 * t.back());

  // Brighter by 8: the metered percentile saturates; the exposure steps down by the max ratio until it is
  // not, then settles.
  CameraSensorParams q = aeParams();
  CameraSensor bright(q, 128, 128, 8);
  bright.settleExposure(rampScene(128, 128, 0.015));
  const cv::Mat1f brighter = rampScene(128, 128, 0.12);
  std::vector<double> tb;
  for (int n = 0; n < 14; ++n) {
    FrameExposure info;
    bright.expose(brighter, n, &info);
    tb.push_back(info.exposure_s);
    if (n == 0) {
      EXPECT_GT(info.saturated_fraction, 0.01);
    }
  }
  EXPECT_NEAR(tb[1] / tb[0], 1.0 / q.ae_max_step_ratio, 0.003);
  EXPECT_NEAR(tb.back(), idealExposure(q, brighter), 0.03 * tb.back());
}

// ------------------------------------------------------------------------------------------------------------
// Motion blur and image motion

TEST(CameraSensor, MotionBlurOfAStepEdgeIsARampOfThePathLength) {
  const int W = 64, H = 8, L = 8;
  cv::Mat1f sharp(H, W, 0.0f);
  sharp.colRange(32, W).setTo(1.0f);
  const cv::Mat2f ds(H, W, cv::Vec2f(-0.5f * L, 0.0f)), de(H, W, cv::Vec2f(0.5f * L, 0.0f));
  const cv::Mat1f blurred = motionBlur(sharp, ds, de, 64);
  // Expected: the box of width L over the bilinear step (a ramp between pixels 31 and 32).
  auto step = [](double x) { return std::clamp(x - 31.0, 0.0, 1.0); };
  int in_ramp = 0;
  for (int c = 0; c < W; ++c) {
    double expected = 0.0;
    constexpr int kFine = 20000;
    for (int k = 0; k < kFine; ++k) expected += step(c - 0.5 * L + L * (k + 0.5) / kFine) / kFine;
    // Midpoint rule with L + 1 samples on a piecewise linear profile: error < (L/(L+1))^2 / (8 L) per kink.
    EXPECT_NEAR(blurred(4, c), expected, 0.03) << c;
    in_ramp += blurred(4, c) > 0.02f && blurred(4, c) < 0.98f;
  }
  EXPECT_EQ(in_ramp, L);                                        // a linear ramp L pixels wide
  EXPECT_NEAR(blurred(4, 32) - blurred(4, 31), 1.0 / L, 0.02);  // slope 1 / L (midpoint-rule error 0.011)

  // No motion: the sharp image, bit for bit.
  const cv::Mat2f zero(H, W, cv::Vec2f(0.0f, 0.0f));
  EXPECT_EQ(cv::norm(motionBlur(sharp, zero, zero, 64), sharp, cv::NORM_INF), 0.0);
  // max_samples caps the work (and so the fidelity): 1 sample is the sharp image.
  EXPECT_EQ(cv::norm(motionBlur(sharp, ds, de, 1), sharp, cv::NORM_INF), 0.0);
}

PinholeCamera distortedCamera() {
  CameraSensorParams p;
  return trueCamera(PinholeCamera::fromFieldOfView(160, 120, 60.0), p);
}

TEST(CameraSensor, ImageMotionOfATranslationOverAPlaneIsFTOverZ) {
  const double Z = 50.0, t = 0.5;
  cv::Mat1f depth(120, 160, static_cast<float>(Z));
  depth.row(0).setTo(0.0f);  // no terrain (sky): infinitely far, a translation does not move it
  Pose T_mid_start = Pose::Identity(), T_mid_end = Pose::Identity();
  T_mid_start.translation() = Eigen::Vector3d(-t, 0.0, 0.0);
  T_mid_end.translation() = Eigen::Vector3d(t, 0.0, 0.0);
  cv::Mat2f ds, de;
  const PinholeCamera pinhole = PinholeCamera::fromFieldOfView(160, 120, 60.0);
  imageMotionFromDepth(depth, pinhole, T_mid_start, T_mid_end, &ds, &de);
  const double flow = pinhole.fx() * t / Z;  // 1.386 px
  for (int c = 0; c < 160; ++c) {
    ASSERT_EQ(de(0, c), cv::Vec2f(0.0f, 0.0f));
    ASSERT_EQ(ds(0, c), cv::Vec2f(0.0f, 0.0f));
  }
  for (int r = 1; r < 120; ++r)
    for (int c = 0; c < 160; ++c) {
      ASSERT_NEAR(de(r, c)[0], -flow, 1e-5);
      ASSERT_NEAR(de(r, c)[1], 0.0, 1e-5);
      ASSERT_NEAR(ds(r, c)[0], flow, 1e-5);
    }
  // With distortion: the flow is that of the undistorted point, mapped through the lens (exact, not f t / Z).
  const PinholeCamera camera = distortedCamera();
  imageMotionFromDepth(depth, camera, T_mid_start, T_mid_end, &ds, &de);
  double max_difference_from_pinhole = 0.0;
  for (int r = 1; r < 120; r += 7)
    for (int c = 0; c < 160; c += 7) {
      const Eigen::Vector2d ideal = camera.undistortPixel(Eigen::Vector2d(c, r));
      const Eigen::Vector2d end = camera.distortPixel(ideal - Eigen::Vector2d(camera.fx() * t / Z, 0.0));
      ASSERT_NEAR(de(r, c)[0], end.x() - c, 1e-4) << r << " " << c;
      ASSERT_NEAR(de(r, c)[1], end.y() - r, 1e-4) << r << " " << c;
      max_difference_from_pinhole = std::max(max_difference_from_pinhole, std::abs(de(r, c)[0] + flow));
    }
  EXPECT_GT(max_difference_from_pinhole, 0.05);  // the lens compresses the flow at the corners
}

TEST(CameraSensor, ImageMotionOfARotationIsTheRotationFlowAtAnyDepth) {
  cv::Mat1f depth(120, 160);
  cv::RNG rng(3);
  rng.fill(depth, cv::RNG::UNIFORM, 10.0, 100.0);
  depth.rowRange(0, 20).setTo(0.0f);  // sky: no terrain
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(-0.002, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  Pose T_mid_end = Pose::Identity();
  T_mid_end.linear() = R;
  for (const PinholeCamera& camera : {PinholeCamera::fromFieldOfView(160, 120, 60.0), distortedCamera()}) {
    cv::Mat2f ds, de;
    imageMotionFromDepth(depth, camera, T_mid_end.inverse(), T_mid_end, &ds, &de);
    for (int r = 0; r < 120; r += 3)
      for (int c = 0; c < 160; c += 3) {
        const Eigen::Vector3d b = camera.distortedPixelToBearing(Eigen::Vector2d(c, r));
        const Eigen::Vector2d end = camera.distortPixel(camera.project(R.transpose() * b));
        const Eigen::Vector2d start = camera.distortPixel(camera.project(R * b));
        ASSERT_NEAR(de(r, c)[0], end.x() - c, 1e-4);
        ASSERT_NEAR(de(r, c)[1], end.y() - r, 1e-4);
        ASSERT_NEAR(ds(r, c)[0], start.x() - c, 1e-4);
        ASSERT_NEAR(ds(r, c)[1], start.y() - r, 1e-4);
      }
  }
}

// ------------------------------------------------------------------------------------------------------------
// Cameras: true and calibrated

TEST(CameraSensor, TrueAndCalibratedCameras) {
  CameraSensorParams p;
  const PinholeCamera nominal = PinholeCamera::fromFieldOfView(1024, 1024, 60.0);
  const PinholeCamera truth = trueCamera(nominal, p);
  EXPECT_EQ(truth.distortionModel(), "plumb_bob");
  EXPECT_EQ(truth.distortion(), p.distortion);
  EXPECT_EQ(truth.fx(), nominal.fx());
  // The default lens: a few px at the edge of a 1024 px 60 deg image (k1 = -0.04, k2 = 0.01).
  const double edge =
      (truth.distortPixel(Eigen::Vector2d(0.0, nominal.cy())) - Eigen::Vector2d(0.0, nominal.cy())).norm();
  EXPECT_GT(edge, 3.0);
  EXPECT_LT(edge, 10.0);
  CameraSensorParams none = p;
  none.distortion_model = "none";
  EXPECT_FALSE(trueCamera(nominal, none).hasDistortion());

  // Zero sigmas: calibration is the truth.
  CameraSensorParams exact = p;
  exact.calibration_focal_sigma = exact.calibration_principal_point_sigma_px =
      exact.calibration_distortion_sigma = 0;
  EXPECT_EQ(calibratedCamera(truth, exact, 5), truth);

  // Spreads over many seeds match the sigmas (sd estimate from N = 4000: 1.1 %; 6 % is 5 sigma).
  const int N = 4000;
  std::vector<double> dfx(N), dfy(N), dcx(N), dk1(N), dk2(N);
  for (int s = 0; s < N; ++s) {
    const PinholeCamera c = calibratedCamera(truth, p, static_cast<uint64_t>(s));
    dfx[s] = c.fx() / truth.fx() - 1.0, dfy[s] = c.fy() / truth.fy() - 1.0, dcx[s] = c.cx() - truth.cx();
    dk1[s] = c.distortion()[0] - truth.distortion()[0], dk2[s] = c.distortion()[1] - truth.distortion()[1];
    ASSERT_EQ(c.distortion()[2], 0.0);                                   // zero coefficients stay zero
    ASSERT_EQ(c, calibratedCamera(truth, p, static_cast<uint64_t>(s)));  // deterministic
  }
  auto sd = [](const std::vector<double>& v) {
    const double m = std::accumulate(v.begin(), v.end(), 0.0) / v.size();
    double s2 = 0.0;
    for (double x : v) s2 += (x - m) * (x - m);
    return std::sqrt(s2 / (v.size() - 1));
  };
  EXPECT_NEAR(sd(dfx), p.calibration_focal_sigma, 0.06 * p.calibration_focal_sigma);
  EXPECT_NEAR(sd(dfy), p.calibration_focal_sigma, 0.06 * p.calibration_focal_sigma);
  EXPECT_NEAR(sd(dcx), p.calibration_principal_point_sigma_px, 0.06 * p.calibration_principal_point_sigma_px);
  EXPECT_NEAR(sd(dk1), p.calibration_distortion_sigma, 0.06 * p.calibration_distortion_sigma);
  EXPECT_NEAR(sd(dk2), p.calibration_distortion_sigma * 0.25, 0.06 * 0.25 * p.calibration_distortion_sigma);
  double cross = 0.0;
  for (int s = 0; s < N; ++s) cross += dfx[s] * dfy[s];
  // fx and fy independent: correlation sd 1/sqrt(N) = 0.016; 0.07 is 4.4 sigma.
  EXPECT_LT(std::abs(cross / N) / (sd(dfx) * sd(dfy)), 0.07);
}

// ------------------------------------------------------------------------------------------------------------
// Determinism

TEST(CameraSensor, OutputDependsOnlyOnSeedFrameAndExposure) {
  CameraSensorParams p;
  p.enabled = true;
  const cv::Mat1f scene = rampScene(96, 64, 0.05);
  CameraSensor a(p, 96, 64, 42), b(p, 96, 64, 42), c(p, 96, 64, 43);
  a.settleExposure(scene);
  b.settleExposure(scene);
  c.settleExposure(scene);
  const cv::Mat1w a0 = a.expose(scene, 0);
  const double exposure_after = a.exposureS();
  const cv::Mat1w a1 = a.expose(scene, 1);
  // b skips frame 0 but uses the same exposure for frame 1: the same image (no hidden state in the noise).
  b.setExposure(exposure_after);
  const cv::Mat1w b1 = b.expose(scene, 1);
  EXPECT_EQ(cv::norm(a1, b1, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a0, a1, cv::NORM_INF), 0.0);  // a new frame has new noise
  c.setExposure(exposure_after);
  EXPECT_GT(cv::norm(c.expose(scene, 1), a1, cv::NORM_L1), 0.0);  // another sensor has other noise
}

// ------------------------------------------------------------------------------------------------------------
// YAML

TEST(CameraSensor, YamlRoundTripAndRejection) {
  CameraSensorParams p;
  p.enabled = true;
  p.read_noise_e = 20.0;
  p.bit_depth = 10;
  p.black_level_dn = 16.0;
  p.psf = "airy";
  p.distortion_model = "equidistant";
  p.distortion = {0.01, -0.002, 0.0003, 0.0};
  p.max_blur_samples = 5;
  p.motion_blur = false;
  CameraSensorParams q;
  readYaml(toYaml(p), &q);
  EXPECT_EQ(YAML::Dump(toYaml(q)), YAML::Dump(toYaml(p)));
  EXPECT_EQ(q.distortion, p.distortion);
  EXPECT_EQ(q.mean_photon_energy_j, p.mean_photon_energy_j);  // doubles survive exactly
  EXPECT_EQ(q.exposure_min_s, p.exposure_min_s);
  EXPECT_EQ(q.calibration_focal_sigma, p.calibration_focal_sigma);
  EXPECT_EQ(q.psf, "airy");
  EXPECT_EQ(q.bit_depth, 10);
  // Only the keys present change.
  CameraSensorParams r;
  readYaml(YAML::Load("{read_noise_e: 7.5}"), &r);
  EXPECT_EQ(r.read_noise_e, 7.5);
  EXPECT_EQ(r.full_well_e, CameraSensorParams().full_well_e);

  auto rejects = [](const std::string& yaml, const std::string& field) {
    CameraSensorParams s;
    try {
      readYaml(YAML::Load(yaml), &s);
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
      EXPECT_EQ(YAML::Dump(toYaml(s)), YAML::Dump(toYaml(CameraSensorParams())));  // unchanged on error
      return;
    }
    ADD_FAILURE() << "accepted " << yaml;
  };
  rejects("{read_nois_e: 3}", "read_nois_e");
  rejects("{full_well_e: -5}", "full_well_e");
  rejects("{bit_depth: 12.5}", "bit_depth");
  rejects("{bit_depth: 20}", "bit_depth");
  rejects("{f_number: abc}", "f_number");
  rejects("{psf: [1, 2]}", "psf");
  rejects("{psf: bessel}", "psf");
  rejects("{psf_sigma_px: 0.05}", "psf_sigma_px");
  rejects("{distortion: 3}", "distortion");
  rejects("{distortion: [0.1, 0.2]}", "distortion");
  rejects("{distortion_model: kannala}", "distortion_model");
  rejects("{exposure_max_s: 1e-6}", "exposure_max_s");
  rejects("{ae_gain: 1.5}", "ae_gain");
  rejects("{ae_max_step_ratio: 0.5}", "ae_max_step_ratio");
  rejects("{vignetting_corner: 0}", "vignetting_corner");
  rejects("{enabled: maybe}", "enabled");
  rejects("{prnu: .nan}", "prnu");
  EXPECT_THROW(CameraSensor(p, 0, 10, 1), std::invalid_argument);
}

// ------------------------------------------------------------------------------------------------------------
// Cost

TEST(CameraSensor, CostPer1024Frame) {
  // The flight chain on a 1024 x 1024 frame (single thread, CPU time): image motion + motion blur + expose.
  // The budget is 100 ms (the renderer spends ~1 s per frame); the check allows 2x for cache effects of a
  // loaded machine.
  CameraSensorParams p;
  p.enabled = true;
  const PinholeCamera camera = trueCamera(PinholeCamera::fromFieldOfView(1024, 1024, 60.0), p);
  cv::Mat1f scene(1024, 1024), depth(1024, 1024);
  cv::RNG rng(1);
  rng.fill(scene, cv::RNG::UNIFORM, 0.0, 0.06);
  rng.fill(depth, cv::RNG::UNIFORM, 500.0, 600.0);
  Pose T_start = Pose::Identity(), T_end = Pose::Identity();
  // A 2 ms exposure at 500-600 m: 50 m/s across, 20 m/s down, 10 deg/s of rotation (paths of ~0.3 px).
  T_start.translation() = Eigen::Vector3d(-0.05, 0.0, -0.02);
  T_end.translation() = Eigen::Vector3d(0.05, 0.0, 0.02);
  T_end.linear() = Eigen::AngleAxisd(0.00035, Eigen::Vector3d::UnitX()).toRotationMatrix();
  cv::Mat2f ds, de;
  // Thread CPU time: the cost of this thread's work, not inflated by other processes on a shared machine.
  struct Clock {
    static double now() {
      timespec ts{};
      clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
      return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
    }
  };
  auto ms = [](double a, double b) { return b - a; };
  const auto t0 = Clock::now();
  imageMotionFromDepth(depth, camera, T_start, T_end, &ds, &de);  // first call: builds the bearing cache
  const auto t1 = Clock::now();
  CameraSensor sensor(p, 1024, 1024, 1);
  const auto t2 = Clock::now();
  sensor.settleExposure(scene);
  const auto t3 = Clock::now();
  double motion = 1e9, blur = 1e9, expose = 1e9;
  for (int i = 0; i < 3; ++i) {
    const auto a = Clock::now();
    imageMotionFromDepth(depth, camera, T_start, T_end, &ds, &de);
    const auto b = Clock::now();
    const cv::Mat1f blurred = motionBlur(scene, ds, de, p.max_blur_samples);
    const auto c = Clock::now();
    sensor.expose(blurred, i);
    const auto d = Clock::now();
    motion = std::min(motion, ms(a, b)), blur = std::min(blur, ms(b, c)), expose = std::min(expose, ms(c, d));
  }
  std::printf(
      "1024x1024: imageMotionFromDepth %.1f ms (first call with bearing cache %.1f ms), motionBlur %.1f ms, "
      "expose %.1f ms, total %.1f ms; sensor construction %.1f ms, settleExposure %.1f ms\n",
      motion, ms(t0, t1), blur, expose, motion + blur + expose, ms(t1, t2), ms(t2, t3));
#ifdef NDEBUG  // the budget is for optimised builds
  EXPECT_LT(motion + blur + expose, 200.0);
#endif
}

}  // namespace
}  // namespace planetary_vo::sensors

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
