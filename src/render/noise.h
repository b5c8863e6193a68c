#pragma once
/// Internal: deterministic hashing and gradient noise shared by the procedural terrain. Everything is a pure
/// function of (seed, integer coordinates), so any point of the infinite terrain can be evaluated in any
/// order, by any thread, with bit-identical results.

#include <cmath>
#include <cstdint>

namespace planetary_vo::render::detail {

inline uint64_t mix64(uint64_t z) {  // splitmix64 finaliser
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

inline uint64_t hash3(uint64_t seed, int64_t a, int64_t b, int64_t c = 0) {
  uint64_t h = mix64(seed ^ 0x51ED270B27A1F3D5ull);
  h = mix64(h ^ static_cast<uint64_t>(a));
  h = mix64(h ^ (static_cast<uint64_t>(b) * 0x9E3779B97F4A7C15ull));
  return mix64(h ^ (static_cast<uint64_t>(c) * 0xC2B2AE3D27D4EB4Full));
}

/// Uniform in [0, 1) from the 53 high bits.
inline double toUnit(uint64_t h) { return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0); }

/// Sequential deterministic generator for a few values drawn from one hash.
struct HashRng {
  uint64_t state;
  explicit HashRng(uint64_t s) : state(s) {}
  double uniform() {
    state = mix64(state);
    return toUnit(state);
  }
};

inline double fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

/// 2D gradient (Perlin) noise, output roughly in [-0.7, 0.7], zero at lattice points, C2 smooth.
inline double gradientNoise(uint64_t seed, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double dx = x - fx, dy = y - fy;
  auto grad = [&](int64_t i, int64_t j, double px, double py) {
    // 16 unit gradients picked by hash bits: avoids trigonometry in the innermost loop of the terrain.
    static const double kGx[16] = {1,  0.924,  0.707,  0.383,  0, -0.383, -0.707, -0.924,
                                   -1, -0.924, -0.707, -0.383, 0, 0.383,  0.707,  0.924};
    const int k = static_cast<int>(hash3(seed, i, j) >> 60);
    return kGx[k] * px + kGx[(k + 12) & 15] * py;
  };
  const double n00 = grad(ix, iy, dx, dy), n10 = grad(ix + 1, iy, dx - 1, dy);
  const double n01 = grad(ix, iy + 1, dx, dy - 1), n11 = grad(ix + 1, iy + 1, dx - 1, dy - 1);
  const double u = fade(dx), v = fade(dy);
  return (n00 * (1 - u) + n10 * u) * (1 - v) + (n01 * (1 - u) + n11 * u) * v;
}

inline double smoothstep(double e0, double e1, double x) {
  const double t = std::fmin(1.0, std::fmax(0.0, (x - e0) / (e1 - e0)));
  return t * t * (3 - 2 * t);
}

}  // namespace planetary_vo::render::detail
