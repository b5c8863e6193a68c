#pragma once
/// Internal to the camera model: deterministic hashing (splitmix64 finaliser) and the random draws built on
/// it, and the 1D Gaussian PSF factor. Everything is a pure function of its arguments, so results do not
/// depend on the order of evaluation or on threads.

#include <cmath>
#include <cstdint>

#include <opencv2/core.hpp>

namespace planetary_vo::sensors::camera_detail {

/// splitmix64 finaliser (a bijection of 64-bit integers with full avalanche).
inline uint64_t mix64(uint64_t z) {
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

/// Hash of (seed, stream, a, b): independent streams of values per (stream, a, b).
inline uint64_t hash4(uint64_t seed, uint64_t stream, int64_t a, int64_t b) {
  uint64_t h = mix64(seed + 0x9E3779B97F4A7C15ull);
  h = mix64(h ^ (stream * 0xC2B2AE3D27D4EB4Full + 0x165667B19E3779F9ull));
  h = mix64(h ^ (static_cast<uint64_t>(a) * 0x9E3779B97F4A7C15ull + 0x27D4EB2F165667C5ull));
  return mix64(h ^ (static_cast<uint64_t>(b) * 0xD6E8FEB86659FD93ull + 0x94D049BB133111EBull));
}

/// Uniform in [0, 1) from the 53 high bits.
inline double toUnit(uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }
/// Uniform in (0, 1] (safe for log).
inline double toUnitOpen(uint64_t h) {
  return static_cast<double>((h >> 11) + 1) * (1.0 / 9007199254740992.0);
}

/// Uniform in (0, 1] with 24 bits (float: for the per-pixel noise, where speed matters more than the far
/// tail; the smallest value 2^-24 bounds a Box-Muller normal at 5.8 sigma).
inline float toUnitOpenF(uint64_t h) { return static_cast<float>((h >> 40) + 1) * (1.0f / 16777216.0f); }
inline float toUnitF(uint64_t h) { return static_cast<float>(h >> 40) * (1.0f / 16777216.0f); }

/// A standard normal from one hash (Box-Muller with two uniforms derived from it).
inline double normalFromHash(uint64_t h) {
  const double u1 = toUnitOpen(h), u2 = toUnit(mix64(h ^ 0x632BE59BD9B4E019ull));
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

/// Poisson draw of mean `mean` (small: the cost is ~mean iterations) by inversion of the CDF at uniform u.
inline double poissonInverse(double mean, double u) {
  double p = std::exp(-mean), cdf = p;
  int k = 0;
  while (u > cdf && k < 1000) {
    ++k;
    p *= mean / k;
    cdf += p;
  }
  return k;
}

/// The optics sigma (px) of the Gaussian that, integrated over the pixels, gives a kernel of second moment
/// sigma_total^2 (about sqrt(sigma_total^2 - 1/12) for a wide PSF; solved exactly).
double gaussianOpticsSigma(double sigma_total_px);
/// Column kernel of that pixel-integrated Gaussian (integrated over [k - 1/2, k + 1/2], normalised): its
/// second moment is sigma_total^2.
cv::Mat1d gaussianPsf1d(double sigma_total_px);

}  // namespace planetary_vo::sensors::camera_detail
