/// @file ba_benchmark.cpp
/// Times the windowed bundle adjustment (adjustBundle) on a synthetic window the size of Main Brake's: a
/// camera 2000 m over rolling terrain moving 60 m between keyframes, 10 keyframes (the oldest two fixed, the
/// monocular gauge), points seen by 2-8 consecutive keyframes, 0.5 px noise, poses and points perturbed.
/// Usage: ba_benchmark [config.yaml] [repeats] [points]. Prints the solve's CPU time (min / median / max over
/// the repeats, the same problem each time) and Ceres' iterations, so that a change to the optimiser can be
/// compared on a quiet core without the noise of a whole run.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "planetary_vo/vo/bundle_adjuster.h"
#include "planetary_vo/vo/config_yaml.h"

namespace {

planetary_vo::BaProblem makeWindow(int num_points, unsigned seed) {
  using planetary_vo::BaKeyframe;
  using planetary_vo::BaObservation;
  using planetary_vo::BaPoint;
  using planetary_vo::Pose;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  planetary_vo::BaProblem p;
  p.fx = p.fy = 886.8;  // 60 deg field of view at 1024 px
  p.cx = p.cy = 511.5;
  const int num_keyframes = 10;
  std::vector<Pose> truth;
  for (int k = 0; k < num_keyframes; ++k) {
    // Nadir camera (optical axis down: x right, y backward in the world, z down) moving along +y.
    Pose T_world_cam = Pose::Identity();
    T_world_cam.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;
    T_world_cam.translation() = Eigen::Vector3d(0.0, 60.0 * k, 2000.0);
    truth.push_back(T_world_cam);
    Pose start = T_world_cam;
    if (k >= 2) {  // the free keyframes start off by 0.05 deg and 1 m
      start.linear() = (Eigen::AngleAxisd(0.05 * M_PI / 180.0,
                                          Eigen::Vector3d(noise(rng), noise(rng), noise(rng)).normalized()) *
                        Eigen::Quaterniond(T_world_cam.linear()))
                           .toRotationMatrix();
      start.translation() += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    }
    p.keyframes.push_back(BaKeyframe{static_cast<uint64_t>(k + 1), start.inverse(), k < 2});
  }
  for (int j = 0; j < num_points; ++j) {
    const int first = static_cast<int>(uni(rng) * (num_keyframes - 1));
    const int last = std::min(num_keyframes - 1, first + 1 + static_cast<int>(uni(rng) * 7));
    // A ground point under the middle of its keyframes' span, within the central 80 % of the view.
    const Eigen::Vector3d centre = 0.5 * (truth[first].translation() + truth[last].translation());
    const Eigen::Vector3d ground(centre.x() + 1600.0 * (uni(rng) - 0.5),
                                 centre.y() + 900.0 * (uni(rng) - 0.5),
                                 30.0 * std::sin(0.01 * centre.x()) + 20.0 * noise(rng));
    p.points.push_back(BaPoint{static_cast<uint64_t>(j + 1),
                               ground + 3.0 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng)), false});
    for (int k = first; k <= last; ++k) {
      const Eigen::Vector3d c = truth[k].inverse() * ground;
      const Eigen::Vector2d px(p.fx * c.x() / c.z() + p.cx + 0.5 * noise(rng),
                               p.fy * c.y() / c.z() + p.cy + 0.5 * noise(rng));
      p.observations.push_back(BaObservation{static_cast<uint64_t>(k + 1), static_cast<uint64_t>(j + 1), px});
    }
  }
  return p;
}

}  // namespace

int main(int argc, char** argv) try {
  planetary_vo::VoConfig config;
  if (argc > 1 && std::string(argv[1]) != "-") config = planetary_vo::loadVoConfig(argv[1]);
  const int repeats = argc > 2 ? std::max(1, std::atoi(argv[2])) : 50;
  const int num_points = argc > 3 ? std::max(10, std::atoi(argv[3])) : 350;
  const planetary_vo::BaProblem window = makeWindow(num_points, 7);
  std::vector<double> cpu_ms;
  planetary_vo::BaSummary summary;
  for (int i = 0; i < repeats; ++i) {
    planetary_vo::BaProblem problem = window;
    summary = planetary_vo::adjustBundle(&problem, config.bundle_adjustment);
    cpu_ms.push_back(summary.solve_cpu_ms);
  }
  std::sort(cpu_ms.begin(), cpu_ms.end());
  std::printf("bundle adjustment: 10 keyframes (2 fixed), %d points, %zu observations, %d repeats\n",
              num_points, window.observations.size(), repeats);
  std::printf(
      "  CPU per solve: min %.3f ms, median %.3f ms, max %.3f ms; %d iterations, RMS %.3f -> %.3f px\n",
      cpu_ms.front(), cpu_ms[cpu_ms.size() / 2], cpu_ms.back(), summary.iterations, summary.initial_rms_px,
      summary.final_rms_px);
  return summary.converged ? 0 : 1;
} catch (const std::exception& e) {
  std::fprintf(stderr, "ba_benchmark: %s\n", e.what());
  return 2;
}
