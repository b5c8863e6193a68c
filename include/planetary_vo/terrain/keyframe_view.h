#pragma once
/// @file keyframe_view.h
/// Where a cell of the landing area falls in a kept keyframe, for the stages that read the keyframe images
/// over the map (shadow_map.h, shading_relief.h): the distorted pixel of a world point, when that keyframe
/// resolves it, i.e. one pixel covers at most `max_footprint_m` of ground there (range / focal length,
/// stretched by the incidence on a level cell).

#include <Eigen/Core>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"

namespace planetary_vo::terrain {

struct KeyframeView {
  KeyframeView() = default;
  explicit KeyframeView(const Pose& T_world_cam)
      : T_cam_world(T_world_cam.inverse()), centre_world(T_world_cam.translation()) {}
  Pose T_cam_world = Pose::Identity();
  Eigen::Vector3d centre_world = Eigen::Vector3d::Zero();
};

/// The distorted pixel (full resolution) of world point `p` in `view`; false when behind the camera, outside
/// the image, or seen with a pixel coarser than max_footprint_m.
bool resolvedPixel(const PinholeCamera& camera, const KeyframeView& view, const Eigen::Vector3d& p,
                   double max_footprint_m, Eigen::Vector2d* distorted_px);

}  // namespace planetary_vo::terrain
