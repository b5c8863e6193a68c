/// input_check.h: FrozenFrameDetector (identical and near-identical consecutive images are frozen, an image
/// with a camera's noise or motion is not, nor a slow motion of a noiseless camera over flat ground, 0
/// switches the check off), checkExposure (black, blank, saturated)
/// and ExposureCompensator (an exposure step is scaled back, slow changes pass untouched).

#include <cmath>

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "planetary_vo/vo/config.h"
#include "planetary_vo/vo/input_check.h"
#include "vo_test_images.h"

namespace planetary_vo {
namespace {

const cv::Size kSize(320, 240);
const double kMaxMovedRatio = PipelineConfig().frozen_frame_max_moved_ratio;

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
  FrozenFrameDetector detector(0.5, kMaxMovedRatio);
  FrozenFrameDetector::Difference diff;
  EXPECT_FALSE(detector.check(image, &diff)) << "the first image has nothing to repeat";
  EXPECT_TRUE(std::isnan(diff.mean_abs_diff));
  EXPECT_TRUE(detector.check(image.clone(), &diff));
  EXPECT_EQ(diff.mean_abs_diff, 0.0);
  // One gray level more on a tenth of the pixels: still the same picture.
  cv::Mat nudged = image.clone();
  for (int r = 0; r < nudged.rows; r += 4)
    for (int c = 0; c < nudged.cols; c += 40)
      nudged.at<uint8_t>(r, c) = cv::saturate_cast<uint8_t>(nudged.at<uint8_t>(r, c) + 1);
  EXPECT_TRUE(detector.check(nudged, &diff));
  EXPECT_GT(diff.mean_abs_diff, 0.0);
  EXPECT_LT(diff.mean_abs_diff, 0.5);
}

TEST(FrozenFrameDetector, CameraNoiseOrMotionIsNotFrozen) {
  const cv::Mat image = test::texture(kSize, 3);
  FrozenFrameDetector detector(0.5, kMaxMovedRatio);
  FrozenFrameDetector::Difference diff;
  detector.check(image);
  // A static scene seen by a real camera: 1.5 gray levels of read noise.
  EXPECT_FALSE(detector.check(withNoise(image, 1.5, 1), &diff));
  EXPECT_GT(diff.mean_abs_diff, 0.5);
  // One pixel of motion on a textured scene.
  detector.check(image);
  cv::Mat shifted;
  cv::Mat(image, cv::Rect(1, 0, kSize.width - 1, kSize.height)).copyTo(shifted);
  cv::Mat moved = image.clone();
  shifted.copyTo(moved(cv::Rect(0, 0, kSize.width - 1, kSize.height)));
  EXPECT_FALSE(detector.check(moved, &diff));
  EXPECT_GT(diff.mean_abs_diff, 0.5);
}

/// A noiseless camera moving slowly over mostly flat ground (the end of a descent rendered without sensor
/// noise): a dark, flat image with a few sharp bright rocks, moved by one pixel. The mean difference is far
/// below the threshold, as on approach_nozzle at 512 px (0.17-0.49 gray levels over 26 frames), but the
/// rocks' edges moved: not frozen. With the moved-edge test switched off (ratio 1) the same pair is refused.
TEST(FrozenFrameDetector, SlowMotionOfANoiselessCameraOverFlatGroundIsNotFrozen) {
  cv::Mat ground(kSize, CV_8UC1, cv::Scalar(40));
  cv::RNG rng(7);
  for (int k = 0; k < 12; ++k)
    cv::circle(ground, cv::Point(rng.uniform(10, kSize.width - 10), rng.uniform(10, kSize.height - 10)),
               rng.uniform(2, 5), cv::Scalar(200), cv::FILLED);
  cv::Mat moved(kSize, CV_8UC1, cv::Scalar(40));
  ground(cv::Rect(0, 0, kSize.width - 1, kSize.height)).copyTo(moved(cv::Rect(1, 0, kSize.width - 1, kSize.height)));

  FrozenFrameDetector detector(0.5, kMaxMovedRatio);
  FrozenFrameDetector::Difference diff;
  detector.check(ground);
  EXPECT_FALSE(detector.check(moved, &diff));
  EXPECT_LT(diff.mean_abs_diff, 0.5) << "the mean difference alone would call it frozen";
  EXPECT_GT(diff.moved_ratio, 2.0 * kMaxMovedRatio);
  // The same pair repeated exactly is frozen again: nothing moved.
  EXPECT_TRUE(detector.check(moved.clone(), &diff));
  EXPECT_EQ(diff.moved_ratio, 0.0);

  FrozenFrameDetector mean_only(0.5, 1.0);
  mean_only.check(ground);
  EXPECT_TRUE(mean_only.check(moved)) << "without the moved-edge test the slow frame is refused";
}

TEST(FrozenFrameDetector, OffResetAndSizeChange) {
  const cv::Mat image = test::texture(kSize, 3);
  FrozenFrameDetector off(0.0);
  off.check(image);
  FrozenFrameDetector::Difference diff;
  EXPECT_FALSE(off.check(image, &diff)) << "0 switches the check off";
  EXPECT_EQ(diff.mean_abs_diff, 0.0) << "the difference is still measured";

  FrozenFrameDetector detector(0.5, kMaxMovedRatio);
  detector.check(image);
  detector.reset();
  EXPECT_FALSE(detector.check(image)) << "reset() forgets the previous image";
  EXPECT_FALSE(detector.check(test::texture(cv::Size(160, 120), 3))) << "a new size has no previous image";
  EXPECT_THROW(detector.check(cv::Mat()), std::invalid_argument);
}

TEST(CheckExposure, BlackBlankAndSaturatedFramesAreNamed) {
  const cv::Mat texture = test::texture(kSize, 3);
  EXPECT_EQ(checkExposure(texture, 2.0, 0.9), "");
  EXPECT_NE(checkExposure(cv::Mat::zeros(kSize, CV_8UC1), 2.0, 0.9).find("black frame"), std::string::npos);
  EXPECT_NE(checkExposure(cv::Mat(kSize, CV_8UC1, cv::Scalar(255)), 2.0, 0.9).find("saturated frame"),
            std::string::npos);
  EXPECT_NE(checkExposure(cv::Mat(kSize, CV_8UC1, cv::Scalar(128)), 2.0, 0.9).find("blank frame"),
            std::string::npos);
  // The thresholds are the caller's: a dim but textured frame passes a low one and fails a high one.
  cv::Mat dim;
  texture.convertTo(dim, CV_8U, 0.05);
  cv::Scalar mean, stddev;
  cv::meanStdDev(dim, mean, stddev);
  EXPECT_EQ(checkExposure(dim, 0.5 * stddev[0], 0.9), "");
  EXPECT_NE(checkExposure(dim, 2.0 * stddev[0], 0.9), "");
  // 95 % of the pixels at 255: saturated at 0.9, not at 0.99.
  cv::Mat bright(kSize, CV_8UC1, cv::Scalar(255));
  texture(cv::Rect(0, 0, kSize.width / 20, kSize.height))
      .copyTo(bright(cv::Rect(0, 0, kSize.width / 20, kSize.height)));
  EXPECT_NE(checkExposure(bright, 2.0, 0.9), "");
  EXPECT_EQ(checkExposure(bright, 2.0, 0.99), "");
  EXPECT_THROW(checkExposure(cv::Mat(), 2.0, 0.9), std::invalid_argument);
}

TEST(ExposureCompensator, AStepIsScaledBackAndSlowChangesPassUntouched) {
  const cv::Mat image = test::texture(kSize, 3);
  ExposureCompensator compensator(1.2);
  cv::Mat buffer;
  EXPECT_EQ(compensator.apply(image, &buffer).data, image.data) << "no step: the image itself";
  // A slow change (5 % per frame) is left to the tracker.
  cv::Mat slightly;
  image.convertTo(slightly, CV_8U, 0.95);
  EXPECT_EQ(compensator.apply(slightly, &buffer).data, slightly.data);
  EXPECT_EQ(compensator.gain(), 1.0);
  // A 0.3x exposure step: scaled back to the brightness before it, to within the 8-bit rounding.
  cv::Mat dark;
  slightly.convertTo(dark, CV_8U, 0.3);
  const cv::Mat& restored = compensator.apply(dark, &buffer);
  EXPECT_NEAR(compensator.gain(), 1.0 / 0.3, 0.1);
  EXPECT_LT(std::abs(cv::mean(restored)[0] - cv::mean(slightly)[0]), 1.0);
  cv::Mat diff;
  cv::absdiff(restored, slightly, diff);
  EXPECT_LT(cv::mean(diff)[0], 2.0) << "the dark image scaled back is the bright one but for quantisation";
  // The gain stays while the exposure stays low ...
  compensator.apply(dark, &buffer);
  EXPECT_NEAR(compensator.gain(), 1.0 / 0.3, 0.1);
  // ... and goes back to 1 (untouched images) when it returns.
  EXPECT_EQ(compensator.apply(slightly, &buffer).data, slightly.data);
  EXPECT_EQ(compensator.gain(), 1.0);
  // Off: never scaled; reset() forgets the gain.
  ExposureCompensator off(0.0);
  off.apply(image, &buffer);
  EXPECT_EQ(off.apply(dark, &buffer).data, dark.data);
  compensator.apply(dark, &buffer);
  compensator.reset();
  EXPECT_EQ(compensator.gain(), 1.0);
}

}  // namespace
}  // namespace planetary_vo

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
