/// geometry_benchmark: the thesis' figures 3.6-3.13 (section 3.4.3) as a table of numbers.
///
/// For each method (F: 8-point, E: 5-point, H: homography without prior, H+n: homography with the nadir
/// prior, EPnP) x baseline (3, 30, 100) x depth spread (planar, 0-100, 0-250, 0-500 above z = 1500) x motion
/// (translation, translation + 30 deg about x and y) x image noise (0, 1 px), over N random point clouds:
/// median rotation error (deg), median translation direction error (deg) over all trials and over the
/// accepted ones, rejection rate (valid == false) and median time per estimator call (microseconds).
///
/// EPnP follows the thesis: the 3D points are triangulated (linear DLT, true relative pose) from the same
/// noisy correspondences, then camera 2 is located from them.
///
/// Usage: geometry_benchmark [--trials N] [--markdown]

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <string>
#include <vector>

#include "planetary_vo/geometry/pnp_solver.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/geometry/synthetic_scene.h"
#include "planetary_vo/geometry/triangulation.h"
#include "planetary_vo/geometry/two_view_geometry.h"

using namespace planetary_vo;

namespace {

struct Outcome {
  bool has_pose = false;
  bool valid = false;
  double rot_err_deg = NAN;
  double trans_err_deg = NAN;
  double time_us = 0.0;
};

double median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return NAN;
  auto mid = v.begin() + v.size() / 2;
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

template <typename F>
double timeUs(F&& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
}

Outcome scoreTwoView(const TwoViewResult& r, const Pose& truth, double time_us) {
  Outcome o;
  o.time_us = time_us;
  o.valid = r.valid;
  o.has_pose = r.num_inliers > 0 && r.t_c2_c1_unit.norm() > 0.0;
  if (o.has_pose) {
    o.rot_err_deg = rotationAngleDeg(r.R_c2_c1 * truth.linear().transpose());
    o.trans_err_deg = angleBetweenDeg(r.t_c2_c1_unit, truth.translation());
  }
  return o;
}

Outcome runMethod(const std::string& method, const SyntheticTwoViewScene& s) {
  const Eigen::Matrix3d K = s.camera.K();
  if (method == "EPnP") {
    TriangulationOptions tri;
    tri.optimal_correction = false;  // the thesis uses the linear method
    tri.max_reprojection_error_px = 1e9;
    tri.min_parallax_deg = 0.0;
    const TriangulationResult points = triangulatePoints(s.px1, s.px2, K, s.T_c2_c1, tri);
    std::vector<Eigen::Vector3d> p;
    std::vector<cv::Point2d> px;
    for (std::size_t i = 0; i < points.points_c1.size(); ++i)
      if (points.points_c1[i].allFinite()) {
        p.push_back(points.points_c1[i]);
        px.push_back(s.px2[i]);
      }
    PnpResult r;
    const double us = timeUs([&] { r = solvePnpRansac(p, px, K); });
    Outcome o;
    o.time_us = us;
    o.valid = r.valid;
    o.has_pose = r.num_inliers > 0;
    if (o.has_pose) {
      o.rot_err_deg = rotationAngleDeg(r.T_cam_world.linear() * s.T_c2_c1.linear().transpose());
      o.trans_err_deg = angleBetweenDeg(r.T_cam_world.translation(), s.T_c2_c1.translation());
    }
    return o;
  }
  TwoViewOptions options;
  TwoViewResult r;
  double us = 0.0;
  if (method == "F") {
    us = timeUs([&] { r = estimateFundamental(s.px1, s.px2, K, options); });
  } else if (method == "E") {
    us = timeUs([&] { r = estimateEssential(s.px1, s.px2, K, options); });
  } else {
    if (method == "H+n") options.prior_plane_normal_c1 = Eigen::Vector3d::UnitZ();  // nadir, plane z = const
    us = timeUs([&] { r = estimateHomography(s.px1, s.px2, K, options); });
  }
  return scoreTwoView(r, s.T_c2_c1, us);
}

std::string fmt(double v, int decimals = 3) {
  if (!std::isfinite(v)) return "-";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  int trials = 10;
  bool markdown = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--trials") && i + 1 < argc) {
      trials = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--markdown")) {
      markdown = true;
    } else {
      std::fprintf(stderr, "usage: %s [--trials N] [--markdown]\n", argv[0]);
      return 2;
    }
  }
  const std::vector<std::string> methods{"F", "E", "H", "H+n", "EPnP"};
  const std::vector<double> baselines{3.0, 30.0, 100.0};
  const std::vector<double> spreads{0.0, 100.0, 250.0, 500.0};
  const std::vector<double> rotations{0.0, 30.0};
  const std::vector<double> noises{0.0, 1.0};

  const char* header[] = {"method",        "baseline",        "depth",
                          "motion",        "noise_px",        "rot_med_deg",
                          "trans_med_deg", "rot_med_acc_deg", "trans_med_acc_deg",
                          "rejected_%",    "time_med_us"};
  if (markdown) {
    std::printf("|");
    for (const char* h : header) std::printf(" %s |", h);
    std::printf("\n|");
    for (std::size_t i = 0; i < sizeof(header) / sizeof(header[0]); ++i) std::printf("---|");
    std::printf("\n");
  } else {
    std::printf("%-6s %8s %8s %6s %8s %11s %13s %15s %17s %10s %11s\n", header[0], header[1], header[2],
                header[3], header[4], header[5], header[6], header[7], header[8], header[9], header[10]);
  }
  std::vector<std::vector<double>> all_times(methods.size());
  for (double noise : noises)
    for (double rotation : rotations)
      for (double baseline : baselines)
        for (double spread : spreads) {
          // The same point clouds for every method of a configuration.
          std::vector<std::vector<Outcome>> outcomes(methods.size());
          for (int t = 0; t < trials; ++t) {
            SyntheticSceneConfig cfg;
            cfg.baseline = baseline;
            cfg.depth_spread = spread;
            cfg.rotation_deg = rotation;
            cfg.noise_px = noise;
            cfg.seed = 1000u * static_cast<unsigned>(t + 1) + static_cast<unsigned>(spread + baseline);
            const SyntheticTwoViewScene scene = makeSyntheticScene(cfg);
            for (std::size_t m = 0; m < methods.size(); ++m)
              outcomes[m].push_back(runMethod(methods[m], scene));
          }
          for (std::size_t m = 0; m < methods.size(); ++m) {
            std::vector<double> rot, trans, rot_acc, trans_acc, times;
            int rejected = 0;
            for (const Outcome& o : outcomes[m]) {
              rot.push_back(o.rot_err_deg);
              trans.push_back(o.trans_err_deg);
              times.push_back(o.time_us);
              all_times[m].push_back(o.time_us);
              if (o.valid) {
                rot_acc.push_back(o.rot_err_deg);
                trans_acc.push_back(o.trans_err_deg);
              } else {
                ++rejected;
              }
            }
            const std::string depth = spread == 0.0 ? "planar" : "0-" + fmt(spread, 0);
            const char* motion = rotation == 0.0 ? "T" : "RT";
            const double reject_pct = 100.0 * rejected / trials;
            if (markdown) {
              std::printf("| %s | %.0f | %s | %s | %.0f | %s | %s | %s | %s | %.0f | %.0f |\n",
                          methods[m].c_str(), baseline, depth.c_str(), motion, noise,
                          fmt(median(rot)).c_str(), fmt(median(trans)).c_str(), fmt(median(rot_acc)).c_str(),
                          fmt(median(trans_acc)).c_str(), reject_pct, median(times));
            } else {
              std::printf("%-6s %8.0f %8s %6s %8.0f %11s %13s %15s %17s %10.0f %11.0f\n", methods[m].c_str(),
                          baseline, depth.c_str(), motion, noise, fmt(median(rot)).c_str(),
                          fmt(median(trans)).c_str(), fmt(median(rot_acc)).c_str(),
                          fmt(median(trans_acc)).c_str(), reject_pct, median(times));
            }
          }
          std::fflush(stdout);
        }
  std::printf(markdown ? "\n| method | median time per call (us), all configurations |\n|---|---|\n" : "\n");
  for (std::size_t m = 0; m < methods.size(); ++m)
    std::printf(markdown ? "| %s | %.0f |\n" : "%-6s median time per call: %.0f us\n", methods[m].c_str(),
                median(all_times[m]));
  return 0;
}
