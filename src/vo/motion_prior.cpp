#include "planetary_vo/vo/motion_prior.h"

namespace planetary_vo {

bool keyframeVelocity(const Map& map, Eigen::Vector3d* v_world_per_s) {
  const auto& kfs = map.keyframes();
  if (kfs.size() < 2) return false;
  const Keyframe& a = kfs[kfs.size() - 2];
  const Keyframe& b = kfs.back();
  const double dt = b.timestamp_s - a.timestamp_s;
  if (!(dt > 0.0)) return false;
  *v_world_per_s = (b.T_world_cam.translation() - a.T_world_cam.translation()) / dt;
  return true;
}

Pose predictConstantVelocity(const Pose& T_world_cam_last, double t_last_s, const Map& map, double t_s) {
  Pose T = T_world_cam_last;
  Eigen::Vector3d v_world_per_s;
  if (keyframeVelocity(map, &v_world_per_s)) T.translation() += v_world_per_s * (t_s - t_last_s);
  return T;
}

}  // namespace planetary_vo
