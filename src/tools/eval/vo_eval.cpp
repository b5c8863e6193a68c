/// @file vo_eval.cpp
/// vo_eval: evaluates an estimated trajectory against ground truth (TUM or KITTI files, or a planetary_vo
/// dataset folder): association by time stamp, alignment (Umeyama sim3/se3, or on the first pose as a
/// navigation handed its initial state), ATE / RPE / rotation / landing-site errors, and the navigation
/// errors (final error, velocity, tilt, scale drift, NEES); text report, JSON with per-pose series and PNG
/// plots. See docs/evaluation.md.

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/evaluation_report.h"

using namespace planetary_vo;

namespace {

const char* kUsage =
    "usage: vo_eval --gt FILE|DIR --est FILE [--align sim3|se3|first|none] [--align-frames N] [--max-dt S]\n"
    "               [--first-scale-window S] [--initial-error-m DX,DY,DZ] [--initial-error-deg RX,RY,RZ]\n"
    "               [--initial-scale-error F] [--gt-state FILE] [--est-velocity FILE] [--est-cov FILE]\n"
    "               [--up-axis +z] [--scale-window S] [--gap-factor F]\n"
    "               [--rpe-frames 1,10] [--rpe-distances M1,M2,...] [--json FILE] [--plot DIR]\n"
    "               [--plot-script PATH] [--title TEXT] [--axes landing|xyz]\n"
    "  --gt             ground truth: TUM (t tx ty tz qx qy qz qw) or KITTI (12 values, 10 Hz) file, or a\n"
    "                   planetary_vo dataset folder (groundtruth.txt and, if present, "
    "groundtruth_state.txt)\n"
    "  --est            estimated trajectory, TUM or KITTI file\n"
    "  --align          alignment of the estimate onto the ground truth (default sim3); first: the first\n"
    "                   associated estimated pose is put on the true one (a navigation handed its initial "
    "state)\n"
    "  --align-frames   align on the first N associated poses only (sim3/se3; default 0: all)\n"
    "  --first-scale-window  with --align first: scale = ground-truth / estimate path length over the first "
    "S\n"
    "                   seconds (estimates without metric scale; uses the ground truth over that window "
    "only);\n"
    "                   default 0: scale 1\n"
    "  --initial-error-m    with --align first: error of the handed-over position, world frame [m]\n"
    "  --initial-error-deg  with --align first: rotation vector applied to the handed-over attitude, world "
    "[deg]\n"
    "  --initial-scale-error with --align first: relative error multiplying the scale, (1 + F)\n"
    "  --gt-state       ground-truth state file (groundtruth_state.txt: t p q v bg ba) for the true "
    "velocity\n"
    "  --est-velocity   estimated velocity, lines t vx vy vz (world of the estimate), optionally followed by\n"
    "                   6 IMU biases (not used here) or the velocity's 3x3 covariance, row-major (its\n"
    "                   NEES); default: differences of the aligned estimated positions\n"
    "  --est-cov        estimated covariance, lines t + 9 (3x3 position) or t + 36 (6x6 position, attitude)\n"
    "                   values, row-major: NEES\n"
    "  --up-axis        up direction of the ground-truth world for the tilt error (default +z; -y for "
    "KITTI)\n"
    "  --scale-window   trailing window of the scale error over time in seconds (default 5)\n"
    "  --gap-factor     stamps more than F x the median period apart are a gap for velocities (default 3)\n"
    "  --max-dt         association tolerance in seconds (default 0.02)\n"
    "  --rpe-frames     RPE frame deltas (default 1,10)\n"
    "  --rpe-distances  RPE distance deltas in metres (default 10,20,30,40,50 % of the path length)\n"
    "  --json           write the results as JSON\n"
    "  --plot           write PNG plots (and pose_errors.csv) into DIR with scripts/plot_trajectory.py\n"
    "  --plot-script    the plot script; default $PLANETARY_VO_ROOT/scripts/plot_trajectory.py, else found "
    "by\n"
    "                   walking up from this executable to the package (package.xml beside scripts/)\n"
    "  --axes           plot axis names: landing (crossrange x, downrange y, altitude z; default) or xyz\n";

bool isFile(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

template <typename T>
std::vector<T> parseList(const std::string& text, const std::string& option) {
  std::vector<T> values;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    std::istringstream in(item);
    T v{};
    if (!(in >> v) || !in.eof()) throw EvalError("bad value '" + item + "' in " + option);
    values.push_back(v);
  }
  return values;
}

double parseNumber(const std::string& text, const std::string& option) {
  const std::vector<double> v = parseList<double>(text, option);
  if (v.size() != 1) throw EvalError(option + " takes one number, got '" + text + "'");
  return v[0];
}

Eigen::Vector3d parseVector(const std::string& text, const std::string& option) {
  const std::vector<double> v = parseList<double>(text, option);
  if (v.size() != 3) throw EvalError(option + " takes three numbers x,y,z, got '" + text + "'");
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

/// The plot script: the option, else $PLANETARY_VO_ROOT, else the first folder up from the executable that is
/// the package (package.xml + scripts/plot_trajectory.py), a catkin workspace holding it in src/, or an
/// install space (share/planetary_vo/scripts/).
std::string findPlotScript() {
  const std::string relative = "scripts/plot_trajectory.py";
  if (const char* root = std::getenv("PLANETARY_VO_ROOT"); root && *root) {
    if (isFile(std::string(root) + "/" + relative)) return std::string(root) + "/" + relative;
  }
  char exe[4096];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n <= 0) return "";
  std::string dir(exe, static_cast<size_t>(n));
  while (dir.size() > 1) {
    dir = dir.substr(0, dir.find_last_of('/'));
    if (dir.empty()) dir = "/";
    for (const std::string& candidate :
         {dir + "/", dir + "/src/planetary_vo/", dir + "/share/planetary_vo/"}) {
      if (isFile(candidate + "package.xml") && isFile(candidate + relative)) return candidate + relative;
    }
  }
  return "";
}

std::string shellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

Trajectory readOrExplain(const std::string& path, const char* what) {
  Trajectory t = readTrajectory(path);  // DatasetError names the file and line
  if (t.empty()) throw EvalError(std::string(what) + " " + path + " has no pose");
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  std::string gt_arg, gt_state_path, est_path, est_velocity_path, est_cov_path, json_path, plot_dir,
      plot_script, title, axes = "landing";
  EvaluationOptions options;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg == "-h" || arg == "--help") {
        std::cout << kUsage;
        return 0;
      }
      if (i + 1 >= argc) throw EvalError("option " + arg + " needs a value (or is unknown)");
      const std::string value = argv[++i];
      if (arg == "--gt") {
        gt_arg = value;
      } else if (arg == "--gt-state") {
        gt_state_path = value;
      } else if (arg == "--est") {
        est_path = value;
      } else if (arg == "--est-velocity") {
        est_velocity_path = value;
      } else if (arg == "--est-cov") {
        est_cov_path = value;
      } else if (arg == "--first-scale-window") {
        options.first_pose.scale_window_s = parseNumber(value, arg);
      } else if (arg == "--initial-error-m") {
        options.first_pose.position_error_m = parseVector(value, arg);
      } else if (arg == "--initial-error-deg") {
        options.first_pose.attitude_error_deg = parseVector(value, arg);
      } else if (arg == "--initial-scale-error") {
        options.first_pose.scale_error = parseNumber(value, arg);
      } else if (arg == "--up-axis") {
        options.up_world = parseAxis(value);
      } else if (arg == "--scale-window") {
        options.scale_window_s = parseNumber(value, arg);
      } else if (arg == "--gap-factor") {
        options.gap_factor = parseNumber(value, arg);
      } else if (arg == "--align") {
        options.alignment = parseAlignmentMode(value);
      } else if (arg == "--align-frames") {
        const double n = parseNumber(value, arg);
        // Range first: converting 1e308 to size_t is undefined (UBSan, issue 12 tools fuzz test).
        if (!(n >= 0.0 && n <= 9007199254740992.0 && n == std::floor(n)))  // 2^53: every integer exact
          throw EvalError("--align-frames takes a count, got " + value);
        options.align_num_pairs = static_cast<size_t>(n);
      } else if (arg == "--max-dt") {
        options.max_dt_s = parseNumber(value, arg);
        if (!(options.max_dt_s >= 0.0)) throw EvalError("--max-dt must be >= 0");
      } else if (arg == "--rpe-frames") {
        options.rpe_frame_deltas = parseList<int>(value, arg);
      } else if (arg == "--rpe-distances") {
        options.rpe_distance_deltas_m = parseList<double>(value, arg);
      } else if (arg == "--json") {
        json_path = value;
      } else if (arg == "--plot") {
        plot_dir = value;
      } else if (arg == "--plot-script") {
        plot_script = value;
      } else if (arg == "--axes") {
        if (value != "landing" && value != "xyz")
          throw EvalError("--axes takes landing or xyz, got " + value);
        axes = value;
      } else if (arg == "--title") {
        title = value;
      } else {
        throw EvalError("unknown option " + arg);
      }
    }
    if (gt_arg.empty() || est_path.empty()) throw EvalError("--gt and --est are required");
    validate(options);  // e.g. --initial-error-m without --align first
  } catch (const std::exception& e) {
    std::cerr << "vo_eval: " << e.what() << "\n" << kUsage;
    return 2;
  }

  try {
    const GroundTruthFiles gt_files = findGroundTruthFiles(gt_arg);
    if (gt_state_path.empty()) gt_state_path = gt_files.state_path;
    const Trajectory gt = readOrExplain(gt_files.trajectory_path, "ground truth");
    const Trajectory est = readOrExplain(est_path, "estimate");
    EvaluationInputs inputs;
    if (!gt_state_path.empty()) inputs.ground_truth_state = readGroundTruthStates(gt_state_path);
    if (!est_velocity_path.empty()) inputs.estimate_velocity = readEstimateVelocities(est_velocity_path);
    if (!est_cov_path.empty()) inputs.estimate_covariance = readEstimateCovariances(est_cov_path);
    const TrajectoryEvaluation ev = evaluateTrajectory(gt, est, options, inputs);
    std::cout << "ground truth: " << gt_files.trajectory_path << "\n";
    if (!gt_state_path.empty()) std::cout << "ground-truth state: " << gt_state_path << "\n";
    std::cout << "estimate:     " << est_path << "\n";
    if (!est_velocity_path.empty()) std::cout << "estimated velocity: " << est_velocity_path << "\n";
    if (!est_cov_path.empty()) std::cout << "estimated covariance: " << est_cov_path << "\n";
    std::cout << "\n" << formatReport(ev);
    if (!json_path.empty()) {
      writeJson(json_path, ev);
      std::cout << "\nJSON written to " << json_path << "\n";
    }
    if (!plot_dir.empty()) {
      if (plot_script.empty()) plot_script = findPlotScript();
      if (plot_script.empty() || !isFile(plot_script))
        throw EvalError("plot script not found" +
                        (plot_script.empty() ? std::string() : " at " + plot_script) +
                        ": give --plot-script or set PLANETARY_VO_ROOT to the package folder");
      if (std::system(("mkdir -p " + shellQuote(plot_dir)).c_str()) != 0)
        throw EvalError("cannot create " + plot_dir);
      const std::string csv = plot_dir + "/pose_errors.csv";
      writePoseErrorsCsv(csv, ev);
      if (title.empty()) title = est_path.substr(est_path.find_last_of('/') + 1);
      char subtitle[256];
      std::snprintf(
          subtitle, sizeof(subtitle),
          "align %s, scale %.4f, ATE RMSE %.3f m (%.2f %% of %.1f m), final %.3f m (%.2f %% of %.1f m)",
          toString(options.alignment), ev.alignment.scale, ev.ate_m.rmse, ev.ate_rmse_percent,
          ev.gt_path_length_m, ev.final_errors.position_error_m,
          ev.final_errors.position_error_percent_of_distance, ev.distance_travelled_m);
      const std::string command = "/usr/bin/python3 " + shellQuote(plot_script) + " --csv " +
                                  shellQuote(csv) + " --out " + shellQuote(plot_dir) + " --title " +
                                  shellQuote(title) + " --subtitle " + shellQuote(subtitle) + " --axes " +
                                  axes;
      std::cout.flush();  // the script's own output comes after the report
      const int rc = std::system(command.c_str());
      if (rc != 0) throw EvalError("plotting failed (exit status " + std::to_string(rc) + "): " + command);
      std::cout << "plots written to " << plot_dir << "\n";
    }
  } catch (const std::exception& e) {
    std::cerr << "vo_eval: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
