// ros_io::runContained: the catch of every callback of the VO and hazard nodelets and aligned_path_node. Each
// case throws what a callback body can meet (an OpenCV assertion, an allocation failure, a thrown int or
// string from a library, a type of its own) and checks that nothing escapes and that the reason names the
// cause.
#include <gtest/gtest.h>

#include <new>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>

#include "planetary_vo/ros_io/containment.h"

namespace planetary_vo::ros_io {
namespace {

struct NotAnException {
  int code = 7;
};

TEST(Containment, ANormalReturnGivesNoReason) {
  int calls = 0;
  EXPECT_FALSE(runContained([&] { ++calls; }).has_value());
  EXPECT_EQ(calls, 1);
}

TEST(Containment, StandardExceptionsAreDescribedByTheirWhat) {
  const auto why = runContained([] { throw std::runtime_error("optimiser diverged"); });
  ASSERT_TRUE(why.has_value());
  EXPECT_EQ(*why, "optimiser diverged");

  const auto alloc = runContained([] { throw std::bad_alloc(); });
  ASSERT_TRUE(alloc.has_value());
  EXPECT_FALSE(alloc->empty());
}

TEST(Containment, AnOpenCvAssertionIsContainedWithItsMessage) {
  // The crash of issue 12: cv::undistortPoints' assertion on a D of 3 coefficients left imageCb.
  const auto why = runContained([] {
    cv::Mat bad_size(2, 2, CV_8UC3);
    cv::Mat sum;
    cv::add(bad_size, cv::Mat(3, 3, CV_8UC1), sum);  // sizes and types differ: cv::Exception
  });
  ASSERT_TRUE(why.has_value());
  EXPECT_NE(why->find("OpenCV"), std::string::npos) << *why;
}

TEST(Containment, ExceptionsNotDerivedFromStdExceptionAreContainedAndNamedSo) {
  // What the `catch (...)` of the callbacks exists for: a library throwing an int, a C string, an std::string
  // or a type of its own. Without it std::terminate would end the nodelet manager (and this test).
  const std::string expected = "unknown exception (not derived from std::exception)";
  const auto from_int = runContained([] { throw 42; });
  const auto from_c_string = runContained([] { throw "raw string"; });
  const auto from_string = runContained([] { throw std::string("a string"); });
  const auto from_struct = runContained([] { throw NotAnException(); });
  for (const auto& why : {from_int, from_c_string, from_string, from_struct}) {
    ASSERT_TRUE(why.has_value());
    EXPECT_EQ(*why, expected);
  }
}

TEST(Containment, ANestedRethrowFromACatchBlockIsContainedToo) {
  // A body whose own handler rethrows (as the VO nodelet's processImage does after logging).
  const auto why = runContained([] {
    try {
      throw std::invalid_argument("camera_info intrinsics are not finite");
    } catch (...) {
      throw;
    }
  });
  ASSERT_TRUE(why.has_value());
  EXPECT_EQ(*why, "camera_info intrinsics are not finite");
}

TEST(Containment, DescribeExceptionNeverThrows) {
  static_assert(noexcept(describeException(std::exception_ptr())), "describeException must be noexcept");
  EXPECT_EQ(describeException(std::make_exception_ptr(std::logic_error("x"))), "x");
  EXPECT_EQ(describeException(std::make_exception_ptr(3.5)),
            "unknown exception (not derived from std::exception)");
}

}  // namespace
}  // namespace planetary_vo::ros_io
