/// Tests of the keyframe policy: each trigger on its own, fixed rate, and the rotation-compensated parallax
/// (zero for a pure rotation, the true angle for a known translation).

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "planetary_vo/vo/keyframe_policy.h"

namespace planetary_vo {
namespace {

KeyframeCandidate quiet() {
  KeyframeCandidate c;
  c.frames_since_keyframe = 3;
  c.tracks_at_keyframe = 200;
  c.surviving_tracks = 190;
  c.median_parallax_deg = 0.2;
  return c;
}

TEST(KeyframePolicy, NoTriggerNoKeyframe) {
  const KeyframePolicy policy{KeyframeConfig()};
  const KeyframeDecision d = policy.decide(quiet());
  EXPECT_FALSE(d.is_keyframe);
  EXPECT_TRUE(d.reason.empty());
}

TEST(KeyframePolicy, EachTriggerFires) {
  KeyframeConfig cfg;
  cfg.min_parallax_deg = 1.0;
  cfg.min_track_ratio = 0.6;
  cfg.max_interval_frames = 20;
  const KeyframePolicy policy(cfg);

  KeyframeCandidate c = quiet();
  c.median_parallax_deg = 1.0;
  EXPECT_EQ(policy.decide(c).reason, "parallax");

  c = quiet();
  c.surviving_tracks = 119;  // below 0.6 * 200
  EXPECT_EQ(policy.decide(c).reason, "track survival");
  c.surviving_tracks = 120;
  EXPECT_FALSE(policy.decide(c).is_keyframe);

  c = quiet();
  c.frames_since_keyframe = 20;
  EXPECT_EQ(policy.decide(c).reason, "interval");
  c.frames_since_keyframe = 19;
  EXPECT_FALSE(policy.decide(c).is_keyframe);
}

TEST(KeyframePolicy, FixedRateMakesEveryProcessedFrameAKeyframe) {
  KeyframeConfig cfg;
  cfg.mode = KeyframeMode::kFixedRate;
  const KeyframeDecision d = KeyframePolicy(cfg).decide(quiet());
  EXPECT_TRUE(d.is_keyframe);
  EXPECT_EQ(d.reason, "fixed rate");
}

TEST(KeyframePolicy, ParallaxIgnoresRotationAndMeasuresTranslation) {
  // Points on a plane 100 m ahead; the camera rotates 5 deg, then translates 2 m sideways.
  std::vector<Eigen::Vector3d> p_kf;
  for (int i = -5; i <= 5; ++i)
    for (int j = -5; j <= 5; ++j) p_kf.emplace_back(3.0 * i, 3.0 * j, 100.0);
  const Eigen::Matrix3d R_cur_kf =
      Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d(0.3, 1, 0).normalized()).toRotationMatrix();
  std::vector<Eigen::Vector3d> b_kf, b_rot, b_trans;
  for (const Eigen::Vector3d& p : p_kf) {
    b_kf.push_back(p.normalized());
    b_rot.push_back((R_cur_kf * p).normalized());
    b_trans.push_back((p - Eigen::Vector3d(2.0, 0.0, 0.0)).normalized());
  }
  std::vector<double> scratch;
  EXPECT_NEAR(KeyframePolicy::medianParallaxDeg(b_kf, b_rot, R_cur_kf, &scratch), 0.0, 1e-9);
  // Without compensation the same rotation would count as 5 deg of "parallax".
  EXPECT_NEAR(KeyframePolicy::medianParallaxDeg(b_kf, b_rot, Eigen::Matrix3d::Identity(), &scratch), 5.0,
              0.5);
  // 2 m at ~100 m: ~1.1 deg, a little less off-axis.
  const double parallax =
      KeyframePolicy::medianParallaxDeg(b_kf, b_trans, Eigen::Matrix3d::Identity(), &scratch);
  EXPECT_GT(parallax, 1.0);
  EXPECT_LT(parallax, 2.0 / 100.0 * 180.0 / M_PI + 1e-6);
  EXPECT_EQ(KeyframePolicy::medianParallaxDeg({}, {}, R_cur_kf, &scratch), 0.0);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
