/// @file cpu_budget.cpp
/// The degradation steps of the tracking and the controller that moves between them.

#include "planetary_vo/vo/cpu_budget.h"

#include <algorithm>
#include <cmath>

#include <opencv2/core/utility.hpp>

#include "planetary_vo/geometry/median.h"

namespace planetary_vo {
namespace {

std::string describeAgainst(const VoConfig& base, const VoConfig& c) {
  std::string what;
  auto add = [&what](const std::string& s) { what += (what.empty() ? "" : ", ") + s; };
  if (c.map.keyframe_features != base.map.keyframe_features)
    add("keyframe_features " + std::to_string(c.map.keyframe_features));
  if (c.detector.num_features != base.detector.num_features)
    add("num_features " + std::to_string(c.detector.num_features));
  if (c.detector.grid_cols != base.detector.grid_cols || c.detector.grid_rows != base.detector.grid_rows)
    add("grid " + std::to_string(c.detector.grid_cols) + "x" + std::to_string(c.detector.grid_rows));
  if (c.tracker.pyramid_levels != base.tracker.pyramid_levels)
    add("pyramid_levels " + std::to_string(c.tracker.pyramid_levels));
  if (c.tracker.anchor_refinement != base.tracker.anchor_refinement)
    add(std::string("anchor_refinement ") + (c.tracker.anchor_refinement ? "on" : "off"));
  if (c.tracker.window_size_px != base.tracker.window_size_px)
    add("window_size_px " + std::to_string(c.tracker.window_size_px));
  return what.empty() ? "base" : what;
}

}  // namespace

void applyOpenCvThreads(const CpuBudgetConfig& config) {
  if (config.opencv_threads > 0) cv::setNumThreads(config.opencv_threads);
}

CpuBudget::CpuBudget(const VoConfig& base) : base_(base) {
  const int floor_features = std::max(1, base.tracker.min_tracked_features);
  // A fraction of the feature budget, with the detection grid scaled along so that a cell holds as many
  // features as at step 0: with the same grid, fewer features per cell leave cells empty sooner, and the
  // replenishment detection that follows runs on most frames (main_brake_down 1024 flight at 100 features:
  // detection median 0.97 ms instead of 0.01, the frame slower than at 300; docs/visual_core.md).
  auto withFeatures = [&](VoConfig* c, int features) {
    features = std::min(c->detector.num_features, features);
    c->detector.num_features = features;
    const double s = std::sqrt(static_cast<double>(features) / std::max(1, base.detector.num_features));
    c->detector.grid_cols =
        std::clamp(static_cast<int>(std::lround(s * base.detector.grid_cols)), 1, base.detector.grid_cols);
    c->detector.grid_rows =
        std::clamp(static_cast<int>(std::lround(s * base.detector.grid_rows)), 1, base.detector.grid_rows);
  };
  auto fraction = [&](double f) {
    return std::max(std::min(floor_features, base.detector.num_features),
                    static_cast<int>(std::lround(f * base.detector.num_features)));
  };
  auto window = [](int current, int at_most) { return std::min(current, at_most); };

  std::vector<VoConfig> ladder{base};
  VoConfig c = base;
  c.map.keyframe_features = 0;  // the map-only features first: off the tracking path, but on the CPU
  ladder.push_back(c);
  if (base.tracker.method == TrackingMethod::kKlt) {
    // LK: its cost is the features times the window's pixels times the levels.
    withFeatures(&c, fraction(0.7));
    ladder.push_back(c);
    c.tracker.pyramid_levels = std::max(1, base.tracker.pyramid_levels - 1);
    ladder.push_back(c);
    c.tracker.anchor_refinement = false;
    ladder.push_back(c);
    withFeatures(&c, fraction(0.5));
    c.tracker.window_size_px = window(c.tracker.window_size_px, 15);
    ladder.push_back(c);
    withFeatures(&c, floor_features);
    c.tracker.window_size_px = window(c.tracker.window_size_px, 11);
    ladder.push_back(c);
  } else {
    // Anchor alignment (and auto, which aligns the anchors on a plane-like view): the alignment's cost is
    // the number of tracks (its levels above full resolution are used only when the prediction misses);
    // the window and the refinement are LK's, and one level less saved nothing measurable (docs). The
    // features go first; with auto one more step makes the frames it tracks by LK (its first ones, a rescue,
    // a 3D scene) lighter as well.
    withFeatures(&c, fraction(0.7));
    ladder.push_back(c);
    withFeatures(&c, fraction(0.5));
    ladder.push_back(c);
    withFeatures(&c, floor_features);
    ladder.push_back(c);
    if (base.tracker.method == TrackingMethod::kAuto) {
      c.tracker.pyramid_levels = std::max(1, base.tracker.pyramid_levels - 1);
      c.tracker.anchor_refinement = false;
      // 15 px, not 11: on the KITTI turn clip (auto tracks the street by LK) 100 features in the 5x5 grid
      // with an 11 px window initialised at frame 47 of 51 (15 px: frame 21; docs/visual_core.md).
      c.tracker.window_size_px = window(c.tracker.window_size_px, 15);
      ladder.push_back(c);
    }
  }

  for (const VoConfig& step : ladder) {
    if (!steps_.empty() && step == steps_.back().config) continue;  // changes nothing here
    steps_.push_back(Step{step, describeAgainst(base, step), 0.0});
  }
  window_ms_.reserve(static_cast<size_t>(std::max(1, base.cpu_budget.window_frames)));
}

std::optional<VoConfig> CpuBudget::observe(double frame_ms) {
  if (!enabled() || !std::isfinite(frame_ms)) return std::nullopt;
  window_ms_.push_back(frame_ms);
  if (static_cast<int>(window_ms_.size()) < base_.cpu_budget.window_frames) return std::nullopt;
  last_median_ms_ = medianInPlace(&window_ms_);
  window_ms_.clear();
  Step& here = steps_[static_cast<size_t>(step_)];
  if (here.cost_ms <= 0.0) here.cost_ms = last_median_ms_;

  const double budget = base_.cpu_budget.frame_budget_ms;
  if (last_median_ms_ > budget && step_ + 1 < numSteps()) {
    ++step_;
    return steps_[static_cast<size_t>(step_)].config;
  }
  if (step_ > 0 && last_median_ms_ < base_.cpu_budget.relax_ratio * budget) {
    // The heavier step's cost, as measured, scaled by how this step's cost changed since (the scene or the
    // machine's load changed): undo only when that fits the budget.
    const Step& heavier = steps_[static_cast<size_t>(step_ - 1)];
    const double predicted =
        heavier.cost_ms > 0.0 ? heavier.cost_ms * last_median_ms_ / here.cost_ms : last_median_ms_;
    if (predicted <= budget) {
      --step_;
      steps_[static_cast<size_t>(step_)].cost_ms = 0.0;  // measured again on return
      return steps_[static_cast<size_t>(step_)].config;
    }
  }
  return std::nullopt;
}

}  // namespace planetary_vo
