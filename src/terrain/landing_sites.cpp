#include "planetary_vo/terrain/landing_sites.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>
#include <opencv2/imgproc.hpp>

#include "planetary_vo/terrain/surface_analysis.h"

namespace planetary_vo::terrain {

namespace {

constexpr double kRad2Deg = 180.0 / M_PI;

const cv::Mat* findLayer(const GridSet& grids, const std::string& name, bool required) {
  const auto it = grids.layers.find(name);
  if (it == grids.layers.end()) {
    if (required) throw std::invalid_argument("landing sites: the grid set has no '" + name + "' layer");
    return nullptr;
  }
  const cv::Mat& m = it->second;
  if (m.type() != CV_32FC1 || m.rows != grids.geometry.rows || m.cols != grids.geometry.cols)
    throw std::invalid_argument("landing sites: layer '" + name + "' is not a rows x cols CV_32F layer");
  return &m;
}

void checkParams(const GridSet& grids, const HazardThresholds& t, const LandingSiteParams& p) {
  if (grids.geometry.cols <= 0 || grids.geometry.rows <= 0 || !(grids.geometry.cell_size_m > 0.0))
    throw std::invalid_argument("landing sites: empty grid or non-positive cell size");
  if (!(t.max_slope_deg > 0.0) || !(t.max_roughness_m > 0.0))
    throw std::invalid_argument("landing sites: the hazard thresholds must be positive");
  if (!(t.max_shadow_fraction >= 0.0 && t.max_shadow_fraction <= 1.0))
    throw std::invalid_argument("landing sites: max_shadow_fraction must be in [0, 1]");
  if (!(t.shading_margin_m >= 0.0) || !std::isfinite(t.shading_margin_m))
    throw std::invalid_argument("landing sites: shading_margin_m must be finite and >= 0");
  if (!(t.max_shading_slope_deg > 0.0))
    throw std::invalid_argument("landing sites: max_shading_slope_deg must be positive");
  if (!(t.shading_slope_weight >= 0.0) || !std::isfinite(t.shading_slope_weight))
    throw std::invalid_argument("landing sites: shading_slope_weight must be finite and >= 0");
  if (p.max_sites < 1) throw std::invalid_argument("landing sites: max_sites must be >= 1");
  if (!(p.confidence_k >= 0.0) || !(p.min_separation_m >= 0.0) || !(p.distance_weight >= 0.0))
    throw std::invalid_argument("landing sites: k, separation and distance weight must be >= 0");
  if (!(p.min_clearance_m > 0.0) || !std::isfinite(p.min_clearance_m) ||
      !(p.max_distance_from_target_m > 0.0) || !std::isfinite(p.max_distance_from_target_m))
    throw std::invalid_argument("landing sites: clearance and search radius must be positive and finite");
  if (!std::isfinite(p.target_x_m) || !std::isfinite(p.target_y_m))
    throw std::invalid_argument("landing sites: the target must be finite");
}

std::string format(const char* fmt, double a, double b = 0.0, double c = 0.0, double d = 0.0) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), fmt, a, b, c, d);
  return buf;
}

}  // namespace

double slopeSigmaPerElevationSigma(double cell_size_m, double footprint_diameter_m) {
  double sum_abs = 0.0, sum_sq = 0.0;  // in cells
  for (const cv::Point& o : footprintOffsets(cell_size_m, footprint_diameter_m)) {
    sum_abs += std::abs(o.x);
    sum_sq += double(o.x) * o.x;
  }
  return sum_abs / sum_sq / cell_size_m;
}

