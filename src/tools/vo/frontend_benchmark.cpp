/// @file frontend_benchmark.cpp
/// Times the front end (GridDetector, KltTracker) on synthetic 1024x1024 frames, the Lunar dataset's size.
/// Usage: frontend_benchmark [config.yaml] [frames]. Prints mean and worst milliseconds per stage.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "planetary_vo/vo/config_yaml.h"
#include "planetary_vo/vo/grid_detector.h"
#include "planetary_vo/vo/klt_tracker.h"

namespace {

/// Blurred-noise terrain with a flat (shadowed) band, so that redistribution and the fallback have work to
/// do.
cv::Mat makeTerrain(const cv::Size& size) {
  cv::Mat noise(size, CV_32F);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(), 1.5);
  cv::Mat gray;
  cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
  noise.convertTo(gray, CV_8U);
  gray(cv::Rect(0, size.height / 3, size.width / 4, size.height / 3)).setTo(20);
  return gray;
}

struct Timing {
  std::vector<double> ms;
  void add(double v) { ms.push_back(v); }
  void print(const char* name) const {
    if (ms.empty()) return;
    double sum = 0.0;
    for (double v : ms) sum += v;
    std::printf("  %-28s mean %7.3f ms   max %7.3f ms   (%zu runs)\n", name, sum / ms.size(),
                *std::max_element(ms.begin(), ms.end()), ms.size());
  }
};

}  // namespace

int main(int argc, char** argv) {
  planetary_vo::VoConfig config;
  if (argc > 1) config = planetary_vo::loadVoConfig(argv[1]);
  const int frames = argc > 2 ? std::atoi(argv[2]) : 100;
  const cv::Size size(1024, 1024);
  const cv::Mat terrain = makeTerrain(cv::Size(size.width + 400, size.height + 400));
  std::printf("front end on %dx%d synthetic frames, %d frames, OpenCV threads %d\n", size.width, size.height,
              frames, cv::getNumThreads());

  for (bool descriptors : {false, true}) {
    planetary_vo::DetectorConfig dc = config.detector;
    dc.compute_descriptors = descriptors;
    planetary_vo::GridDetector detector(dc);
    Timing detect, describe;
    size_t count = 0;
    for (int i = 0; i < frames; ++i) {
      const cv::Mat frame = terrain(cv::Rect(i % 200, (2 * i) % 200, size.width, size.height));
      count = detector.detect(frame).size();
      detect.add(detector.lastStats().detect_ms);
      describe.add(detector.lastStats().describe_ms);
    }
    std::printf("GridDetector full detection (%zu features, descriptors %s):\n", count,
                descriptors ? "on" : "off");
    detect.print("detect");
    if (descriptors) describe.print("describe");
  }

  // The tracker on a slow drift (1.3 px/frame diagonally) with replenishment.
  planetary_vo::KltTracker tracker(config.tracker, config.detector);
  Timing pyramid, lk, replenish, total;
  int tracked = 0, added = 0;
  for (int i = 0; i < frames; ++i) {
    const int offset = static_cast<int>(1.3 * i) % 380;
    const cv::Mat frame = terrain(cv::Rect(offset, offset, size.width, size.height));
    const planetary_vo::TrackingResult r = tracker.track(frame);
    if (i == 0) continue;  // the first frame only detects
    pyramid.add(r.pyramid_ms);
    lk.add(r.lk_ms);
    replenish.add(r.detect_ms);
    total.add(r.total_ms);
    tracked += r.num_tracked;
    added += r.num_new;
  }
  std::printf("KltTracker per frame (mean %.0f tracked, %.1f new):\n", tracked / std::max(1.0, frames - 1.0),
              added / std::max(1.0, frames - 1.0));
  pyramid.print("pyramid");
  lk.print("LK forward+backward");
  replenish.print("replenishment detection");
  total.print("total");
  return 0;
}
