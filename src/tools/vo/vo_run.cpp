/// @file vo_run.cpp
/// Runs the VO pipeline over a dataset (planetary_vo format, KITTI, EuRoC, TUM RGB-D) and writes the
/// trajectory.
///
///   vo_run --dataset DIR [--config YAML] --output traj.txt [--max-frames N] [--quiet]
///          [--initial-state-from-groundtruth]
///
/// With `altimeter.enabled` in the configuration the dataset's altimeter.txt is given to the pipeline, each
/// reading before the first image at or after its stamp (as a live driver would deliver it); likewise
/// imu.txt with `imu.enabled`. With --initial-state-from-groundtruth the pipeline is handed the first
/// ground-truth pose and, when the dataset has groundtruth_state.txt, the velocity at the first image (as
/// guidance hands over the initial state), and nothing else from the ground truth, so the trajectory is
/// written in the dataset's world frame. --output-velocity writes the estimated velocity of every frame
/// that has one (camera + IMU mode).
///
/// Writes a TUM line (T_world_cam) for every processed frame that has a pose (tracking, recovered, or lost =
/// held pose); frames before the initialisation have none. Prints per-stage time (median, p99), peak memory
/// and how many frames ended in each state; with ground truth, the Sim(3)-aligned ATE as a quick check
/// (vo_eval gives the full report). Exit code 0 on success, 1 on bad arguments or input.

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <glog/logging.h>
#include <yaml-cpp/yaml.h>
#include <Eigen/Geometry>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/evaluation_inputs.h"
#include "planetary_vo/eval/trajectory_metrics.h"
#include "planetary_vo/terrain/hazard_mapper.h"
#include "planetary_vo/vo/config_yaml.h"
#include "planetary_vo/vo/cpu_budget.h"
#include "planetary_vo/vo/pipeline.h"

namespace {

using namespace planetary_vo;

struct Options {
  std::string dataset_dir;
  std::string config_path;
  std::string output_path;
  long max_frames = -1;
  long first_frame = 0;  ///< the first input image given to the VO (the earlier ones are skipped)
  std::string frame_log_path;
  bool quiet = false;
  bool initial_state_from_groundtruth = false;
  bool initial_pose_only = false;
  std::string velocity_path;
  std::string covariance_path;
  std::string keyframes_path;
  std::string terrain_dir;
  std::string hazard_config_path;
  double sun_elevation_deg = -1.0;  ///< < 0: the hazard config's, or when that is 0 the dataset's
  double sun_azimuth_deg = -1.0;    ///< < 0: the hazard config's, or when that is < 0 the dataset's
  Eigen::Vector3d initial_error_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d initial_error_deg = Eigen::Vector3d::Zero();
  double cpu_budget_ms = -1.0;  ///< < 0: the configuration's cpu_budget.frame_budget_ms
  double cpu_slowdown = 1.0;
  int cpu_budget_step = 0;  ///< run at this step of the CPU budget's ladder from the start
  bool realtime = false;    ///< feed the frames at the dataset's own rate instead of back to back
};

/// sun/<key> (deg) of a rendered dataset's sequence.yaml (`elevation_deg`, `azimuth_deg`: the ephemeris a
/// mission would have for its landing), `missing` when absent or not readable (real data); the range is
/// the shading config's to check.
double datasetSunDeg(const std::string& sequence_yaml, const char* key, double missing) {
  try {
    const YAML::Node root = YAML::Load(sequence_yaml);
    if (root && root.IsMap() && root["sun"] && root["sun"][key]) return root["sun"][key].as<double>();
  } catch (const YAML::Exception&) {
  }
  return missing;
}

/// A finite number >= lo from text; false when malformed.
bool parseAtLeast(const std::string& text, double lo, double* out) {
  char* end = nullptr;
  *out = std::strtod(text.c_str(), &end);
  return end != text.c_str() && *end == '\0' && std::isfinite(*out) && *out >= lo;
}

/// "X,Y,Z" -> vector; false when malformed.
bool parseTriple(const std::string& text, Eigen::Vector3d* out) {
  double v[3];
  char tail = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &tail) != 3) return false;
  *out = Eigen::Vector3d(v[0], v[1], v[2]);
  return out->allFinite();
}

