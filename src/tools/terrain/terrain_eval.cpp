/// terrain_eval: scores an estimated terrain map of the landing area (vo_run --output-terrain) against the
/// true one the renderer wrote into the dataset (groundtruth_terrain, render/terrain_truth.h).
///
///   terrain_eval --gt DATASET_DIR --est DIR [--est-name terrain] [--max-slope-deg 10]
///                [--max-roughness-m 0.3] [--max-shadow-fraction 0.5] [--max-shading-slope-deg 3]
///                [--shading-slope-weight W] [--shading-margin-m 2]
///                [--target-x-m 0 --target-y-m 0] [--max-divert-m 100] [--confidence-k 2.5] [--json FILE]
///                [--write-truth-at-resolution DIR] [--navigation-error-from TRAJECTORY]
///
/// Prints coverage, elevation, slope and roughness errors and the hazard map's precision and recall
/// (terrain/terrain_score.h; an estimate with the layer shadow_fraction has its cells seen in shadow unknown,
/// as it publishes them, and one with the layer shading_slope_deg its cells above --max-shading-slope-deg and
/// those within --shading-margin-m of them hazards, and those whose slope plus --shading-slope-weight times
/// it exceeds --max-slope-deg; a large threshold and a weight 0 ignore that layer) against the truth as
/// sampled, and, when the estimate says its plane-fit support (parameter support_radius_m), against the truth
/// seen at that resolution (terrain/resolution.h); then the landing site the run chose
/// (DIR/landing_sites.yaml, written by vo_run --output-terrain and by hazard_recorder from the hazard
/// nodelet) or, when the file is absent or a site option is given, the one the estimated map gives here
/// (terrain/landing_sites.h; defaults but for the options), and whether it is truly safe (checkSite).
/// --write-truth-at-resolution writes that truth (elevation, slope, roughness) to
/// DIR/truth_at_resolution.yaml and its TIFFs, for scripts/terrain_errors.py.
///
/// --navigation-error-from takes the run's estimated trajectory (TUM, vo_run --output): the navigation's
/// error at its last pose (estimate - DATASET_DIR/groundtruth.txt interpolated at that stamp) is printed,
/// and the map and the site are scored once more against the truth moved into the navigation's frame
/// (truthInNavigationFrame): the ground the map saw, and where a lander guided by this navigation to the
/// site touches down ("at touchdown"). Exit 0 when scored, 2 on bad arguments or files.

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/terrain/resolution.h"
#include "planetary_vo/terrain/terrain_score.h"

using namespace planetary_vo::terrain;

namespace {

int usage(const char* why) {
  std::fprintf(
      stderr,
      "terrain_eval: %s\nusage: terrain_eval --gt DATASET_DIR --est DIR [--est-name terrain] "
      "[--max-slope-deg D] [--max-roughness-m M] [--max-shadow-fraction F] [--max-shading-slope-deg S] "
      "[--shading-slope-weight W] [--shading-margin-m M] "
      "[--target-x-m X --target-y-m Y] [--max-divert-m R] [--confidence-k K] [--json FILE] "
      "[--write-truth-at-resolution DIR] [--navigation-error-from TRAJECTORY]\n",
      why);
  return 2;
}

/// The three lines of a score: elevation, slope and roughness, hazards.
void printScore(const TerrainScore& s, const HazardThresholds& thresholds) {
  std::printf("  elevation  coverage %.1f %% (%d cells), RMSE %.3f m, mean error %+.3f m\n",
              100.0 * s.elevation_coverage, s.cells_elevation, s.elevation_rmse_m, s.elevation_mean_error_m);
  std::printf(
      "  surface    coverage %.1f %% (%d cells), slope RMSE %.2f deg (|error| median %.2f, p90 %.2f, mean "
      "error %+.2f), roughness RMSE %.3f m (mean error %+.3f)\n",
      100.0 * s.surface_coverage, s.cells_surface, s.slope_rmse_deg, s.slope_error_median_deg,
      s.slope_error_p90_deg, s.slope_mean_error_deg, s.roughness_rmse_m, s.roughness_mean_error_m);
  std::printf(
      "  hazards (slope > %.1f deg or roughness > %.2f m): precision %.3f, recall %.3f (tp %d, fp %d, fn %d, "
      "tn %d)\n",
      thresholds.max_slope_deg, thresholds.max_roughness_m, s.hazard_precision, s.hazard_recall, s.hazard_tp,
      s.hazard_fp, s.hazard_fn, s.hazard_tn);
  if (s.cells_sigma > 0)
    std::printf(
        "  its sigmas (%d cells): slope error within 1 / 2 sigma %.2f / %.2f, roughness %.2f / %.2f "
        "(calibrated: 0.68 / 0.95)\n",
        s.cells_sigma, s.slope_within_1sigma, s.slope_within_2sigma, s.roughness_within_1sigma,
        s.roughness_within_2sigma);
}

}  // namespace

