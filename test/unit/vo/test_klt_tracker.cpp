/// Tests of KltTracker on synthetic warps with known motion: sub-pixel accuracy, forward-backward rejection,
/// persistent ids, replenishment of emptied cells and the thesis restart strategy.

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <iostream>

#include <gtest/gtest.h>

#include "planetary_vo/vo/klt_tracker.h"
#include "vo_test_images.h"

namespace planetary_vo {
namespace {

using test::translation;
using test::ViewPair;
using test::warpedPair;

const cv::Size kSize(640, 480);

/// The LK tracker these tests are about (the default method is auto: anchor alignment on a plane-like view,
/// test_anchor_alignment.cpp), detecting in every frame where a cell empties.
TrackerConfig lk() {
  TrackerConfig c;
  c.method = TrackingMethod::kKlt;
  c.replenish_min_cells = 1;
  return c;
}

struct ErrorStats {
  double max_px = 0.0, mean_px = 0.0;
  int count = 0;
};

/// Half of the 21 px LK window plus one: a point closer to the border has part of its window outside the
/// image, where the two frames show different (reflected) content, and LK is then biased by up to about half
/// a pixel.
constexpr float kInteriorMarginPx = 11.f;

bool interior(const cv::Point2f& p) {
  return p.x >= kInteriorMarginPx && p.y >= kInteriorMarginPx && p.x <= kSize.width - 1 - kInteriorMarginPx &&
         p.y <= kSize.height - 1 - kInteriorMarginPx;
}

/// Distance of each tracked point from where the known warp puts it; with `interior_only`, only over points
/// whose LK window lies inside both images.
ErrorStats trackingErrors(const FrameCorrespondences& c, const ViewPair& views, bool interior_only) {
  ErrorStats s;
  for (size_t i = 0; i < c.size(); ++i) {
    const cv::Point2f truth = views.map(c.prev_px[i]);
    if (interior_only && !(interior(c.prev_px[i]) && interior(truth))) continue;
    const double e = cv::norm(c.curr_px[i] - truth);
    s.max_px = std::max(s.max_px, e);
    s.mean_px += e;
    ++s.count;
  }
  if (s.count > 0) s.mean_px /= s.count;
  return s;
}

/// `mean_max_px`: the mean error allowed over the interior points.
void expectAccurateTracking(const cv::Matx23d& A, uint64_t seed, const TrackerConfig& config = lk(),
                            double mean_max_px = 0.02) {
  const ViewPair views = warpedPair(kSize, A, seed);
  KltTracker tracker{config, DetectorConfig()};
  const TrackingResult first = tracker.track(views.first);
  EXPECT_EQ(first.frame_index, 0);
  EXPECT_EQ(first.num_new, 300);
  EXPECT_TRUE(first.correspondences.empty());

  const TrackingResult second = tracker.track(views.second);
  EXPECT_EQ(second.frame_index, 1);
  // A few features may leave the image or sit on its edge; all others must be found.
  EXPECT_GE(second.num_tracked, 280) << "lk " << second.num_lost_lk << " border " << second.num_lost_border
                                     << " fb " << second.num_lost_fb;
  EXPECT_EQ(second.num_tracked + second.num_lost_lk + second.num_lost_border + second.num_lost_fb, 300);
  const ErrorStats e = trackingErrors(second.correspondences, views, true);
  EXPECT_GE(e.count, 240);
  EXPECT_LT(e.max_px, 0.1);
  EXPECT_LT(e.mean_px, mean_max_px);
  // Near the border the accuracy is lower, but the forward-backward check still bounds it.
  EXPECT_LT(trackingErrors(second.correspondences, views, false).max_px, lk().fb_max_error_px);
}

TEST(KltTracker, SubPixelTranslationIsRecovered) { expectAccurateTracking(translation(1.37, -0.62), 11); }

TEST(KltTracker, LargeTranslationNeedsAndUsesThePyramid) {
  // 18 px (15.3, -9.8) is far outside the 10 px half-window at full resolution; three pyramid levels bring it
  // within reach.
  expectAccurateTracking(translation(15.3, -9.8), 12);
}

TEST(KltTracker, SmallRotationAndScaleAreRecovered) {
  const cv::Point2f centre(kSize.width / 2.f, kSize.height / 2.f);
  // LK models a translating window: 0.4 deg and 0.3 % zoom deform the 21 px window by under 0.1 px at its
  // edge (larger inter-frame rotations are what the pyramid-level prediction of a later stage is for).
  cv::Matx23d A = cv::getRotationMatrix2D(centre, 0.4, 1.003);
  A(0, 2) += 0.4;
  TrackerConfig klt_only = lk();
  klt_only.anchor_refinement = false;
  expectAccurateTracking(A, 13, klt_only);
  // The anchor refinement's 11 px translation-only patch is a little less accurate on one deformed step
  // (measured: mean 0.022 px against LK's 0.018); what it gains is on long tracks (test_patch_alignment.cpp).
  expectAccurateTracking(A, 13, lk(), 0.03);
}

TEST(KltTracker, AConfigChangeBetweenFramesAppliesToTheLiveTracks) {
  // The CPU budget's steps (cpu_budget.h) change the LK window, levels and anchor refinement between frames.
  // Going back from a light step (11 px, no pyramid) to the default, the previous image's pyramid must be
  // rebuilt: LK takes its levels from the previous pyramid, and an 18 px motion needs them.
  const ViewPair views = warpedPair(kSize, translation(15.3, -9.8), 12);
  TrackerConfig light = lk();
  light.window_size_px = 11;
  light.pyramid_levels = 0;
  light.anchor_refinement = false;
  KltTracker tracker{light, DetectorConfig()};
  ASSERT_EQ(tracker.track(views.first).num_new, 300);
  tracker.setConfig(lk());
  EXPECT_EQ(tracker.config(), lk());
  const TrackingResult second = tracker.track(views.second);
  EXPECT_GE(second.num_tracked, 280) << "lk " << second.num_lost_lk << " border " << second.num_lost_border
                                     << " fb " << second.num_lost_fb;
  const ErrorStats e = trackingErrors(second.correspondences, views, true);
  EXPECT_GE(e.count, 240);
  EXPECT_LT(e.mean_px, 0.03);
  // The anchors came back with the refinement: the tracks are refined against them from the next image on.
  EXPECT_EQ(second.num_refined, 0);  // anchored in this image
  const TrackingResult third = tracker.track(views.second);
  EXPECT_GT(third.num_refined, 200);
}

/// Views of one plane-wave texture moving right and up by `shift_px[k]` in frame k (the image content of a
/// turning camera), tracked with one pyramid level so that LK alone reaches only about 10 px on this texture.
std::vector<int> trackedPerStep(bool predict_flow, const std::vector<double>& shift_px,
                                double* worst_error_px) {
  TrackerConfig config = lk();
  config.pyramid_levels = 1;
  config.predict_flow = predict_flow;
  KltTracker tracker(config, DetectorConfig());
  std::vector<int> tracked;
  *worst_error_px = 0.0;
  for (size_t k = 0; k < shift_px.size(); ++k) {
    const double s = shift_px[k];
    // Pixel q shows the texture at q - (s, -s/2): the content moved by (s, -s/2).
    const cv::Mat image = test::toGray(test::planeWaveTexture(kSize, 21, cv::Matx23d(1, 0, -s, 0, 1, s / 2)));
    const TrackingResult r = tracker.track(image);
    if (k == 0) continue;
    tracked.push_back(r.num_tracked);
    const double step = s - shift_px[k - 1];
    for (size_t i = 0; i < r.correspondences.size(); ++i) {
      const cv::Point2f truth = r.correspondences.prev_px[i] + cv::Point2f(step, -step / 2);
      if (interior(r.correspondences.prev_px[i]) && interior(truth))
        *worst_error_px =
            std::max(*worst_error_px, static_cast<double>(cv::norm(r.correspondences.curr_px[i] - truth)));
    }
  }
  return tracked;
}

TEST(KltTracker, PredictedFlowFollowsAnAcceleratingImageMotion) {
  // Steps of 6, 12, 18 and 24 px (x, and half that in y) as the turn speeds up: the first is within LK's
  // reach from the old position; for the others the tracks' last motion leaves a 6 px residual.
  const std::vector<double> shifts{0, 6, 18, 36, 60};
  double worst_predicted = 0.0, worst_plain = 0.0;
  const std::vector<int> predicted = trackedPerStep(true, shifts, &worst_predicted);
  const std::vector<int> plain = trackedPerStep(false, shifts, &worst_plain);
  for (size_t k = 0; k < predicted.size(); ++k)
    std::cout << "step " << k + 1 << ": " << predicted[k] << " tracked with prediction, " << plain[k]
              << " without\n";
  std::cout << "worst interior error: " << worst_predicted << " px with prediction, " << worst_plain
            << " px without\n";
  ASSERT_EQ(predicted.size(), 4u);
  for (size_t k = 0; k < predicted.size(); ++k) {
    SCOPED_TRACE("step " + std::to_string(k + 1));
    // Features near the leading edge leave the image: a 24 px step over 640 px loses a few per cent.
    EXPECT_GE(predicted[k], 250) << "with prediction";
  }
  EXPECT_LT(worst_predicted, 0.1);
  // Precondition that makes the test meaningful: without prediction the last step is out of LK's reach.
  EXPECT_LT(plain.back(), predicted.back() / 2) << "without prediction " << plain.back() << " tracked";
}

TEST(KltTracker, ForwardBackwardCheckRemovesTracksInAChangedRegion) {
  ViewPair views = warpedPair(kSize, translation(2.3, 1.1), 14);
  // A region of the second image is replaced by unrelated texture (a shadow edge moving, a plume): LK still
  // "converges" on some of those points, to wrong positions.
  const cv::Rect changed(200, 150, 240, 180);
  test::texture(changed.size(), 99).copyTo(views.second(changed));

  auto wrongTracks = [&](const TrackingResult& r) {
    int wrong = 0;
    for (size_t i = 0; i < r.correspondences.size(); ++i)
      wrong += cv::norm(r.correspondences.curr_px[i] - views.map(r.correspondences.prev_px[i])) > 1.0;
    return wrong;
  };

  TrackerConfig no_fb = lk();
  no_fb.fb_max_error_px = 0.0;
  KltTracker unchecked(no_fb, DetectorConfig());
  unchecked.track(views.first);
  const TrackingResult r_unchecked = unchecked.track(views.second);
  ASSERT_GT(wrongTracks(r_unchecked), 5) << "precondition: without the check some wrong tracks survive";
  EXPECT_EQ(r_unchecked.num_lost_fb, 0);

  KltTracker checked{lk(), DetectorConfig()};
  checked.track(views.first);
  const TrackingResult r = checked.track(views.second);
  // Most wrong tracks fail the round trip. Not all: in uncorrelated texture the coarse pyramid levels, whose
  // windows reach the unchanged surroundings, steer both passes, and some land on matching false minima. (A
  // patch correlation check would be needed for those; the geometry stage's RANSAC sees them as outliers.)
  const int wrong_unchecked = wrongTracks(r_unchecked), wrong_checked = wrongTracks(r);
  EXPECT_LE(wrong_checked * 2, wrong_unchecked) << wrong_checked << " of " << wrong_unchecked << " survive";
  EXPECT_GE(r.num_lost_fb, wrong_unchecked - wrong_checked);
  for (size_t i = 0; i < r.correspondences.size(); ++i) {
    if (cv::norm(r.correspondences.curr_px[i] - views.map(r.correspondences.prev_px[i])) > 1.0) {
      EXPECT_TRUE(changed.contains(r.correspondences.prev_px[i])) << "wrong track outside the changed region";
    }
  }
  // Outside the changed region (and its window-wide fringe) nothing is lost.
  cv::Rect fringe(changed.x - 15, changed.y - 15, changed.width + 30, changed.height + 30);
  int outside_before = 0, outside_after = 0;
  for (size_t i = 0; i < r.correspondences.size(); ++i)
    outside_after += !fringe.contains(r.correspondences.prev_px[i]);
  KltTracker reference{lk(), DetectorConfig()};
  reference.track(views.first);
  for (const FeatureTrack& t : reference.tracks()) outside_before += !fringe.contains(t.px);
  EXPECT_EQ(outside_after, outside_before);
}

TEST(KltTracker, SurvivorsKeepTheirIdsAndOnlyEmptiedCellsAreReplenished) {
  ViewPair views = warpedPair(kSize, translation(0.8, 0.5), 15);
  // The right quarter of the second image changes completely: its tracks are lost and its cells empty.
  const cv::Rect changed(480, 0, 160, 480);
  test::texture(changed.size(), 98).copyTo(views.second(changed));

  KltTracker tracker{lk(), DetectorConfig()};
  tracker.track(views.first);
  std::set<uint64_t> first_ids;
  for (const FeatureTrack& t : tracker.tracks()) first_ids.insert(t.id);
  ASSERT_EQ(first_ids.size(), 300u);

  const TrackingResult r = tracker.track(views.second);
  EXPECT_GT(r.num_lost_lk + r.num_lost_fb, 40);  // about the 75 features of the right quarter
  EXPECT_GT(r.num_new, 0);

  const GridDetector& grid = tracker.detector();
  std::vector<int> survivors_per_cell(grid.numCells(), 0);
  std::set<uint64_t> ids;
  int survivors = 0, fresh = 0;
  for (const FeatureTrack& t : tracker.tracks()) {
    EXPECT_TRUE(ids.insert(t.id).second) << "duplicate id " << t.id;
    if (first_ids.count(t.id)) {
      ++survivors;
      EXPECT_EQ(t.first_frame, 0);
      EXPECT_EQ(t.age_frames, 1);
      ++survivors_per_cell[grid.cellIndex(t.px, kSize)];
    }
  }
  for (const FeatureTrack& t : tracker.tracks()) {
    if (first_ids.count(t.id)) continue;
    ++fresh;
    EXPECT_EQ(t.first_frame, 1);
    EXPECT_EQ(t.age_frames, 0);
    EXPECT_EQ(t.px, t.prev_px);
    EXPECT_EQ(survivors_per_cell[grid.cellIndex(t.px, kSize)], 0)
        << "new feature in an occupied cell at " << t.px;
    EXPECT_GE(t.px.x, changed.x - 80) << "new feature far from the changed region at " << t.px;
  }
  EXPECT_EQ(survivors, r.num_tracked);
  EXPECT_EQ(fresh, r.num_new);
  // Correspondences are exactly the survivors, by id.
  for (uint64_t id : r.correspondences.track_ids) EXPECT_TRUE(first_ids.count(id));
  EXPECT_EQ(static_cast<int>(r.correspondences.size()), survivors);
  // The emptied quarter gets back about its share: up to 16 cells x 300/64 (cells at the edge of the change
  // may keep a survivor and are then not refilled).
  EXPECT_GE(fresh, 45);
  EXPECT_LE(fresh, 80);

  // Outliers removed by the geometry stage free their cells; ids of the others persist into the next frame.
  std::vector<uint64_t> outliers(r.correspondences.track_ids.begin(),
                                 r.correspondences.track_ids.begin() + 10);
  EXPECT_EQ(tracker.removeTracks(outliers), 10);
  EXPECT_EQ(tracker.removeTracks(outliers), 0);
  const TrackingResult again = tracker.track(views.second);  // no motion
  for (uint64_t id : outliers)
    EXPECT_EQ(std::count(again.correspondences.track_ids.begin(), again.correspondences.track_ids.end(), id),
              0);
  for (size_t i = 0; i < again.correspondences.size(); ++i)
    EXPECT_LT(cv::norm(again.correspondences.curr_px[i] - again.correspondences.prev_px[i]), 0.05);
}

TEST(KltTracker, DetectionWaitsUntilEnoughCellsAreShort) {
  // replenish_min_cells 3: emptying two grid cells detects nothing; the third triggers one detection that
  // refills all three.
  const ViewPair views = warpedPair(kSize, translation(0.3, 0.2), 15);
  TrackerConfig config = lk();
  config.replenish_min_cells = 3;
  KltTracker tracker{config, DetectorConfig()};
  ASSERT_EQ(tracker.track(views.first).num_new, 300);
  const GridDetector& grid = tracker.detector();
  auto emptyCell = [&](int cell) {
    std::vector<uint64_t> ids;
    for (const FeatureTrack& t : tracker.tracks())
      if (grid.cellIndex(t.px, kSize) == cell) ids.push_back(t.id);
    EXPECT_FALSE(ids.empty());
    tracker.removeTracks(ids);
  };
  auto tracksIn = [&](int cell) {
    int n = 0;
    for (const FeatureTrack& t : tracker.tracks()) n += grid.cellIndex(t.px, kSize) == cell ? 1 : 0;
    return n;
  };
  emptyCell(9);
  emptyCell(27);
  EXPECT_EQ(tracker.track(views.second).num_new, 0) << "two short cells of the three needed";
  EXPECT_EQ(tracksIn(9), 0);
  emptyCell(45);
  const TrackingResult r = tracker.track(views.second);
  EXPECT_GT(r.num_new, 0);
  for (const int cell : {9, 27, 45}) EXPECT_GT(tracksIn(cell), 0) << "cell " << cell << " not refilled";
  // With 1 (the thesis' replenishment), the first emptied cell is refilled in the next frame.
  KltTracker eager{lk(), DetectorConfig()};
  eager.track(views.first);
  std::vector<uint64_t> ids;
  for (const FeatureTrack& t : eager.tracks())
    if (grid.cellIndex(t.px, kSize) == 9) ids.push_back(t.id);
  eager.removeTracks(ids);
  EXPECT_GT(eager.track(views.second).num_new, 0);
}

TEST(KltTracker, FewerFeaturesInTheSameGridDetectOnMoreFrames) {
  // Why the CPU budget's lighter steps scale the detection grid with the features (cpu_budget.h): tracks are
  // lost inside the image at random (here 4 % per frame, as outliers and failed alignments are), a cell
  // with fewer features empties sooner, and the replenishment detection runs on more frames. The default
  // tracker (auto: anchor alignment once the view is planar), a steady image motion of (3, 1) px per frame.
  auto framesWithDetection = [](int features, int grid) {
    DetectorConfig detector;
    detector.num_features = features;
    detector.grid_cols = detector.grid_rows = grid;
    KltTracker tracker{TrackerConfig(), detector};
    cv::RNG rng(11);
    int frames = 0;
    for (int k = 0; k < 60; ++k) {
      const cv::Mat image = test::toGray(test::planeWaveTexture(kSize, 5, translation(3.0 * k, 1.0 * k)));
      const TrackingResult r = tracker.track(image);
      if (k > 0 && r.num_new > 0) ++frames;
      std::vector<uint64_t> lost;
      for (const FeatureTrack& t : tracker.tracks())
        if (rng.uniform(0.0, 1.0) < 0.04) lost.push_back(t.id);
      tracker.removeTracks(lost);
    }
    return frames;
  };
  const int base = framesWithDetection(300, 8);       // the default: 4.7 features per cell
  const int same_grid = framesWithDetection(100, 8);  // 1.6 per cell
  const int scaled = framesWithDetection(100, 5);     // 4.0 per cell, the budget's lightest step
  std::cout << "frames with a detection in 59: 300 in 8x8 " << base << ", 100 in 8x8 " << same_grid
            << ", 100 in 5x5 " << scaled << "\n";
  EXPECT_GE(same_grid, 2 * scaled);
  EXPECT_LE(scaled, base + 3);
}

TEST(KltTracker, RestartStrategyRedetectsOnThePreviousImage) {
  const ViewPair views = warpedPair(kSize, translation(3.2, -1.7), 16);
  TrackerConfig cfg = lk();
  cfg.replenish_strategy = ReplenishStrategy::kRestartBelowMin;
  cfg.min_tracked_features = 100;
  KltTracker tracker(cfg, DetectorConfig());
  tracker.track(views.first);

  // Enough survivors: no restart, no new features (restart mode never tops up).
  const TrackingResult kept = tracker.track(views.second);
  EXPECT_FALSE(kept.restarted);
  EXPECT_EQ(kept.num_new, 0);
  EXPECT_GE(kept.num_tracked, 280);

  // Remove tracks until fewer than 100 survive: the next frame restarts from features of the previous image.
  std::vector<uint64_t> ids;
  for (const FeatureTrack& t : tracker.tracks()) ids.push_back(t.id);
  ids.resize(ids.size() - 50);
  tracker.removeTracks(ids);
  const uint64_t max_old_id =
      *std::max_element(kept.correspondences.track_ids.begin(), kept.correspondences.track_ids.end());
  const ViewPair back = {views.second, views.first, cv::Matx23d(1, 0, -3.2, 0, 1, 1.7)};
  const TrackingResult restarted = tracker.track(views.first);
  EXPECT_TRUE(restarted.restarted);
  EXPECT_GE(restarted.num_tracked, 250);  // fresh features tracked into this frame
  EXPECT_EQ(restarted.num_new, restarted.num_tracked);
  for (uint64_t id : restarted.correspondences.track_ids) EXPECT_GT(id, max_old_id);
  for (const FeatureTrack& t : tracker.tracks()) {
    EXPECT_EQ(t.first_frame, 1);
    EXPECT_EQ(t.age_frames, 1);
  }
  const ErrorStats e = trackingErrors(restarted.correspondences, back, true);
  EXPECT_LT(e.max_px, 0.1);
}

TEST(KltTracker, CallerMayReuseItsImageBuffer) {
  const ViewPair views = warpedPair(kSize, translation(1.1, 0.7), 17);
  KltTracker tracker{lk(), DetectorConfig()};
  // One buffer with a border, as a camera driver's ring buffer might hand out: overwrite it between frames.
  // The 64 px border is wide enough for OpenCV to build the pyramid in place if the tracker allowed it.
  cv::Mat buffer(kSize.height + 128, kSize.width + 128, CV_8U, cv::Scalar(0));
  cv::Mat frame = buffer(cv::Rect(64, 64, kSize.width, kSize.height));
  views.first.copyTo(frame);
  tracker.track(frame);
  views.second.copyTo(frame);
  const TrackingResult r = tracker.track(frame);
  EXPECT_GE(r.num_tracked, 280);
  EXPECT_LT(trackingErrors(r.correspondences, views, true).max_px, 0.1);
}

TEST(KltTracker, RejectsBadImagesAndSizeChangesUntilReset) {
  KltTracker tracker{lk(), DetectorConfig()};
  EXPECT_THROW(tracker.track(cv::Mat()), std::invalid_argument);
  EXPECT_THROW(tracker.track(cv::Mat(kSize, CV_8UC3, cv::Scalar::all(0))), std::invalid_argument);
  tracker.track(test::texture(kSize, 18));
  EXPECT_THROW(tracker.track(test::texture(cv::Size(320, 240), 18)), std::invalid_argument);
  tracker.reset();
  EXPECT_TRUE(tracker.tracks().empty());
  const TrackingResult r = tracker.track(test::texture(cv::Size(320, 240), 18));
  EXPECT_GT(r.num_new, 0);
  EXPECT_TRUE(r.correspondences.empty());
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
