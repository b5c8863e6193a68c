/// @file make_noisy_trajectory.cpp
/// make_noisy_trajectory: turns a ground-truth trajectory (TUM or KITTI) into a VO-like estimate in TUM
/// format, for demonstrating and checking vo_eval. The relative motion of each step gets Gaussian noise
/// (translation noise proportional to the step length, rotation noise in degrees), so errors accumulate as in
/// odometry; the result is then expressed in another world frame at another scale, as a monocular VO would
/// report it.

#include <cstdlib>
#include <iostream>
#include <random>
#include <string>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/eval/trajectory_alignment.h"

using namespace planetary_vo;

namespace {
const char* kUsage =
    "usage: make_noisy_trajectory --gt FILE --out FILE [--trans-noise FRACTION] [--rot-noise DEG] [--scale "
    "S]\n"
    "                             [--yaw DEG] [--seed N]\n"
    "  --trans-noise  std of the per-step translation noise, as a fraction of the step length (default "
    "0.01)\n"
    "  --rot-noise    std of the per-step rotation noise per axis in degrees (default 0.05)\n"
    "  --scale        scale of the output world relative to the ground truth (default 0.5)\n"
    "  --yaw          rotation of the output world about z in degrees (default 30)\n"
    "  --seed         random seed (default 1)\n";
}  // namespace

int main(int argc, char** argv) {
  std::string gt_path, out_path;
  double trans_noise = 0.01, rot_noise_deg = 0.05, scale = 0.5, yaw_deg = 30.0;
  unsigned seed = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "-h" || arg == "--help" || i + 1 >= argc) {
      std::cerr << kUsage;
      return arg == "-h" || arg == "--help" ? 0 : 2;
    }
    const std::string value = argv[++i];
    char* end = nullptr;
    const double number = std::strtod(value.c_str(), &end);
    const bool is_number = end != value.c_str() && *end == '\0';
    if (arg == "--gt") {
      gt_path = value;
    } else if (arg == "--out") {
      out_path = value;
    } else if (is_number && arg == "--trans-noise") {
      trans_noise = number;
    } else if (is_number && arg == "--rot-noise") {
      rot_noise_deg = number;
    } else if (is_number && arg == "--scale" && number > 0.0) {
      scale = number;
    } else if (is_number && arg == "--yaw") {
      yaw_deg = number;
    } else if (is_number && arg == "--seed") {
      seed = static_cast<unsigned>(number);
    } else {
      std::cerr << "make_noisy_trajectory: bad option " << arg << " " << value << "\n" << kUsage;
      return 2;
    }
  }
  if (gt_path.empty() || out_path.empty()) {
    std::cerr << "make_noisy_trajectory: --gt and --out are required\n" << kUsage;
    return 2;
  }
  try {
    const Trajectory gt = readTrajectory(gt_path);
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    Trajectory est = gt;
    for (size_t k = 1; k < gt.size(); ++k) {
      Pose step = gt[k - 1].T_world_cam.inverse() * gt[k].T_world_cam;
      const double length = step.translation().norm();
      step.translation() += trans_noise * length * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      const Eigen::Vector3d rot_noise =
          rot_noise_deg * M_PI / 180.0 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      if (rot_noise.norm() > 0.0)
        step.linear() =
            step.rotation() * Eigen::AngleAxisd(rot_noise.norm(), rot_noise.normalized()).toRotationMatrix();
      est[k].T_world_cam = est[k - 1].T_world_cam * step;
    }
    // Express in another world: p_out = scale * Rz(yaw) * p + t.
    Sim3Transform to_output;
    to_output.scale = scale;
    to_output.R_gt_est =
        Eigen::AngleAxisd(yaw_deg * M_PI / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    to_output.t_gt_est_m = Eigen::Vector3d(3.0, -2.0, 1.0);
    writeTumTrajectory(out_path, to_output.transformTrajectory(est));
    std::cout << "wrote " << est.size() << " poses to " << out_path << "\n";
  } catch (const std::exception& e) {
    std::cerr << "make_noisy_trajectory: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