SurfaceSigmas surfaceSigmas(const GridSet& grids) {
  const GridGeometry& g = grids.geometry;
  const cv::Mat* elevation_sigma = findLayer(grids, "elevation_sigma_m", false);
  const cv::Mat* fit_slope_sigma = findLayer(grids, "slope_sigma_deg", false);
  const cv::Mat* fit_relief_sigma = findLayer(grids, "relief_sigma_m", false);
  const cv::Mat* residual_rms = findLayer(grids, "residual_rms_m", false);
  SurfaceSigmas out;
  if (!elevation_sigma) return out;
  const auto footprint = grids.parameters.find("footprint_diameter_m");
  if (footprint == grids.parameters.end())
    throw std::invalid_argument(
        "landing sites: 'elevation_sigma_m' needs the grid set's parameter 'footprint_diameter_m'");
  const std::vector<cv::Point> disc = footprintOffsets(g.cell_size_m, footprint->second);
  int R = 0;
  for (const cv::Point& o : disc) R = std::max(R, o.x);
  cv::Mat kernel = cv::Mat::zeros(2 * R + 1, 2 * R + 1, CV_8U);
  for (const cv::Point& o : disc) kernel.at<uint8_t>(o.y + R, o.x + R) = 1;
  // The largest value over each cell's footprint disc; unknown (NaN) anywhere in it -> +inf -> unknown.
  // Outside the grid the dilation's default border is neutral (the cells there have no slope anyway).
  auto discMax = [&](const cv::Mat& layer) {
    cv::Mat v = layer.clone(), out_layer;
    cv::patchNaNs(v, std::numeric_limits<double>::infinity());
    cv::dilate(v, out_layer, kernel);
    return out_layer;
  };
  const cv::Mat sigma_z = discMax(*elevation_sigma);
  const cv::Mat sigma_unknown = sigma_z == std::numeric_limits<float>::infinity();
  out.roughness_m = fit_relief_sigma ? discMax(*fit_relief_sigma) : sigma_z;
  if (residual_rms) out.unresolved_relief_m = discMax(*residual_rms);
  if (fit_slope_sigma) {
    out.slope_deg = discMax(*fit_slope_sigma);
    out.slope_from_fit = true;
  } else {
    out.slope_deg = g.newLayer(0.0f);
    const double c = slopeSigmaPerElevationSigma(g.cell_size_m, footprint->second);
    for (int row = 0; row < g.rows; ++row) {
      const float* s = sigma_z.ptr<float>(row);
      float* o = out.slope_deg.ptr<float>(row);
      for (int col = 0; col < g.cols; ++col)
        o[col] = static_cast<float>(std::atan(c * double(s[col])) * kRad2Deg);
    }
  }
  // A footprint with an unknown sigma leaves the cell unknown, whatever k.
  out.roughness_m.setTo(std::numeric_limits<float>::quiet_NaN(),
                        sigma_unknown | (out.roughness_m == std::numeric_limits<float>::infinity()));
  out.slope_deg.setTo(std::numeric_limits<float>::quiet_NaN(),
                      sigma_unknown | (out.slope_deg == std::numeric_limits<float>::infinity()));
  out.available = true;
  return out;
}

