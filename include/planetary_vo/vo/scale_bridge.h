#pragma once
/// @file scale_bridge.h
/// Recovery of the vision-only chain: after a loss, a new two-view map (unit baseline) is attached to the
/// last good pose of the old trajectory. Its scale must continue the old one; this stage chooses it from what
/// the old map observed, best evidence first:
///   1. points of the old map that the new one triangulated again (their depths in the reference camera must
///      agree): the median depth ratio;
///   2. the speed between the last two keyframes of the old map over the new baseline's time span;
///   3. the median scene depth of the old map seen from the reference pose against the new map's.
/// Each source lowers the scale confidence by its own factor (FrameResult::scale_confidence). The bridge is a
/// pure function of the old map and the new initialisation: nothing accumulates between recoveries.

#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/vo/initializer.h"
#include "planetary_vo/vo/map.h"

namespace planetary_vo {

enum class ScaleBridgeSource { kSharedPoints, kKeyframeSpeed, kSceneDepth, kNone };
/// "shared points", "keyframe speed", "scene depth", "none".
const char* toString(ScaleBridgeSource source);

struct ScaleBridge {
  double scale = 1.0;              ///< old-map units per unit baseline of the new initialisation
  double confidence_factor = 0.0;  ///< multiplies the scale confidence (0.8 / 0.5 / 0.3 / 0 by source)
  ScaleBridgeSource source = ScaleBridgeSource::kNone;
};

/// @param old_map the map that was lost (still holding its points and keyframes).
/// @param T_world_ref pose of the new map's reference camera (the last good pose), taken at t_ref_s.
/// @param init the new two-view initialisation between the reference and the current frame (time t_cur_s).
ScaleBridge bridgeScale(const Map& old_map, const Pose& T_world_ref, double t_ref_s, double t_cur_s,
                        const Initialization& init);

}  // namespace planetary_vo
