/// PinholeCamera::isValid() rejects every camera the geometry cannot use safely (issue 12, fault
/// containment): a distortion vector of the wrong length for its model (cv::undistortPoints asserts on it), a
/// principal point outside the image, a focal length outside a plausible field of view, and a distortion that
/// folds back (not invertible) before the image corners. The reason names the problem.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "planetary_vo/geometry/camera_model.h"

namespace planetary_vo {
namespace {

const PinholeCamera kNominal = PinholeCamera::fromFieldOfView(640, 480, 60.0);

PinholeCamera withDistortion(const std::string& model, std::vector<double> d,
                             const PinholeCamera& c = kNominal) {
  return PinholeCamera(c.width(), c.height(), c.fx(), c.fy(), c.cx(), c.cy(), model, std::move(d));
}

PinholeCamera withIntrinsics(double fx, double fy, double cx, double cy) {
  return PinholeCamera(kNominal.width(), kNominal.height(), fx, fy, cx, cy);
}

::testing::AssertionResult rejected(const PinholeCamera& c, const std::string& text) {
  std::string why;
  if (c.isValid(&why)) return ::testing::AssertionFailure() << "accepted";
  if (why.find(text) == std::string::npos)
    return ::testing::AssertionFailure() << "reason '" << why << "' lacks '" << text << "'";
  return ::testing::AssertionSuccess();
}

::testing::AssertionResult accepted(const PinholeCamera& c) {
  std::string why;
  if (!c.isValid(&why)) return ::testing::AssertionFailure() << "rejected: " << why;
  return ::testing::AssertionSuccess();
}

TEST(CameraValidation, DistortionLengthPerModel) {
  EXPECT_TRUE(accepted(withDistortion("plumb_bob", {-0.04, 0.01, 4e-4, -3e-4, -0.002})));
  EXPECT_TRUE(
      accepted(withDistortion("rational_polynomial", {0.25, -0.08, 2e-4, 1e-4, 0.01, 0.3, -0.05, 0.02})));
  const PinholeCamera wide = PinholeCamera::fromFieldOfView(640, 480, 90.0);
  EXPECT_TRUE(accepted(withDistortion("equidistant", {-0.01, 0.003, -0.0008, 0.0001}, wide)));
  // No coefficients: an ideal camera whatever the model says (ROS sends plumb_bob with D = []).
  for (const char* model : {"plumb_bob", "rational_polynomial", "equidistant"})
    EXPECT_TRUE(accepted(withDistortion(model, {}))) << model;

  for (size_t n : {1u, 3u, 4u, 6u, 7u, 8u, 14u, 100u})
    EXPECT_TRUE(rejected(withDistortion("plumb_bob", std::vector<double>(n, 0.001)),
                         "plumb_bob distortion needs 5 coefficients, got " + std::to_string(n)))
        << n;
  for (size_t n : {3u, 5u, 6u, 7u, 12u})
    EXPECT_TRUE(rejected(withDistortion("rational_polynomial", std::vector<double>(n, 0.001)),
                         "rational_polynomial distortion needs 8 coefficients"))
        << n;
  for (size_t n : {3u, 5u, 8u})
    EXPECT_TRUE(rejected(withDistortion("equidistant", std::vector<double>(n, 0.001)),
                         "equidistant distortion needs 4 coefficients"))
        << n;
  EXPECT_TRUE(rejected(withDistortion("fisheye_xyz", {0.1, 0, 0, 0}), "unsupported distortion model"));
}

TEST(CameraValidation, CoefficientsWithoutAModelAreRefusedNotIgnored) {
  // "" and "none" are an ideal camera only when D says so too: coefficients the camera cannot apply would
  // leave the tracks on a distorted image treated as ideal.
  for (const char* model : {"", "none"}) {
    EXPECT_TRUE(accepted(withDistortion(model, {}))) << model;
    EXPECT_TRUE(accepted(withDistortion(model, {0.0, 0.0, 0.0, 0.0, 0.0}))) << model;
    EXPECT_TRUE(rejected(withDistortion(model, {-0.04, 0.01, 4e-4, -3e-4, -0.002}),
                         "non-zero distortion coefficients without a distortion model"))
        << model;
    EXPECT_TRUE(rejected(withDistortion(model, {0.001}), "without a distortion model")) << model;
  }
}

TEST(CameraValidation, PrincipalPointInsideTheImage) {
  const double f = kNominal.fx();
  EXPECT_TRUE(accepted(withIntrinsics(f, f, 0.0, 0.0)));
  EXPECT_TRUE(accepted(withIntrinsics(f, f, 639.0, 479.0)));
  for (double cx : {1e9, 1e6, 700.0, -3.0, -1e9})
    EXPECT_TRUE(rejected(withIntrinsics(f, f, cx, 240.0), "principal point")) << cx;
  for (double cy : {1e9, 480.5, -1.0})
    EXPECT_TRUE(rejected(withIntrinsics(f, f, 320.0, cy), "principal point")) << cy;
}

TEST(CameraValidation, FocalLengthWithinAPlausibleFieldOfView) {
  // Narrow (2.85 deg, like LROC's narrow-angle camera) and wide (150 deg) lenses are fine.
  EXPECT_TRUE(accepted(PinholeCamera::fromFieldOfView(640, 480, 2.85)));
  EXPECT_TRUE(accepted(PinholeCamera::fromFieldOfView(640, 480, 150.0)));
  for (double fx : {1e9, 1e7, 1e-3, 1.0})
    EXPECT_TRUE(rejected(withIntrinsics(fx, kNominal.fy(), 319.5, 239.5), "field of view")) << fx;
  EXPECT_TRUE(rejected(withIntrinsics(kNominal.fx(), 1e9, 319.5, 239.5), "field of view"));
}

TEST(CameraValidation, DistortionMustBeInvertibleOverTheImage) {
  // Barrel distortion so strong that the radial mapping turns back before the image corner (k1 = -0.9 at
  // 60 deg: d(r (1 + k1 r^2))/dr = 0 at r = 0.61, the corner is at r = 0.72).
  EXPECT_TRUE(rejected(withDistortion("plumb_bob", {-0.9, 0, 0, 0, 0}), "not invertible"));
  // A large negative k2 folds back before the corner too; k1 = -0.2 alone does not (it turns at r = 1.29,
  // beyond the corner's distorted radius).
  EXPECT_TRUE(rejected(withDistortion("plumb_bob", {0.0, -2.0, 0, 0, 0}), "not invertible"));
  EXPECT_TRUE(accepted(withDistortion("plumb_bob", {-0.2, 0, 0, 0, 0})));
  // Pincushion grows monotonically: fine however strong.
  EXPECT_TRUE(accepted(withDistortion("plumb_bob", {0.5, 0.2, 0, 0, 0})));
  // A rational model whose radial mapping r / (1 + 4 r^2) saturates at 0.25, below the corner's 0.72.
  EXPECT_TRUE(rejected(withDistortion("rational_polynomial", {0, 0, 0, 0, 0, 4.0, 0, 0}), "not invertible"));
  // An equidistant lens whose angle mapping saturates before the corners: they have no ray.
  const PinholeCamera wide = PinholeCamera::fromFieldOfView(640, 480, 90.0);
  EXPECT_TRUE(rejected(withDistortion("equidistant", {-0.3, 0, 0, 0}, wide), "not invertible"));
  // Huge but finite coefficients: the corners' rays are squeezed to a sliver of view, or the mapping folds.
  EXPECT_TRUE(rejected(withDistortion("plumb_bob", {1e30, -1e30, 0, 0, 0}), "field of view"));
  EXPECT_TRUE(rejected(withDistortion("plumb_bob", {-1e30, 1e30, 0, 0, 0}), "not invertible"));
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
