#include "planetary_vo/terrain/surface_analysis.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace planetary_vo::terrain {

namespace {

/// Half-width (in cells) of each row of the disc, from row offset -R to R.
std::vector<int> discHalfWidths(double cell_size_m, double footprint_diameter_m) {
  if (!(cell_size_m > 0.0) || !(footprint_diameter_m >= 2.0 * cell_size_m))
    throw std::invalid_argument("surface analysis: the footprint diameter must be at least two cells");
  const double r = 0.5 * footprint_diameter_m / cell_size_m;  // radius in cells
  const double r2 = r * r * (1.0 + 1e-12);                    // a centre on the circle is in
  const int R = static_cast<int>(std::floor(r * (1.0 + 1e-12)));
  std::vector<int> half(2 * R + 1);
  for (int dj = -R; dj <= R; ++dj) {
    int w = 0;
    while ((w + 1.0) * (w + 1.0) + double(dj) * dj <= r2) ++w;
    half[dj + R] = w;
  }
  return half;
}

}  // namespace

std::vector<cv::Point> footprintOffsets(double cell_size_m, double footprint_diameter_m) {
  const std::vector<int> half = discHalfWidths(cell_size_m, footprint_diameter_m);
  const int R = static_cast<int>(half.size()) / 2;
  std::vector<cv::Point> offsets;
  for (int dj = -R; dj <= R; ++dj)
    for (int di = -half[dj + R]; di <= half[dj + R]; ++di) offsets.emplace_back(di, dj);
  return offsets;
}

SurfaceMaps analyzeSurface(const GridGeometry& g, const cv::Mat& elevation_m, double footprint_diameter_m) {
  if (elevation_m.type() != CV_32FC1 || elevation_m.rows != g.rows || elevation_m.cols != g.cols)
    throw std::invalid_argument("surface analysis: the elevation must be a rows x cols CV_32F layer");
  const std::vector<int> half = discHalfWidths(g.cell_size_m, footprint_diameter_m);
  const std::vector<cv::Point> offsets = footprintOffsets(g.cell_size_m, footprint_diameter_m);
  const int R = static_cast<int>(half.size()) / 2;
  const double n = static_cast<double>(offsets.size());
  // sum of dx^2 over the disc (in cells^2) = sum of dy^2 (the disc is symmetric under x <-> y); the sums of
  // dx, dy and dx dy vanish, so the least-squares normal equations are diagonal.
  double sum_dx2 = 0.0;
  for (const cv::Point& o : offsets) sum_dx2 += double(o.x) * o.x;

  // Row prefix sums: of z (unknown = 0), of col * z, and of the number of unknown cells.
  const int cols = g.cols, rows = g.rows, stride = cols + 1;
  std::vector<double> p_z(static_cast<size_t>(rows) * stride), p_cz(p_z.size());
  std::vector<int> p_nan(p_z.size());
  for (int row = 0; row < rows; ++row) {
    const float* z = elevation_m.ptr<float>(row);
    const size_t base = static_cast<size_t>(row) * stride;
    p_z[base] = p_cz[base] = 0.0;
    p_nan[base] = 0;
    for (int col = 0; col < cols; ++col) {
      const bool known = std::isfinite(z[col]);
      const double v = known ? z[col] : 0.0;
      p_z[base + col + 1] = p_z[base + col] + v;
      p_cz[base + col + 1] = p_cz[base + col] + col * v;
      p_nan[base + col + 1] = p_nan[base + col] + (known ? 0 : 1);
    }
  }

  const float nan = std::numeric_limits<float>::quiet_NaN();
  SurfaceMaps out{g.newLayer(nan), g.newLayer(nan)};
  const double cell = g.cell_size_m;
  for (int row = R; row + R < rows; ++row) {
    float* slope = out.slope_deg.ptr<float>(row);
    float* rough = out.roughness_m.ptr<float>(row);
    for (int col = R; col + R < cols; ++col) {
      double s_z = 0.0, s_dxz = 0.0, s_dyz = 0.0;  // moments over the disc, offsets in cells
      int unknown = 0;
      for (int dj = -R; dj <= R; ++dj) {
        const size_t base = static_cast<size_t>(row + dj) * stride;
        const int a = col - half[dj + R], b = col + half[dj + R] + 1;
        const double seg_z = p_z[base + b] - p_z[base + a];
        s_z += seg_z;
        s_dxz += (p_cz[base + b] - p_cz[base + a]) - col * seg_z;
        s_dyz += dj * seg_z;
        unknown += p_nan[base + b] - p_nan[base + a];
      }
      if (unknown > 0) continue;
      const double mean = s_z / n;
      const double gx_per_cell = s_dxz / sum_dx2, gy_per_cell = s_dyz / sum_dx2;  // dz per cell step
      slope[col] = static_cast<float>(std::atan(std::hypot(gx_per_cell, gy_per_cell) / cell) * 180.0 / M_PI);
      double worst = 0.0;
      for (const cv::Point& o : offsets) {
        const double z = elevation_m.ptr<float>(row + o.y)[col + o.x];
        worst = std::max(worst, std::abs(z - (mean + gx_per_cell * o.x + gy_per_cell * o.y)));
      }
      rough[col] = static_cast<float>(worst);
    }
  }
  return out;
}

}  // namespace planetary_vo::terrain