LandingSiteResult findLandingSites(const GridSet& grids, const HazardThresholds& thresholds,
                                   const LandingSiteParams& params) {
  checkParams(grids, thresholds, params);
  const GridGeometry& g = grids.geometry;
  const cv::Mat& slope = *findLayer(grids, "slope_deg", true);
  const cv::Mat& rough = *findLayer(grids, "roughness_m", true);
  const cv::Mat* elevation = findLayer(grids, "elevation_m", false);

  LandingSiteResult result;
  const double k = params.confidence_k;

  const SurfaceSigmas sigmas = surfaceSigmas(grids);
  result.uncertainty_applied = sigmas.available;
  const cv::Mat sigma_slope_deg = sigmas.available ? sigmas.slope_deg : g.newLayer(0.0f);
  const cv::Mat sigma_rough_m = sigmas.available ? sigmas.roughness_m : g.newLayer(0.0f);

  // Cells seen in shadow (terrain/shadow_map.h): their relief is unseen. Cells whose shading shows relief
  // below the plane fit (terrain/shading_relief.h): hazards above max_shading_slope_deg, and so are the
  // cells within shading_margin_m of them; their slope raised by shading_slope_weight times it
  // (terrain/hazard.h).
  const cv::Mat* shadow = findLayer(grids, "shadow_fraction", false);
  const cv::Mat* shading = findLayer(grids, "shading_slope_deg", false);
  // Safe with confidence: the hazard mask of the raised slope and roughness (NaN stays unknown).
  const cv::Mat slope_upper = slopeWithShading(slope + k * sigma_slope_deg, shading ? *shading : cv::Mat(),
                                               thresholds.shading_slope_weight);
  cv::Mat rough_upper = rough + k * sigma_rough_m;
  // Relief the map does not resolve: the points' RMS distance from their fitted planes (noise plus rocks
  // smaller than the plane-fit support), over the footprint; the roughness limit cannot be certified where it
  // exceeds it (an unknown stays unknown).
  if (!sigmas.unresolved_relief_m.empty())
    for (int row = 0; row < g.rows; ++row) {
      float* r = rough_upper.ptr<float>(row);
      const float* u = sigmas.unresolved_relief_m.ptr<float>(row);
      for (int col = 0; col < g.cols; ++col)
        r[col] = std::isfinite(u[col]) ? std::max(r[col], u[col]) : std::numeric_limits<float>::quiet_NaN();
    }
  HazardThresholds raised = thresholds;
  raised.shading_slope_weight = 0.0;  // already in slope_upper
  const cv::Mat mask = hazardMask(slope_upper, rough_upper, shadow ? *shadow : cv::Mat(),
                                  shading ? *shading : cv::Mat(), shadingWithinMargin(grids, thresholds), raised);

  // Clearance: distance to the nearest cell that is not safe with confidence; one border cell of unknown
  // around the grid so that leaving it counts too.
  cv::Mat safe_padded = cv::Mat::zeros(g.rows + 2, g.cols + 2, CV_8U);
  safe_padded(cv::Rect(1, 1, g.cols, g.rows)).setTo(1, mask == kSafe);
  cv::Mat dist_cells;
  cv::distanceTransform(safe_padded, dist_cells, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  const cv::Mat clearance_cells = dist_cells(cv::Rect(1, 1, g.cols, g.rows));

  struct Candidate {
    int col, row;
    double distance_m, score;
  };
  std::vector<Candidate> candidates;
  const double reach = params.max_distance_from_target_m;
  double best_slope_upper = std::numeric_limits<double>::infinity();
  double best_rough_upper = best_slope_upper, best_clearance_m = 0.0;
  // Only the rows and columns that can be within reach (a cell on the circle stays in; the clamp keeps the
  // index arithmetic in int range).
  const auto first = [&](double v0, double target, int n) {
    return static_cast<int>(
        std::clamp(std::ceil((target - reach - v0) / g.cell_size_m - 1e-9), 0.0, double(n)));
  };
  const auto last = [&](double v0, double target, int n) {
    return static_cast<int>(
        std::clamp(std::floor((target + reach - v0) / g.cell_size_m + 1e-9), -1.0, n - 1.0));
  };
  const int col_first = first(g.x0_m, params.target_x_m, g.cols),
            col_last = last(g.x0_m, params.target_x_m, g.cols);
  const int row_first = first(g.y0_m, params.target_y_m, g.rows),
            row_last = last(g.y0_m, params.target_y_m, g.rows);
  for (int row = row_first; row <= row_last; ++row) {
    const double dy = g.y_m(row) - params.target_y_m;
    const float* s_up = slope_upper.ptr<float>(row);
    const float* r_up = rough_upper.ptr<float>(row);
    const float* clear = clearance_cells.ptr<float>(row);
    const uint8_t* m = mask.ptr<uint8_t>(row);
    for (int col = col_first; col <= col_last; ++col) {
      const double distance_m = std::hypot(g.x_m(col) - params.target_x_m, dy);
      if (distance_m > reach) continue;
      ++result.cells_in_reach;
      if (m[col] == kUnknown) continue;
      ++result.cells_known;
      best_slope_upper = std::min(best_slope_upper, double(s_up[col]));
      best_rough_upper = std::min(best_rough_upper, double(r_up[col]));
      if (m[col] != kSafe) continue;
      ++result.cells_safe;
      const double clearance_m = clear[col] * g.cell_size_m;
      best_clearance_m = std::max(best_clearance_m, clearance_m);
      // The distance transform's float: a clearance meant to equal the limit must not fail on rounding.
      if (clearance_m < params.min_clearance_m * (1.0 - 1e-6)) continue;
      const double margin = std::min({(thresholds.max_slope_deg - s_up[col]) / thresholds.max_slope_deg,
                                      (thresholds.max_roughness_m - r_up[col]) / thresholds.max_roughness_m,
                                      (clearance_m - params.min_clearance_m) / params.min_clearance_m});
      candidates.push_back({col, row, distance_m, margin - params.distance_weight * distance_m / reach});
    }
  }
  result.cells_qualifying = static_cast<int>(candidates.size());

  if (candidates.empty()) {
    const std::string where =
        format("within %.1f m of the target (%.1f, %.1f)", reach, params.target_x_m, params.target_y_m);
    if (result.cells_in_reach == 0)
      result.reason = "no cell of the grid lies " + where;
    else if (result.cells_known == 0)
      result.reason = "no cell " + where + " has a known slope and roughness";
    else if (result.cells_safe == 0)
      result.reason = std::to_string(result.cells_known) + " cells " + where +
                      " have a known slope and roughness, none is safe with confidence" +
                      format(
                          " (k = %.2f; the smallest slope + k sigma is %.2f deg (limit %.2f), the smallest "
                          "roughness + k sigma %.3f m",
                          k, best_slope_upper, thresholds.max_slope_deg, best_rough_upper) +
                      format(" (limit %.3f))", thresholds.max_roughness_m);
    else
      result.reason = std::to_string(result.cells_safe) + " cells " + where +
                      " are safe with confidence, none has the clearance required" +
                      format(" (%.2f m; the largest is %.2f m)", params.min_clearance_m, best_clearance_m);
    return result;
  }

  // Greedy: the best remaining candidate at least min_separation_m from every site taken.
  const auto better = [](const Candidate& a, const Candidate& b) {
    if (a.score != b.score) return a.score > b.score;
    if (a.distance_m != b.distance_m) return a.distance_m < b.distance_m;
    if (a.row != b.row) return a.row < b.row;
    return a.col < b.col;
  };
  const double sep2 = params.min_separation_m * params.min_separation_m;
  std::vector<const Candidate*> taken;
  while (static_cast<int>(taken.size()) < params.max_sites) {
    const Candidate* best = nullptr;
    for (const Candidate& c : candidates) {
      if (best && !better(c, *best)) continue;
      bool far_enough = true;
      for (const Candidate* t : taken) {
        const double dx = (c.col - t->col) * g.cell_size_m, dy = (c.row - t->row) * g.cell_size_m;
        if (dx * dx + dy * dy < sep2) {
          far_enough = false;
          break;
        }
      }
      if (far_enough) best = &c;
    }
    if (!best) break;
    taken.push_back(best);
  }

  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const Candidate* c : taken) {
    LandingSite s;
    s.col = c->col;
    s.row = c->row;
    s.x_m = g.x_m(c->col);
    s.y_m = g.y_m(c->row);
    s.elevation_m = elevation ? elevation->at<float>(c->row, c->col) : nan;
    s.slope_deg = slope.at<float>(c->row, c->col);
    s.roughness_m = rough.at<float>(c->row, c->col);
    s.slope_sigma_deg = sigma_slope_deg.at<float>(c->row, c->col);
    s.roughness_sigma_m = sigma_rough_m.at<float>(c->row, c->col);
    s.slope_margin_deg = thresholds.max_slope_deg - slope_upper.at<float>(c->row, c->col);
    s.roughness_margin_m = thresholds.max_roughness_m - rough_upper.at<float>(c->row, c->col);
    s.clearance_m = clearance_cells.at<float>(c->row, c->col) * g.cell_size_m;
    s.distance_to_target_m = c->distance_m;
    s.score = c->score;
    result.sites.push_back(s);
  }
  return result;
}

