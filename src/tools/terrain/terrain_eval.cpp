/// terrain_eval: scores an estimated terrain map of the landing area (vo_run --output-terrain) against the
/// true one the renderer wrote into the dataset (groundtruth_terrain, render/terrain_truth.h).
///
///   terrain_eval --gt DATASET_DIR --est DIR [--est-name terrain] [--max-slope-deg 10] [--max-roughness-m
///   0.3]
///                [--json FILE]
///
/// Prints coverage, elevation, slope and roughness errors and the hazard map's precision and recall
/// (terrain/terrain_score.h); exit 0 when scored, 2 on bad arguments or files.

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>

#include "planetary_vo/terrain/terrain_score.h"

using namespace planetary_vo::terrain;

namespace {

int usage(const char* why) {
  std::fprintf(stderr,
               "terrain_eval: %s\nusage: terrain_eval --gt DATASET_DIR --est DIR [--est-name terrain] "
               "[--max-slope-deg D] [--max-roughness-m M] [--json FILE]\n",
               why);
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string gt_dir, est_dir, est_name = "terrain", json_path;
  HazardThresholds thresholds;
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
      else if (arg == "--max-slope-deg")
        thresholds.max_slope_deg = std::stod(value);
      else if (arg == "--max-roughness-m")
        thresholds.max_roughness_m = std::stod(value);
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
    std::printf("terrain: %d x %d cells of %.2f m (%d cells)\n", truth.geometry.cols, truth.geometry.rows,
                truth.geometry.cell_size_m, s.cells);
    std::printf("  elevation  coverage %.1f %% (%d cells), RMSE %.3f m, mean error %+.3f m\n",
                100.0 * s.elevation_coverage, s.cells_elevation, s.elevation_rmse_m,
                s.elevation_mean_error_m);
    std::printf("  surface    coverage %.1f %% (%d cells), slope RMSE %.2f deg, roughness RMSE %.3f m\n",
                100.0 * s.surface_coverage, s.cells_surface, s.slope_rmse_deg, s.roughness_rmse_m);
    std::printf(
        "  hazards (slope > %.1f deg or roughness > %.2f m): precision %.3f, recall %.3f "
        "(tp %d, fp %d, fn %d, tn %d)\n",
        thresholds.max_slope_deg, thresholds.max_roughness_m, s.hazard_precision, s.hazard_recall,
        s.hazard_tp, s.hazard_fp, s.hazard_fn, s.hazard_tn);
    if (!json_path.empty()) {
      std::ofstream out(json_path);
      out << toJson(s);
      if (!out) throw std::runtime_error("cannot write " + json_path);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "terrain_eval: %s\n", e.what());
    return 2;
  }
  return 0;
}
