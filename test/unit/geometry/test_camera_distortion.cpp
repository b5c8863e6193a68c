/// PinholeCamera lens distortion: distortPixel() agrees with OpenCV's projection (cv::projectPoints,
/// cv::fisheye::projectPoints), undistortPixel() inverts it to 1e-8 px over the whole image, and
/// distortedPixelToBearing() gives the ray that projects back to the pixel. For the three models of ROS
/// camera_info: plumb_bob, rational_polynomial, equidistant.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "planetary_vo/geometry/camera_model.h"

namespace planetary_vo {
namespace {

struct Lens {
  std::string name;
  PinholeCamera camera;
};

/// Lenses with a few to tens of pixels of distortion at the edge, all monotonic over the image.
std::vector<Lens> lenses() {
  const PinholeCamera n = PinholeCamera::fromFieldOfView(640, 480, 60.0);
  // The fisheye: 90 deg across with the pinhole focal length, so the image corner is at 71.5 deg off axis
  // (the equidistant model maps angles beyond 90 deg, which no pinhole ray reaches).
  const PinholeCamera w = PinholeCamera::fromFieldOfView(640, 480, 90.0);
  return {
      {"plumb_bob", PinholeCamera(640, 480, n.fx(), n.fy() * 1.001, n.cx() + 3.2, n.cy() - 2.1, "plumb_bob",
                                  {-0.04, 0.01, 4e-4, -3e-4, -0.002})},
      {"rational_polynomial", PinholeCamera(640, 480, n.fx(), n.fy(), n.cx(), n.cy(), "rational_polynomial",
                                            {0.25, -0.08, 2e-4, 1e-4, 0.01, 0.3, -0.05, 0.02})},
      {"equidistant", PinholeCamera(640, 480, w.fx(), w.fy(), w.cx(), w.cy(), "equidistant",
                                    {-0.01, 0.003, -0.0008, 0.0001})},
  };
}

/// Ideal (undistorted) pixels on a grid covering the image, corners included.
std::vector<Eigen::Vector2d> grid(const PinholeCamera& c) {
  std::vector<Eigen::Vector2d> px;
  for (int r = 0; r <= 12; ++r)
    for (int k = 0; k <= 16; ++k) px.emplace_back(k * (c.width() - 1) / 16.0, r * (c.height() - 1) / 12.0);
  return px;
}

TEST(CameraDistortion, DistortPixelMatchesOpenCvProjection) {
  for (const Lens& lens : lenses()) {
    const PinholeCamera& c = lens.camera;
    std::vector<cv::Point3d> points;
    const std::vector<Eigen::Vector2d> ideal = grid(c);
    for (const Eigen::Vector2d& p : ideal) {
      const Eigen::Vector2d n = c.pixelToNormalized(p);
      points.emplace_back(2.0 * n.x(), 2.0 * n.y(), 2.0);  // any depth: projection is scale-free
    }
    std::vector<cv::Point2d> projected;
    const cv::Mat K(c.Kcv()), D(c.distortion());
    if (c.distortionModel() == "equidistant") {
      cv::fisheye::projectPoints(points, projected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D);
    } else {
      cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, projected);
    }
    double largest = 0.0;
    for (size_t i = 0; i < ideal.size(); ++i) {
      const Eigen::Vector2d d = c.distortPixel(ideal[i]);
      EXPECT_NEAR(d.x(), projected[i].x, 1e-8) << lens.name << " " << ideal[i].transpose();
      EXPECT_NEAR(d.y(), projected[i].y, 1e-8) << lens.name << " " << ideal[i].transpose();
      largest = std::max(largest, (d - ideal[i]).norm());
    }
    EXPECT_GT(largest, 2.0) << lens.name;  // the lens does distort: the comparison is not trivial
  }
}

TEST(CameraDistortion, UndistortPixelInvertsDistortPixel) {
  for (const Lens& lens : lenses()) {
    const PinholeCamera& c = lens.camera;
    for (const Eigen::Vector2d& p : grid(c)) {
      // Measured pixel -> ideal -> back.
      bool converged = false;
      const Eigen::Vector2d ideal = c.undistortPixel(p, &converged);
      EXPECT_TRUE(converged) << lens.name << " " << p.transpose();
      EXPECT_NEAR((c.distortPixel(ideal) - p).norm(), 0.0, 1e-8) << lens.name << " " << p.transpose();
      // Ideal -> measured -> back.
      EXPECT_NEAR((c.undistortPixel(c.distortPixel(p)) - p).norm(), 0.0, 1e-8)
          << lens.name << " " << p.transpose();
      // The bearing of a measured pixel projects back onto it.
      const Eigen::Vector3d b = c.distortedPixelToBearing(p);
      EXPECT_NEAR(b.norm(), 1.0, 1e-12);
      EXPECT_NEAR((c.distortPixel(c.project(b)) - p).norm(), 0.0, 1e-8) << lens.name << " " << p.transpose();
    }
  }
}

TEST(CameraDistortion, UndistortPixelAgreesWithOpenCvUndistortPoints) {
  // OpenCV's iterative undistortion (the batch undistortPixels()) converges to the same ideal pixels.
  for (const Lens& lens : lenses()) {
    const PinholeCamera& c = lens.camera;
    std::vector<cv::Point2f> measured;
    for (const Eigen::Vector2d& p : grid(c))
      measured.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
    const std::vector<cv::Point2f> cv_ideal = c.undistortPixels(measured);
    ASSERT_EQ(cv_ideal.size(), measured.size());
    for (size_t i = 0; i < measured.size(); ++i) {
      const Eigen::Vector2d ideal = c.undistortPixel(Eigen::Vector2d(measured[i].x, measured[i].y));
      // OpenCV iterates a fixed number of times (and in float): 0.05 px.
      EXPECT_NEAR(ideal.x(), cv_ideal[i].x, 0.05) << lens.name << " " << measured[i];
      EXPECT_NEAR(ideal.y(), cv_ideal[i].y, 0.05) << lens.name << " " << measured[i];
    }
  }
}

TEST(CameraDistortion, NoDistortionIsTheIdentity) {
  const PinholeCamera c = PinholeCamera::fromFieldOfView(320, 240, 60.0);
  const PinholeCamera zero(320, 240, c.fx(), c.fy(), c.cx(), c.cy(), "plumb_bob", {0, 0, 0, 0, 0});
  for (const PinholeCamera& cam : {c, zero})
    for (const Eigen::Vector2d& p : grid(cam)) {
      EXPECT_EQ(cam.distortPixel(p), p);
      EXPECT_EQ(cam.undistortPixel(p), p);
    }
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
