#pragma once
/// Internal: deterministic hashing and gradient noise shared by the procedural terrain. Everything is a pure
/// function of (seed, integer coordinates), so any point of the infinite terrain can be evaluated in any
/// order, by any thread, with bit-identical results.

#include <cmath>
#include <cstdint>
#include <vector>

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

// 16 unit gradients picked by hash bits: avoids trigonometry in the innermost loop of the terrain.
constexpr double kGradX[16] = {1,  0.924,  0.707,  0.383,  0, -0.383, -0.707, -0.924,
                               -1, -0.924, -0.707, -0.383, 0, 0.383,  0.707,  0.924};

/// Gradient index (0-15) of lattice corner (i, j).
inline int gradientIndex(uint64_t seed, int64_t i, int64_t j) {
  return static_cast<int>(hash3(seed, i, j) >> 60);
}
inline double gradientDot(int k, double px, double py) { return kGradX[k] * px + kGradX[(k + 12) & 15] * py; }

/// Perlin interpolation of the four corner dot products; shared by the point and grid evaluations so both
/// give bit-identical values.
inline double gradientBlend(int k00, int k10, int k01, int k11, double dx, double dy) {
  const double n00 = gradientDot(k00, dx, dy), n10 = gradientDot(k10, dx - 1, dy);
  const double n01 = gradientDot(k01, dx, dy - 1), n11 = gradientDot(k11, dx - 1, dy - 1);
  const double u = fade(dx), v = fade(dy);
  return (n00 * (1 - u) + n10 * u) * (1 - v) + (n01 * (1 - u) + n11 * u) * v;
}

/// 2D gradient (Perlin) noise, output roughly in [-0.7, 0.7], zero at lattice points, C2 smooth.
inline double gradientNoise(uint64_t seed, double x, double y) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  return gradientBlend(gradientIndex(seed, ix, iy), gradientIndex(seed, ix + 1, iy),
                       gradientIndex(seed, ix, iy + 1), gradientIndex(seed, ix + 1, iy + 1), x - fx, y - fy);
}

/// gradientNoise(seed, u[i], v[j]) for a separable grid (u, v increasing), added times `scale` to
/// out[j * nu + i]. Each lattice corner is hashed once per grid instead of four times per sample: on a
/// terrain chunk the fine octaves have ~1 corner per 4 samples and the coarse ones a handful per chunk.
/// Bit-identical to gradientNoise (same arithmetic, same order).
inline void addGradientNoiseGrid(uint64_t seed, const std::vector<double>& u, const std::vector<double>& v,
                                 double scale, std::vector<double>* out, std::vector<int8_t>* table,
                                 std::vector<int64_t>* ix) {
  const int nu = static_cast<int>(u.size()), nv = static_cast<int>(v.size());
  ix->resize(nu + nv);
  for (int i = 0; i < nu; ++i) (*ix)[i] = static_cast<int64_t>(std::floor(u[i]));
  for (int j = 0; j < nv; ++j) (*ix)[nu + j] = static_cast<int64_t>(std::floor(v[j]));
  const int64_t i0 = (*ix)[0], j0 = (*ix)[nu];
  const int64_t mx = (*ix)[nu - 1] - i0 + 2, my = (*ix)[nu + nv - 1] - j0 + 2;
  table->resize(static_cast<size_t>(mx * my));
  for (int64_t b = 0; b < my; ++b)
    for (int64_t a = 0; a < mx; ++a)
      (*table)[b * mx + a] = static_cast<int8_t>(gradientIndex(seed, i0 + a, j0 + b));
  for (int j = 0; j < nv; ++j) {
    const int64_t iy = (*ix)[nu + j];
    const double dy = v[j] - static_cast<double>(iy);
    const int8_t* row0 = table->data() + (iy - j0) * mx - i0;
    const int8_t* row1 = row0 + mx;
    double* o = out->data() + static_cast<size_t>(j) * nu;
    for (int i = 0; i < nu; ++i) {
      const int64_t xi = (*ix)[i];
      o[i] += scale * gradientBlend(row0[xi], row0[xi + 1], row1[xi], row1[xi + 1],
                                    u[i] - static_cast<double>(xi), dy);
    }
  }
}

inline double smoothstep(double e0, double e1, double x) {
  const double t = std::fmin(1.0, std::fmax(0.0, (x - e0) / (e1 - e0)));
  return t * t * (3 - 2 * t);
}

}  // namespace planetary_vo::render::detail