void usage(std::ostream& out) {
  out << "usage: vo_run --dataset DIR --output traj.txt [--config YAML] [--max-frames N] [--frame-log FILE]\n"
         "              [--quiet] [--initial-state-from-groundtruth]\n"
         "  --dataset DIR     planetary_vo, KITTI odometry, EuRoC or TUM RGB-D folder\n"
         "  --config YAML     VO configuration (default: built-in defaults = config/default.yaml)\n"
         "  --output FILE     TUM trajectory (t tx ty tz qx qy qz qw, T_world_cam) of the processed frames\n"
         "                    with a pose (camera + IMU: also the IMU's dead reckoning while there is no map)\n"
         "  --output-keyframes FILE  TUM trajectory of the keyframes, each with its last estimate: its pose\n"
         "                    when it left the bundle adjustment's window (the ones still in it at the end:\n"
         "                    their pose then). Not causal: a keyframe's pose is refined by adjustments\n"
         "                    after its image (what DSO's result.txt and ORB-SLAM's KeyFrameTrajectory.txt\n"
         "                    hold). Vision only: a later change of the world (metric scale, gravity\n"
         "                    alignment, map restart) is not applied to keyframes that had already left\n"
         "  --max-frames N    stop after N input frames\n"
         "  --first-frame N   start at input image N (0-based; the images before it, and the IMU and\n"
         "                    altimeter samples before it, are not used; a handed-over state is the one\n"
         "                    at that image): the same sequence started elsewhere, to see how much a\n"
         "                    result depends on where the VO began\n"
         "  --frame-log FILE  one line per processed frame: state, counts, model, keyframe, the stage\n"
         "                    times (ms: total, pose, tracking, detect, ba, optimiser) and the pipeline's\n"
         "                    message (why a frame got no pose, why it became a keyframe)\n"
         "  --quiet           no progress and no summary\n"
         "  --output-velocity FILE  t vx vy vz [m/s, world] and the IMU bias estimates of every frame\n"
         "                    with a velocity (camera + IMU mode); without the IMU, the motion filter's\n"
         "                    velocity of the camera centre of every filtered frame (with the\n"
         "                    altimeter: m/s, the frames of a metric map only; vision only: map units/s)\n"
         "  --initial-pose-only  with --initial-state-from-groundtruth: hand over the pose but not the\n"
         "                    velocity (the camera + IMU mode then aligns vision and IMU itself)\n"
         "  --initial-error-m DX,DY,DZ / --initial-error-deg RX,RY,RZ  error of the handed-over state:\n"
         "                    position offset (world, m) and rotation vector applied to the attitude "
         "(world,\n"
         "                    deg), as vo_eval --initial-error-m/-deg (Monte Carlo campaigns)\n"
         "  --output-covariance FILE  t and the 6x6 covariance of [position (m), attitude (rad)], world "
         "frame,\n"
         "                    row-major, of every frame with one (camera + IMU mode; vision + altimeter\n"
         "                    once metric, with the map's drift; vo_eval --est-cov)\n"
         "  --output-terrain DIR  the terrain model of the landing area (terrain/terrain_map.h) from the "
         "map\n"
         "                    events, densified at each keyframe once metric (terrain/densifier.h), at the\n"
         "                    end of the run: DIR/terrain.yaml and its layers (terrain_eval --est DIR), "
         "with\n"
         "                    the hazard layer, and DIR/landing_sites.yaml (terrain/hazard_mapper.h)\n"
         "  --hazard-config FILE  the terrain and hazard parameters for --output-terrain (default\n"
         "                    config/hazard.yaml's values)\n"
         "  --sun-elevation-deg E  the Sun's elevation over the landing area (the ephemeris), for the\n"
         "                    shading relief of the hazard map (terrain/shading_relief.h); 0 = none.\n"
         "                    Default: the hazard config's, or when that is 0 the dataset's\n"
         "                    sequence.yaml sun\n"
         "  --sun-azimuth-deg A  the Sun's azimuth (the ephemeris; from +y, downrange, toward +x), so that\n"
         "                    the shading relief is read against the Sun over the map's own ground.\n"
         "                    Default: the hazard config's, or when that is negative the dataset's\n"
         "  --initial-state-from-groundtruth\n"
         "                    start at the dataset's first ground-truth pose (the state guidance hands "
         "over;\n"
         "                    nothing else of the ground truth is used): poses in the dataset's world "
         "frame\n"
         "  --cpu-budget MS   budget of one frame's processing (sets cpu_budget.frame_budget_ms; 0 = off):\n"
         "                    above it the tracking gets lighter step by step (vo/cpu_budget.h); the steps\n"
         "                    taken and the frames spent at each are printed\n"
         "  --cpu-slowdown F  the budget sees every frame's time multiplied by F (>= 1): how the "
         "degradation\n"
         "                    path looks on a CPU F times slower than this one (default 1)\n"
         "  --cpu-budget-step K  run with step K of that path from the first frame (0 = the configuration;\n"
         "                    the steps are printed), without a budget: each step's cost and accuracy\n"
         "  --realtime        give each frame to the pipeline at its own time (the dataset's rate, from the\n"
         "                    first frame on; loaded from disk before), as a camera would, instead of\n"
         "                    back to back: the bundle adjustment thread then has the time between frames,\n"
         "                    as in flight. The trajectory does not change; the stage times do\n";
}

