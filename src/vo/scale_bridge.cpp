#include "planetary_vo/vo/scale_bridge.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "planetary_vo/geometry/median.h"
#include "planetary_vo/vo/motion_prior.h"

namespace planetary_vo {
namespace {

// A recovery whose scale came from points shared with the old map keeps most of the confidence; one that had
// to assume the last keyframe speed, less; one that only matched the scene depth, least; one whose evidence
// contradicted itself (the first map's depth), none.
constexpr double kSharedPointsBridgeConfidence = 0.8;
constexpr double kSpeedBridgeConfidence = 0.5;
constexpr double kDepthBridgeConfidence = 0.3;
constexpr double kFirstMapDepthConfidence = 0.0;
constexpr int kMinSharedPointsForBridge = 5;
constexpr double kMinSharedPointFraction = 0.5;     // of the shared points, within the angle of their tracks
constexpr double kMaxSharedPointRatioSpread = 0.1;  // median |ratio / median - 1| of those
constexpr int kMinPointsInViewForDepth = 5;

/// Median depth of the old map's points that the reference camera sees (in front of it, projecting into the
/// image); all points in front of it when fewer than kMinPointsInViewForDepth are in view; 0 when none are.
double oldMapDepthInView(const Map& old_map, const PinholeCamera& camera, const Pose& T_ref_world) {
  std::vector<double> in_view, in_front;
  for (const auto& entry : old_map.points()) {
    const Eigen::Vector3d p_ref = T_ref_world * entry.second.p_world;
    if (!(p_ref.z() > 0.0)) continue;
    in_front.push_back(p_ref.z());
    const Eigen::Vector2d px = camera.project(p_ref);
    if (px.x() >= 0.0 && px.y() >= 0.0 && px.x() <= camera.width() - 1.0 && px.y() <= camera.height() - 1.0)
      in_view.push_back(p_ref.z());
  }
  std::vector<double>* depths =
      static_cast<int>(in_view.size()) >= kMinPointsInViewForDepth ? &in_view : &in_front;
  return depths->empty() ? 0.0 : medianInPlace(depths);
}

}  // namespace

const char* toString(ScaleBridgeSource source) {
  switch (source) {
    case ScaleBridgeSource::kSharedPoints:
      return "shared points";
    case ScaleBridgeSource::kKeyframeSpeed:
      return "keyframe speed";
    case ScaleBridgeSource::kFirstMapDepth:
      return "first map's scene depth";
    case ScaleBridgeSource::kSceneDepth:
      return "scene depth";
    case ScaleBridgeSource::kNone:
      break;
  }
  return "none";
}

ScaleBridge bridgeScale(const Map& old_map, const PinholeCamera& camera, const Pose& T_world_ref,
                        double t_ref_s, double t_cur_s, const Initialization& init, double first_map_depth) {
  ScaleBridge bridge;
  // 1. Shared points: their depths in the reference camera fix the scale without assuming anything about the
  //    motion.
  const Pose T_ref_world = T_world_ref.inverse();
  //    A shared point counts only where the reference pose sees it in the direction of its track: after a
  //    jump of the view, the reference pose (the last good one, carried on at constant velocity) is wrong,
  //    and a few tracks that LK carried across the jump land on other ground.
  const double max_angle_rad = kMaxSharedPointAngleDeg * M_PI / 180.0;
  std::vector<double> ratios;
  int shared = 0;
  for (size_t i = 0; i < init.track_ids.size(); ++i) {
    const MapPoint* old = old_map.pointForTrack(init.track_ids[i]);
    if (old == nullptr) continue;
    ++shared;
    const Eigen::Vector3d p_ref = T_ref_world * old->p_world;
    const Eigen::Vector3d& p_new = init.points_c1[i];
    if (!(p_ref.z() > 0.0 && p_new.z() > 0.0)) continue;
    const double angle_rad = std::atan2(p_ref.cross(p_new).norm(), p_ref.dot(p_new));
    if (angle_rad <= max_angle_rad) ratios.push_back(p_ref.z() / p_new.z());
  }
  // They must be most of the shared points and agree on the scale: points of the old map that LK carried onto
  // other ground scatter in depth ratio, the same points seen again do not.
  const int consistent = static_cast<int>(ratios.size());
  // Enough shared points, but most of them off their tracks: LK carried them onto other ground, which is
  // itself evidence that the view jumped (tested with the depths below, which cannot tell a jump from a
  // descent whose speed falls with its altitude: one of the 66 jumps of a 6-minute soak passed them).
  bool tracks_jumped = false;
  if (consistent >= kMinSharedPointsForBridge && consistent >= kMinSharedPointFraction * shared) {
    const double scale = medianInPlace(&ratios);
    std::vector<double> deviations;
    for (double r : ratios) deviations.push_back(std::abs(r / scale - 1.0));
    const double spread = medianInPlace(&deviations);
    if (spread <= kMaxSharedPointRatioSpread) {
      bridge.scale = scale;
      bridge.confidence_factor = kSharedPointsBridgeConfidence;
      bridge.source = ScaleBridgeSource::kSharedPoints;
      return bridge;
    }
    bridge.detail = std::to_string(consistent) + " shared points disagree on the scale (median deviation " +
                    std::to_string(100.0 * spread) + " %)";
  } else if (shared >= kMinSharedPointsForBridge) {
    tracks_jumped = consistent < kMinSharedPointFraction * shared;
    bridge.detail = std::to_string(shared - consistent) + " of " + std::to_string(shared) +
                    " shared points off their tracks by more than " +
                    std::to_string(kMaxSharedPointAngleDeg) + " deg";
  }
  const double old_depth = oldMapDepthInView(old_map, camera, T_ref_world);
  const bool new_depth_known = init.median_depth > 0.0;
  // 2. The keyframe speed of the old map: the new baseline (unit length) gets the distance it covers, unless
  //    the scene depth that gives contradicts the old map's depth seen from the same pose.
  Eigen::Vector3d v_world_per_s;
  const double dt_new = t_cur_s - t_ref_s;
  bool view_jumped = false;
  if (keyframeVelocity(old_map, &v_world_per_s) && dt_new > 0.0 && v_world_per_s.norm() > 0.0) {
    const double speed_scale = v_world_per_s.norm() * dt_new;
    const double implied_depth = speed_scale * init.median_depth;
    const bool depth_jumped =
        old_depth > 0.0 && new_depth_known &&
        (implied_depth > kMaxDepthJumpFactor * old_depth || old_depth > kMaxDepthJumpFactor * implied_depth);
    view_jumped = depth_jumped || tracks_jumped;
    if (!view_jumped) {
      bridge.scale = speed_scale;
      bridge.confidence_factor = kSpeedBridgeConfidence;
      bridge.source = ScaleBridgeSource::kKeyframeSpeed;
      return bridge;
    }
    bridge.detail +=
        std::string(bridge.detail.empty() ? "" : "; ") +
        (depth_jumped ? "the keyframe speed would put the scene at " + std::to_string(implied_depth) +
                            " where the old map is seen at " + std::to_string(old_depth)
                      : std::string("the shared points left their tracks")) +
        ": the view jumped";
    // 3. The first map's scene depth: nothing observed relates the two maps.
    if (first_map_depth > 0.0) {
      bridge.scale = first_map_depth / init.median_depth;
      bridge.confidence_factor = kFirstMapDepthConfidence;
      bridge.source = ScaleBridgeSource::kFirstMapDepth;
      return bridge;
    }
  }
  // 4. The median scene depth of the old map seen from the reference pose (the altitude changes little over a
  //    short loss).
  if (old_depth > 0.0 && new_depth_known) {
    bridge.scale = old_depth / init.median_depth;
    bridge.confidence_factor = view_jumped ? 0.0 : kDepthBridgeConfidence;
    bridge.source = ScaleBridgeSource::kSceneDepth;
  }
  return bridge;
}

}  // namespace planetary_vo
