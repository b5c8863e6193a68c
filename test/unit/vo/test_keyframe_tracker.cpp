/// Tests of KeyframeTracker (map-only features followed from keyframe to keyframe) on synthetic keyframes
/// with known motion: the tracks stay on their true positions over many keyframes (the anchor alignment
/// keeps them from drifting as chained LK does), the frame tracks' motion brings LK to a move beyond its
/// reach, and ids, removal and reset behave.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/vo/keyframe_tracker.h"
#include "vo_test_images.h"

namespace planetary_vo {
namespace {

using test::planeWaveTexture;
using test::toGray;

const cv::Size kSize(480, 360);

/// Keyframe k of a nadir descent: zoom `zoom`^k about the image centre and a drift of `shift` px per keyframe
/// (texture -> image; keyframe 0 shows the texture directly).
cv::Matx33d keyframeMotion(int k, double zoom, const cv::Point2d& shift) {
  const double s = std::pow(zoom, k), cx = kSize.width / 2.0, cy = kSize.height / 2.0;
  return cv::Matx33d(s, 0, cx * (1 - s) + shift.x * k, 0, s, cy * (1 - s) + shift.y * k, 0, 0, 1);
}

cv::Mat keyframeImage(const cv::Matx33d& H, uint64_t noise_seed) {
  const cv::Matx33d Hi = H.inv();
  cv::Mat image =
      planeWaveTexture(kSize, 5, cv::Matx23d(Hi(0, 0), Hi(0, 1), Hi(0, 2), Hi(1, 0), Hi(1, 1), Hi(1, 2)));
  cv::Mat noise(image.size(), CV_32F);
  cv::RNG rng(noise_seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
  return toGray(image + noise);
}

cv::Point2f apply(const cv::Matx33d& H, const cv::Point2f& p) {
  const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1.0);
  return cv::Point2f(static_cast<float>(q[0] / q[2]), static_cast<float>(q[1] / q[2]));
}

/// The frame tracker's tracks at keyframe k: a grid of texture points at their exact positions.
void liveTracks(const cv::Matx33d& H, std::vector<uint64_t>* ids, std::vector<cv::Point2f>* px) {
  ids->clear();
  px->clear();
  uint64_t id = 0;
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 6; ++j, ++id) {
      const cv::Point2f p = apply(H, cv::Point2f(40.f + 57.f * i, 30.f + 58.f * j));
      if (p.x < 5 || p.y < 5 || p.x > kSize.width - 6 || p.y > kSize.height - 6) continue;
      ids->push_back(id);
      px->push_back(p);
    }
  }
}

struct Followed {
  int first = 0;        ///< map-only tracks detected in keyframe 0
  int survivors = 0;    ///< of those, alive in the last keyframe
  double rms_px = 0.0;  ///< their RMS distance from the true position there
};

Followed follow(const TrackerConfig& config, int anchor_max_age, int keyframes, double zoom,
                const cv::Point2d& shift) {
  DetectorConfig detector;
  KeyframeTracker tracker(300, anchor_max_age, config, detector);
  std::vector<uint64_t> live_ids;
  std::vector<cv::Point2f> live_px;
  std::map<uint64_t, cv::Point2f> start;
  Followed out;
  for (int k = 0; k < keyframes; ++k) {
    const cv::Matx33d H = keyframeMotion(k, zoom, shift);
    liveTracks(H, &live_ids, &live_px);
    tracker.track(keyframeImage(H, 40 + k), live_ids, live_px);
    if (k == 0) {
      for (size_t i = 0; i < tracker.ids().size(); ++i) start[tracker.ids()[i]] = tracker.px()[i];
      out.first = static_cast<int>(start.size());
    }
  }
  const cv::Matx33d H = keyframeMotion(keyframes - 1, zoom, shift);
  double sum2 = 0.0;
  for (size_t i = 0; i < tracker.ids().size(); ++i) {
    const auto it = start.find(tracker.ids()[i]);
    if (it == start.end()) continue;
    const cv::Point2f e = tracker.px()[i] - apply(H, it->second);
    sum2 += e.dot(e);
    ++out.survivors;
  }
  out.rms_px = out.survivors > 0 ? std::sqrt(sum2 / out.survivors) : 1e9;
  return out;
}