bool parseArgs(int argc, char** argv, Options* options) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&](std::string* out) {
      if (i + 1 >= argc) {
        std::cerr << "vo_run: " << arg << " needs a value\n";
        return false;
      }
      *out = argv[++i];
      return true;
    };
    std::string text;
    if (arg == "--dataset") {
      if (!value(&options->dataset_dir)) return false;
    } else if (arg == "--config") {
      if (!value(&options->config_path)) return false;
    } else if (arg == "--output") {
      if (!value(&options->output_path)) return false;
    } else if (arg == "--max-frames") {
      if (!value(&text)) return false;
      char* end = nullptr;
      options->max_frames = std::strtol(text.c_str(), &end, 10);
      if (end == text.c_str() || *end != '\0' || options->max_frames <= 0) {
        std::cerr << "vo_run: --max-frames needs a positive integer, got '" << text << "'\n";
        return false;
      }
    } else if (arg == "--first-frame") {
      if (!value(&text)) return false;
      char* end = nullptr;
      options->first_frame = std::strtol(text.c_str(), &end, 10);
      if (end == text.c_str() || *end != '\0' || options->first_frame < 0) {
        std::cerr << "vo_run: --first-frame needs a non-negative integer, got '" << text << "'\n";
        return false;
      }
    } else if (arg == "--frame-log") {
      if (!value(&options->frame_log_path)) return false;
    } else if (arg == "--initial-error-m" || arg == "--initial-error-deg") {
      if (!value(&text)) return false;
      if (!parseTriple(
              text, arg == "--initial-error-m" ? &options->initial_error_m : &options->initial_error_deg)) {
        std::cerr << "vo_run: " << arg << " needs X,Y,Z, got '" << text << "'\n";
        return false;
      }
    } else if (arg == "--cpu-budget" || arg == "--cpu-slowdown") {
      if (!value(&text)) return false;
      const bool budget = arg == "--cpu-budget";
      if (!parseAtLeast(text, budget ? 0.0 : 1.0,
                        budget ? &options->cpu_budget_ms : &options->cpu_slowdown)) {
        std::cerr << "vo_run: " << arg << " needs a number " << (budget ? ">= 0" : ">= 1") << ", got '"
                  << text << "'\n";
        return false;
      }
    } else if (arg == "--cpu-budget-step") {
      if (!value(&text)) return false;
      char* end = nullptr;
      const long step = std::strtol(text.c_str(), &end, 10);
      if (end == text.c_str() || *end != '\0' || step < 0 || step > 100) {
        std::cerr << "vo_run: --cpu-budget-step needs an integer >= 0, got '" << text << "'\n";
        return false;
      }
      options->cpu_budget_step = static_cast<int>(step);
    } else if (arg == "--output-covariance") {
      if (!value(&options->covariance_path)) return false;
    } else if (arg == "--output-terrain") {
      if (!value(&options->terrain_dir)) return false;
    } else if (arg == "--hazard-config") {
      if (!value(&options->hazard_config_path)) return false;
    } else if (arg == "--sun-elevation-deg") {
      // >= 0 here; the upper limit is the shading config's (terrain/shading_relief.h), checked when the
      // hazard mapper is built.
      std::string text;
      if (!value(&text)) return false;
      if (!parseAtLeast(text, 0.0, &options->sun_elevation_deg)) {
        std::cerr << "vo_run: --sun-elevation-deg needs a number >= 0, got '" << text << "'\n";
        return false;
      }
    } else if (arg == "--sun-azimuth-deg") {
      std::string text;
      if (!value(&text)) return false;
      if (!parseAtLeast(text, 0.0, &options->sun_azimuth_deg) || options->sun_azimuth_deg > 360.0) {
        std::cerr << "vo_run: --sun-azimuth-deg needs a number in [0, 360], got '" << text << "'\n";
        return false;
      }
    } else if (arg == "--output-velocity") {
      if (!value(&options->velocity_path)) return false;
    } else if (arg == "--output-keyframes") {
      if (!value(&options->keyframes_path)) return false;
    } else if (arg == "--initial-pose-only") {
      options->initial_pose_only = true;
    } else if (arg == "--initial-state-from-groundtruth") {
      options->initial_state_from_groundtruth = true;
    } else if (arg == "--quiet") {
      options->quiet = true;
    } else if (arg == "--realtime") {
      options->realtime = true;
    } else if (arg == "--help" || arg == "-h") {
      usage(std::cout);
      std::exit(0);
    } else {
      std::cerr << "vo_run: unknown argument '" << arg << "'\n";
      return false;
    }
  }
  if (options->dataset_dir.empty() || options->output_path.empty()) {
    std::cerr << "vo_run: --dataset and --output are required\n";
    return false;
  }
  return true;
}

/// Resident set size of this process now (MB), from /proc/self/statm; 0 where that is unavailable.
double residentMb() {
  std::ifstream statm("/proc/self/statm");
  long total_pages = 0, resident_pages = 0;
  if (!(statm >> total_pages >> resident_pages)) return 0.0;
  return static_cast<double>(resident_pages) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

/// Value at quantile q (0..1) of `values` (copied: nearest-rank).
double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return values[k];
}

}  // namespace

