#include "planetary_vo/render/terrain.h"

#include <cmath>

#include "noise.h"

namespace planetary_vo::render {

using detail::gradientNoise;

LunarTerrain::LunarTerrain(std::shared_ptr<const LunarDem> dem, const DemPlacement& placement,
                           const TerrainParams& params)
    : dem_(std::move(dem)), placement_(placement), params_(params), craters_(params.seed, params.craters) {
  double wavelength = params_.roughness_max_wavelength_m;
  for (int octave = 0; octave < 40; ++octave, wavelength *= 0.5)
    octave_amplitude_[octave] = params_.roughness_rms_1m * std::pow(wavelength, params_.hurst);
  cos_heading_ = std::cos(placement_.heading_rad);
  sin_heading_ = std::sin(placement_.heading_rad);
}

double LunarTerrain::demHeight(double x, double y) const {
  // Same arithmetic as DemPlacement::worldToDem, without its two trigonometric calls per query.
  const double c = cos_heading_, s = sin_heading_;
  return dem_->height(placement_.origin_east_m + c * x + s * y, placement_.origin_north_m - s * x + c * y) -
         placement_.datum_m;
}

LunarTerrain::Sample LunarTerrain::sample(double x, double y, double lod_m) const {
  Sample s;
  s.height_m = demHeight(x, y);

  // Fractal roughness: octaves of gradient noise from the largest wavelength down to two footprints; the last
  // octave fades in over one octave so the surface changes continuously with the LOD.
  const double min_wavelength = 2.0 * lod_m;
  double wavelength = params_.roughness_max_wavelength_m;
  const uint64_t rough_seed = params_.seed * 0x9E3779B97F4A7C15ull + 17;
  for (int octave = 0; wavelength >= min_wavelength && octave < 40; ++octave, wavelength *= 0.5) {
    const double ratio = wavelength / min_wavelength;
    const double weight = ratio >= 2.0 ? 1.0 : std::log2(ratio);
    const double amplitude = octave_amplitude_[octave];
    // A per-octave offset decorrelates the lattices of successive octaves (no grid-aligned artefacts).
    s.height_m +=
        weight * amplitude *
        gradientNoise(rough_seed + octave, x / wavelength + 0.37 * octave, y / wavelength - 0.71 * octave);
  }

  const CraterField::Contribution c = craters_.evaluate(x, y, lod_m);
  s.height_m += c.height_m;

  // Albedo: mature regolith with km-scale patches, plus fresh crater ejecta.
  const uint64_t albedo_seed = params_.seed * 31 + 5;
  s.albedo = params_.albedo +
             params_.albedo_variation * (gradientNoise(albedo_seed, x / 3000.0, y / 3000.0) +
                                         0.5 * gradientNoise(albedo_seed + 1, x / 700.0, y / 700.0) +
                                         0.3 * detail::smoothstep(80.0, 40.0, lod_m) *
                                             gradientNoise(albedo_seed + 2, x / 80.0, y / 80.0)) +
             c.albedo;
  return s;
}

void LunarTerrain::sampleGrid(int64_t i0, int64_t j0, int nx, int ny, double spacing, double lod_m,
                              float* height, float* albedo) const {
  // Every step mirrors sample(): same expressions, same summation order per node, so the baked lattice is
  // bit-identical to point sampling (the unit test checks it).
  const size_t n = static_cast<size_t>(nx) * ny;
  std::vector<double> xs(nx), ys(ny), h(n), a(n, 0.0), noise1(n, 0.0), noise2(n, 0.0), noise3(n, 0.0);
  for (int i = 0; i < nx; ++i) xs[i] = static_cast<double>(i0 + i) * spacing;
  for (int j = 0; j < ny; ++j) ys[j] = static_cast<double>(j0 + j) * spacing;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) h[static_cast<size_t>(j) * nx + i] = demHeight(xs[i], ys[j]);

  std::vector<double> u(nx), v(ny);
  std::vector<int8_t> table;
  std::vector<int64_t> cells;
  const double min_wavelength = 2.0 * lod_m;
  double wavelength = params_.roughness_max_wavelength_m;
  const uint64_t rough_seed = params_.seed * 0x9E3779B97F4A7C15ull + 17;
  for (int octave = 0; wavelength >= min_wavelength && octave < 40; ++octave, wavelength *= 0.5) {
    const double ratio = wavelength / min_wavelength;
    const double weight = ratio >= 2.0 ? 1.0 : std::log2(ratio);
    const double amplitude = octave_amplitude_[octave];
    for (int i = 0; i < nx; ++i) u[i] = xs[i] / wavelength + 0.37 * octave;
    for (int j = 0; j < ny; ++j) v[j] = ys[j] / wavelength - 0.71 * octave;
    detail::addGradientNoiseGrid(rough_seed + octave, u, v, weight * amplitude, &h, &table, &cells);
  }

  std::vector<double> crater_h(n, 0.0), crater_a(n, 0.0);
  craters_.evaluateGrid(xs, ys, lod_m, crater_h.data(), crater_a.data());

  const uint64_t albedo_seed = params_.seed * 31 + 5;
  auto albedoNoise = [&](uint64_t seed, double scale, std::vector<double>* out) {
    for (int i = 0; i < nx; ++i) u[i] = xs[i] / scale;
    for (int j = 0; j < ny; ++j) v[j] = ys[j] / scale;
    detail::addGradientNoiseGrid(seed, u, v, 1.0, out, &table, &cells);
  };
  albedoNoise(albedo_seed, 3000.0, &noise1);
  albedoNoise(albedo_seed + 1, 700.0, &noise2);
  const double fine = detail::smoothstep(80.0, 40.0, lod_m);
  if (fine != 0.0) albedoNoise(albedo_seed + 2, 80.0, &noise3);
  for (size_t k = 0; k < n; ++k) {
    height[k] = static_cast<float>(h[k] + crater_h[k]);
    albedo[k] = static_cast<float>(
        params_.albedo + params_.albedo_variation * (noise1[k] + 0.5 * noise2[k] + 0.3 * fine * noise3[k]) +
        crater_a[k]);
  }
}

Eigen::Vector3d LunarTerrain::normal(double x, double y, double lod_m) const {
  const double d = lod_m;
  const double dhdx = (height(x + d, y, lod_m) - height(x - d, y, lod_m)) / (2 * d);
  const double dhdy = (height(x, y + d, lod_m) - height(x, y - d, lod_m)) / (2 * d);
  return Eigen::Vector3d(-dhdx, -dhdy, 1.0).normalized();
}

double LunarTerrain::maxProceduralReliefM() const {
  const double dmax = params_.craters.max_diameter_m;
  return 0.24 * dmax +
         2.0 * params_.roughness_rms_1m * std::pow(params_.roughness_max_wavelength_m, params_.hurst);
}

}  // namespace planetary_vo::render
