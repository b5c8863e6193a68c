/// @file track_truth.cpp
/// How far the front end's tracks are from the true projection of their point, on a render whose depth was
/// saved (`lunar_render ... --depth`). Runs the tracking stage alone (KltTracker with the configuration's
/// tracker and detector sections) over the images. A track's point is where the ray of its first pixel meets
/// the terrain (the depth image of that frame, true pose); in each later frame the track is compared with
/// that point projected by the true pose. The error therefore starts at zero and shows what the tracker adds
/// with age: the chained error of frame-to-frame tracking, the anchor patches' precision, jumps to wrong
/// structure.
///
/// Nothing here feeds the estimator: it is a measuring instrument for the tracking stage.
///
/// Usage: track_truth --dataset DIR [--config YAML] [--max-frames N] [--csv FILE]
/// Prints, per age bin (frames since detection), the number of track samples, the median, p90 and RMS of the
/// error (px; the RMS over errors below 1 px) and the share above 1 px. --csv writes every sample
/// (frame, track id, age, error x, error y).

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/vo/config_yaml.h"
#include "planetary_vo/vo/klt_tracker.h"

namespace pv = planetary_vo;

namespace {

void usage() {
  std::cerr
      << "usage: track_truth --dataset DIR [--config YAML] [--max-frames N] [--csv FILE]\n"
         "  --dataset     a planetary_vo render with its depth images (lunar_render --depth)\n"
         "  --config      VO configuration (its tracker and detector sections are used); default: defaults\n"
         "  --max-frames  stop after N images (default: all)\n"
         "  --csv         write every sample: frame,track_id,age_frames,err_x_px,err_y_px\n";
}

/// Bilinear depth at `px`, or NaN where the four neighbours are not one surface (their spread above 0.5 % of
/// the depth: an occluding edge) or hold no terrain (0).
double depthAt(const cv::Mat1f& depth, const cv::Point2f& px) {
  const int x0 = static_cast<int>(std::floor(px.x)), y0 = static_cast<int>(std::floor(px.y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= depth.cols || y0 + 1 >= depth.rows) return std::nan("");
  const float d00 = depth(y0, x0), d01 = depth(y0, x0 + 1), d10 = depth(y0 + 1, x0),
              d11 = depth(y0 + 1, x0 + 1);
  const float lo = std::min({d00, d01, d10, d11}), hi = std::max({d00, d01, d10, d11});
  if (!(lo > 0.f) || hi - lo > 0.005f * lo) return std::nan("");
  const double ax = px.x - x0, ay = px.y - y0;
  return (1 - ay) * ((1 - ax) * d00 + ax * d01) + ay * ((1 - ax) * d10 + ax * d11);
}

struct Bin {
  int lo, hi;  // ages [lo, hi]
  std::vector<double> errors;
  std::vector<double> across;  // |error| across the epipolar line: free of the true depth's error
};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

}  // namespace

int main(int argc, char** argv) {
  std::string dataset_dir, config_path, csv_path;
  long max_frames = -1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        usage();
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--dataset")
      dataset_dir = next();
    else if (a == "--config")
      config_path = next();
    else if (a == "--max-frames")
      max_frames = std::atol(next().c_str());
    else if (a == "--csv")
      csv_path = next();
    else if (a == "-h" || a == "--help") {
      usage();
      return 0;
    } else {
      std::cerr << "track_truth: unknown argument " << a << "\n";
      usage();
      return 2;
    }
  }
  if (dataset_dir.empty()) {
    usage();
    return 2;
  }
  try {
    const pv::Dataset dataset = pv::Dataset::open(dataset_dir);
    if (!dataset.hasGroundTruth() || dataset.groundTruth().size() != dataset.size())
      throw std::runtime_error("the dataset has no ground-truth pose for every image");
    const pv::VoConfig config = config_path.empty() ? pv::VoConfig() : pv::loadVoConfig(config_path);
    const pv::PinholeCamera& camera = dataset.camera();
    pv::KltTracker tracker(config.tracker, config.detector);
    // The pixel a point in the camera frame is seen at, through the lens (images are stored distorted).
    auto projectPx = [&camera](const Eigen::Vector3d& p_in_cam) {
      const Eigen::Vector2d ideal = camera.project(p_in_cam);
      return camera.hasDistortion() ? camera.distortPixel(ideal) : ideal;
    };

    std::ofstream csv;
    if (!csv_path.empty()) {
      csv.open(csv_path);
      if (!csv) throw std::runtime_error("cannot write " + csv_path);
      csv << "frame,track_id,age_frames,err_x_px,err_y_px\n";
    }
    std::vector<Bin> bins = {
        {1, 1, {}, {}}, {2, 5, {}, {}}, {6, 20, {}, {}}, {21, 60, {}, {}}, {61, 1 << 30, {}, {}}};
    struct TruePoint {
      Eigen::Vector3d p_world, centre_world;  // the point and the camera centre it was first seen from
    };
    std::unordered_map<uint64_t, TruePoint> point_world;  // track id -> its true point
    size_t frames = dataset.size();
    if (max_frames >= 0) frames = std::min(frames, static_cast<size_t>(max_frames));
    long no_depth = 0, born = 0;
    for (size_t i = 0; i < frames; ++i) {
      char name[64];
      std::snprintf(name, sizeof(name), "/depth/%06zu.tiff", i);
      const cv::Mat depth_any = cv::imread(dataset.directory() + name, cv::IMREAD_UNCHANGED);
      if (depth_any.empty() || depth_any.type() != CV_32FC1)
        throw std::runtime_error(std::string("no float depth image ") + dataset.directory() + name +
                                 ": render the dataset with lunar_render --depth");
      const cv::Mat1f depth(depth_any);
      tracker.track(dataset.loadImage(i));
      const pv::Pose& T_world_cam = dataset.groundTruth()[i].T_world_cam;
      const pv::Pose T_cam_world = T_world_cam.inverse();
      for (const pv::FeatureTrack& t : tracker.tracks()) {
        if (t.first_frame == static_cast<int64_t>(i)) {
          ++born;
          const double z = depthAt(depth, t.px);
          if (!std::isfinite(z)) {
            ++no_depth;
            continue;
          }
          const Eigen::Vector3d bearing = camera.distortedPixelToBearing(Eigen::Vector2d(t.px.x, t.px.y));
          point_world[t.id] = {T_world_cam * (bearing * (z / bearing.z())), T_world_cam.translation()};
          continue;
        }
        const auto it = point_world.find(t.id);
        if (it == point_world.end()) continue;
        const Eigen::Vector3d p_cam = T_cam_world * it->second.p_world;
        if (p_cam.z() <= 0.0) continue;
        const Eigen::Vector2d truth = projectPx(p_cam);
        const double ex = t.px.x - truth.x(), ey = t.px.y - truth.y();
        // The epipolar direction: where the projection moves when the point slides along its first ray (an
        // error of the true depth moves it only this way).
        const Eigen::Vector3d further =
            it->second.p_world + 1e-3 * (it->second.p_world - it->second.centre_world);
        Eigen::Vector2d epi = projectPx(T_cam_world * further) - truth;
        const double epi_norm = epi.norm();
        const double across =
            epi_norm > 1e-9 ? std::abs(-epi.y() * ex + epi.x() * ey) / epi_norm : std::hypot(ex, ey);
        const int age = static_cast<int>(static_cast<int64_t>(i) - t.first_frame);
        for (Bin& b : bins)
          if (age >= b.lo && age <= b.hi) {
            b.errors.push_back(std::hypot(ex, ey));
            b.across.push_back(across);
          }
        if (csv) csv << i << ',' << t.id << ',' << age << ',' << ex << ',' << ey << '\n';
      }
    }
    std::printf("track_truth: %s, %zu frames, %ld tracks born (%ld without a usable depth), method %s\n",
                dataset.name().c_str(), frames, born, no_depth, pv::toString(config.tracker.method));
    std::printf("%-12s %9s %10s %10s %14s %10s %17s %14s\n", "age_frames", "samples", "median_px", "p90_px",
                "rms<1px_px", "share>1px", "across_median_px", "across_p90_px");
    for (const Bin& b : bins) {
      double sum2 = 0.0;
      long n_in = 0;
      for (double e : b.errors)
        if (e < 1.0) sum2 += e * e, ++n_in;
      const double share =
          b.errors.empty() ? std::nan("") : 1.0 - static_cast<double>(n_in) / b.errors.size();
      const std::string label =
          b.hi >= (1 << 30) ? std::to_string(b.lo) + "+" : std::to_string(b.lo) + "-" + std::to_string(b.hi);
      std::printf("%-12s %9zu %10.4f %10.4f %14.4f %10.4f %17.4f %14.4f\n", label.c_str(), b.errors.size(),
                  percentile(b.errors, 0.5), percentile(b.errors, 0.9),
                  n_in ? std::sqrt(sum2 / n_in) : std::nan(""), share, percentile(b.across, 0.5),
                  percentile(b.across, 0.9));
    }
  } catch (const std::exception& e) {
    std::cerr << "track_truth: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
