/// FrozenFrameDetector (input_check.h): identical and near-identical consecutive images are frozen, an image
/// with a camera's noise or motion is not, 0 switches the check off.

#include <cmath>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "planetary_vo/vo/input_check.h"
#include "vo_test_images.h"

namespace planetary_vo {
namespace {

const cv::Size kSize(320, 240);

cv::Mat withNoise(const cv::Mat& image, double sigma, uint64_t seed) {
  cv::Mat noise(image.size(), CV_16S);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, sigma);
  cv::Mat out;
  cv::Mat wide;
  image.convertTo(wide, CV_16S);
  cv::Mat(wide + noise).convertTo(out, CV_8U);
  return out;
}

TEST(FrozenFrameDetector, IdenticalAndNearIdenticalFramesAreFrozen) {
  const cv::Mat image = test::texture(kSize, 3);
  FrozenFrameDetector detector(0.5);
  double mad = 0.0;
  EXPECT_FALSE(detector.check(image, &mad)) << "the first image has nothing to repeat";
  EXPECT_TRUE(std::isnan(mad));
  EXPECT_TRUE(detector.check(image.clone(), &mad));
  EXPECT_EQ(mad, 0.0);
  // One gray level more on a tenth of the pixels: still the same picture.
  cv::Mat nudged = image.clone();
  for (int r = 0; r < nudged.rows; r += 4)
    for (int c = 0; c < nudged.cols; c += 40)
      nudged.at<uint8_t>(r, c) = cv::saturate_cast<uint8_t>(nudged.at<uint8_t>(r, c) + 1);
  EXPECT_TRUE(detector.check(nudged, &mad));
  EXPECT_GT(mad, 0.0);
  EXPECT_LT(mad, 0.5);
}

TEST(FrozenFrameDetector, CameraNoiseOrMotionIsNotFrozen) {
  const cv::Mat image = test::texture(kSize, 3);
  FrozenFrameDetector detector(0.5);
  double mad = 0.0;
  detector.check(image);
  // A static scene seen by a real camera: 1.5 gray levels of read noise.
  EXPECT_FALSE(detector.check(withNoise(image, 1.5, 1), &mad));
  EXPECT_GT(mad, 0.5);
  // One pixel of motion on a textured scene.
  detector.check(image);
  cv::Mat shifted;
  cv::Mat(image, cv::Rect(1, 0, kSize.width - 1, kSize.height)).copyTo(shifted);
  cv::Mat moved = image.clone();
  shifted.copyTo(moved(cv::Rect(0, 0, kSize.width - 1, kSize.height)));
  EXPECT_FALSE(detector.check(moved, &mad));
  EXPECT_GT(mad, 0.5);
}

TEST(FrozenFrameDetector, OffResetAndSizeChange) {
  const cv::Mat image = test::texture(kSize, 3);
  FrozenFrameDetector off(0.0);
  off.check(image);
  double mad = -1.0;
  EXPECT_FALSE(off.check(image, &mad)) << "0 switches the check off";
  EXPECT_EQ(mad, 0.0) << "the difference is still measured";

  FrozenFrameDetector detector(0.5);
  detector.check(image);
  detector.reset();
  EXPECT_FALSE(detector.check(image)) << "reset() forgets the previous image";
  EXPECT_FALSE(detector.check(test::texture(cv::Size(160, 120), 3))) << "a new size has no previous image";
  EXPECT_THROW(detector.check(cv::Mat()), std::invalid_argument);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
