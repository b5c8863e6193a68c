#include "planetary_vo/terrain/keyframe_view.h"

#include <algorithm>
#include <cmath>

namespace planetary_vo::terrain {

bool resolvedPixel(const PinholeCamera& camera, const KeyframeView& view, const Eigen::Vector3d& p,
                   double max_footprint_m, Eigen::Vector2d* distorted_px) {
  const Eigen::Vector3d ray = p - view.centre_world;
  const double range = ray.norm();
  const double cos_incidence = std::abs(ray.z()) / range;  // on a level cell
  if (!(cos_incidence > 1e-3) || range / std::max(camera.fx(), camera.fy()) / cos_incidence > max_footprint_m)
    return false;
  const Eigen::Vector3d p_cam = view.T_cam_world * p;
  if (!(p_cam.z() > 0.0)) return false;
  const Eigen::Vector2d ideal = camera.project(p_cam);
  if (!camera.isInImage(ideal, 0.0)) return false;
  *distorted_px = camera.distortPixel(ideal);
  return true;
}

}  // namespace planetary_vo::terrain
