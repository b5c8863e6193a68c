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

// The pipeline's background path: each keyframe is inserted with its frame tracks only and its map-only
// tracks are attached afterwards (Mapper::attachKeyframeTracks). The map ends the same as when they are given
// at insertion: the same points, exact to 1e-6, observed by the same keyframes; the drifted track is
// detached; a keyframe inserted without map-only tracks leaves the map-only tracks' points attached (they are
// followed at keyframes only), and attaching without a track detaches it.
TEST(Mapper, MapOnlyTracksAttachedAfterTheKeyframeGiveTheSameMapAsAtInsertion) {
  const Mapper mapper{MapConfig()};
  const std::vector<Eigen::Vector3d> points = groundPoints();
  const std::vector<uint64_t> frame_ids{7};
  const std::vector<Eigen::Vector2d> frame_px{Eigen::Vector2d(320, 240)};
  const std::vector<Pose> poses{nadirAt(0.0), nadirAt(10.0), nadirAt(20.0)};
  const size_t drifted = 11;
  Map at_insertion, attached_after;
  for (size_t k = 0; k < poses.size(); ++k) {
    KeyframeTracks tracks = seen(poses[k], points);
    if (k == 2) tracks.px[drifted] += Eigen::Vector2d(5.0, 0.0);
    mapper.insertKeyframe(k, poses[k], frame_ids, frame_px, MapAssociations(), kCamera, &at_insertion,
                          &tracks);
    const KeyframeInsertion inserted =
        mapper.insertKeyframe(k, poses[k], frame_ids, frame_px, MapAssociations(), kCamera, &attached_after);
    // Between insertion and attachment the map-only points keep their tracks.
    if (k == 2) {
      for (const uint64_t id : tracks.ids) EXPECT_NE(attached_after.pointForTrack(id), nullptr);
    }
    const KeyframeInsertion attached =
        mapper.attachKeyframeTracks(inserted.keyframe_id, tracks, kCamera, &attached_after);
    EXPECT_EQ(attached.points_created, k == 1 ? static_cast<int>(points.size()) : 0);
    if (k == 2) {
      EXPECT_EQ(attached.keyframe_track_observations, static_cast<int>(points.size()) - 1);
      ASSERT_EQ(attached.rejected_keyframe_tracks.size(), 1u);
      EXPECT_EQ(attached.rejected_keyframe_tracks[0], tracks.ids[drifted]);
    }
  }
  ASSERT_EQ(attached_after.numPoints(), at_insertion.numPoints());
  ASSERT_EQ(attached_after.numPoints(), points.size());
  const KeyframeTracks ids = seen(poses[0], points);
  for (size_t i = 0; i < points.size(); ++i) {
    const MapPoint* a = at_insertion.pointForTrack(ids.ids[i]);
    const MapPoint* b = attached_after.pointForTrack(ids.ids[i]);
    ASSERT_EQ(a == nullptr, b == nullptr) << i;
    if (i == drifted) {
      EXPECT_EQ(b, nullptr);
      continue;
    }
    ASSERT_NE(b, nullptr);
    EXPECT_LT((b->p_world - points[i]).norm(), 1e-6);
    ASSERT_EQ(b->observations.size(), a->observations.size());
    for (size_t o = 0; o < a->observations.size(); ++o)
      EXPECT_EQ(b->observations[o].keyframe_id, a->observations[o].keyframe_id);
  }
  EXPECT_EQ(attached_after.keyframes().back().px_by_track.size(),
            at_insertion.keyframes().back().px_by_track.size());

  // A track the keyframe tracker lost: attaching the others detaches it.
  KeyframeTracks fewer = seen(poses[2], points);
  fewer.ids.erase(fewer.ids.begin());
  fewer.px.erase(fewer.px.begin());
  const uint64_t lost = ids.ids[0];
  mapper.insertKeyframe(3.0, nadirAt(30.0), frame_ids, frame_px, MapAssociations(), kCamera, &attached_after);
  ASSERT_NE(attached_after.pointForTrack(lost), nullptr);
  mapper.attachKeyframeTracks(attached_after.keyframes().back().id, KeyframeTracks(), kCamera,
                              &attached_after);
  EXPECT_EQ(attached_after.pointForTrack(lost), nullptr);
}

TEST(Mapper, MapOnlyTracksAreAttachedToTheNewestKeyframeOnly) {
  const Mapper mapper{MapConfig()};
  Map map;
  const std::vector<uint64_t> frame_ids{7};
  const std::vector<Eigen::Vector2d> frame_px{Eigen::Vector2d(320, 240)};
  const KeyframeInsertion first =
      mapper.insertKeyframe(0.0, nadirAt(0.0), frame_ids, frame_px, MapAssociations(), kCamera, &map);
  mapper.insertKeyframe(1.0, nadirAt(10.0), frame_ids, frame_px, MapAssociations(), kCamera, &map);
  const KeyframeTracks tracks = seen(nadirAt(0.0), groundPoints());
  EXPECT_THROW(mapper.attachKeyframeTracks(first.keyframe_id, tracks, kCamera, &map), std::invalid_argument);
  KeyframeTracks frame_range;
  frame_range.ids = {3};
  frame_range.px = {Eigen::Vector2d(100, 100)};
  EXPECT_THROW(mapper.attachKeyframeTracks(map.keyframes().back().id, frame_range, kCamera, &map),
               std::invalid_argument);
  for (const Keyframe& kf : map.keyframes()) EXPECT_EQ(kf.px_by_track.size(), 1u);
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
