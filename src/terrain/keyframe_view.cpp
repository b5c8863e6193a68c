#include "planetary_vo/terrain/keyframe_view.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

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

void checkKeyframeImage(const PinholeCamera& camera, const cv::Mat& gray, const std::string& who) {
  if (gray.type() != CV_8UC1 || gray.cols != camera.width() || gray.rows != camera.height())
    throw std::invalid_argument(who + ": the keyframe image is not 8-bit gray of the camera's size (" +
                                std::to_string(gray.cols) + "x" + std::to_string(gray.rows) + ", camera " +
                                std::to_string(camera.width()) + "x" + std::to_string(camera.height()) + ")");
}

bool centrePixelFootprint(const PinholeCamera& camera, const Pose& T_world_cam, double ground_elevation_m,
                          double* footprint_m) {
  const Eigen::Vector3d axis = T_world_cam.linear().col(2);
  const double height = T_world_cam.translation().z() - ground_elevation_m;
  if (!(axis.z() < -0.1) || !(height > 0.0)) return false;
  *footprint_m = height / -axis.z() / std::max(camera.fx(), camera.fy());
  return true;
}

bool keepReducedImage(const PinholeCamera& camera, const Pose& T_world_cam, double ground_elevation_m,
                      double max_footprint_m, int max_images,
                      const std::function<cv::Mat(double footprint_m, int* scale)>& reduce,
                      std::deque<KeptImage>* images) {
  double footprint = 0.0;
  if (!centrePixelFootprint(camera, T_world_cam, ground_elevation_m, &footprint) ||
      footprint > max_footprint_m)
    return false;
  KeptImage image;
  image.pose = KeyframeView(T_world_cam);
  reduce(footprint, &image.scale).convertTo(image.values, CV_16F);
  images->push_back(std::move(image));
  while (images->size() > static_cast<size_t>(std::max(0, max_images))) images->pop_front();
  return true;
}

cv::Mat reducedForSigma(const cv::Mat& gray, double sigma_m, double pixel_footprint_m, int* scale_out) {
  if (!(pixel_footprint_m > 0.0)) throw std::invalid_argument("reducedForSigma: pixel footprint must be > 0");
  cv::Mat image;
  gray.convertTo(image, CV_32F);
  int scale = 1;
  while (sigma_m / (pixel_footprint_m * scale * 2) >= 2.0 && image.cols >= 64 && image.rows >= 64) {
    cv::pyrDown(image, image);
    scale *= 2;
  }
  if (scale_out) *scale_out = scale;
  return image;
}

cv::Mat meanOverKeptImages(const PinholeCamera& camera, const std::deque<KeptImage>& images,
                           const GridGeometry& geometry, const cv::Mat& elevation_m, double max_footprint_m) {
  cv::Mat out = geometry.newLayer();
  if (images.empty()) return out;
  for (int row = 0; row < geometry.rows; ++row) {
    const float* z = elevation_m.ptr<float>(row);
    float* o = out.ptr<float>(row);
    for (int col = 0; col < geometry.cols; ++col) {
      if (!std::isfinite(z[col])) continue;
      const Eigen::Vector3d p(geometry.x_m(col), geometry.y_m(row), z[col]);
      double sum = 0.0;
      int n = 0;
      for (const KeptImage& image : images) {
        Eigen::Vector2d px;
        if (!resolvedPixel(camera, image.pose, p, max_footprint_m, &px)) continue;
        px /= image.scale;
        const int c = static_cast<int>(std::lround(px.x())), r = static_cast<int>(std::lround(px.y()));
        if (c < 0 || r < 0 || c >= image.values.cols || r >= image.values.rows) continue;
        const float v = static_cast<float>(image.values.at<cv::float16_t>(r, c));
        if (!std::isfinite(v)) continue;
        sum += v;
        ++n;
      }
      if (n > 0) o[col] = static_cast<float>(sum / n);
    }
  }
  return out;
}

}  // namespace planetary_vo::terrain