int main(int argc, char** argv) {
  std::string gt_dir, est_dir, est_name = "terrain", json_path, truth_out_dir, trajectory_path;
  HazardThresholds thresholds;
  LandingSiteParams site_params;
  bool choose_here = false;  // a site option given: choose on the map here rather than read the run's choice
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (i + 1 >= argc) return usage(("missing value after " + arg).c_str());
    const std::string value = argv[++i];
    try {
      if (arg == "--gt")
        gt_dir = value;
      else if (arg == "--est")
        est_dir = value;
      else if (arg == "--est-name")
        est_name = value;
      else if (arg == "--json")
        json_path = value;
      else if (arg == "--write-truth-at-resolution")
        truth_out_dir = value;
      else if (arg == "--navigation-error-from")
        trajectory_path = value;
      else if (arg == "--max-slope-deg")
        thresholds.max_slope_deg = std::stod(value);
      else if (arg == "--max-roughness-m")
        thresholds.max_roughness_m = std::stod(value);
      else if (arg == "--max-shadow-fraction")
        thresholds.max_shadow_fraction = std::stod(value), choose_here = true;
      else if (arg == "--max-shading-slope-deg")
        thresholds.max_shading_slope_deg = std::stod(value), choose_here = true;
      else if (arg == "--shading-margin-m")
        thresholds.shading_margin_m = std::stod(value), choose_here = true;
      else if (arg == "--shading-slope-weight")
        thresholds.shading_slope_weight = std::stod(value), choose_here = true;
      else if (arg == "--target-x-m")
        site_params.target_x_m = std::stod(value), choose_here = true;
      else if (arg == "--target-y-m")
        site_params.target_y_m = std::stod(value), choose_here = true;
      else if (arg == "--max-divert-m")
        site_params.max_distance_from_target_m = std::stod(value), choose_here = true;
      else if (arg == "--confidence-k")
        site_params.confidence_k = std::stod(value), choose_here = true;
      else
        return usage(("unknown option " + arg).c_str());
    } catch (const std::exception&) {
      return usage(("not a number: " + arg + " " + value).c_str());
    }
  }
  if (gt_dir.empty() || est_dir.empty()) return usage("--gt and --est are required");
  try {
    // The name under which lunar_render writes the truth (render::kGroundTruthTerrainName).
    const GridSet truth = readGridSet(gt_dir, "groundtruth_terrain");
    const GridSet estimate = readGridSet(est_dir, est_name);
    const TerrainScore s = scoreTerrain(truth, estimate, thresholds);
    // The truth at the resolution the map claims (its plane-fit support), when it says.
    std::optional<TerrainScore> at_support;
    double support_m = 0.0;
    if (const auto it = estimate.parameters.find("support_radius_m"); it != estimate.parameters.end()) {
      support_m = it->second;
      const auto footprint = truth.parameters.find("footprint_diameter_m");
      if (footprint == truth.parameters.end())
        throw std::runtime_error("the truth's grid set has no footprint_diameter_m parameter");
      const GridSet truth_at_support = truthAtSupport(truth, support_m, footprint->second);
      at_support = scoreTerrain(truth_at_support, estimate, thresholds);
      if (!truth_out_dir.empty()) {
        std::filesystem::create_directories(truth_out_dir);
        writeGridSet(truth_out_dir, "truth_at_resolution", truth_at_support);
      }
    } else if (!truth_out_dir.empty()) {
      throw std::runtime_error("--write-truth-at-resolution: the map states no support_radius_m");
    }
    // The navigation's error at the end of the run, and the truth in its frame.
    std::optional<Eigen::Vector3d> nav_error;
    std::optional<GridSet> truth_nav;
    std::optional<TerrainScore> nav_score, nav_at_support;
    double nav_stamp_s = 0.0;
    if (!trajectory_path.empty()) {
      const planetary_vo::Trajectory estimated = planetary_vo::readTumTrajectory(trajectory_path);
      if (estimated.empty()) throw std::runtime_error(trajectory_path + " has no pose");
      const planetary_vo::Trajectory true_path = planetary_vo::readTumTrajectory(gt_dir + "/groundtruth.txt");
      nav_stamp_s = estimated.back().timestamp_s;
      planetary_vo::Pose T_true;
      if (!planetary_vo::interpolatePose(true_path, nav_stamp_s, &T_true))
        throw std::runtime_error("the ground truth does not cover the trajectory's last stamp " +
                                 std::to_string(nav_stamp_s));
      nav_error = estimated.back().T_world_cam.translation() - T_true.translation();
      truth_nav = truthInNavigationFrame(truth, nav_error->x(), nav_error->y(), nav_error->z());
      nav_score = scoreTerrain(*truth_nav, estimate, thresholds);
      if (at_support)
        nav_at_support =
            scoreTerrain(truthAtSupport(*truth_nav, support_m, truth.parameters.at("footprint_diameter_m")),
                         estimate, thresholds);
    }
    std::printf("terrain: %d x %d cells of %.2f m (%d cells)\n", truth.geometry.cols, truth.geometry.rows,
                truth.geometry.cell_size_m, s.cells);
    printScore(s, thresholds);
    if (at_support) {
      std::printf("at the map's resolution (the truth seen through its %.1f m plane-fit support):\n",
                  support_m);
      printScore(*at_support, thresholds);
    }
    if (nav_error) {
      std::printf(
          "in the navigation's frame: its error at the end of the run (t = %.3f s, estimate - truth) is "
          "(%+.2f, %+.2f, %+.2f) m; the truth moved by it (where the map saw the ground, and where a lander "
          "guided by this navigation touches down):\n",
          nav_stamp_s, nav_error->x(), nav_error->y(), nav_error->z());
      printScore(*nav_score, thresholds);
      if (nav_at_support) {
        std::printf("in the navigation's frame at the map's resolution:\n");
        printScore(*nav_at_support, thresholds);
      }
    }
    // The landing site the run chose (DIR/landing_sites.yaml, vo_run or hazard_recorder), else the one the
    // map would choose with the parameters given here, and whether the truth agrees.
    const std::string sites_file = est_dir + "/landing_sites.yaml";
    const bool from_run = !choose_here && std::ifstream(sites_file).good();
    const LandingSiteResult chosen = from_run ? readLandingSites(sites_file, &site_params)
                                              : findLandingSites(estimate, thresholds, site_params);
    std::printf("landing site chosen %s (confidence k = %.1f, clearance %.1f m):\n",
                from_run ? ("by the run, " + sites_file).c_str() : "here on the estimated map",
                site_params.confidence_k, site_params.min_clearance_m);
    std::optional<SiteCheck> site_check, touchdown_check;
    if (chosen.sites.empty()) {
      std::printf("landing site: none within %.0f m of (%.1f, %.1f): %s\n",
                  site_params.max_distance_from_target_m, site_params.target_x_m, site_params.target_y_m,
                  chosen.reason.c_str());
    } else {
      const LandingSite& best = chosen.sites.front();
      const SiteCheck check = checkSite(truth, best, thresholds, site_params);
      site_check = check;
      std::printf(
          "landing site: (%.1f, %.1f) m, %.1f m from the target, estimated slope %.1f deg, roughness "
          "%.2f m, clearance %.1f m; truth: slope %.1f deg, roughness %.2f m, %s (%d hazardous and %d "
          "unknown of %d cells within %.1f m)\n",
          best.x_m, best.y_m, best.distance_to_target_m, best.slope_deg, best.roughness_m, best.clearance_m,
          check.true_slope_deg, check.true_roughness_m, check.truly_safe ? "SAFE" : "NOT SAFE",
          check.cells_hazard, check.cells_unknown, check.cells_checked, site_params.min_clearance_m);
      if (truth_nav) {
        touchdown_check = checkSite(*truth_nav, best, thresholds, site_params);
        std::printf(
            "landing site at touchdown (the truth in the navigation's frame): slope %.1f deg, roughness %.2f "
            "m, %s (%d hazardous and %d unknown of %d cells within %.1f m)\n",
            touchdown_check->true_slope_deg, touchdown_check->true_roughness_m,
            touchdown_check->truly_safe ? "SAFE" : "NOT SAFE", touchdown_check->cells_hazard,
            touchdown_check->cells_unknown, touchdown_check->cells_checked, site_params.min_clearance_m);
      }
    }
    if (!json_path.empty()) {
      std::ofstream out(json_path);
      out.precision(10);
      out << "{\"full_resolution\": " << toJson(s);
      if (at_support) out << ", \"at_map_resolution\": " << toJson(*at_support);
      if (nav_error) {
        out << ", \"navigation_error_m\": [" << nav_error->x() << ", " << nav_error->y() << ", "
            << nav_error->z() << "], \"navigation_frame\": {\"full_resolution\": " << toJson(*nav_score);
        if (nav_at_support) out << ", \"at_map_resolution\": " << toJson(*nav_at_support);
        out << "}";
      }
      if (site_check) {
        const LandingSite& best = chosen.sites.front();
        auto num = [](double v) { return std::isfinite(v) ? std::to_string(v) : std::string("null"); };
        out << ", \"landing_site\": {\"x_m\": " << num(best.x_m) << ", \"y_m\": " << num(best.y_m)
            << ", \"slope_deg\": " << num(best.slope_deg) << ", \"roughness_m\": " << num(best.roughness_m)
            << ", \"true_slope_deg\": " << num(site_check->true_slope_deg)
            << ", \"true_roughness_m\": " << num(site_check->true_roughness_m)
            << ", \"truly_safe\": " << (site_check->truly_safe ? "true" : "false")
            << ", \"cells_hazard\": " << site_check->cells_hazard
            << ", \"cells_unknown\": " << site_check->cells_unknown;
        if (touchdown_check)
          out << ", \"safe_at_touchdown\": " << (touchdown_check->truly_safe ? "true" : "false")
              << ", \"true_slope_at_touchdown_deg\": " << num(touchdown_check->true_slope_deg)
              << ", \"true_roughness_at_touchdown_m\": " << num(touchdown_check->true_roughness_m)
              << ", \"cells_hazard_at_touchdown\": " << touchdown_check->cells_hazard
              << ", \"cells_unknown_at_touchdown\": " << touchdown_check->cells_unknown;
        out << "}";
      } else {
        out << ", \"landing_site\": null";
      }
      out << "}\n";
      if (!out) throw std::runtime_error("cannot write " + json_path);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "terrain_eval: %s\n", e.what());
    return 2;
  }
  return 0;
}
