#include "planetary_vo/vo/map.h"

#include <algorithm>
#include <unordered_set>

namespace planetary_vo {

namespace {

MapKeyframeState keyframeState(const Keyframe& kf) { return {kf.id, kf.timestamp_s, kf.T_world_cam}; }

}  // namespace

void Map::clear() {
  for (const auto& entry : points_) markRetired(entry.second);
  for (const Keyframe& kf : keyframes_) pending_keyframes_retired_.push_back(keyframeState(kf));
  pending_restart_ = true;
  keyframes_.clear();
  points_.clear();
  point_by_track_.clear();
  // Ids keep increasing so that an asynchronous BA result computed before the clear cannot touch new entries.
}

uint64_t Map::addKeyframe(double timestamp_s, const Pose& T_world_cam, const std::vector<uint64_t>& track_ids,
                          const std::vector<Eigen::Vector2d>& px) {
  Keyframe kf;
  kf.id = next_keyframe_id_++;
  kf.timestamp_s = timestamp_s;
  kf.T_world_cam = T_world_cam;
  kf.px_by_track.reserve(track_ids.size());
  for (size_t i = 0; i < track_ids.size() && i < px.size(); ++i) kf.px_by_track.emplace(track_ids[i], px[i]);
  kf.num_frame_tracks = static_cast<int>(kf.px_by_track.size());
  pending_keyframes_.push_back(kf.id);
  keyframes_.push_back(std::move(kf));
  return keyframes_.back().id;
}

uint64_t Map::addPoint(uint64_t track_id, const Eigen::Vector3d& p_world,
                       std::vector<MapObservation> observations) {
  detachTrack(track_id);
  MapPoint point;
  point.id = next_point_id_++;
  point.p_world = p_world;
  point.observations = std::move(observations);
  point.track_id = track_id;
  point.has_track = true;
  point_by_track_[track_id] = point.id;
  const uint64_t id = point.id;
  points_.emplace(id, std::move(point));
  pending_points_[id] = true;
  return id;
}

void Map::addObservation(uint64_t point_id, uint64_t keyframe_id, const Eigen::Vector2d& px) {
  MapPoint* p = point(point_id);
  if (p == nullptr || keyframe(keyframe_id) == nullptr) return;
  for (const MapObservation& obs : p->observations)
    if (obs.keyframe_id == keyframe_id) return;
  p->observations.push_back({keyframe_id, px});
  markUpdated(point_id);
}

void Map::removePoint(uint64_t point_id) {
  auto it = points_.find(point_id);
  if (it == points_.end()) return;
  if (it->second.has_track) point_by_track_.erase(it->second.track_id);
  markRemoved(point_id);
  points_.erase(it);
}

MapPoint* Map::pointForTrack(uint64_t track_id) {
  auto it = point_by_track_.find(track_id);
  return it == point_by_track_.end() ? nullptr : point(it->second);
}

const MapPoint* Map::pointForTrack(uint64_t track_id) const {
  return const_cast<Map*>(this)->pointForTrack(track_id);
}

MapPoint* Map::point(uint64_t point_id) {
  auto it = points_.find(point_id);
  return it == points_.end() ? nullptr : &it->second;
}

const Keyframe* Map::keyframe(uint64_t keyframe_id) const {
  return const_cast<Map*>(this)->keyframe(keyframe_id);
}

Keyframe* Map::keyframe(uint64_t keyframe_id) {
  // Keyframe ids increase along the deque, so a binary search finds them.
  auto it = std::lower_bound(keyframes_.begin(), keyframes_.end(), keyframe_id,
                             [](const Keyframe& kf, uint64_t id) { return kf.id < id; });
  return (it != keyframes_.end() && it->id == keyframe_id) ? &*it : nullptr;
}

void Map::detachTrack(uint64_t track_id) {
  auto it = point_by_track_.find(track_id);
  if (it == point_by_track_.end()) return;
  if (MapPoint* p = point(it->second)) p->has_track = false;
  point_by_track_.erase(it);
}

void Map::retainTracks(const std::vector<uint64_t>& live_track_ids_sorted, uint64_t first_id,
                       uint64_t end_id) {
  for (auto it = point_by_track_.begin(); it != point_by_track_.end();) {
    if (it->first < first_id || it->first >= end_id ||
        std::binary_search(live_track_ids_sorted.begin(), live_track_ids_sorted.end(), it->first)) {
      ++it;
      continue;
    }
    if (MapPoint* p = point(it->second)) p->has_track = false;
    it = point_by_track_.erase(it);
  }
}

int Map::dropKeyframesOutsideWindow(int window_keyframes) {
  if (window_keyframes < 1) window_keyframes = 1;
  if (static_cast<int>(keyframes_.size()) <= window_keyframes) return 0;
  const size_t num_drop = keyframes_.size() - static_cast<size_t>(window_keyframes);
  const uint64_t first_kept_id = keyframes_[num_drop].id;
  // The points that leave with these keyframes are retired with the state their observations give.
  for (const auto& entry : points_) {
    const MapPoint& p = entry.second;
    if (!p.has_track && std::all_of(p.observations.begin(), p.observations.end(),
                                    [&](const MapObservation& o) { return o.keyframe_id < first_kept_id; }))
      markRetired(p);
  }
  for (size_t i = 0; i < num_drop; ++i) pending_keyframes_retired_.push_back(keyframeState(keyframes_[i]));
  keyframes_.erase(keyframes_.begin(), keyframes_.begin() + static_cast<std::ptrdiff_t>(num_drop));

  int removed = 0;
  for (auto it = points_.begin(); it != points_.end();) {
    auto& obs = it->second.observations;
    obs.erase(
        std::remove_if(obs.begin(), obs.end(),
                       [first_kept_id](const MapObservation& o) { return o.keyframe_id < first_kept_id; }),
        obs.end());
    // A point still followed by a live track keeps serving PnP even when its keyframes left the window.
    if (obs.empty() && !it->second.has_track) {
      it = points_.erase(it);
      ++removed;
    } else {
      ++it;
    }
  }
  return removed;
}

int Map::cull(const MapConfig& config) {
  constexpr int kMinVisibleBeforeJudging = 5;
  int removed = 0;
  for (auto it = points_.begin(); it != points_.end();) {
    const MapPoint& p = it->second;
    const bool rarely_found = p.times_visible >= kMinVisibleBeforeJudging &&
                              p.times_found < config.cull_min_found_ratio * p.times_visible;
    const bool unsupported =
        !p.has_track && static_cast<int>(p.observations.size()) < config.min_observations;
    if (rarely_found || unsupported) {
      if (rarely_found)
        markRemoved(p.id);
      else
        markRetired(p);
      if (p.has_track) point_by_track_.erase(p.track_id);
      it = points_.erase(it);
      ++removed;
    } else {
      ++it;
    }
  }
  return removed;
}

BaProblem Map::makeBaProblem(int window_keyframes, int num_fixed_oldest, double fx, double fy, double cx,
                             double cy) const {
  BaProblem problem;
  problem.fx = fx;
  problem.fy = fy;
  problem.cx = cx;
  problem.cy = cy;
  if (keyframes_.empty()) return problem;
  const size_t window = std::min(keyframes_.size(), static_cast<size_t>(std::max(1, window_keyframes)));
  const size_t first_window = keyframes_.size() - window;
  const uint64_t first_window_id = keyframes_[first_window].id;

  std::unordered_set<uint64_t> used_keyframes;
  for (const auto& entry : points_) {
    const MapPoint& p = entry.second;
    int in_window = 0;
    for (const MapObservation& o : p.observations) in_window += o.keyframe_id >= first_window_id ? 1 : 0;
    if (in_window < 2) continue;
    problem.points.push_back({p.id, p.p_world, false});
    for (const MapObservation& o : p.observations) {
      problem.observations.push_back({o.keyframe_id, p.id, o.px});
      used_keyframes.insert(o.keyframe_id);
    }
  }
  for (size_t i = 0; i < keyframes_.size(); ++i) {
    const Keyframe& kf = keyframes_[i];
    if (used_keyframes.count(kf.id) == 0) continue;
    const bool fixed = i < first_window + static_cast<size_t>(std::max(0, num_fixed_oldest));
    problem.keyframes.push_back({kf.id, kf.T_world_cam.inverse(), fixed});
  }
  return problem;
}

int Map::applyBaResult(const BaProblem& problem, const std::vector<BaObservation>& outliers) {
  for (const BaKeyframe& k : problem.keyframes) {
    if (k.fixed) continue;
    if (Keyframe* kf = keyframe(k.id)) kf->T_world_cam = k.T_cam_world.inverse();
  }
  for (const BaPoint& bp : problem.points) {
    if (MapPoint* p = point(bp.id)) {
      p->p_world = bp.p_world;
      markUpdated(bp.id);
    }
  }
  for (const BaInertialState& st : problem.inertial.states) {
    if (Keyframe* kf = keyframe(st.keyframe_id)) {
      kf->v_world_mps = st.v_world_mps;
      kf->imu_bias = st.bias;
    }
  }
  applyCovariances(problem.inertial.states);
  std::unordered_set<uint64_t> touched;
  for (const BaObservation& o : outliers) {
    MapPoint* p = point(o.point_id);
    if (p == nullptr) continue;
    auto& obs = p->observations;
    obs.erase(std::remove_if(obs.begin(), obs.end(),
                             [&o](const MapObservation& m) { return m.keyframe_id == o.keyframe_id; }),
              obs.end());
    touched.insert(o.point_id);
  }
  int removed = 0;
  for (uint64_t id : touched) {
    MapPoint* p = point(id);
    if (p != nullptr && p->observations.size() < 2) {
      removePoint(id);
      ++removed;
    }
  }
  return removed;
}

void Map::transformAbout(const Eigen::Vector3d& centre, const Eigen::Matrix3d& R, double s) {
  for (Keyframe& kf : keyframes_) {
    kf.T_world_cam.translation() = centre + s * R * (kf.T_world_cam.translation() - centre);
    kf.T_world_cam.linear() = R * kf.T_world_cam.linear();
    kf.v_world_mps = R * kf.v_world_mps;
  }
  for (auto& entry : points_) {
    entry.second.p_world = centre + s * R * (entry.second.p_world - centre);
    markUpdated(entry.first);
  }
}

void Map::applyCovariances(const std::vector<BaInertialState>& states) {
  for (const BaInertialState& st : states) {
    Keyframe* kf = keyframe(st.keyframe_id);
    if (kf == nullptr || !st.has_covariance || kf->has_covariance) continue;
    kf->has_covariance = true;
    kf->covariance = st.covariance;
    kf->imu_bias_at_covariance = st.bias;
    kf->bias_covariance = st.bias_covariance;
  }
}

void Map::pointViews(std::vector<MapPointView>* out) const {
  out->clear();
  out->reserve(points_.size());
  for (const auto& entry : points_)
    out->push_back(
        {entry.second.id, entry.second.p_world, static_cast<int>(entry.second.observations.size())});
}

void Map::scaleAbout(const Eigen::Vector3d& centre, double s) {
  for (Keyframe& kf : keyframes_) {
    kf.T_world_cam.translation() = centre + s * (kf.T_world_cam.translation() - centre);
    kf.v_world_mps *= s;
  }
  for (auto& entry : points_) {
    entry.second.p_world = centre + s * (entry.second.p_world - centre);
    markUpdated(entry.first);
  }
}

MapPointState Map::stateOf(const MapPoint& p) const {
  MapPointState state;
  state.id = p.id;
  state.p_world = p.p_world;
  state.num_observations = static_cast<int>(p.observations.size());
  // Information of the point from its observations (Gauss-Newton, poses exact): each one constrains the two
  // directions across its ray by the normalised-image Jacobian.
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  const double weight = 1.0 / (observation_sigma_rad_ * observation_sigma_rad_);
  for (const MapObservation& o : p.observations) {
    const Keyframe* kf = keyframe(o.keyframe_id);
    if (kf == nullptr) continue;
    const Eigen::Matrix3d R_cam_world = kf->T_world_cam.linear().transpose();
    const Eigen::Vector3d p_cam = R_cam_world * (p.p_world - kf->T_world_cam.translation());
    if (!(p_cam.z() > 0.0)) continue;
    Eigen::Matrix<double, 2, 3> J;
    J << 1.0, 0.0, -p_cam.x() / p_cam.z(), 0.0, 1.0, -p_cam.y() / p_cam.z();
    J = (J / p_cam.z()) * R_cam_world;
    information += weight * J.transpose() * J;
  }
  constexpr double kMaxVariance = 1e12;
  information += (1.0 / kMaxVariance) * Eigen::Matrix3d::Identity();
  state.covariance_world = information.ldlt().solve(Eigen::Matrix3d::Identity());
  return state;
}

void Map::markUpdated(uint64_t point_id) { pending_points_.emplace(point_id, false); }

void Map::markRemoved(uint64_t point_id) {
  auto it = pending_points_.find(point_id);
  const bool added_this_frame = it != pending_points_.end() && it->second;
  if (it != pending_points_.end()) pending_points_.erase(it);
  if (!added_this_frame) pending_removed_.push_back(point_id);
}

void Map::markRetired(const MapPoint& p) {
  pending_points_.erase(p.id);
  pending_retired_.push_back(stateOf(p));
}

MapEvents Map::takeEvents() {
  MapEvents events;
  events.map_restarted = pending_restart_;
  for (uint64_t id : pending_keyframes_)
    if (const Keyframe* kf = keyframe(id)) events.keyframes_added.push_back(keyframeState(*kf));
  for (const auto& entry : pending_points_) {
    const auto it = points_.find(entry.first);
    if (it == points_.end()) continue;
    (entry.second ? events.points_added : events.points_updated).push_back(stateOf(it->second));
  }
  // Ascending ids, so that the record does not depend on the hash map's order.
  auto byId = [](const MapPointState& a, const MapPointState& b) { return a.id < b.id; };
  std::sort(events.points_added.begin(), events.points_added.end(), byId);
  std::sort(events.points_updated.begin(), events.points_updated.end(), byId);
  events.keyframes_retired = std::move(pending_keyframes_retired_);
  events.points_retired = std::move(pending_retired_);
  events.points_removed = std::move(pending_removed_);
  pending_points_.clear();
  pending_retired_.clear();
  pending_removed_.clear();
  pending_keyframes_.clear();
  pending_keyframes_retired_.clear();
  pending_restart_ = false;
  return events;
}

}  // namespace planetary_vo
