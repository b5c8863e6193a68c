/// Tests of the stages the pipeline delegates its recovery to: the motion prior (motion_prior.h) and the
/// scale bridge of a re-initialisation (scale_bridge.h), each source of evidence on its own.

#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/vo/motion_prior.h"
#include "planetary_vo/vo/scale_bridge.h"

namespace planetary_vo {
namespace {

/// Sees the lost map's points (world +z is its optical axis at the identity attitude).
const PinholeCamera kCamera = PinholeCamera::fromFieldOfView(640, 480, 90.0);

Pose at(const Eigen::Vector3d& p) {
  Pose T = Pose::Identity();
  T.translation() = p;
  return T;
}

/// A lost map: two keyframes 1 s apart, the camera moving 3 units/s along its optical axis (world +z) towards
/// points at world z = 20, each followed by one of the tracks 1..n.
Map lostMap(int num_points) {
  Map map;
  std::vector<uint64_t> tracks;
  for (int i = 1; i <= num_points; ++i) tracks.push_back(static_cast<uint64_t>(i));
  const std::vector<Eigen::Vector2d> px(tracks.size(), Eigen::Vector2d(100, 100));
  const uint64_t kf0 = map.addKeyframe(0.0, at({0, 0, 0}), tracks, px);
  const uint64_t kf1 = map.addKeyframe(1.0, at({0, 0, 3}), tracks, px);
  for (int i = 1; i <= num_points; ++i)
    map.addPoint(static_cast<uint64_t>(i), Eigen::Vector3d(0.5 * i, -0.3 * i, 20.0),
                 {{kf0, {1, 1}}, {kf1, {2, 2}}});
  return map;
}

TEST(MotionPrior, ConstantVelocityFromTheTwoNewestKeyframes) {
  const Map map = lostMap(3);
  Eigen::Vector3d v;
  ASSERT_TRUE(keyframeVelocity(map, &v));
  EXPECT_NEAR((v - Eigen::Vector3d(0, 0, 3)).norm(), 0.0, 1e-12);
  Pose last = at({1, 2, 3});
  last.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Pose predicted = predictConstantVelocity(last, 1.0, map, 1.5);
  EXPECT_NEAR((predicted.translation() - Eigen::Vector3d(1, 2, 4.5)).norm(), 0.0, 1e-12);
  EXPECT_TRUE(predicted.linear().isApprox(last.linear()));  // attitude held

  Map one;  // a single keyframe gives no velocity: the pose is held
  one.addKeyframe(0.0, at({0, 0, 0}), {}, {});
  EXPECT_FALSE(keyframeVelocity(one, &v));
  EXPECT_TRUE(predictConstantVelocity(last, 1.0, one, 5.0).isApprox(last));
}

/// A new map that triangulated lostMap(8)'s points again from a reference camera at world (0, 0, 3), at a
/// quarter of their depth: its baseline is 4 old units long.
Initialization initSeeingTheOldPointsAgain() {
  const Pose T_world_ref = at({0, 0, 3});
  Initialization init;
  for (int i = 1; i <= 8; ++i) {
    init.track_ids.push_back(static_cast<uint64_t>(i));
    init.points_c1.push_back(T_world_ref.inverse() * Eigen::Vector3d(0.5 * i, -0.3 * i, 20.0) / 4.0);
  }
  init.median_depth = 17.0 / 4.0;
  return init;
}

TEST(ScaleBridge, SharedPointsFixTheScaleFirst) {
  const Map map = lostMap(8);
  const Pose T_world_ref = at({0, 0, 3});
  const Initialization init = initSeeingTheOldPointsAgain();
  const ScaleBridge bridge = bridgeScale(map, kCamera, T_world_ref, 1.0, 1.4, init, 0.0);
  EXPECT_EQ(bridge.source, ScaleBridgeSource::kSharedPoints);
  EXPECT_NEAR(bridge.scale, 4.0, 1e-9);
  EXPECT_DOUBLE_EQ(bridge.confidence_factor, 0.8);
}

TEST(ScaleBridge, SharedPointsOffTheirTracksDoNotBridge) {
  // The same new map, but the reference pose is 5 units off sideways (the view jumped while the pose went on
  // at constant velocity): from it the old points are 16 deg or more off their tracks' directions.
  const Map map = lostMap(8);
  const Initialization init = initSeeingTheOldPointsAgain();
  const ScaleBridge off = bridgeScale(map, kCamera, at({5, 0, 3}), 1.0, 1.4, init, 0.0);
  EXPECT_NE(off.source, ScaleBridgeSource::kSharedPoints);
  EXPECT_NE(off.detail.find("8 of 8 shared points off their tracks"), std::string::npos) << off.detail;
  // A small pose error (0.3 units sideways, about 1 deg) keeps them.
  const ScaleBridge near = bridgeScale(map, kCamera, at({0.3, 0, 3}), 1.0, 1.4, init, 0.0);
  EXPECT_EQ(near.source, ScaleBridgeSource::kSharedPoints);
  EXPECT_NEAR(near.scale, 4.0, 0.1);
}

TEST(ScaleBridge, KeyframeSpeedWhenTooFewPointsAreShared) {
  const Map map = lostMap(8);
  Initialization init;
  for (int i = 1; i <= 4; ++i) {  // 4 shared points are not enough
    init.track_ids.push_back(static_cast<uint64_t>(i));
    init.points_c1.push_back(Eigen::Vector3d(0, 0, 5));
  }
  // 3 units/s over a 0.5 s baseline; the new map sees its scene 10 baselines deep, i.e. at 15 old units where
  // the old map is seen at 17 from the same pose: consistent.
  init.median_depth = 10.0;
  const ScaleBridge bridge = bridgeScale(map, kCamera, at({0, 0, 3}), 1.0, 1.5, init, 50.0);
  EXPECT_EQ(bridge.source, ScaleBridgeSource::kKeyframeSpeed);
  EXPECT_NEAR(bridge.scale, 1.5, 1e-12);
  EXPECT_DOUBLE_EQ(bridge.confidence_factor, 0.5);
  EXPECT_TRUE(bridge.detail.empty());
}

TEST(ScaleBridge, AViewThatJumpedTakesTheFirstMapsDepthNotTheOldSpeed) {
  const Map map = lostMap(8);
  Initialization init;
  // The speed would put the new scene 40 baselines x 1.5 = 60 old units deep, where the old map is seen at 17
  // from the same pose: the view jumped (the soak's loop back to the start). The first map was 50 units deep.
  init.median_depth = 40.0;
  ScaleBridge bridge = bridgeScale(map, kCamera, at({0, 0, 3}), 1.0, 1.5, init, 50.0);
  EXPECT_EQ(bridge.source, ScaleBridgeSource::kFirstMapDepth);
  EXPECT_NEAR(bridge.scale, 50.0 / 40.0, 1e-12);
  EXPECT_DOUBLE_EQ(bridge.confidence_factor, 0.0);
  EXPECT_NE(bridge.detail.find("the view jumped"), std::string::npos) << bridge.detail;
  // Just inside the factor either way, the speed is kept.
  for (double depth : {17.0 / 1.5 * 1.49, 17.0 / 1.5 / 1.49}) {
    init.median_depth = depth;
    EXPECT_EQ(bridgeScale(map, kCamera, at({0, 0, 3}), 1.0, 1.5, init, 50.0).source,
              ScaleBridgeSource::kKeyframeSpeed)
        << depth;
  }
  // Without a first map's depth, the old map's depth seen from the reference pose, with no confidence left.
  init.median_depth = 40.0;
  bridge = bridgeScale(map, kCamera, at({0, 0, 3}), 1.0, 1.5, init, 0.0);
  EXPECT_EQ(bridge.source, ScaleBridgeSource::kSceneDepth);
  EXPECT_NEAR(bridge.scale, 17.0 / 40.0, 1e-12);
  EXPECT_DOUBLE_EQ(bridge.confidence_factor, 0.0);
}

TEST(ScaleBridge, SharedPointsOffTheirTracksMeanTheViewJumpedEvenWhenTheDepthsAgree) {
  // The soak's loop back to the start of a descent whose speed falls with its altitude: the keyframe speed of
  // the slow, low end and the new map's deep scene multiply to about the old map's depth, so the depth check
  // passes (1 jump in 60), but the points LK carried over the jump are off their tracks (8 of 8 here: the
  // reference pose is 5 units sideways). That is evidence of the jump: the first map's depth is taken.
  const Map map = lostMap(8);
  Initialization init = initSeeingTheOldPointsAgain();
  init.median_depth = 10.0;  // 3 units/s x 0.5 s x 10 = 15 old units, where the old map is seen at about 17
  const ScaleBridge bridge = bridgeScale(map, kCamera, at({5, 0, 3}), 1.0, 1.5, init, 50.0);
  EXPECT_EQ(bridge.source, ScaleBridgeSource::kFirstMapDepth) << bridge.detail;
  EXPECT_NEAR(bridge.scale, 50.0 / 10.0, 1e-12);
  EXPECT_DOUBLE_EQ(bridge.confidence_factor, 0.0);
  EXPECT_NE(bridge.detail.find("the shared points left their tracks: the view jumped"), std::string::npos)
      << bridge.detail;
  // Fewer than 5 shared points say nothing either way: the speed bridges as before.
  Initialization few = init;
  few.track_ids.resize(4);
  few.points_c1.resize(4);
  EXPECT_EQ(bridgeScale(map, kCamera, at({5, 0, 3}), 1.0, 1.5, few, 50.0).source,
            ScaleBridgeSource::kKeyframeSpeed);
}

TEST(ScaleBridge, SceneDepthWithoutAVelocityAndNothingWithoutAMap) {
  Map map;
  const uint64_t kf = map.addKeyframe(0.0, at({0, 0, 0}), {1, 2, 3}, std::vector<Eigen::Vector2d>(3));
  for (uint64_t t = 1; t <= 3; ++t) map.addPoint(t, Eigen::Vector3d(0, 0, 10.0 * t), {{kf, {1, 1}}});
  Initialization init;
  init.median_depth = 4.0;  // the old median depth 20 over the new 4
  ScaleBridge bridge = bridgeScale(map, kCamera, at({0, 0, 0}), 0.0, 0.5, init, 0.0);
  EXPECT_EQ(bridge.source, ScaleBridgeSource::kSceneDepth);
  EXPECT_NEAR(bridge.scale, 5.0, 1e-12);
  EXPECT_DOUBLE_EQ(bridge.confidence_factor, 0.3);

  bridge = bridgeScale(Map(), kCamera, at({0, 0, 0}), 0.0, 0.5, init, 0.0);
  EXPECT_EQ(bridge.source, ScaleBridgeSource::kNone);
  EXPECT_DOUBLE_EQ(bridge.scale, 1.0);
  EXPECT_DOUBLE_EQ(bridge.confidence_factor, 0.0);
  EXPECT_STREQ(toString(ScaleBridgeSource::kKeyframeSpeed), "keyframe speed");
  EXPECT_STREQ(toString(ScaleBridgeSource::kFirstMapDepth), "first map's scene depth");
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
