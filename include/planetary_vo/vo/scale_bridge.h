#pragma once
/// @file scale_bridge.h
/// Recovery of the vision-only chain: after a loss, a new two-view map (unit baseline) is attached to the
/// last good pose of the old trajectory. Its scale must continue the old one; this stage chooses it from what
/// the old map observed, best evidence first:
///   1. points of the old map that the new one triangulated again, seen from the reference pose within
///      kMaxSharedPointAngleDeg of their tracks (at least 5, and half of the shared points) and agreeing on the
///      depth ratio (median deviation within 10 %): the median depth ratio;
///   2. the speed between the last two keyframes of the old map over the new baseline's time span, if the
///      scene depth it implies agrees with the depth at which the reference camera sees the old map (within
///      kMaxDepthJumpFactor either way: both depths are taken from the same pose, so a larger jump means the
///      view changed discontinuously - a jump in the imagery, the soak's loop back to the start - and the
///      old map's speed says nothing about the new scene), and if the shared points (5 or more) were not
///      mostly off their tracks (LK carried them onto other ground: the view jumped as well);
///   3. when they contradict each other: the first map's scene depth (the new map's median depth is set to
///      the median depth of the navigation's first map, in world units). Vision alone then has no evidence
///      of the scale; this keeps it within the range of scene depths of the descent instead of compounding
///      a wrong guess at every such loss, and the scale confidence drops to zero;
///   4. without a speed: the median depth of the old map seen from the reference pose against the new map's.
/// Each source lowers the scale confidence by its own factor (FrameResult::scale_confidence). The bridge is a
/// pure function of the old map, the first map's depth and the new initialisation.

#include <string>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/initializer.h"
#include "planetary_vo/vo/map.h"

namespace planetary_vo {

enum class ScaleBridgeSource { kSharedPoints, kKeyframeSpeed, kFirstMapDepth, kSceneDepth, kNone };
/// "shared points", "keyframe speed", "first map's scene depth", "scene depth", "none".
const char* toString(ScaleBridgeSource source);

struct ScaleBridge {
  double scale = 1.0;              ///< old-map units per unit baseline of the new initialisation
  double confidence_factor = 0.0;  ///< multiplies the scale confidence (0.8 / 0.5 / 0 / 0.3 / 0 by source)
  ScaleBridgeSource source = ScaleBridgeSource::kNone;
  std::string
      detail;  ///< why a source was passed over (shared points off their tracks, the contradiction of 2.)
};

/// A shared point bridges the scale only if the reference pose sees it within this angle of its track's
/// direction in the new map.
constexpr double kMaxSharedPointAngleDeg = 3.0;
/// Factor by which the scene depth implied by the keyframe-speed bridge may differ from the depth at which
/// the reference camera sees the old map before the two are taken to contradict each other.
constexpr double kMaxDepthJumpFactor = 1.5;

/// @param old_map the map that was lost (still holding its points and keyframes).
/// @param camera the camera model: the old map's depth is taken over the points the reference camera sees.
/// @param T_world_ref pose of the new map's reference camera (the last good pose), taken at t_ref_s.
/// @param init the new two-view initialisation between the reference and the current frame (time t_cur_s).
/// @param first_map_depth median scene depth of the navigation's first map in world units (<= 0: unknown).
ScaleBridge bridgeScale(const Map& old_map, const PinholeCamera& camera, const Pose& T_world_ref,
                        double t_ref_s, double t_cur_s, const Initialization& init, double first_map_depth);

}  // namespace planetary_vo
