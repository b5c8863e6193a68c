#pragma once
/// Helpers of the dataset tests: synthetic images, file writing and pose comparison.

#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "planetary_vo/dataset/dataset.h"
#include "planetary_vo/geometry/pose.h"
#include "test_support.h"  // readText

namespace planetary_vo::test {

/// A textured image that differs from frame to frame (gradient + seeded noise).
inline cv::Mat syntheticImage(int width, int height, int type, int seed) {
  cv::Mat image(height, width, type);
  cv::RNG rng(static_cast<uint64_t>(seed) + 1);
  rng.fill(image, cv::RNG::UNIFORM, 0, type == CV_16UC1 ? 65536 : 256);
  for (int x = 0; x < width; ++x)
    image.col(x) += cv::Scalar::all(x % 7);  // saturates at the top of the range
  return image;
}

inline void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  ASSERT_TRUE(out.good()) << "cannot write " << path;
  out << text;
}

/// Translation distance [m] and rotation angle [rad] between two poses.
inline double translationError(const Pose& a, const Pose& b) {
  return (a.translation() - b.translation()).norm();
}
inline double rotationErrorRad(const Pose& a, const Pose& b) {
  return rotationAngleDeg(a.rotation().transpose() * b.rotation()) * M_PI / 180.0;
}

inline Pose makePose(const Eigen::Vector3d& axis, double angle_rad, const Eigen::Vector3d& t) {
  Pose T = Pose::Identity();
  T.linear() = Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
  T.translation() = t;
  return T;
}

/// Asserts that `call` throws DatasetError whose message contains `expected`.
template <typename Call>
::testing::AssertionResult throwsDatasetError(Call call, const std::string& expected) {
  try {
    call();
  } catch (const DatasetError& e) {
    if (std::string(e.what()).find(expected) != std::string::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure()
           << "message '" << e.what() << "' does not contain '" << expected << "'";
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "threw another exception: " << e.what();
  }
  return ::testing::AssertionFailure() << "did not throw (expected '" << expected << "')";
}

}  // namespace planetary_vo::test
