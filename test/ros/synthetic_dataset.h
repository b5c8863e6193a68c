#pragma once
/// A tiny planetary_vo-format dataset with every stream (images, ground truth, 200 Hz IMU, altimeter between
/// the images), written with the core DatasetWriter. Used by the player tests, here and through
/// make_player_test_dataset for the rostests.

#include <cmath>
#include <string>

#include <opencv2/core.hpp>

#include "planetary_vo/dataset/dataset.h"

namespace planetary_vo::test {

struct SyntheticLanding {
  int num_images = 20;
  double image_rate_hz = 10.0;
  double imu_rate_hz = 200.0;
  double t0_s = 0.0;  ///< time of the first image (and of the first IMU sample)
};

/// Camera looking straight down (optical z = world -z), descending 10 m/s from 1000 m. Image k is a gradient
/// whose pixel (0, 0) is k. IMU samples run from t0 to the last image time, both included; altimeter samples
/// at t0 + (k + 0.5) / image_rate for k = 0 .. num_images - 2 (between the images).
inline void writeSyntheticLanding(const std::string& directory,
                                  const SyntheticLanding& spec = SyntheticLanding()) {
  const PinholeCamera camera(64, 48, 50.0, 50.0, 31.5, 23.5, "plumb_bob", {0.01, -0.002, 0.0, 0.0, 0.0});
  DatasetWriter writer(directory, camera);
  writer.setSequenceYaml("name: player_synthetic\n");
  auto height = [](double t_rel) { return 1000.0 - 10.0 * t_rel; };
  for (int k = 0; k < spec.num_images; ++k) {
    const double t_rel = k / spec.image_rate_hz;
    cv::Mat image(camera.height(), camera.width(), CV_8UC1);
    for (int r = 0; r < image.rows; ++r)
      for (int c = 0; c < image.cols; ++c)
        image.at<uint8_t>(r, c) = static_cast<uint8_t>((k + r + 2 * c) % 256);
    Pose T_world_cam = Pose::Identity();
    T_world_cam.linear() = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix() *
                           Eigen::AngleAxisd(0.01 * k, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T_world_cam.translation() = Eigen::Vector3d(0.5 * k, -0.25 * k, height(t_rel));
    writer.addFrame(spec.t0_s + t_rel, image, T_world_cam);
  }
  const double duration = (spec.num_images - 1) / spec.image_rate_hz;
  const int num_imu = static_cast<int>(std::lround(duration * spec.imu_rate_hz)) + 1;
  for (int i = 0; i < num_imu; ++i) {
    ImuSample s;
    s.timestamp_s = spec.t0_s + i / spec.imu_rate_hz;
    s.angular_velocity_radps = Eigen::Vector3d(0.0, 0.0, 0.1 + 0.001 * i);
    s.specific_force_mps2 = Eigen::Vector3d(0.01 * i, 0.0, -1.62);
    writer.addImu(s);
  }
  for (int k = 0; k + 1 < spec.num_images; ++k) {
    AltimeterSample s;
    const double t_rel = (k + 0.5) / spec.image_rate_hz;
    s.timestamp_s = spec.t0_s + t_rel;
    s.slant_range_m = height(t_rel) + 0.5;
    writer.addAltimeter(s);
  }
  writer.finish();
}

}  // namespace planetary_vo::test
