/// Tests of CpuBudget: the degradation steps of the tracking and the controller's decisions on given frame
/// times (no timing is measured here: the times are the input).

#include <optional>
#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/vo/cpu_budget.h"
#include "planetary_vo/vo/pipeline.h"

namespace planetary_vo {
namespace {

VoConfig withBudget(double budget_ms, int window = 5) {
  VoConfig c;
  c.cpu_budget.frame_budget_ms = budget_ms;
  c.cpu_budget.window_frames = window;
  c.cpu_budget.relax_ratio = 0.6;
  return c;
}

/// Feeds `frames` frames of `ms` each; returns the step after the last change (or -1 if none changed it).
int feed(CpuBudget* budget, double ms, int frames) {
  int changed_to = -1;
  for (int i = 0; i < frames; ++i)
    if (const std::optional<VoConfig> next = budget->observe(ms)) changed_to = budget->step();
  return changed_to;
}

/// Only the runtime-changeable fields differ from the base (Pipeline::reconfigure accepts the step).
void expectRuntimeChangeable(const CpuBudget& budget, const VoConfig& base) {
  for (int k = 0; k < budget.numSteps(); ++k) {
    EXPECT_NO_THROW(budget.config(k).validate()) << "step " << k;
    EXPECT_EQ(withRuntimeChangeableFields(base, budget.config(k)), budget.config(k)) << "step " << k;
  }
}

/// Features per detection-grid cell of a step.
double featuresPerCell(const VoConfig& c) {
  return static_cast<double>(c.detector.num_features) / (c.detector.grid_cols * c.detector.grid_rows);
}

TEST(CpuBudget, StepsGetLighterInTheDocumentedOrder) {
  // The default, tracker.method auto (anchor alignment on a plane-like view): the features first, then one
  // step for the frames it tracks by LK.
  const VoConfig base = withBudget(10.0);
  ASSERT_EQ(base.tracker.method, TrackingMethod::kAuto);
  const CpuBudget budget(base);
  ASSERT_EQ(budget.numSteps(), 5);
  EXPECT_EQ(budget.config(0), base);
  EXPECT_EQ(budget.describe(0), "base");
  EXPECT_EQ(budget.config(1).detector.num_features, 210);
  EXPECT_EQ(budget.config(2).detector.num_features, 150);
  EXPECT_EQ(budget.config(3).detector.num_features, base.tracker.min_tracked_features);
  for (int k = 1; k <= 3; ++k) EXPECT_EQ(budget.config(k).tracker, base.tracker) << "step " << k;
  EXPECT_EQ(budget.config(4).tracker.pyramid_levels, base.tracker.pyramid_levels - 1);
  EXPECT_FALSE(budget.config(4).tracker.anchor_refinement);
  EXPECT_EQ(budget.config(4).tracker.window_size_px, 15);
  EXPECT_EQ(budget.describe(1), "num_features 210, grid 7x7");
  EXPECT_EQ(budget.describe(4),
            "num_features 100, grid 5x5, pyramid_levels 2, anchor_refinement off, window_size_px 15");
  expectRuntimeChangeable(budget, base);

  // anchor_alignment alone: the LK step changes nothing it uses and is not there.
  VoConfig aligned = base;
  aligned.tracker.method = TrackingMethod::kAnchorAlignment;
  const CpuBudget aligned_budget(aligned);
  ASSERT_EQ(aligned_budget.numSteps(), 4);
  EXPECT_EQ(aligned_budget.describe(3), "num_features 100, grid 5x5");
}

TEST(CpuBudget, LkStepsGetLighterInTheDocumentedOrder) {
  // 1: fewer features; 2: one LK level less; 3: no anchor refinement; 4: half the features, 15 px window;
  // 5: the tracker's minimum of features, 11 px window.
  VoConfig base = withBudget(10.0);
  base.tracker.method = TrackingMethod::kKlt;
  const CpuBudget budget(base);
  ASSERT_EQ(budget.numSteps(), 6);
  EXPECT_EQ(budget.config(1).detector.num_features, 210);
  EXPECT_EQ(budget.config(1).tracker.pyramid_levels, base.tracker.pyramid_levels);
  EXPECT_EQ(budget.config(2).tracker.pyramid_levels, base.tracker.pyramid_levels - 1);
  EXPECT_TRUE(budget.config(2).tracker.anchor_refinement);
  EXPECT_FALSE(budget.config(3).tracker.anchor_refinement);
  EXPECT_EQ(budget.config(4).detector.num_features, 150);
  EXPECT_EQ(budget.config(4).tracker.window_size_px, 15);
  EXPECT_EQ(budget.config(5).detector.num_features, base.tracker.min_tracked_features);
  EXPECT_EQ(budget.config(5).tracker.window_size_px, 11);
  EXPECT_EQ(budget.describe(5),
            "num_features 100, grid 5x5, pyramid_levels 2, anchor_refinement off, window_size_px 11");
  expectRuntimeChangeable(budget, base);
}

TEST(CpuBudget, TheGridFollowsTheFeatures) {
  // A cell keeps about as many features as at step 0 (300 in 8x8 cells: 4.7), so that cells do not empty
  // sooner (KltTracker.FewerFeaturesInTheSameGridDetectOnMoreFrames shows why).
  for (const TrackingMethod method : {TrackingMethod::kAuto, TrackingMethod::kKlt}) {
    VoConfig base = withBudget(10.0);
    base.tracker.method = method;
    const CpuBudget budget(base);
    for (int k = 1; k < budget.numSteps(); ++k) {
      const VoConfig& c = budget.config(k);
      EXPECT_NEAR(featuresPerCell(c) / featuresPerCell(base), 1.0, 0.2) << "step " << k;
      EXPECT_EQ(c.detector.grid_cols, c.detector.grid_rows) << "the square grid stays square";
    }
  }
  // A wide grid keeps its aspect; a grid never grows, and never goes below one cell.
  VoConfig wide = withBudget(10.0);
  wide.detector.grid_cols = 12;
  wide.detector.grid_rows = 4;
  const CpuBudget wide_budget(wide);
  const VoConfig& lightest = wide_budget.config(wide_budget.numSteps() - 1);
  EXPECT_EQ(lightest.detector.grid_cols, 7);  // 12 x sqrt(100 / 300) = 6.9
  EXPECT_EQ(lightest.detector.grid_rows, 2);
  VoConfig few = withBudget(10.0);
  few.detector.num_features = 20;
  few.detector.grid_cols = few.detector.grid_rows = 1;
  few.tracker.min_tracked_features = 10;
  const CpuBudget few_budget(few);
  for (int k = 0; k < few_budget.numSteps(); ++k) EXPECT_EQ(few_budget.config(k).detector.grid_cols, 1);
}

TEST(CpuBudget, StepsThatChangeNothingAreLeftOut) {
  VoConfig light = withBudget(10.0);
  light.tracker.anchor_refinement = false;  // as the thesis configurations
  light.tracker.pyramid_levels = 1;
  light.tracker.window_size_px = 11;
  // base, 70 % features, 50 % features, minimum features: the level, refinement and window steps are gone,
  // with LK and with auto.
  for (const TrackingMethod method : {TrackingMethod::kAuto, TrackingMethod::kKlt}) {
    light.tracker.method = method;
    const CpuBudget budget(light);
    ASSERT_EQ(budget.numSteps(), 4);
    EXPECT_EQ(budget.describe(1), "num_features 210, grid 7x7");
    EXPECT_EQ(budget.describe(3), "num_features 100, grid 5x5");
  }
}

TEST(CpuBudget, MapOnlyFeaturesAreTurnedOffFirst) {
  VoConfig dense = withBudget(10.0);
  dense.map.keyframe_features = 500;
  const CpuBudget budget(dense);
  ASSERT_EQ(budget.numSteps(), 6);
  EXPECT_EQ(budget.config(1).map.keyframe_features, 0);
  EXPECT_EQ(budget.config(1).detector.num_features, dense.detector.num_features);
  EXPECT_EQ(budget.describe(1), "keyframe_features 0");
  EXPECT_EQ(budget.config(2).detector.num_features, 210);  // then the steps of the default, in order
  for (int k = 1; k < budget.numSteps(); ++k) EXPECT_EQ(budget.config(k).map.keyframe_features, 0) << k;
  // Without them (the default) there is no such step.
  EXPECT_EQ(CpuBudget(withBudget(10.0)).numSteps(), 5);
}

TEST(CpuBudget, OffByDefault) {
  CpuBudget budget{VoConfig()};
  EXPECT_FALSE(budget.enabled());
  EXPECT_EQ(feed(&budget, 1e6, 1000), -1);
  EXPECT_EQ(budget.step(), 0);
}

TEST(CpuBudget, StepsDownOneWindowAtATimeAndStopsAtTheLightest) {
  CpuBudget budget(withBudget(10.0, 5));
  EXPECT_EQ(feed(&budget, 20.0, 4), -1) << "decided before a full window";
  EXPECT_EQ(feed(&budget, 20.0, 1), 1);
  EXPECT_DOUBLE_EQ(budget.lastMedianMs(), 20.0);
  // The median decides, not one slow frame: four fast and one slow frame keep the step.
  EXPECT_EQ(feed(&budget, 8.0, 4), -1);
  EXPECT_EQ(feed(&budget, 50.0, 1), -1);
  EXPECT_EQ(budget.step(), 1);
  for (int k = 2; k < budget.numSteps(); ++k) EXPECT_EQ(feed(&budget, 20.0, 5), k);
  EXPECT_EQ(feed(&budget, 20.0, 50), -1) << "no step beyond the lightest";
  EXPECT_EQ(budget.step(), budget.numSteps() - 1);
}

TEST(CpuBudget, StepsBackOnlyWhenTheHeavierStepFits) {
  CpuBudget budget(withBudget(10.0, 5));
  EXPECT_EQ(feed(&budget, 20.0, 5), 1);  // the base costs 20 ms: over the budget
  EXPECT_EQ(feed(&budget, 8.0, 5), -1);  // step 1 costs 8 ms: fits, but not below 0.6 x 10 ms
  // 5 ms is below 6 ms, but the base would cost about 20 x 5 / 8 = 12.5 ms: stay (no back and forth).
  EXPECT_EQ(feed(&budget, 5.0, 20), -1);
  EXPECT_EQ(budget.step(), 1);
  // 3 ms: the base would cost about 7.5 ms, which fits: back to the base.
  EXPECT_EQ(feed(&budget, 3.0, 5), 0);
  EXPECT_EQ(budget.config(budget.step()), withBudget(10.0, 5));
}

TEST(CpuBudget, IgnoresNonFiniteTimes) {
  CpuBudget budget(withBudget(10.0, 2));
  EXPECT_EQ(feed(&budget, std::numeric_limits<double>::quiet_NaN(), 10), -1);
  EXPECT_EQ(feed(&budget, std::numeric_limits<double>::infinity(), 10), -1);
  EXPECT_EQ(budget.step(), 0);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
