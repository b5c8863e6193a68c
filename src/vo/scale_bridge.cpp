#include "planetary_vo/vo/scale_bridge.h"

#include <algorithm>
#include <vector>

#include "planetary_vo/geometry/median.h"
#include "planetary_vo/vo/motion_prior.h"

namespace planetary_vo {
namespace {

// A recovery whose scale came from points shared with the old map keeps most of the confidence; one that had
// to assume the last keyframe speed, less; one that only matched the scene depth, least.
constexpr double kSharedPointsBridgeConfidence = 0.8;
constexpr double kSpeedBridgeConfidence = 0.5;
constexpr double kDepthBridgeConfidence = 0.3;
constexpr int kMinSharedPointsForBridge = 5;

}  // namespace

const char* toString(ScaleBridgeSource source) {
  switch (source) {
    case ScaleBridgeSource::kSharedPoints:
      return "shared points";
    case ScaleBridgeSource::kKeyframeSpeed:
      return "keyframe speed";
    case ScaleBridgeSource::kSceneDepth:
      return "scene depth";
    case ScaleBridgeSource::kNone:
      break;
  }
  return "none";
}

ScaleBridge bridgeScale(const Map& old_map, const Pose& T_world_ref, double t_ref_s, double t_cur_s,
                        const Initialization& init) {
  ScaleBridge bridge;
  // 1. Shared points: their depths in the reference camera fix the scale without assuming anything about the
  //    motion.
  const Pose T_ref_world = T_world_ref.inverse();
  std::vector<double> ratios;
  for (size_t i = 0; i < init.track_ids.size(); ++i) {
    const MapPoint* old = old_map.pointForTrack(init.track_ids[i]);
    if (old == nullptr) continue;
    const double old_depth = (T_ref_world * old->p_world).z();
    if (old_depth > 0.0 && init.points_c1[i].z() > 0.0) ratios.push_back(old_depth / init.points_c1[i].z());
  }
  if (static_cast<int>(ratios.size()) >= kMinSharedPointsForBridge) {
    bridge.scale = medianInPlace(&ratios);
    bridge.confidence_factor = kSharedPointsBridgeConfidence;
    bridge.source = ScaleBridgeSource::kSharedPoints;
    return bridge;
  }
  // 2. The keyframe speed of the old map: the new baseline (unit length) gets the distance it covers.
  Eigen::Vector3d v_world_per_s;
  const double dt_new = t_cur_s - t_ref_s;
  if (keyframeVelocity(old_map, &v_world_per_s) && dt_new > 0.0 && v_world_per_s.norm() > 0.0) {
    bridge.scale = v_world_per_s.norm() * dt_new;
    bridge.confidence_factor = kSpeedBridgeConfidence;
    bridge.source = ScaleBridgeSource::kKeyframeSpeed;
    return bridge;
  }
  // 3. The median scene depth of the old map seen from the reference pose (the altitude changes little over a
  //    short loss).
  std::vector<double> depths;
  for (const auto& entry : old_map.points()) {
    const double z = (T_ref_world * entry.second.p_world).z();
    if (z > 0.0) depths.push_back(z);
  }
  if (!depths.empty() && init.median_depth > 0.0) {
    bridge.scale = medianInPlace(&depths) / init.median_depth;
    bridge.confidence_factor = kDepthBridgeConfidence;
    bridge.source = ScaleBridgeSource::kSceneDepth;
  }
  return bridge;
}

}  // namespace planetary_vo