namespace {

/// Doubles to 17 digits (read back exactly); NaN as .nan.
std::string num(double v) {
  if (std::isnan(v)) return ".nan";
  std::ostringstream os;
  os << std::setprecision(17) << v;
  return os.str();
}

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c == '\n' ? ' ' : c;
  }
  return out + "\"";
}

}  // namespace

void writeLandingSites(const std::string& path, const LandingSiteResult& result, const LandingSiteParams& p) {
  std::ofstream out(path);
  out << "# Landing sites chosen on an estimated hazard map (terrain/landing_sites.h), best first; world "
         "frame "
         "of the map, metres\n"
      << "params:\n"
      << "  target_x_m: " << num(p.target_x_m) << "\n  target_y_m: " << num(p.target_y_m)
      << "\n  max_distance_from_target_m: " << num(p.max_distance_from_target_m)
      << "\n  max_sites: " << p.max_sites << "\n  min_separation_m: " << num(p.min_separation_m)
      << "\n  confidence_k: " << num(p.confidence_k) << "\n  min_clearance_m: " << num(p.min_clearance_m)
      << "\n  distance_weight: " << num(p.distance_weight) << "\n"
      << "reason: " << quoted(result.reason) << "\n"
      << "uncertainty_applied: " << (result.uncertainty_applied ? "true" : "false") << "\n"
      << "cells_in_reach: " << result.cells_in_reach << "\ncells_known: " << result.cells_known
      << "\ncells_safe: " << result.cells_safe << "\ncells_qualifying: " << result.cells_qualifying << "\n"
      << "sites:" << (result.sites.empty() ? " []\n" : "\n");
  for (const LandingSite& s : result.sites)
    out << "  - {col: " << s.col << ", row: " << s.row << ", x_m: " << num(s.x_m) << ", y_m: " << num(s.y_m)
        << ", elevation_m: " << num(s.elevation_m) << ", slope_deg: " << num(s.slope_deg)
        << ", roughness_m: " << num(s.roughness_m) << ", slope_sigma_deg: " << num(s.slope_sigma_deg)
        << ", roughness_sigma_m: " << num(s.roughness_sigma_m)
        << ", slope_margin_deg: " << num(s.slope_margin_deg)
        << ", roughness_margin_m: " << num(s.roughness_margin_m) << ", clearance_m: " << num(s.clearance_m)
        << ", distance_to_target_m: " << num(s.distance_to_target_m) << ", score: " << num(s.score) << "}\n";
  if (!out) throw std::runtime_error("cannot write " + path);
}

