#include "planetary_vo/vo/mapper.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "planetary_vo/geometry/triangulation.h"

namespace planetary_vo {
namespace {

/// Index of `id` in the ascending `ids`, or -1.
int findSorted(const std::vector<uint64_t>& ids, uint64_t id) {
  auto it = std::lower_bound(ids.begin(), ids.end(), id);
  return (it != ids.end() && *it == id) ? static_cast<int>(it - ids.begin()) : -1;
}

}  // namespace

void MapAssociations::clear() {
  p_world.clear();
  px.clear();
  track_ids.clear();
  point_ids.clear();
  inlier.clear();
}

Mapper::Mapper(const MapConfig& config) : config_(config) {}

void Mapper::checkKeyframeTracks(const KeyframeTracks& tracks, const Pose& T_world_cam,
                                 const PinholeCamera& camera, const Map& map, KeyframeTracks* kept,
                                 std::vector<std::pair<uint64_t, Eigen::Vector2d>>* observed,
                                 std::vector<uint64_t>* rejected) const {
  // No PnP saw the map-only tracks: the keyframe's pose checks those that carry a point. One that reprojects
  // too far from it has drifted off its point: it is detached and left out of the keyframe.
  const Pose T_cam_world = T_world_cam.inverse();
  for (size_t i = 0; i < tracks.ids.size(); ++i) {
    const uint64_t id = tracks.ids[i];
    if (const MapPoint* point = map.pointForTrack(id)) {
      const Eigen::Vector3d p_cam = T_cam_world * point->p_world;
      if (p_cam.z() <= 0.0 ||
          (camera.project(p_cam) - tracks.px[i]).norm() > config_.max_reprojection_error_px) {
        rejected->push_back(id);
        continue;
      }
      observed->emplace_back(point->id, tracks.px[i]);
    }
    kept->ids.push_back(id);
    kept->px.push_back(tracks.px[i]);
  }
}

KeyframeInsertion Mapper::insertKeyframe(double timestamp_s, const Pose& T_world_cam,
                                         const std::vector<uint64_t>& track_ids,
                                         const std::vector<Eigen::Vector2d>& px,
                                         const MapAssociations& associations, const PinholeCamera& camera,
                                         Map* map, const KeyframeTracks* keyframe_tracks) const {
  KeyframeInsertion out;
  std::vector<uint64_t> merged_ids;
  std::vector<Eigen::Vector2d> merged_px;
  std::vector<std::pair<uint64_t, Eigen::Vector2d>> observed;  // (point id, pixel)
  const bool with_keyframe_tracks = keyframe_tracks != nullptr && !keyframe_tracks->ids.empty();
  if (with_keyframe_tracks) {
    KeyframeTracks kept;
    checkKeyframeTracks(*keyframe_tracks, T_world_cam, camera, *map, &kept, &observed,
                        &out.rejected_keyframe_tracks);
    merged_ids = track_ids;
    merged_px = px;
    merged_ids.insert(merged_ids.end(), kept.ids.begin(), kept.ids.end());
    merged_px.insert(merged_px.end(), kept.px.begin(), kept.px.end());
    // The frame tracks, then the map-only ones: ascending, as addKeyframe() and the lookups below need.
    if (!std::is_sorted(merged_ids.begin(), merged_ids.end()))
      throw std::invalid_argument(
          "Mapper::insertKeyframe: map-only track ids must ascend and lie above the frame tracks' ids");
    for (const uint64_t id : out.rejected_keyframe_tracks) map->detachTrack(id);
  }
  const std::vector<uint64_t>& all_ids = with_keyframe_tracks ? merged_ids : track_ids;
  const std::vector<Eigen::Vector2d>& all_px = with_keyframe_tracks ? merged_px : px;

  out.keyframe_id = map->addKeyframe(timestamp_s, T_world_cam, all_ids, all_px);
  map->keyframe(out.keyframe_id)->num_frame_tracks = static_cast<int>(track_ids.size());
  for (size_t i = 0; i < associations.size(); ++i) {
    if (!associations.inlier[i]) continue;
    const int k = findSorted(track_ids, associations.track_ids[i]);
    if (k >= 0) map->addObservation(associations.point_ids[i], out.keyframe_id, px[static_cast<size_t>(k)]);
  }
  for (const auto& o : observed) map->addObservation(o.first, out.keyframe_id, o.second);
  out.keyframe_track_observations = static_cast<int>(observed.size());
  out.points_created = triangulateNewPoints(out.keyframe_id, all_ids, all_px, camera, map);
  // Without map-only tracks given, those of the map (attached later by attachKeyframeTracks()) keep theirs.
  if (keyframe_tracks != nullptr)
    map->retainTracks(all_ids);
  else
    map->retainTracks(all_ids, 0, kFirstMapOnlyTrackId);
  map->dropKeyframesOutsideWindow(config_.window_keyframes);
  out.points_culled = map->cull(config_);
  return out;
}

KeyframeInsertion Mapper::attachKeyframeTracks(uint64_t keyframe_id, const KeyframeTracks& keyframe_tracks,
                                               const PinholeCamera& camera, Map* map) const {
  if (map->keyframes().empty() || map->keyframes().back().id != keyframe_id)
    throw std::invalid_argument("Mapper::attachKeyframeTracks: keyframe " + std::to_string(keyframe_id) +
                                " is not the newest keyframe of the map");
  if (keyframe_tracks.ids.size() != keyframe_tracks.px.size() ||
      !std::is_sorted(keyframe_tracks.ids.begin(), keyframe_tracks.ids.end()) ||
      (!keyframe_tracks.ids.empty() && keyframe_tracks.ids.front() < kFirstMapOnlyTrackId))
    throw std::invalid_argument(
        "Mapper::attachKeyframeTracks: map-only track ids must ascend from kFirstMapOnlyTrackId, one pixel "
        "each");
  KeyframeInsertion out;
  out.keyframe_id = keyframe_id;
  Keyframe& kf = *map->keyframe(keyframe_id);
  KeyframeTracks kept;
  std::vector<std::pair<uint64_t, Eigen::Vector2d>> observed;
  checkKeyframeTracks(keyframe_tracks, kf.T_world_cam, camera, *map, &kept, &observed,
                      &out.rejected_keyframe_tracks);
  for (const uint64_t id : out.rejected_keyframe_tracks) map->detachTrack(id);
  for (size_t i = 0; i < kept.ids.size(); ++i) kf.px_by_track[kept.ids[i]] = kept.px[i];
  for (const auto& o : observed) map->addObservation(o.first, keyframe_id, o.second);
  out.keyframe_track_observations = static_cast<int>(observed.size());
  out.points_created = triangulateNewPoints(keyframe_id, kept.ids, kept.px, camera, map);
  // The map-only tracks the keyframe tracker lost stop following their point (the frame tracks' are left).
  map->retainTracks(kept.ids, kFirstMapOnlyTrackId);
  return out;
}

int Mapper::triangulateNewPoints(uint64_t new_keyframe_id, const std::vector<uint64_t>& track_ids,
                                 const std::vector<Eigen::Vector2d>& px, const PinholeCamera& camera,
                                 Map* map) const {
  const auto& kfs = map->keyframes();
  const Keyframe& cur = kfs.back();
  // Each track without a point is triangulated against the OLDEST kept keyframe that saw it: the widest
  // baseline. Tracks are grouped by that keyframe so that each group is one triangulatePoints() call.
  std::vector<std::vector<size_t>> groups(kfs.size());
  for (size_t i = 0; i < track_ids.size(); ++i) {
    if (map->pointForTrack(track_ids[i]) != nullptr) continue;
    for (size_t k = 0; k + 1 < kfs.size(); ++k) {
      if (kfs[k].px_by_track.count(track_ids[i]) != 0) {
        groups[k].push_back(i);
        break;
      }
    }
  }
  TriangulationOptions options;
  options.max_reprojection_error_px = config_.max_reprojection_error_px;
  options.min_parallax_deg = config_.min_triangulation_parallax_deg;
  const Eigen::Matrix3d K = camera.K();
  const Pose T_cur_world = cur.T_world_cam.inverse();
  int created = 0;
  std::vector<cv::Point2d> px1, px2;
  for (size_t k = 0; k + 1 < kfs.size(); ++k) {
    if (groups[k].empty()) continue;
    const Keyframe& ref = kfs[k];
    px1.clear();
    px2.clear();
    for (size_t i : groups[k]) {
      const Eigen::Vector2d& a = ref.px_by_track.at(track_ids[i]);
      px1.emplace_back(a.x(), a.y());
      px2.emplace_back(px[i].x(), px[i].y());
    }
    const TriangulationResult tri = triangulatePoints(px1, px2, K, T_cur_world * ref.T_world_cam, options);
    for (size_t j = 0; j < groups[k].size(); ++j) {
      if (!tri.valid[j]) continue;
      const size_t i = groups[k][j];
      const Eigen::Vector3d p_world = ref.T_world_cam * tri.points_c1[j];
      std::vector<MapObservation> observations;
      // Every kept keyframe that saw the track and agrees with the point observes it (BA constraints); the
      // reprojection check keeps a track's drift out of the map.
      for (size_t m = k; m < kfs.size(); ++m) {
        auto it = kfs[m].px_by_track.find(track_ids[i]);
        if (it == kfs[m].px_by_track.end()) continue;
        const Eigen::Vector3d p_cam = kfs[m].T_world_cam.inverse() * p_world;
        if (p_cam.z() <= 0.0) continue;
        const double err = (camera.project(p_cam) - it->second).norm();
        if (m == k || kfs[m].id == new_keyframe_id || err <= config_.max_reprojection_error_px)
          observations.push_back({kfs[m].id, it->second});
      }
      map->addPoint(track_ids[i], p_world, std::move(observations));
      ++created;
    }
  }
  return created;
}

}  // namespace planetary_vo
