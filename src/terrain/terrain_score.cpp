#include "planetary_vo/terrain/terrain_score.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace planetary_vo::terrain {
namespace {

const cv::Mat& layer(const GridSet& grids, const char* name, const char* which) {
  const auto it = grids.layers.find(name);
  if (it == grids.layers.end() || it->second.type() != CV_32FC1 || it->second.rows != grids.geometry.rows ||
      it->second.cols != grids.geometry.cols)
    throw std::invalid_argument(std::string("scoreTerrain: the ") + which + " has no layer " + name +
                                " of its grid's size");
  return it->second;
}

double ratio(double a, double b) { return b > 0 ? a / b : std::numeric_limits<double>::quiet_NaN(); }

}  // namespace

TerrainScore scoreTerrain(const GridSet& truth, const GridSet& estimate, const HazardThresholds& thresholds) {
  if (truth.geometry != estimate.geometry)
    throw std::invalid_argument(
        "scoreTerrain: the estimate's grid is not the truth's (origin, cell size, size)");
  const cv::Mat& z_true = layer(truth, "elevation_m", "truth");
  const cv::Mat& z_est = layer(estimate, "elevation_m", "estimate");
  const cv::Mat& s_true = layer(truth, "slope_deg", "truth");
  const cv::Mat& s_est = layer(estimate, "slope_deg", "estimate");
  const cv::Mat& r_true = layer(truth, "roughness_m", "truth");
  const cv::Mat& r_est = layer(estimate, "roughness_m", "estimate");
  const cv::Mat hazard_true = hazardMask(s_true, r_true, thresholds);
  // The surface is scored wherever the estimate has a slope and roughness; the hazards as the estimate
  // publishes them: its cells seen in shadow unknown (terrain/shadow_map.h), so not scored, and its cells
  // with shading relief above the threshold hazards (terrain/shading_relief.h).
  const cv::Mat surface_est = hazardMask(s_est, r_est, thresholds);
  const auto shadow = estimate.layers.find("shadow_fraction");
  const auto shading = estimate.layers.find("shading_slope_deg");
  const cv::Mat hazard_est =
      hazardMask(s_est, r_est, shadow == estimate.layers.end() ? cv::Mat() : shadow->second,
                 shading == estimate.layers.end() ? cv::Mat() : shading->second,
                 shadingWithinMargin(estimate, thresholds), thresholds);
  TerrainScore score;
  score.cells = truth.geometry.rows * truth.geometry.cols;
  int true_elevation = 0, true_surface = 0;
  double sz = 0, szz = 0, sss = 0, srr = 0;
  std::vector<double> slope_errors;
  double ss = 0, sr = 0;
  const SurfaceSigmas sigmas = surfaceSigmas(estimate);
  int s1 = 0, s2 = 0, r1 = 0, r2 = 0;
  for (int row = 0; row < truth.geometry.rows; ++row) {
    for (int col = 0; col < truth.geometry.cols; ++col) {
      const float zt = z_true.at<float>(row, col), ze = z_est.at<float>(row, col);
      if (std::isfinite(zt)) {
        ++true_elevation;
        if (std::isfinite(ze)) {
          ++score.cells_elevation;
          sz += ze - zt;
          szz += (ze - zt) * (ze - zt);
        }
      }
      const uint8_t ht = hazard_true.at<uint8_t>(row, col), he = hazard_est.at<uint8_t>(row, col);
      if (ht == kUnknown) continue;
      ++true_surface;
      if (surface_est.at<uint8_t>(row, col) == kUnknown) continue;
      ++score.cells_surface;
      sss += std::pow(s_est.at<float>(row, col) - s_true.at<float>(row, col), 2);
      slope_errors.push_back(std::abs(s_est.at<float>(row, col) - s_true.at<float>(row, col)));
      ss += s_est.at<float>(row, col) - s_true.at<float>(row, col);
      sr += r_est.at<float>(row, col) - r_true.at<float>(row, col);
      srr += std::pow(r_est.at<float>(row, col) - r_true.at<float>(row, col), 2);
      if (sigmas.available) {
        const float ssig = sigmas.slope_deg.at<float>(row, col),
                    rsig = sigmas.roughness_m.at<float>(row, col);
        if (std::isfinite(ssig) && std::isfinite(rsig)) {
          ++score.cells_sigma;
          const double es = std::abs(s_est.at<float>(row, col) - s_true.at<float>(row, col));
          const double er = std::abs(r_est.at<float>(row, col) - r_true.at<float>(row, col));
          s1 += es <= ssig;
          s2 += es <= 2.0 * ssig;
          r1 += er <= rsig;
          r2 += er <= 2.0 * rsig;
        }
      }
      if (ht == kHazard && he == kHazard) ++score.hazard_tp;
      if (ht == kSafe && he == kHazard) ++score.hazard_fp;
      if (ht == kHazard && he == kSafe) ++score.hazard_fn;
      if (ht == kSafe && he == kSafe) ++score.hazard_tn;
    }
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  score.elevation_coverage = ratio(score.cells_elevation, true_elevation);
  score.elevation_rmse_m = score.cells_elevation > 0 ? std::sqrt(szz / score.cells_elevation) : nan;
  score.elevation_mean_error_m = score.cells_elevation > 0 ? sz / score.cells_elevation : nan;
  score.surface_coverage = ratio(score.cells_surface, true_surface);
  score.slope_rmse_deg = score.cells_surface > 0 ? std::sqrt(sss / score.cells_surface) : nan;
  score.roughness_rmse_m = score.cells_surface > 0 ? std::sqrt(srr / score.cells_surface) : nan;
  auto quantile = [&](double q) {
    if (slope_errors.empty()) return nan;
    const auto k = static_cast<std::ptrdiff_t>(q * static_cast<double>(slope_errors.size() - 1));
    std::nth_element(slope_errors.begin(), slope_errors.begin() + k, slope_errors.end());
    return slope_errors[static_cast<size_t>(k)];
  };
  score.slope_mean_error_deg = score.cells_surface > 0 ? ss / score.cells_surface : nan;
  score.roughness_mean_error_m = score.cells_surface > 0 ? sr / score.cells_surface : nan;
  score.slope_error_median_deg = quantile(0.5);
  score.slope_error_p90_deg = quantile(0.9);
  score.hazard_precision = ratio(score.hazard_tp, score.hazard_tp + score.hazard_fp);
  score.hazard_recall = ratio(score.hazard_tp, score.hazard_tp + score.hazard_fn);
  score.slope_within_1sigma = ratio(s1, score.cells_sigma);
  score.slope_within_2sigma = ratio(s2, score.cells_sigma);
  score.roughness_within_1sigma = ratio(r1, score.cells_sigma);
  score.roughness_within_2sigma = ratio(r2, score.cells_sigma);
  return score;
}

SiteCheck checkSite(const GridSet& truth, const LandingSite& site, const HazardThresholds& thresholds,
                    const LandingSiteParams& params) {
  const cv::Mat& slope = layer(truth, "slope_deg", "truth");
  const cv::Mat& roughness = layer(truth, "roughness_m", "truth");
  const cv::Mat hazard = hazardMask(slope, roughness, thresholds);
  const GridGeometry& g = truth.geometry;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  SiteCheck check;
  int col = 0, row = 0;
  const bool inside = g.cellAt(site.x_m, site.y_m, &col, &row);
  check.true_slope_deg = inside ? slope.at<float>(row, col) : nan;
  check.true_roughness_m = inside ? roughness.at<float>(row, col) : nan;
  check.nearest_unsafe_m = nan;
  const double clearance = params.min_clearance_m;
  const int reach = static_cast<int>(std::ceil(3.0 * clearance / g.cell_size_m)) + 1;
  for (int dr = -reach; dr <= reach; ++dr) {
    for (int dc = -reach; dc <= reach; ++dc) {
      const double d = std::hypot(dc * g.cell_size_m, dr * g.cell_size_m);
      if (d > 3.0 * clearance) continue;
      const int c = col + dc, r = row + dr;
      const uint8_t h = (inside && g.contains(c, r)) ? hazard.at<uint8_t>(r, c) : uint8_t{kUnknown};
      if (h != kSafe && !(d >= check.nearest_unsafe_m)) check.nearest_unsafe_m = d;
      if (d > clearance) continue;
      ++check.cells_checked;
      check.cells_hazard += h == kHazard ? 1 : 0;
      check.cells_unknown += h == kUnknown ? 1 : 0;
    }
  }
  check.truly_safe = inside && check.cells_hazard == 0 && check.cells_unknown == 0;
  return check;
}

GridSet truthInNavigationFrame(const GridSet& truth, double error_x_m, double error_y_m, double error_z_m) {
  if (!std::isfinite(error_x_m) || !std::isfinite(error_y_m) || !std::isfinite(error_z_m))
    throw std::invalid_argument("truthInNavigationFrame: the navigation error is not finite");
  const GridGeometry& g = truth.geometry;
  const long dc = std::lround(error_x_m / g.cell_size_m), dr = std::lround(error_y_m / g.cell_size_m);
  GridSet moved = truth;
  for (auto& [name, values] : moved.layers) {
    const cv::Mat& from = truth.layers.at(name);
    if (from.type() != CV_32FC1 || from.rows != g.rows || from.cols != g.cols)
      throw std::invalid_argument("truthInNavigationFrame: the layer " + name + " is not CV_32F of its grid");
    cv::Mat to = g.newLayer();
    // to(row, col) = from(row - dr, col - dc): the cell at x shows the ground at x - e.
    for (int row = 0; row < g.rows; ++row)
      for (int col = 0; col < g.cols; ++col) {
        const long r = row - dr, c = col - dc;
        if (r >= 0 && c >= 0 && r < g.rows && c < g.cols) to.at<float>(row, col) = from.at<float>(r, c);
      }
    if (name == "elevation_m") to += static_cast<float>(error_z_m);
    values = to;
  }
  moved.parameters["navigation_error_x_m"] = error_x_m;
  moved.parameters["navigation_error_y_m"] = error_y_m;
  moved.parameters["navigation_error_z_m"] = error_z_m;
  return moved;
}

std::string toJson(const TerrainScore& s) {
  std::ostringstream out;
  out.precision(10);
  auto num = [&](const char* key, double v, bool last = false) {
    out << "  \"" << key << "\": ";
    if (std::isfinite(v))
      out << v;
    else
      out << "null";
    out << (last ? "\n" : ",\n");
  };
  out << "{\n";
  num("cells", s.cells);
  num("cells_elevation", s.cells_elevation);
  num("elevation_coverage", s.elevation_coverage);
  num("elevation_rmse_m", s.elevation_rmse_m);
  num("elevation_mean_error_m", s.elevation_mean_error_m);
  num("cells_surface", s.cells_surface);
  num("surface_coverage", s.surface_coverage);
  num("slope_rmse_deg", s.slope_rmse_deg);
  num("roughness_rmse_m", s.roughness_rmse_m);
  num("slope_error_median_deg", s.slope_error_median_deg);
  num("slope_error_p90_deg", s.slope_error_p90_deg);
  num("slope_mean_error_deg", s.slope_mean_error_deg);
  num("roughness_mean_error_m", s.roughness_mean_error_m);
  num("hazard_tp", s.hazard_tp);
  num("hazard_fp", s.hazard_fp);
  num("hazard_fn", s.hazard_fn);
  num("hazard_tn", s.hazard_tn);
  num("hazard_precision", s.hazard_precision);
  num("hazard_recall", s.hazard_recall);
  num("cells_sigma", s.cells_sigma);
  num("slope_within_1sigma", s.slope_within_1sigma);
  num("slope_within_2sigma", s.slope_within_2sigma);
  num("roughness_within_1sigma", s.roughness_within_1sigma);
  num("roughness_within_2sigma", s.roughness_within_2sigma, true);
  out << "}\n";
  return out.str();
}

}  // namespace planetary_vo::terrain