LandingSiteResult readLandingSites(const std::string& path, LandingSiteParams* params) {
  try {
    const YAML::Node root = YAML::LoadFile(path);
    LandingSiteResult r;
    if (params != nullptr) {
      const YAML::Node p = root["params"];
      params->target_x_m = p["target_x_m"].as<double>();
      params->target_y_m = p["target_y_m"].as<double>();
      params->max_distance_from_target_m = p["max_distance_from_target_m"].as<double>();
      params->max_sites = p["max_sites"].as<int>();
      params->min_separation_m = p["min_separation_m"].as<double>();
      params->confidence_k = p["confidence_k"].as<double>();
      params->min_clearance_m = p["min_clearance_m"].as<double>();
      params->distance_weight = p["distance_weight"].as<double>();
    }
    r.reason = root["reason"].as<std::string>();
    r.uncertainty_applied = root["uncertainty_applied"].as<bool>();
    r.cells_in_reach = root["cells_in_reach"].as<int>();
    r.cells_known = root["cells_known"].as<int>();
    r.cells_safe = root["cells_safe"].as<int>();
    r.cells_qualifying = root["cells_qualifying"].as<int>();
    for (const YAML::Node& n : root["sites"]) {
      LandingSite s;
      s.col = n["col"].as<int>();
      s.row = n["row"].as<int>();
      s.x_m = n["x_m"].as<double>();
      s.y_m = n["y_m"].as<double>();
      s.elevation_m = n["elevation_m"].as<double>();
      s.slope_deg = n["slope_deg"].as<double>();
      s.roughness_m = n["roughness_m"].as<double>();
      s.slope_sigma_deg = n["slope_sigma_deg"].as<double>();
      s.roughness_sigma_m = n["roughness_sigma_m"].as<double>();
      s.slope_margin_deg = n["slope_margin_deg"].as<double>();
      s.roughness_margin_m = n["roughness_margin_m"].as<double>();
      s.clearance_m = n["clearance_m"].as<double>();
      s.distance_to_target_m = n["distance_to_target_m"].as<double>();
      s.score = n["score"].as<double>();
      r.sites.push_back(s);
    }
    return r;
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": not a landing-sites file: " + e.what());
  }
}

}  // namespace planetary_vo::terrain