int main(int argc, char** argv) {
  // Ceres logs through glog; its warnings (e.g. a covariance that falls back to held points) would flood the
  // summary. Errors still print.
  FLAGS_minloglevel = google::GLOG_ERROR;
  Options options;
  if (!parseArgs(argc, argv, &options)) {
    usage(std::cerr);
    return 1;
  }
  try {
    VoConfig config = options.config_path.empty() ? VoConfig() : loadVoConfig(options.config_path);
    if (options.cpu_budget_ms >= 0.0) config.cpu_budget.frame_budget_ms = options.cpu_budget_ms;
    if (options.cpu_budget_step > 0) {
      const CpuBudget ladder(config);
      if (options.cpu_budget_step >= ladder.numSteps())
        throw std::runtime_error("--cpu-budget-step " + std::to_string(options.cpu_budget_step) +
                                 ": this configuration has steps 0 to " +
                                 std::to_string(ladder.numSteps() - 1));
      if (!options.quiet)
        std::printf("cpu budget step %d of %d: %s\n", options.cpu_budget_step, ladder.numSteps() - 1,
                    ladder.describe(options.cpu_budget_step).c_str());
      config = ladder.config(options.cpu_budget_step);
      config.cpu_budget.frame_budget_ms = 0.0;  // fixed at that step
    }
    const Dataset dataset = Dataset::open(options.dataset_dir);
    if (static_cast<size_t>(options.first_frame) >= dataset.size())
      throw std::runtime_error("--first-frame " + std::to_string(options.first_frame) + ": the dataset has " +
                               std::to_string(dataset.size()) + " images");
    const size_t first_frame = static_cast<size_t>(options.first_frame);
    applyOpenCvThreads(config.cpu_budget);
    Pipeline pipeline(config, dataset.camera());
    CpuBudget cpu_budget(config);
    std::vector<int> frames_at_step(static_cast<size_t>(cpu_budget.numSteps()), 0);
    if (options.initial_state_from_groundtruth) {
      if (!dataset.hasGroundTruth())
        throw std::runtime_error("--initial-state-from-groundtruth: the dataset has no ground truth");
      // The true pose at the first image given to the VO.
      const Trajectory& truth = dataset.groundTruth();
      const double t_first = dataset.timestamp(first_frame);
      const auto at_image = std::find_if(truth.begin(), truth.end(), [t_first](const StampedPose& p) {
        return std::abs(p.timestamp_s - t_first) < 1e-6;
      });
      if (at_image == truth.end())
        throw std::runtime_error("--initial-state-from-groundtruth: no ground-truth pose at image " +
                                 std::to_string(first_frame));
      StampedPose first = *at_image;
      // The handover as guidance would give it, with its error (campaigns disperse it).
      const Eigen::Vector3d rv = options.initial_error_deg * M_PI / 180.0;
      if (rv.norm() > 0.0)
        first.T_world_cam.linear() =
            Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix() * first.T_world_cam.linear();
      first.T_world_cam.translation() += options.initial_error_m;
      const std::string state_path = dataset.directory() + "/groundtruth_state.txt";
      std::vector<GroundTruthState> states;
      if (std::ifstream(state_path).good()) states = readGroundTruthStates(state_path);
      // The state at the first image: the guidance handover (pose, velocity), nothing else.
      const auto at_first = std::find_if(states.begin(), states.end(), [&first](const GroundTruthState& s) {
        return std::abs(s.timestamp_s - first.timestamp_s) < 1e-6;
      });
      if (at_first != states.end() && !options.initial_pose_only)
        pipeline.setInitialState(first.T_world_cam, at_first->velocity_world_mps);
      else
        pipeline.setInitialPose(first.T_world_cam);
    }
    const std::vector<ImuSample>& imu = dataset.imu();
    if (config.imu.enabled && imu.empty())
      throw std::runtime_error("imu.enabled: the dataset has no IMU samples (imu.txt)");
    size_t next_imu = 0;
    std::ofstream velocity_out, covariance_out;
    if (!options.covariance_path.empty()) {
      covariance_out.open(options.covariance_path);
      if (!covariance_out) throw std::runtime_error("cannot write " + options.covariance_path);
      covariance_out << "# timestamp[s] and the 6x6 covariance of [position (m), attitude (rad, world-frame "
                        "rotation vector: truth = Exp(theta) estimate)], row-major\n";
    }
    if (!options.velocity_path.empty()) {
      velocity_out.open(options.velocity_path);
      if (!velocity_out) throw std::runtime_error("cannot write " + options.velocity_path);
      if (config.imu.enabled)
        velocity_out << "# timestamp[s] vx vy vz[m/s] (IMU body, world frame) bgx bgy bgz[rad/s] bax bay "
                        "baz[m/s^2] (IMU bias estimates)\n";
      else
        velocity_out << "# timestamp[s] vx vy vz (camera centre, world frame; "
                     << (config.altimeter.enabled ? "m/s, the frames of a metric map only"
                                                  : "map units/s: vision only has no metric scale")
                     << ") and its 3x3 covariance, row-major: the motion filter's velocity "
                        "(motion_filter.enabled)\n";
    }
    const std::vector<AltimeterSample>& altimeter = dataset.altimeter();
    if (config.altimeter.enabled && altimeter.empty())
      throw std::runtime_error("altimeter.enabled: the dataset has no altimeter readings (altimeter.txt)");
    size_t next_altimeter = 0;
    int metric_from_frame = -1;
    int inertial_frames = 0;
    if (first_frame > 0) {  // samples before the first image belong to the skipped part
      while (next_imu < imu.size() && imu[next_imu].timestamp_s < dataset.timestamp(first_frame)) ++next_imu;
      while (next_altimeter < altimeter.size() &&
             altimeter[next_altimeter].timestamp_s < dataset.timestamp(first_frame))
        ++next_altimeter;
    }
    const size_t num_frames =
        options.max_frames > 0
            ? std::min(dataset.size(), first_frame + static_cast<size_t>(options.max_frames))
            : dataset.size();
    const bool progress = !options.quiet && isatty(STDERR_FILENO);

    std::ofstream frame_log;
    if (!options.frame_log_path.empty()) {
      frame_log.open(options.frame_log_path);
      if (!frame_log) throw std::runtime_error("cannot write " + options.frame_log_path);
      frame_log << "# frame timestamp_s state tracked new inliers map_points keyframe model total_ms pose_ms "
                   "tracking_ms detect_ms ba_ms optimiser_ms message\n";
    }
    std::optional<terrain::HazardMapper> hazard_mapper;
    terrain::DensifierStats densified;
    if (!options.terrain_dir.empty()) {
      std::filesystem::create_directories(options.terrain_dir);
      terrain::HazardMapperConfig hazard_config =
          options.hazard_config_path.empty() ? terrain::HazardMapperConfig()
                                             : terrain::loadHazardMapperConfig(options.hazard_config_path);
      std::string sun_source = "--sun-elevation-deg";
      if (options.sun_elevation_deg >= 0.0) {
        hazard_config.shading.sun_elevation_deg = options.sun_elevation_deg;
      } else if (hazard_config.shading.sun_elevation_deg > 0.0) {
        sun_source = "the hazard config";
      } else {
        hazard_config.shading.sun_elevation_deg =
            std::max(0.0, datasetSunDeg(dataset.sequenceYaml(), "elevation_deg", 0.0));
        sun_source = "the dataset's sequence.yaml (the ephemeris of the landing)";
      }
      std::string azimuth_source = "--sun-azimuth-deg";
      if (options.sun_azimuth_deg >= 0.0) {
        hazard_config.shading.sun_azimuth_deg = options.sun_azimuth_deg;
      } else if (hazard_config.shading.sun_azimuth_deg >= 0.0) {
        azimuth_source = "the hazard config";
      } else {
        hazard_config.shading.sun_azimuth_deg = datasetSunDeg(dataset.sequenceYaml(), "azimuth_deg", -1.0);
        azimuth_source = "the dataset's sequence.yaml";
      }
      const terrain::ShadingReliefConfig& shading = hazard_config.shading;
      if (!options.quiet && shading.enabled) {
        if (!(shading.sun_elevation_deg > 0.0))
          std::printf("terrain: no Sun elevation (not given by %s): shading relief off\n",
                      sun_source.c_str());
        else if (shading.sun_elevation_deg < shading.min_sun_elevation_deg)
          std::printf(
              "terrain: Sun elevation %.1f deg from %s, below %.0f deg: shading relief off (the shadows take "
              "over)\n",
              shading.sun_elevation_deg, sun_source.c_str(), shading.min_sun_elevation_deg);
        else if (shading.sun_azimuth_deg < 0.0)
          std::printf(
              "terrain: Sun elevation %.1f deg from %s: shading relief on; no Sun azimuth (not given by %s): "
              "the ground under each cell taken as level\n",
              shading.sun_elevation_deg, sun_source.c_str(), azimuth_source.c_str());
        else
          std::printf(
              "terrain: Sun elevation %.1f deg from %s, azimuth %.1f deg from %s: shading relief on, read "
              "against the Sun over the map's ground\n",
              shading.sun_elevation_deg, sun_source.c_str(), shading.sun_azimuth_deg, azimuth_source.c_str());
      }
      hazard_mapper.emplace(hazard_config);
      hazard_mapper->setCamera(dataset.camera());
    }
    Trajectory trajectory;
    Trajectory keyframe_trajectory;  // the keyframes' last estimates (--output-keyframes)
    std::vector<double> tracking_ms, pyramid_ms, klt_ms, refine_ms, detect_ms, motion_ms, mapping_ms, ba_ms,
        pose_ms, total_ms, optimiser_ms, keyframe_tracking_ms;
    std::array<int, 4> state_counts{};
    int aligned_frames = 0, rescued_frames = 0;  // tracked by anchor alignment; of those, handed to LK
    int pnp_frames = 0, predicted_frames = 0;    // posed against the map; of those, without RANSAC
    int keyframes = 0, processed = 0, max_map_points = 0;
    // Memory after the first tenth of the frames against the end shows whether the windowed map keeps it
    // flat.
    double resident_mb_early = 0.0;
    const auto run_start = std::chrono::steady_clock::now();
    for (size_t i = first_frame; i < num_frames; ++i) {
      const cv::Mat gray = dataset.loadImage(i);
      if (options.realtime) {
        // The frame is due at its time since the first frame; a frame that is late (the previous one took
        // longer than the frame period) is given at once.
        const double due_s = dataset.timestamp(i) - dataset.timestamp(first_frame);
        std::this_thread::sleep_until(run_start +
                                      std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                          std::chrono::duration<double>(due_s)));
      }
      while (config.altimeter.enabled && next_altimeter < altimeter.size() &&
             altimeter[next_altimeter].timestamp_s <= dataset.timestamp(i))
        pipeline.addAltimeter(altimeter[next_altimeter++]);
      while (config.imu.enabled && next_imu < imu.size() && imu[next_imu].timestamp_s <= dataset.timestamp(i))
        pipeline.addImu(imu[next_imu++]);
      const FrameResult r = pipeline.process(dataset.timestamp(i), gray);
      if (r.metric_scale && metric_from_frame < 0) metric_from_frame = static_cast<int>(r.frame_index);
      if (hazard_mapper) {
        // The events, and the new keyframe's image to densify the landing area against an earlier one.
        const terrain::HazardMapperUpdate u = hazard_mapper->apply(
            r.map_events, r.metric_scale, r.map_events.keyframes_added.empty() ? cv::Mat() : gray);
        densified.seeds += u.densifier.seeds;
        densified.tracked += u.densifier.tracked;
        densified.triangulated += u.densifier.triangulated;
      }
      for (const MapKeyframeState& kf : r.map_events.keyframes_retired)
        keyframe_trajectory.push_back({kf.timestamp_s, kf.T_world_cam});
      if (i + 1 == first_frame + std::max<size_t>(1, (num_frames - first_frame) / 10))
        resident_mb_early = residentMb();
      if (!r.processed) continue;
      ++processed;
      max_map_points = std::max(max_map_points, r.num_map_points);
      ++state_counts[static_cast<size_t>(r.state)];
      if (r.processed && !r.input_rejected) {
        if (r.anchor_alignment) ++aligned_frames;
        if (r.lk_rescue) ++rescued_frames;
      }
      if (r.motion == MotionEstimate::kPnp) {
        ++pnp_frames;
        if (r.pose_from_prediction) ++predicted_frames;
      }
      keyframes += r.is_keyframe ? 1 : 0;
      tracking_ms.push_back(r.times.tracking_ms);
      pyramid_ms.push_back(r.times.pyramid_ms);
      klt_ms.push_back(r.times.klt_ms);
      refine_ms.push_back(r.times.refine_ms);
      detect_ms.push_back(r.times.detect_ms);
      motion_ms.push_back(r.times.motion_ms);
      mapping_ms.push_back(r.times.mapping_ms);
      ba_ms.push_back(r.times.ba_ms);
      pose_ms.push_back(r.times.pose_ms);
      total_ms.push_back(r.times.total_ms);
      if (r.times.optimiser_ms > 0.0) optimiser_ms.push_back(r.times.optimiser_ms);
      if (r.times.keyframe_tracking_ms > 0.0) keyframe_tracking_ms.push_back(r.times.keyframe_tracking_ms);
      ++frames_at_step[static_cast<size_t>(cpu_budget.step())];
      if (const std::optional<VoConfig> next = cpu_budget.observe(r.times.total_ms * options.cpu_slowdown)) {
        pipeline.reconfigure(*next);  // between two frames; tracks, map and trajectory are kept
        if (!options.quiet)
          std::printf("%scpu budget: frame %lld: median %.1f ms%s against %.1f ms: step %d (%s)\n",
                      progress ? "\n" : "", static_cast<long long>(r.frame_index), cpu_budget.lastMedianMs(),
                      options.cpu_slowdown != 1.0 ? " (scaled)" : "", config.cpu_budget.frame_budget_ms,
                      cpu_budget.step(), cpu_budget.describe(cpu_budget.step()).c_str());
      }
      if (frame_log.is_open())
        frame_log << r.frame_index << ' ' << std::fixed << std::setprecision(6) << r.timestamp_s << ' '
                  << toString(r.state) << ' ' << r.num_tracked << ' ' << r.num_new_features << ' '
                  << r.num_inliers << ' ' << r.num_map_points << ' ' << (r.is_keyframe ? 1 : 0) << ' '
                  << toString(r.motion) << ' ' << std::setprecision(2) << r.times.total_ms << ' '
                  << r.times.pose_ms << ' ' << r.times.tracking_ms << ' ' << r.times.detect_ms << ' '
                  << r.times.ba_ms << ' ' << r.times.optimiser_ms << ' '
                  << (r.message.empty() ? "-" : r.message) << '\n';
      // Initialising frames have no pose, except the IMU's dead reckoning (camera + IMU, no map yet).
      const bool has_pose = r.state != TrackingState::kInitialising || r.inertial_only;
      if (has_pose) trajectory.push_back({r.timestamp_s, r.T_world_cam});
      if (velocity_out.is_open() && r.has_velocity && has_pose)
        velocity_out << std::fixed << std::setprecision(6) << r.timestamp_s << std::setprecision(9) << ' '
                     << r.v_world_mps.x() << ' ' << r.v_world_mps.y() << ' ' << r.v_world_mps.z() << ' '
                     << r.imu_bias.gyro_radps.x() << ' ' << r.imu_bias.gyro_radps.y() << ' '
                     << r.imu_bias.gyro_radps.z() << ' ' << r.imu_bias.accel_mps2.x() << ' '
                     << r.imu_bias.accel_mps2.y() << ' ' << r.imu_bias.accel_mps2.z() << '\n';
      else if (velocity_out.is_open() && r.filtered_motion.valid &&
               (r.metric_scale || !config.altimeter.enabled)) {  // one unit per file
        velocity_out << std::fixed << std::setprecision(6) << r.timestamp_s << std::setprecision(9) << ' '
                     << r.filtered_motion.v_world.x() << ' ' << r.filtered_motion.v_world.y() << ' '
                     << r.filtered_motion.v_world.z() << std::scientific;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b) velocity_out << ' ' << r.filtered_motion.v_covariance(a, b);
        velocity_out << std::defaultfloat << '\n';
      }
      if (r.inertial) ++inertial_frames;
      if (covariance_out.is_open() && r.has_covariance && has_pose) {
        covariance_out << std::fixed << std::setprecision(6) << r.timestamp_s << std::scientific
                       << std::setprecision(9);
        for (int a = 0; a < 6; ++a)
          for (int b = 0; b < 6; ++b) covariance_out << ' ' << r.covariance(a, b);
        covariance_out << std::defaultfloat << '\n';
      }
      if (progress) {
        std::fprintf(stderr, "\r%zu/%zu  %-12s %4d tracked %4d inliers %5d points %5.1f ms", i + 1,
                     num_frames, toString(r.state), r.num_tracked, r.num_inliers, r.num_map_points,
                     r.times.total_ms);
        std::fflush(stderr);
      }
    }
    if (progress) std::fprintf(stderr, "\n");
    writeTumTrajectory(options.output_path, trajectory);
    if (!options.keyframes_path.empty()) {
      for (const Keyframe& kf : pipeline.map().keyframes())
        keyframe_trajectory.push_back({kf.timestamp_s, kf.T_world_cam});
      std::stable_sort(keyframe_trajectory.begin(), keyframe_trajectory.end(),
                       [](const auto& a, const auto& b) { return a.timestamp_s < b.timestamp_s; });
      writeTumTrajectory(options.keyframes_path, keyframe_trajectory);
    }
    if (hazard_mapper) {
      if (!options.quiet)
        std::printf("terrain: densified %d corners, %d tracked, %d triangulated\n", densified.seeds,
                    densified.tracked, densified.triangulated);
      const auto products_start = std::chrono::steady_clock::now();
      const terrain::HazardProducts hazard = hazard_mapper->products();
      const double products_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - products_start)
              .count();
      const terrain::TerrainProducts& products = hazard.terrain;
      terrain::writeGridSet(options.terrain_dir, "terrain", products.grids);
      terrain::writeLandingSites(options.terrain_dir + "/landing_sites.yaml", hazard.sites,
                                 hazard_mapper->config().sites);
      if (!options.quiet)
        std::printf(
            "terrain: %zu points (%zu used in the landing area), %d of %d cells with an elevation%s -> "
            "%s/terrain.yaml\n",
            products.num_points, products.num_used, products.cells_known,
            products.grids.geometry.rows * products.grids.geometry.cols,
            products.metric ? "" : " (NOT metric: map units)", options.terrain_dir.c_str());
      if (!options.quiet && products.grids.layers.count("shading_slope_deg"))
        std::printf("terrain: shading relief: %d cells measured, %d of them above %.1f deg (hazards)\n",
                    hazard.shading.cells_measured, hazard.shading.cells_above,
                    hazard_mapper->config().thresholds.max_shading_slope_deg);
      if (!options.quiet && products.grids.layers.count("shadow_fraction"))
        std::printf(
            "terrain: shadows: %d cells seen at the resolution by the last keyframes, %d of them in shadow\n",
            hazard.shadows.cells_seen, hazard.shadows.cells_shadowed);
      if (!options.quiet)
        std::printf("terrain: products (rasters, hazard mask, landing sites) computed in %.0f ms\n",
                    products_ms);
      if (!options.quiet && !hazard.sites.sites.empty()) {
        const terrain::LandingSite& best = hazard.sites.sites.front();
        std::printf(
            "terrain: best landing site (%.1f, %.1f) m, %.1f m from the target: slope %.1f deg, roughness "
            "%.2f m, clearance %.1f m (%zu sites)\n",
            best.x_m, best.y_m, best.distance_to_target_m, best.slope_deg, best.roughness_m, best.clearance_m,
            hazard.sites.sites.size());
      } else if (!options.quiet) {
        std::printf("terrain: no landing site: %s\n", hazard.sites.reason.c_str());
      }
    }

    if (!options.quiet) {
      struct rusage usage_info {};
      getrusage(RUSAGE_SELF, &usage_info);
      std::printf("vo_run: %s (%s, %dx%d), %s mode, %d processed frames, %d keyframes, %zu poses -> %s\n",
                  dataset.name().c_str(), toString(dataset.format()), dataset.camera().width(),
                  dataset.camera().height(), toString(config.pipeline.trajectory_mode), processed, keyframes,
                  trajectory.size(), options.output_path.c_str());
      std::printf("%-10s %10s %10s\n", "stage", "median_ms", "p99_ms");
      // The tracking stage's parts are indented below it (their medians need not add up to its median). pose:
      // image in, pose out (FrameResult::times.pose_ms); total: the whole process() call.
      const std::array<std::pair<const char*, const std::vector<double>*>, 10> stages{
          {{"tracking", &tracking_ms},
           {"  pyramid", &pyramid_ms},
           {"  klt", &klt_ms},
           {"  refine", &refine_ms},
           {"  detect", &detect_ms},
           {"motion", &motion_ms},
           {"mapping", &mapping_ms},
           {"ba", &ba_ms},
           {"pose", &pose_ms},
           {"total", &total_ms}}};
      for (const auto& stage : stages)
        std::printf("%-10s %10.2f %10.2f\n", stage.first, quantile(*stage.second, 0.5),
                    quantile(*stage.second, 0.99));
      // Per adjustment, not per frame: the solve in the optimiser thread (asynchronous), which the tracking
      // shares the CPU with, or inline.
      if (!optimiser_ms.empty())
        std::printf("%-10s %10.2f %10.2f  (%zu adjustments)\n", "optimiser", quantile(optimiser_ms, 0.5),
                    quantile(optimiser_ms, 0.99), optimiser_ms.size());
      // Per keyframe: the map-only features (map.keyframe_features): part of that keyframe's mapping time
      // with a synchronous optimiser, else tracked in the background (FrameResult::Times).
      if (!keyframe_tracking_ms.empty())
        std::printf("%-10s %10.2f %10.2f  (%zu keyframes; map-only features, %s)\n", "kf tracks",
                    quantile(keyframe_tracking_ms, 0.5), quantile(keyframe_tracking_ms, 0.99),
                    keyframe_tracking_ms.size(),
                    config.bundle_adjustment.enabled && config.bundle_adjustment.asynchronous
                        ? "in the background"
                        : "part of mapping");
      if (cpu_budget.enabled()) {
        std::printf("cpu budget %.1f ms per frame, frame times x%.2f; processed frames per step:",
                    config.cpu_budget.frame_budget_ms, options.cpu_slowdown);
        for (int k = 0; k < cpu_budget.numSteps(); ++k)
          std::printf("%s %d (%s) %d", k ? "," : "", k, cpu_budget.describe(k).c_str(),
                      frames_at_step[static_cast<size_t>(k)]);
        std::printf("\n");
      }
      std::printf("states: initialising %d, tracking %d, lost %d, recovered %d\n", state_counts[0],
                  state_counts[1], state_counts[2], state_counts[3]);
      if (aligned_frames == 0)
        std::printf("tracker (%s): LK in every frame\n", toString(config.tracker.method));
      else
        std::printf(
            "tracker (%s): anchor alignment in %d frames (%d of them tracked again by LK: most "
            "tracks were lost), LK in the others\n",
            toString(config.tracker.method), aligned_frames, rescued_frames);
      std::printf(
          "motion: %d frames posed against the map, %d of them refined from the prediction (no RANSAC)\n",
          pnp_frames, predicted_frames);
      if (config.altimeter.enabled || config.imu.enabled) {
        if (metric_from_frame >= 0)
          std::printf("scale: metres from frame %d on\n", metric_from_frame);
        else
          std::printf("scale: never metric (no altimeter fix, no IMU baseline; see the frame log)\n");
      }
      if (config.imu.enabled)
        std::printf("imu: %d of %d processed frames on an IMU-constrained map\n", inertial_frames, processed);
      std::printf(
          "peak memory: %.1f MB; resident %.1f MB after 10 %% of the frames, %.1f MB at the end; at most "
          "%d map points\n",
          static_cast<double>(usage_info.ru_maxrss) / 1024.0, resident_mb_early, residentMb(),
          max_map_points);
      if (dataset.hasGroundTruth() && trajectory.size() >= 3) {
        try {
          const TrajectoryEvaluation eval = evaluateTrajectory(dataset.groundTruth(), trajectory, {});
          std::printf("sim3 ATE: %.4f m RMSE = %.3f %% of %.1f m path, rotation RMS %.3f deg (%zu poses)\n",
                      eval.ate_m.rmse, eval.ate_rmse_percent, eval.gt_path_length_m, eval.rotation_deg.rmse,
                      eval.num_associated);
          // The alignment uses positions only, so on a nearly straight path its rotation about the path is
          // poorly determined; the relative rotation error does not depend on it.
          for (const RelativeError& rpe : eval.rpe)
            if (rpe.delta_unit == "frames")
              std::printf("RPE over %g frames: translation %.3f %%, rotation RMS %.3f deg\n", rpe.delta,
                          rpe.translation_percent.rmse, rpe.rotation_deg.rmse);
        } catch (const EvalError& e) {
          std::printf("sim3 ATE: not computable (%s)\n", e.what());
        }
      }
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "vo_run: " << e.what() << "\n";
    return 1;
  }
}
