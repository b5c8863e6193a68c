/// Pipeline::reconfigure(): runtime knobs (detector.num_features, motion.model, bundle_adjustment.enabled)
/// changed in place on a running pipeline. The clip is test_pipeline.cpp's rendered planar descent (a
/// textured ground plane warped into each view by its exact homography, nadir camera, known poses). The
/// trajectory must run on as if nothing happened: every frame tracked (no re-initialisation), and the scale
/// of the part before the first change (its Sim(3) alignment to the ground truth) still fitting every step
/// after it. A negative control runs the same schedule through a rebuilt pipeline (the most the core API can
/// hand over to a new one: the last pose) and checks that the same criteria catch it.

#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "planar_descent.h"
#include "planetary_vo/eval/trajectory_metrics.h"
#include "planetary_vo/vo/cpu_budget.h"
#include "planetary_vo/vo/pipeline.h"

namespace planetary_vo {
namespace {

using test::groundTexture;
using test::renderView;
using test::truePose;
constexpr double kRateHz = 10.0;

PinholeCamera testCamera() { return test::planarDescentCamera(); }

/// The defaults, initialising at the thesis' 1.0 deg of parallax instead of 0.7. With the anchor refinement
/// of the tracks (issue 13), 0.7 deg is reached one frame earlier on this clip, from two frames; that thinner
/// start gives the part before the first change a noisier scale (step-to-step spread 8 % instead of 3.6 %)
/// than these continuity checks tolerate, in the baseline without any change too. At 1.0 deg both trackers
/// pass (worst position error 0.38 % with the refinement, 1.05 % without).
VoConfig clipConfig() {
  VoConfig config;
  config.motion.min_parallax_deg = 1.0;
  return config;
}

/// A configuration change given to the pipeline just before frame `frame` is processed.
struct Change {
  int frame;
  std::function<void(VoConfig*)> edit;
};

/// How a change reaches the pipeline.
enum class Apply {
  kInPlace,  ///< Pipeline::reconfigure()
  kRebuild,  ///< a new Pipeline with the new configuration, started at the last output pose
};

struct ClipRun {
  std::vector<FrameResult> results;
  Trajectory ground_truth;
};

ClipRun runWithChanges(const VoConfig& config, int num_frames, const std::vector<Change>& changes,
                       Apply apply) {
  static const cv::Mat texture = groundTexture();
  const PinholeCamera camera = testCamera();
  auto pipeline = std::make_unique<Pipeline>(config, camera);
  ClipRun run;
  for (int i = 0; i < num_frames; ++i) {
    for (const Change& change : changes) {
      if (change.frame != i) continue;
      VoConfig next = pipeline->config();
      change.edit(&next);
      if (apply == Apply::kInPlace) {
        pipeline->reconfigure(next);
        EXPECT_EQ(pipeline->config(), next);
      } else {
        auto rebuilt = std::make_unique<Pipeline>(next, camera);
        if (!run.results.empty()) rebuilt->setInitialPose(run.results.back().T_world_cam);
        pipeline = std::move(rebuilt);
      }
    }
    const double t = i / kRateHz;
    const Pose T_world_cam = truePose(t);
    run.ground_truth.push_back({t, T_world_cam});
    run.results.push_back(pipeline->process(t, renderView(texture, camera, T_world_cam)));
  }
  return run;
}

/// The trajectory runs on through frame `first_change` and after it as if nothing happened: (with
/// `check_states`) every frame from the first pose on is tracked (a rebuilt pipeline re-initialises), and
/// with the Sim(3) alignment of the poses before `first_change` to the ground truth (their scale), every
/// later step between two pose estimates matches the true step within `max_step_ratio` and the later
/// positions stay within `max_error_percent` of the distance flown since the first pose.
::testing::AssertionResult continuousWithoutScaleJump(const ClipRun& run, int first_change,
                                                      double max_step_ratio, double max_error_percent,
                                                      bool check_states = true) {
  Trajectory estimate;
  size_t num_before = 0;
  int first_pose = -1;
  for (size_t i = 0; i < run.results.size(); ++i) {  // i, not frame_index: a rebuilt pipeline counts anew
    const FrameResult& r = run.results[i];
    const int frame = static_cast<int>(i);
    if (first_pose < 0 && r.state != TrackingState::kInitialising) first_pose = frame;
    if (check_states && first_pose >= 0 && r.state != TrackingState::kTracking)
      return ::testing::AssertionFailure()
             << "frame " << frame << " is " << toString(r.state) << ", not tracking: " << r.message;
    if (!r.hasPoseEstimate()) continue;
    estimate.push_back({r.timestamp_s, r.T_world_cam});
    if (frame < first_change) ++num_before;
  }
  if (first_pose < 0 || first_pose + 5 > first_change)
    return ::testing::AssertionFailure()
           << "first pose at frame " << first_pose << ", too late for frame " << first_change;
  EvaluationOptions options;
  options.align_num_pairs = num_before;  // the scale (and frame) of the part before the first change
  const TrajectoryEvaluation eval = evaluateTrajectory(run.ground_truth, estimate, options);
  const Sim3Transform& S = eval.alignment;
  double worst_ratio = 1.0, worst_error_percent = 0.0;
  const double distance_m =
      (truePose(run.results.back().timestamp_s).translation() - truePose(first_pose / kRateHz).translation())
          .norm();
  for (size_t k = num_before; k < estimate.size(); ++k) {
    const double t0 = estimate[k - 1].timestamp_s, t1 = estimate[k].timestamp_s;
    const double step_est =
        S.scale * (estimate[k].T_world_cam.translation() - estimate[k - 1].T_world_cam.translation()).norm();
    const double step_true = (truePose(t1).translation() - truePose(t0).translation()).norm();
    const double ratio = step_est / step_true;
    if (std::max(ratio, 1.0 / ratio) > std::max(worst_ratio, 1.0 / worst_ratio)) worst_ratio = ratio;
    if (!(ratio < max_step_ratio && ratio > 1.0 / max_step_ratio))
      return ::testing::AssertionFailure() << "step at t = " << t1 << " s is x" << ratio
                                           << " the true one (scale of the first part " << S.scale << ")";
    const double error_percent =
        100.0 *
        (S.transformPoint(estimate[k].T_world_cam.translation()) - truePose(t1).translation()).norm() /
        distance_m;
    worst_error_percent = std::max(worst_error_percent, error_percent);
    if (!(error_percent < max_error_percent))
      return ::testing::AssertionFailure()
             << "position at t = " << t1 << " s is off by " << error_percent << " % of the " << distance_m
             << " m flown (alignment of the first part)";
  }
  return ::testing::AssertionSuccess() << "worst step ratio " << worst_ratio << ", worst position error "
                                       << worst_error_percent << " % of " << distance_m << " m";
}

/// Five changes three frames apart (the ROS layer's rebuild compounded its bridged speed x17 on such a
/// schedule), then bundle adjustment back on later.
std::vector<Change> schedule() {
  return {
      {20, [](VoConfig* c) { c->detector.num_features = 600; }},
      {23, [](VoConfig* c) { c->motion.model = MotionModel::kEssential; }},
      {26, [](VoConfig* c) { c->bundle_adjustment.enabled = false; }},
      {29, [](VoConfig* c) { c->detector.num_features = 200; }},
      {32, [](VoConfig* c) { c->motion.model = MotionModel::kHomography; }},
      {45, [](VoConfig* c) { c->bundle_adjustment.enabled = true; }},
  };
}
constexpr int kFrames = 75;
constexpr double kMaxStepRatio = 1.25;
constexpr double kMaxErrorPercent = 2.0;

TEST(PipelineReconfigure, KnobsChangeInPlaceWithoutAJumpOrANewScale) {
  const ClipRun baseline = runWithChanges(clipConfig(), kFrames, {}, Apply::kInPlace);
  const ::testing::AssertionResult baseline_check =
      continuousWithoutScaleJump(baseline, 20, kMaxStepRatio, kMaxErrorPercent);
  std::cout << "no change: " << baseline_check.message() << "\n";
  ASSERT_TRUE(baseline_check);

  const ClipRun run = runWithChanges(clipConfig(), kFrames, schedule(), Apply::kInPlace);
  const ::testing::AssertionResult check =
      continuousWithoutScaleJump(run, 20, kMaxStepRatio, kMaxErrorPercent);
  std::cout << "six in-place changes: " << check.message() << "\n";
  EXPECT_TRUE(check);
  // The map is kept: it never shrinks to a fresh two-view map's two keyframes after the first change.
  for (const FrameResult& r : run.results) {
    if (r.frame_index >= 20) {
      EXPECT_GT(r.num_keyframes, 2) << "frame " << r.frame_index;
    }
  }
  // Bundle adjustment off from frame 26 to 44 (the solve in flight at 26 is applied by reconfigure(), not
  // by a frame), on again from 45: it runs at a keyframe then.
  int keyframes_off = 0, adjusted_after = 0;
  for (const FrameResult& r : run.results) {
    if (r.frame_index >= 26 && r.frame_index < 45) {
      EXPECT_EQ(r.times.ba_ms, 0.0) << "frame " << r.frame_index << ": " << r.message;
      keyframes_off += r.is_keyframe ? 1 : 0;
    }
    if (r.frame_index >= 45 && r.times.ba_ms > 0.0) ++adjusted_after;
  }
  EXPECT_GE(keyframes_off, 1) << "no keyframe while bundle adjustment was off: the check above is empty";
  EXPECT_GE(adjusted_after, 1);
}

TEST(PipelineReconfigure, CpuBudgetStepsChangeInPlace) {
  // Every step of the CPU budget's degradation path (lighter and lighter tracking, cpu_budget.h: fewer
  // features in a coarser grid, then LK's lighter window and levels), three frames apart, then straight back
  // to the base: window 15 -> 21 px needs the previous pyramid rebuilt with its larger padding (LK asserts
  // it), and the anchors come back for the live tracks.
  const VoConfig base = clipConfig();
  const CpuBudget budget(base);
  ASSERT_EQ(budget.numSteps(), 5);
  std::vector<Change> steps;
  for (int k = 1; k < budget.numSteps(); ++k) {
    const VoConfig step = budget.config(k);
    steps.push_back({17 + 3 * k, [step](VoConfig* c) { *c = step; }});
  }
  steps.push_back({45, [base](VoConfig* c) { *c = base; }});
  const ClipRun run = runWithChanges(base, kFrames, steps, Apply::kInPlace);
  const ::testing::AssertionResult check =
      continuousWithoutScaleJump(run, 20, kMaxStepRatio, kMaxErrorPercent);
  std::cout << "the CPU budget's four steps and back: " << check.message() << "\n";
  EXPECT_TRUE(check);
  // The lightest step really is lighter: no anchor refinement, and the smaller budget at replenishment.
  for (const FrameResult& r : run.results) {
    if (r.frame_index >= 33 && r.frame_index < 45) {
      EXPECT_EQ(r.times.refine_ms, 0.0) << "frame " << r.frame_index;
      EXPECT_LE(r.num_new_features, budget.config(4).detector.num_features) << "frame " << r.frame_index;
    }
  }
}

TEST(PipelineReconfigure, MapOnlyFeaturesTurnOffAndOnInPlace) {
  // map.keyframe_features (the CPU budget's first step when they are on) off at frame 25, while the tracking
  // of the last keyframe's runs in the background, and on again at 45: the trajectory runs on; no keyframe
  // in between reports map-only tracking, and after 45 they are tracked again.
  VoConfig base = clipConfig();
  base.map.keyframe_features = 300;
  const std::vector<Change> changes{{25, [](VoConfig* c) { c->map.keyframe_features = 0; }},
                                    {45, [](VoConfig* c) { c->map.keyframe_features = 300; }}};
  const ClipRun run = runWithChanges(base, kFrames, changes, Apply::kInPlace);
  const ::testing::AssertionResult check =
      continuousWithoutScaleJump(run, 25, kMaxStepRatio, kMaxErrorPercent);
  std::cout << "map-only features off and on: " << check.message() << "\n";
  EXPECT_TRUE(check);
  int before = 0, off = 0, after = 0;
  for (const FrameResult& r : run.results) {
    if (r.times.keyframe_tracking_ms <= 0.0) continue;
    // Back on, they start afresh: the first tracking carries no track over from before frame 25.
    if (r.frame_index >= 45 && after == 0)
      EXPECT_NE(r.message.find("map-only tracks of the last keyframe 0 ("), std::string::npos) << r.message;
    (r.frame_index < 25 ? before : r.frame_index < 45 ? off : after) += 1;
  }
  EXPECT_GE(before, 1);
  EXPECT_EQ(off, 0);
  EXPECT_GE(after, 1);
}

TEST(PipelineReconfigure, InlineBundleAdjustmentTogglesToo) {
  VoConfig config = clipConfig();
  config.bundle_adjustment.asynchronous = false;
  const ClipRun run = runWithChanges(config, 60, schedule(), Apply::kInPlace);
  const ::testing::AssertionResult check =
      continuousWithoutScaleJump(run, 20, kMaxStepRatio, kMaxErrorPercent);
  std::cout << "inline BA, six in-place changes: " << check.message() << "\n";
  EXPECT_TRUE(check);
}

TEST(PipelineReconfigure, ARebuildFailsTheSameCheck) {
  // Negative control: the criteria above catch a rebuilt pipeline, even one started at the last pose: it
  // re-initialises (states), and its new two-view map has a scale of its own (steps, positions).
  const ClipRun rebuilt = runWithChanges(clipConfig(), kFrames, schedule(), Apply::kRebuild);
  const ::testing::AssertionResult check =
      continuousWithoutScaleJump(rebuilt, 20, kMaxStepRatio, kMaxErrorPercent);
  std::cout << "rebuilt at every change: " << check.message() << "\n";
  EXPECT_FALSE(check);
  const ::testing::AssertionResult scale_check =
      continuousWithoutScaleJump(rebuilt, 20, kMaxStepRatio, kMaxErrorPercent, /*check_states=*/false);
  std::cout << "rebuilt at every change, scale only: " << scale_check.message() << "\n";
  EXPECT_FALSE(scale_check);
}

TEST(PipelineReconfigure, NewSettingsReachTheStages) {
  static const cv::Mat texture = groundTexture();
  const PinholeCamera camera = testCamera();
  // detector.num_features: the first detection after the change uses the new budget.
  for (int budget : {64, 600}) {
    Pipeline pipeline(VoConfig(), camera);
    VoConfig next = pipeline.config();
    next.detector.num_features = budget;
    pipeline.reconfigure(next);
    const FrameResult r = pipeline.process(0.0, renderView(texture, camera, truePose(0.0)));
    EXPECT_LE(r.num_new_features, budget);
    // 64: at least half of it; 600: more than the default 300 allows (the 320x240 image has ~370 corners).
    EXPECT_GT(r.num_new_features, budget == 64 ? 32 : VoConfig().detector.num_features)
        << "budget " << budget;
  }
  // motion.model: the two-view model of the initialisation.
  for (MotionModel model : {MotionModel::kEssential, MotionModel::kHomography}) {
    Pipeline pipeline(clipConfig(), camera);
    int first_pose = -1;
    for (int i = 0; i < 30 && first_pose < 0; ++i) {
      if (i == 2) {
        VoConfig next = pipeline.config();
        next.motion.model = model;
        pipeline.reconfigure(next);
      }
      const FrameResult r = pipeline.process(i / kRateHz, renderView(texture, camera, truePose(i / kRateHz)));
      if (r.hasPoseEstimate()) {
        first_pose = i;
        EXPECT_EQ(r.motion,
                  model == MotionModel::kEssential ? MotionEstimate::kEssential : MotionEstimate::kHomography)
            << r.message;
      }
    }
    EXPECT_GE(first_pose, 3) << toString(model);
  }
}

TEST(PipelineReconfigure, RejectsOtherFieldsAndInvalidValuesLeavingThePipelineAsItWas) {
  static const cv::Mat texture = groundTexture();
  const PinholeCamera camera = testCamera();
  Pipeline pipeline(VoConfig(), camera);
  std::vector<FrameResult> results;
  auto processFrame = [&](int i) {
    results.push_back(pipeline.process(i / kRateHz, renderView(texture, camera, truePose(i / kRateHz))));
  };
  for (int i = 0; i < 20; ++i) processFrame(i);
  ASSERT_EQ(results.back().state, TrackingState::kTracking);
  const VoConfig before = pipeline.config();
  const size_t keyframes_before = pipeline.map().numKeyframes();

  auto expectRejected = [&](const std::function<void(VoConfig*)>& edit,
                            const std::vector<std::string>& named) {
    VoConfig next = pipeline.config();
    next.detector.num_features = 500;  // a runtime change alongside is refused with the rest
    edit(&next);
    try {
      pipeline.reconfigure(next);
      ADD_FAILURE() << "accepted a change of " << named.front();
    } catch (const std::invalid_argument& e) {
      for (const std::string& name : named)
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find("detector.num_features ("), std::string::npos)
          << "names a runtime field: " << e.what();
    }
    EXPECT_EQ(pipeline.config(), before);
  };
  expectRejected([](VoConfig* c) { c->tracker.fb_max_error_px = 2.0; }, {"tracker.fb_max_error_px"});
  expectRejected(
      [](VoConfig* c) {
        c->map.window_keyframes = 12;
        c->bundle_adjustment.asynchronous = false;
      },
      {"map.window_keyframes", "bundle_adjustment.asynchronous"});
  expectRejected([](VoConfig* c) { c->imu.enabled = true; }, {"imu.enabled"});
  expectRejected(
      [](VoConfig* c) {
        c->pipeline.trajectory_mode = TrajectoryMode::kUnitStepConcatenation;
        c->bundle_adjustment.enabled = false;  // runtime-changeable, and needed by the chain
      },
      {"pipeline.trajectory_mode"});

  // Invalid values: ConfigError naming the key (VoConfig::validationErrors()).
  VoConfig invalid = pipeline.config();
  invalid.detector.num_features = 0;
  try {
    pipeline.reconfigure(invalid);
    ADD_FAILURE() << "accepted detector.num_features 0";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("detector.num_features"), std::string::npos) << e.what();
  }
  EXPECT_EQ(pipeline.config(), before);

  // The pipeline runs on untouched: still tracking, map kept.
  for (int i = 20; i < 30; ++i) {
    processFrame(i);
    EXPECT_EQ(results.back().state, TrackingState::kTracking)
        << "frame " << i << ": " << results.back().message;
  }
  EXPECT_GE(pipeline.map().numKeyframes(), keyframes_before);
  // Reconfiguring to the same configuration is a no-op.
  pipeline.reconfigure(pipeline.config());
  EXPECT_EQ(pipeline.config(), before);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
