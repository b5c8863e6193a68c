#pragma once
/// @file cpu_budget.h
/// Degradation path of the tracking when the CPU cannot keep up (issue 13, VoConfig::cpu_budget).
///
/// The caller measures each processed frame's Pipeline::process() time and hands it to observe(). When the
/// median over cpu_budget.window_frames frames is above cpu_budget.frame_budget_ms, observe() returns the
/// next lighter configuration, which the caller applies with Pipeline::reconfigure() between two frames
/// (tracks, map and trajectory are kept). The steps, cheapest in accuracy first (docs/visual_core.md measures
/// them); a step with fewer features scales the detection grid along (a cell keeps as many features, so that
/// replenishment stays as rare as at step 0):
///   -  when map-only features are on (map.keyframe_features), a step before all others turns them off: they
///      run beside the tracking, but their tracking and the larger adjustment share the CPU with it;
///   tracker.method anchor_alignment or auto (the default), whose cost is the number of tracks:
///   1. 70 % of the feature budget (detector.num_features)
///   2. half of it
///   3. tracker.min_tracked_features features
///   4. auto only, for the frames it tracks by LK: one pyramid level less (tracker.pyramid_levels, at least
///      1), no anchor refinement and an LK window of at most 15 px
///   tracker.method klt, whose cost is also the window and the levels:
///   1. 70 % of the feature budget
///   2. one LK pyramid level less
///   3. no anchor refinement (tracker.anchor_refinement)
///   4. half the feature budget and an LK window of at most 15 px
///   5. tracker.min_tracked_features features and an 11 px window
/// Steps that change nothing for the configuration at hand are left out. A lighter step changes how much
/// work the tracking does, never the checks a pose must pass: when too few features remain, the pipeline
/// reports lost frames as always.
///
/// When the median is below cpu_budget.relax_ratio of the budget and the heavier step, at the cost measured
/// when it was left (scaled by how the lighter one's cost has changed since), fits the budget, the step is
/// undone. Not thread-safe; one instance per pipeline.

#include <optional>
#include <string>
#include <vector>

#include "planetary_vo/vo/config.h"

namespace planetary_vo {

/// Sets the threads of OpenCV's parallel loops to cpu_budget.opencv_threads (cv::setNumThreads, for the whole
/// process) when it is > 0; 0 leaves OpenCV's default. The callers that make a Pipeline (vo_run, the VO
/// nodelet) call it; the pipeline itself does not touch process-wide settings.
void applyOpenCvThreads(const CpuBudgetConfig& config);

class CpuBudget {
 public:
  /// @param base the configuration of step 0 (its cpu_budget section is the controller's own).
  explicit CpuBudget(const VoConfig& base);

  /// Whether a budget is set (cpu_budget.frame_budget_ms > 0); observe() returns nothing otherwise.
  bool enabled() const { return base_.cpu_budget.frame_budget_ms > 0.0; }

  /// @brief One processed frame's time in ms (a caller simulating a slower CPU scales it). Returns the
  /// configuration to apply before the next frame when the step changes, nothing otherwise.
  std::optional<VoConfig> observe(double frame_ms);

  /// The current step: 0 = the base configuration, numSteps() - 1 = the lightest.
  int step() const { return step_; }
  int numSteps() const { return static_cast<int>(steps_.size()); }
  const VoConfig& config(int step) const { return steps_.at(step).config; }
  /// What a step changes against the base, e.g. "num_features 210, pyramid_levels 2"; "base" for step 0.
  const std::string& describe(int step) const { return steps_.at(step).what; }
  /// Median frame time of the last full window (ms), 0 before the first one.
  double lastMedianMs() const { return last_median_ms_; }

 private:
  struct Step {
    VoConfig config;
    std::string what;
    double cost_ms = 0.0;  ///< median frame time of the first full window spent at this step; 0 = unknown
  };
  VoConfig base_;
  std::vector<Step> steps_;
  std::vector<double> window_ms_;
  int step_ = 0;
  double last_median_ms_ = 0.0;
};

}  // namespace planetary_vo