TEST(KeyframeTracker, TracksStayOnTheirTruePositionsOverManyKeyframes) {
  // Eight keyframes zooming in by 4 % and drifting by (6, -3) px each. Aligned to one anchor the tracks stay
  // on their points; re-anchored every third keyframe (the default) they gain a little error at each new
  // anchor; LK alone, chained from keyframe to keyframe, wanders off them.
  TrackerConfig aligned;
  TrackerConfig lk_only;
  lk_only.anchor_refinement = false;
  const MapConfig defaults;
  const Followed one = follow(aligned, 1000, 8, 1.04, {6.0, -3.0});
  const Followed every3 = follow(aligned, defaults.keyframe_anchor_max_age, 8, 1.04, {6.0, -3.0});
  const Followed lk = follow(lk_only, 1000, 8, 1.04, {6.0, -3.0});
  std::printf(
      "8 keyframes: one anchor %d of %d tracks, %.3f px RMS; anchor every %d keyframes %d, %.3f px RMS; LK "
      "alone %d, %.3f px RMS\n",
      one.survivors, one.first, one.rms_px, defaults.keyframe_anchor_max_age, every3.survivors, every3.rms_px,
      lk.survivors, lk.rms_px);
  EXPECT_GE(one.first, 250);
  EXPECT_GE(one.survivors, one.first / 3);
  EXPECT_GE(every3.survivors, one.first / 3);
  EXPECT_LT(one.rms_px, 0.1);
  EXPECT_LT(one.rms_px, 0.2 * lk.rms_px);
  EXPECT_LT(every3.rms_px, 0.5 * lk.rms_px);
}

TEST(KeyframeTracker, TheFrameTracksMotionBringsLkToAMoveBeyondItsReach) {
  // 30 px between two keyframes with a single-level LK (reach: about half its 11 px window): started at the
  // previous position it loses the tracks; started where the frame tracks' homography puts them, it keeps
  // them.
  TrackerConfig config;
  config.pyramid_levels = 0;
  config.window_size_px = 11;
  const cv::Matx33d H0 = keyframeMotion(0, 1.0, {30.0, 0.0}), H1 = keyframeMotion(1, 1.0, {30.0, 0.0});
  const cv::Mat image0 = keyframeImage(H0, 1), image1 = keyframeImage(H1, 2);
  std::vector<uint64_t> ids0, ids1;
  std::vector<cv::Point2f> px0, px1;
  liveTracks(H0, &ids0, &px0);
  liveTracks(H1, &ids1, &px1);

  KeyframeTracker predicted(300, 3, config, DetectorConfig());
  predicted.track(image0, ids0, px0);
  const int detected = static_cast<int>(predicted.ids().size());
  const KeyframeTrackingResult with = predicted.track(image1, ids1, px1);
  KeyframeTracker blind(300, 3, config, DetectorConfig());
  blind.track(image0, {}, {});
  const int detected_blind = static_cast<int>(blind.ids().size());
  const KeyframeTrackingResult without = blind.track(image1, {}, {});
  std::printf("30 px move: predicted %d of %d tracked, not predicted %d of %d\n", with.num_tracked, detected,
              without.num_tracked, detected_blind);
  EXPECT_TRUE(with.predicted_by_homography);
  EXPECT_FALSE(without.predicted_by_homography);
  EXPECT_GE(with.num_tracked, detected * 8 / 10);  // those that stay in the image
  EXPECT_LE(without.num_tracked, detected_blind / 10);
}

TEST(KeyframeTracker, IdsAscendAboveTheFrameTracksAndSurviveRemovalAndReset) {
  KeyframeTracker tracker(200, 3, TrackerConfig(), DetectorConfig());
  std::vector<uint64_t> live_ids;
  std::vector<cv::Point2f> live_px;
  const cv::Matx33d H0 = keyframeMotion(0, 1.02, {3.0, 2.0});
  liveTracks(H0, &live_ids, &live_px);
  const KeyframeTrackingResult first = tracker.track(keyframeImage(H0, 3), live_ids, live_px);
  ASSERT_GT(first.num_new, 100);
  EXPECT_EQ(first.num_tracked, 0);
  EXPECT_TRUE(std::is_sorted(tracker.ids().begin(), tracker.ids().end()));
  EXPECT_GE(tracker.ids().front(), KeyframeTracker::kFirstId);
  // New features keep clear of the frame tracks.
  for (const cv::Point2f& p : tracker.px())
    for (const cv::Point2f& q : live_px) EXPECT_GE(cv::norm(p - q), 9.99);

  const std::vector<uint64_t> drop{tracker.ids()[0], tracker.ids()[5]};
  const size_t before = tracker.ids().size();
  EXPECT_EQ(tracker.removeTracks(drop), 2);
  EXPECT_EQ(tracker.ids().size(), before - 2);
  EXPECT_EQ(tracker.removeTracks(drop), 0);

  const cv::Matx33d H1 = keyframeMotion(1, 1.02, {3.0, 2.0});
  liveTracks(H1, &live_ids, &live_px);
  const KeyframeTrackingResult second = tracker.track(keyframeImage(H1, 4), live_ids, live_px);
  EXPECT_GT(second.num_tracked, static_cast<int>(before) * 8 / 10);
  EXPECT_TRUE(std::is_sorted(tracker.ids().begin(), tracker.ids().end()));
  const uint64_t last_id = tracker.ids().back();

  tracker.reset();
  EXPECT_TRUE(tracker.ids().empty());
  const KeyframeTrackingResult after = tracker.track(keyframeImage(H1, 5), live_ids, live_px);
  EXPECT_EQ(after.num_tracked, 0);  // nothing to follow from before the reset
  ASSERT_FALSE(tracker.ids().empty());
  EXPECT_GT(tracker.ids().front(), last_id);  // ids are never reused
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
