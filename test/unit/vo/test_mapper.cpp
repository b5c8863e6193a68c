/// Tests of the Mapper's map-only tracks (KeyframeTracks, keyframe_tracker.h) on exact projections of known
/// points: they join the keyframe and are triangulated like frame tracks, a later keyframe observes their
/// points, and a track that has drifted off its point is detached and reported instead of observing it.

#include <cmath>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/vo/keyframe_tracker.h"
#include "planetary_vo/vo/mapper.h"

namespace planetary_vo {
namespace {

const PinholeCamera kCamera(640, 480, 500.0, 500.0, 320.0, 240.0);

/// A camera looking down (+z of the camera = -z of the world) from height 100 m at x = `x_m`.
Pose nadirAt(double x_m) {
  Pose T = Pose::Identity();
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // camera x = world x, camera y = -world y, camera z = -world z
  T.linear() = R;
  T.translation() = Eigen::Vector3d(x_m, 0.0, 100.0);
  return T;
}

/// Ground points on a 6 x 5 grid with some relief.
std::vector<Eigen::Vector3d> groundPoints() {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 5; ++j)
      points.emplace_back(-40.0 + 16.0 * i, -30.0 + 15.0 * j, 2.0 * std::sin(0.7 * i + 1.3 * j));
  return points;
}

KeyframeTracks seen(const Pose& T_world_cam, const std::vector<Eigen::Vector3d>& points) {
  KeyframeTracks tracks;
  for (size_t i = 0; i < points.size(); ++i) {
    tracks.ids.push_back(KeyframeTracker::kFirstId + i);
    tracks.px.push_back(kCamera.project(T_world_cam.inverse() * points[i]));
  }
  return tracks;
}

TEST(Mapper, MapOnlyTracksAreTriangulatedObservedAndDetachedWhenOffTheirPoint) {
  MapConfig config;
  const Mapper mapper(config);
  Map map;
  const std::vector<Eigen::Vector3d> points = groundPoints();
  // The frame tracks are kept out of the way: a single one, never triangulated (it sits on no point here).
  const std::vector<uint64_t> frame_ids{7};
  const std::vector<Eigen::Vector2d> frame_px{Eigen::Vector2d(320, 240)};
  const MapAssociations no_associations;

  const Pose T0 = nadirAt(0.0), T1 = nadirAt(10.0), T2 = nadirAt(20.0);
  const KeyframeTracks k0 = seen(T0, points);
  const KeyframeInsertion i0 =
      mapper.insertKeyframe(0.0, T0, frame_ids, frame_px, no_associations, kCamera, &map, &k0);
  EXPECT_EQ(i0.points_created, 0);
  EXPECT_EQ(map.keyframes().back().px_by_track.size(), points.size() + 1);
  EXPECT_EQ(map.keyframes().back().num_frame_tracks, 1);  // the keyframe policy's track ratio counts these

  // Second keyframe, 10 m baseline (about 6 deg of parallax): every map-only track becomes a point.
  const KeyframeTracks k1 = seen(T1, points);
  const KeyframeInsertion i1 =
      mapper.insertKeyframe(1.0, T1, frame_ids, frame_px, no_associations, kCamera, &map, &k1);
  ASSERT_EQ(i1.points_created, static_cast<int>(points.size()));
  for (size_t i = 0; i < points.size(); ++i) {
    const MapPoint* p = map.pointForTrack(k1.ids[i]);
    ASSERT_NE(p, nullptr);
    EXPECT_LT((p->p_world - points[i]).norm(), 1e-6);
    EXPECT_EQ(p->observations.size(), 2u);
  }

  // Third keyframe: the tracks observe their points, but one has drifted 5 px (beyond
  // max_reprojection_error_px = 2): it is detached and reported, and the keyframe does not hold it.
  KeyframeTracks k2 = seen(T2, points);
  const size_t drifted = 11;
  k2.px[drifted] += Eigen::Vector2d(5.0, 0.0);
  const uint64_t drifted_point = map.pointForTrack(k2.ids[drifted])->id;
  const KeyframeInsertion i2 =
      mapper.insertKeyframe(2.0, T2, frame_ids, frame_px, no_associations, kCamera, &map, &k2);
  EXPECT_EQ(i2.keyframe_track_observations, static_cast<int>(points.size()) - 1);
  ASSERT_EQ(i2.rejected_keyframe_tracks.size(), 1u);
  EXPECT_EQ(i2.rejected_keyframe_tracks[0], k2.ids[drifted]);
  EXPECT_EQ(map.pointForTrack(k2.ids[drifted]), nullptr);
  EXPECT_EQ(map.keyframes().back().px_by_track.count(k2.ids[drifted]), 0u);
  ASSERT_NE(map.point(drifted_point), nullptr);  // the point stays for the adjustment (two keyframes see it)
  EXPECT_EQ(map.point(drifted_point)->observations.size(), 2u);
  for (size_t i = 0; i < points.size(); ++i) {
    if (i == drifted) continue;
    const MapPoint* p = map.pointForTrack(k2.ids[i]);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(p->observations.size(), 3u);
    EXPECT_EQ(p->observations.back().keyframe_id, i2.keyframe_id);
  }
  EXPECT_EQ(i2.points_created, 0);
}

TEST(Mapper, MapOnlyIdsBelowTheFrameTracksAreRefusedAndTheMapStaysUnchanged) {
  const Mapper mapper{MapConfig()};
  Map map;
  KeyframeTracks wrong;
  wrong.ids = {5};  // below the frame track 7
  wrong.px = {Eigen::Vector2d(100, 100)};
  EXPECT_THROW(mapper.insertKeyframe(0.0, nadirAt(0.0), {7}, {Eigen::Vector2d(320, 240)}, MapAssociations(),
                                     kCamera, &map, &wrong),
               std::invalid_argument);
  EXPECT_EQ(map.numKeyframes(), 0u);
}

TEST(Mapper, WithoutMapOnlyTracksTheKeyframeHoldsTheFrameTracksOnly) {
  MapConfig config;
  const Mapper mapper(config);
  Map map;
  const KeyframeTracks none;
  const std::vector<uint64_t> ids{1, 2, 3};
  const std::vector<Eigen::Vector2d> px(3, Eigen::Vector2d(100, 100));
  mapper.insertKeyframe(0.0, nadirAt(0.0), ids, px, MapAssociations(), kCamera, &map, &none);
  mapper.insertKeyframe(1.0, nadirAt(1.0), ids, px, MapAssociations(), kCamera, &map, nullptr);
  for (const Keyframe& kf : map.keyframes()) EXPECT_EQ(kf.px_by_track.size(), 3u);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
