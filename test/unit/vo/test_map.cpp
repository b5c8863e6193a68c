/// Tests of the windowed Map: track <-> point links, the window dropping keyframes and orphaned points (flat
/// memory), culling, and the bundle-adjustment copy and write-back.

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/vo/map.h"

namespace planetary_vo {
namespace {

Pose at(double x) {
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return T;
}

uint64_t addKf(Map* map, double x, const std::vector<uint64_t>& tracks) {
  return map->addKeyframe(x, at(x), tracks,
                          std::vector<Eigen::Vector2d>(tracks.size(), Eigen::Vector2d(1, 2)));
}

TEST(Map, TracksCarryPoints) {
  Map map;
  const uint64_t kf0 = addKf(&map, 0.0, {1, 2, 3});
  const uint64_t kf1 = addKf(&map, 1.0, {1, 2, 3});
  const uint64_t p = map.addPoint(2, Eigen::Vector3d(0, 0, 10), {{kf0, {1, 1}}, {kf1, {2, 2}}});
  ASSERT_NE(map.pointForTrack(2), nullptr);
  EXPECT_EQ(map.pointForTrack(2)->id, p);
  EXPECT_EQ(map.pointForTrack(1), nullptr);
  EXPECT_EQ(map.keyframe(kf1)->px_by_track.size(), 3u);
  EXPECT_EQ(map.keyframe(kf1)->T_world_cam.translation().x(), 1.0);

  map.addObservation(p, kf1, {5, 5});  // duplicate keyframe: ignored
  EXPECT_EQ(map.point(p)->observations.size(), 2u);

  map.retainTracks({1, 3});  // track 2 died
  EXPECT_EQ(map.pointForTrack(2), nullptr);
  ASSERT_NE(map.point(p), nullptr);  // the point stays for BA while keyframes observe it
  EXPECT_FALSE(map.point(p)->has_track);
}

TEST(Map, WindowDropsOldKeyframesAndOrphanedPoints) {
  Map map;
  std::vector<uint64_t> kfs;
  for (int i = 0; i < 5; ++i) kfs.push_back(addKf(&map, i, {10, 11}));
  // Point A only seen by the two oldest keyframes, its track dead; point B the same but its track alive;
  // point C seen by the newest keyframes.
  const uint64_t a = map.addPoint(10, {0, 0, 5}, {{kfs[0], {1, 1}}, {kfs[1], {1, 1}}});
  map.detachTrack(10);
  const uint64_t b = map.addPoint(11, {0, 0, 6}, {{kfs[0], {1, 1}}, {kfs[1], {1, 1}}});
  const uint64_t c = map.addPoint(12, {0, 0, 7}, {{kfs[3], {1, 1}}, {kfs[4], {1, 1}}});
  EXPECT_EQ(map.dropKeyframesOutsideWindow(3), 1);
  EXPECT_EQ(map.numKeyframes(), 3u);
  EXPECT_EQ(map.keyframes().front().id, kfs[2]);
  EXPECT_EQ(map.keyframe(kfs[0]), nullptr);
  EXPECT_EQ(map.point(a), nullptr);
  ASSERT_NE(map.point(b), nullptr);  // still tracked: keeps serving PnP
  EXPECT_TRUE(map.point(b)->observations.empty());
  EXPECT_EQ(map.point(c)->observations.size(), 2u);

  // Memory stays flat: a long run through the window keeps at most `window` keyframes.
  for (int i = 5; i < 100; ++i) {
    addKf(&map, i, {11});
    map.dropKeyframesOutsideWindow(3);
  }
  EXPECT_EQ(map.numKeyframes(), 3u);
}

TEST(Map, CullRemovesRarelyFoundAndUnsupportedPoints) {
  Map map;
  const uint64_t kf0 = addKf(&map, 0, {1, 2, 3});
  const uint64_t kf1 = addKf(&map, 1, {1, 2, 3});
  const uint64_t good = map.addPoint(1, {0, 0, 5}, {{kf0, {1, 1}}, {kf1, {1, 1}}});
  const uint64_t bad = map.addPoint(2, {0, 0, 5}, {{kf0, {1, 1}}, {kf1, {1, 1}}});
  const uint64_t lonely = map.addPoint(3, {0, 0, 5}, {{kf1, {1, 1}}});
  map.point(good)->times_visible = 10;
  map.point(good)->times_found = 9;
  map.point(bad)->times_visible = 10;
  map.point(bad)->times_found = 1;  // below 0.25
  map.detachTrack(3);               // no track and one observation < min_observations 2
  EXPECT_EQ(map.cull(MapConfig()), 2);
  EXPECT_NE(map.point(good), nullptr);
  EXPECT_EQ(map.point(bad), nullptr);
  EXPECT_EQ(map.pointForTrack(2), nullptr);
  EXPECT_EQ(map.point(lonely), nullptr);
}

TEST(Map, BundleAdjustmentCopyAndWriteBack) {
  Map map;
  std::vector<uint64_t> kfs;
  for (int i = 0; i < 4; ++i) kfs.push_back(addKf(&map, i, {1, 2}));
  const uint64_t p1 = map.addPoint(1, {0, 0, 5}, {{kfs[0], {1, 1}}, {kfs[2], {1, 1}}, {kfs[3], {1, 1}}});
  const uint64_t p2 = map.addPoint(2, {1, 0, 5}, {{kfs[3], {1, 1}}});  // one observation: not in BA
  BaProblem problem = map.makeBaProblem(3, 2, 500, 500, 320, 240);
  EXPECT_EQ(problem.fx, 500.0);
  ASSERT_EQ(problem.points.size(), 1u);
  EXPECT_EQ(problem.points[0].id, p1);
  EXPECT_EQ(problem.observations.size(), 3u);
  // Keyframes 0 (outside the window, observing p1), 2 (oldest two of window {1,2,3}; 1 sees nothing) and 3.
  ASSERT_EQ(problem.keyframes.size(), 3u);
  for (const BaKeyframe& k : problem.keyframes) {
    EXPECT_EQ(k.fixed, k.id != kfs[3]) << k.id;
    EXPECT_TRUE(k.T_cam_world.isApprox(map.keyframe(k.id)->T_world_cam.inverse()));
  }

  problem.points[0].p_world = Eigen::Vector3d(0.5, 0.5, 6.0);
  problem.keyframes.back().T_cam_world.translation() = Eigen::Vector3d(-7.0, 0, 0);
  problem.keyframes.front().T_cam_world.translation() = Eigen::Vector3d(99.0, 0, 0);  // fixed: not written
  EXPECT_EQ(map.applyBaResult(problem, {{kfs[0], p1, {1, 1}}}), 0);
  EXPECT_TRUE(map.point(p1)->p_world.isApprox(Eigen::Vector3d(0.5, 0.5, 6.0)));
  EXPECT_EQ(map.point(p1)->observations.size(), 2u);
  EXPECT_NEAR(map.keyframe(kfs[3])->T_world_cam.translation().x(), 7.0, 1e-12);
  EXPECT_NEAR(map.keyframe(kfs[0])->T_world_cam.translation().x(), 0.0, 1e-12);

  // An outlier that leaves fewer than two observations removes the point.
  EXPECT_EQ(map.applyBaResult(problem, {{kfs[2], p1, {1, 1}}}), 1);
  EXPECT_EQ(map.point(p1), nullptr);
  EXPECT_NE(map.point(p2), nullptr);

  std::vector<MapPointView> views;
  map.pointViews(&views);
  ASSERT_EQ(views.size(), 1u);
  EXPECT_EQ(views[0].id, p2);
  EXPECT_EQ(views[0].num_observations, 1);
}

// Every change is recorded as a map event: added, updated, retired with its last state (left the window),
// removed (rejected), each point at most once per frame; added and rejected in the same frame is not
// reported.
TEST(Map, EventsRecordEveryChangeOncePerFrame) {
  Map map;
  map.setObservationSigma(1e-3);
  const uint64_t kf0 = addKf(&map, 0.0, {1, 2, 3, 4});
  const uint64_t kf1 = addKf(&map, 1.0, {1, 2, 3, 4});
  // Cameras at x = 0 and 1 looking along +z (identity attitude): a point 10 m ahead, 1 m baseline.
  const uint64_t a = map.addPoint(1, {0.5, 0, 10}, {{kf0, {1, 1}}, {kf1, {2, 2}}});
  const uint64_t b = map.addPoint(2, {0.5, 1, 10}, {{kf0, {1, 1}}});
  const uint64_t gone = map.addPoint(3, {0.5, 2, 10}, {{kf0, {1, 1}}, {kf1, {2, 2}}});
  map.removePoint(gone);
  MapEvents e = map.takeEvents();
  EXPECT_EQ(e.keyframes_added.size(), 2u);
  ASSERT_EQ(e.points_added.size(), 2u);
  EXPECT_EQ(e.points_added[0].id, a);
  EXPECT_EQ(e.points_added[1].id, b);
  EXPECT_TRUE(e.points_updated.empty());
  EXPECT_TRUE(e.points_removed.empty());  // added and removed in the same frame: never announced
  // Two rays 1 m apart at 10 m: across the ray 1e-3 * 10 / sqrt(2) m, along it about 10 / 1 times more.
  const Eigen::Matrix3d& cov = e.points_added[0].covariance_world;
  EXPECT_NEAR(std::sqrt(cov(0, 0)), 0.01 / std::sqrt(2.0) * std::sqrt(1.0 + 0.05 * 0.05 * 4), 2e-3);
  EXPECT_GT(std::sqrt(cov(2, 2)), 5.0 * std::sqrt(cov(1, 1)));
  EXPECT_GT(e.points_added[1].covariance_world(2, 2), 1e6);  // one ray: no depth
  EXPECT_TRUE(map.takeEvents().empty());

  // Bundle adjustment moves a; an outlier observation leaves `a` with one: rejected.
  BaProblem problem = map.makeBaProblem(10, 1, 500, 500, 320, 240);
  ASSERT_EQ(problem.points.size(), 1u);
  problem.points[0].p_world.x() = 0.6;
  map.applyBaResult(problem, {});
  e = map.takeEvents();
  ASSERT_EQ(e.points_updated.size(), 1u);
  EXPECT_EQ(e.points_updated[0].p_world.x(), 0.6);
  map.applyBaResult(problem, {{kf0, a, {1, 1}}});
  e = map.takeEvents();
  EXPECT_TRUE(e.points_updated.empty());
  ASSERT_EQ(e.points_removed.size(), 1u);
  EXPECT_EQ(e.points_removed[0], a);

  // b leaves with its keyframe (track dead): retired with its last position; cull splits rejected points
  // (PnP keeps rejecting them) from unsupported ones (retired).
  map.detachTrack(2);
  addKf(&map, 2.0, {4});
  addKf(&map, 3.0, {4});
  map.dropKeyframesOutsideWindow(2);
  e = map.takeEvents();
  ASSERT_EQ(e.points_retired.size(), 1u);
  EXPECT_EQ(e.points_retired[0].id, b);
  EXPECT_EQ(e.points_retired[0].p_world, Eigen::Vector3d(0.5, 1, 10));
  const uint64_t kf2 = map.keyframes().front().id, kf3 = map.keyframes().back().id;
  const uint64_t bad = map.addPoint(4, {0, 0, 5}, {{kf2, {1, 1}}, {kf3, {1, 1}}});
  const uint64_t lonely = map.addPoint(5, {0, 0, 6}, {{kf3, {1, 1}}});
  map.takeEvents();
  map.point(bad)->times_visible = 10;
  map.detachTrack(5);
  map.scaleAbout(Eigen::Vector3d::Zero(), 2.0);
  map.cull(MapConfig());
  e = map.takeEvents();
  EXPECT_TRUE(e.points_updated.empty());  // both left after the scaling: reported as what they became
  ASSERT_EQ(e.points_removed.size(), 1u);
  EXPECT_EQ(e.points_removed[0], bad);
  ASSERT_EQ(e.points_retired.size(), 1u);
  EXPECT_EQ(e.points_retired[0].id, lonely);
  EXPECT_EQ(e.points_retired[0].p_world, Eigen::Vector3d(0, 0, 12));

  // A new map: every point retired.
  const uint64_t kept = map.addPoint(4, {1, 1, 7}, {{kf2, {1, 1}}, {kf3, {1, 1}}});
  map.takeEvents();
  map.clear();
  e = map.takeEvents();
  EXPECT_TRUE(e.map_restarted);
  ASSERT_EQ(e.points_retired.size(), 1u);
  EXPECT_EQ(e.points_retired[0].id, kept);
}

// A keyframe that leaves the window is reported once, with the pose the last bundle adjustment gave it (not
// the pose it was inserted with); on a restart, all keyframes of the old map are.
TEST(Map, KeyframesLeaveWithTheirLastPose) {
  Map map;
  std::vector<uint64_t> kfs;
  for (int i = 0; i < 4; ++i) kfs.push_back(addKf(&map, i, {1, 2}));
  map.addPoint(1, {0, 0, 5}, {{kfs[0], {1, 1}}, {kfs[1], {1, 1}}, {kfs[2], {1, 1}}, {kfs[3], {1, 1}}});
  EXPECT_TRUE(map.takeEvents().keyframes_retired.empty());

  // The adjustment moves keyframes 1-3 (keyframe 0 is fixed).
  BaProblem problem = map.makeBaProblem(4, 1, 500, 500, 320, 240);
  ASSERT_EQ(problem.keyframes.size(), 4u);
  for (BaKeyframe& k : problem.keyframes)
    if (!k.fixed) k.T_cam_world.translation().y() = -0.25;  // camera centre at y = +0.25
  map.applyBaResult(problem, {});
  map.takeEvents();

  EXPECT_EQ(map.dropKeyframesOutsideWindow(2), 0);
  MapEvents e = map.takeEvents();
  ASSERT_EQ(e.keyframes_retired.size(), 2u);
  EXPECT_EQ(e.keyframes_retired[0].id, kfs[0]);
  EXPECT_EQ(e.keyframes_retired[1].id, kfs[1]);
  EXPECT_EQ(e.keyframes_retired[1].timestamp_s, 1.0);
  EXPECT_NEAR(e.keyframes_retired[0].T_world_cam.translation().y(), 0.0, 1e-12);  // fixed: as inserted
  EXPECT_NEAR(e.keyframes_retired[1].T_world_cam.translation().y(), 0.25, 1e-12);  // as adjusted
  EXPECT_NEAR(e.keyframes_retired[1].T_world_cam.translation().x(), 1.0, 1e-12);
  EXPECT_FALSE(e.empty());
  EXPECT_TRUE(map.takeEvents().keyframes_retired.empty());  // reported once

  map.clear();
  e = map.takeEvents();
  ASSERT_EQ(e.keyframes_retired.size(), 2u);
  EXPECT_EQ(e.keyframes_retired[0].id, kfs[2]);
  EXPECT_EQ(e.keyframes_retired[1].id, kfs[3]);
  EXPECT_NEAR(e.keyframes_retired[1].T_world_cam.translation().y(), 0.25, 1e-12);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
