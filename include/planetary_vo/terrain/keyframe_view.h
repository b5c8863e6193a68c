#pragma once
/// @file keyframe_view.h
/// Where a cell of the landing area falls in a kept keyframe, for the stages that read the keyframe images
/// over the map (shadow_map.h, shading_relief.h): the distorted pixel of a world point, when that keyframe
/// resolves it, i.e. one pixel covers at most `max_footprint_m` of ground there (range / focal length,
/// stretched by the incidence on a level cell); and what the image-reading stages share: the keyframe
/// image's check, the ground under the image centre's pixel, the reduction of an image to a scale, and the
/// mean over kept images per cell.

#include <deque>
#include <functional>
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "planetary_vo/geometry/camera_model.h"
#include "planetary_vo/geometry/pose.h"
#include "planetary_vo/terrain/grid.h"

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

/// A keyframe's reduced image of per-pixel values (CV_16F, NaN = unknown) kept with its pose.
struct KeptImage {
  KeyframeView pose;
  int scale = 1;  ///< full-resolution pixels per reduced pixel
  cv::Mat values;
};

/// Throws std::invalid_argument ("<who>: the keyframe image is not 8-bit gray of the camera's size ...")
/// unless `gray` is CV_8UC1 of the camera's size.
void checkKeyframeImage(const PinholeCamera& camera, const cv::Mat& gray, const std::string& who);

/// The ground (m) one pixel at the image centre covers, for a camera `ground_elevation_m` above the ground
/// (world z) along its optical axis; false when that axis does not point down (its z >= -0.1) or the
/// camera is not above the ground.
bool centrePixelFootprint(const PinholeCamera& camera, const Pose& T_world_cam, double ground_elevation_m,
                          double* footprint_m);

/// Keeps a keyframe's reduced image in `images` (the newest `max_images`, oldest dropped) when its centre
/// pixel covers at most `max_footprint_m` of ground (centrePixelFootprint): `reduce(footprint_m, &scale)`
/// gives its per-pixel values (stored as CV_16F) and their scale. False, nothing kept, otherwise.
bool keepReducedImage(const PinholeCamera& camera, const Pose& T_world_cam, double ground_elevation_m,
                      double max_footprint_m, int max_images,
                      const std::function<cv::Mat(double footprint_m, int* scale)>& reduce,
                      std::deque<KeptImage>* images);
/// `gray` as CV_32F, halved (pyrDown) while `sigma_m` would still span at least 2 pixels after the halving
/// and the image has at least 64 pixels a side; `scale_out`: full-resolution pixels per reduced pixel.
/// Throws std::invalid_argument unless pixel_footprint_m > 0.
cv::Mat reducedForSigma(const cv::Mat& gray, double sigma_m, double pixel_footprint_m, int* scale_out);

/// Per cell of `elevation_m` (CV_32F on `geometry`, NaN = unknown): the mean of the finite values of the
/// kept images that resolve it (resolvedPixel, the nearest reduced pixel); NaN where none does.
cv::Mat meanOverKeptImages(const PinholeCamera& camera, const std::deque<KeptImage>& images,
                           const GridGeometry& geometry, const cv::Mat& elevation_m, double max_footprint_m);

}  // namespace planetary_vo::terrain
