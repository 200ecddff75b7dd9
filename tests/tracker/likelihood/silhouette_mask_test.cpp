// Prefix-summed masks count exactly what a brute-force count finds.
#include "tracker/likelihood/silhouette_mask.h"

#include <gtest/gtest.h>

#include <random>

#include <opencv2/core.hpp>

namespace mocap {
namespace {

TEST(SilhouetteMask, CountsMatchBruteForce) {
  cv::Mat image(37, 53, CV_8UC1);
  cv::randu(image, 0, 2);
  image *= 200;
  const SilhouetteMask mask(image);
  std::mt19937 rng(3);
  for (int trial = 0; trial < 2000; ++trial) {
    const int y = std::uniform_int_distribution<int>(0, 36)(rng);
    int a = std::uniform_int_distribution<int>(0, 53)(rng);
    int b = std::uniform_int_distribution<int>(0, 53)(rng);
    if (a > b) std::swap(a, b);
    int expected = 0;
    for (int x = a; x < b; ++x) expected += image.at<uint8_t>(y, x) != 0;
    ASSERT_EQ(mask.count(y, a, b), expected);
  }
  EXPECT_EQ(mask.total(), cv::countNonZero(image));
  EXPECT_EQ(cv::countNonZero(mask.toMat() != (image != 0)), 0);
}

TEST(SilhouetteMask, RejectsNonBinaryImageTypes) {
  EXPECT_THROW(SilhouetteMask(cv::Mat(4, 4, CV_8UC3)), std::invalid_argument);
  EXPECT_THROW(SilhouetteMask(cv::Mat(4, 4, CV_32F)), std::invalid_argument);
}

TEST(SilhouetteMask, WordBoundariesAndFullRows) {
  cv::Mat image = cv::Mat::zeros(2, 130, CV_8UC1);
  image.row(1) = 255;
  image.at<uint8_t>(0, 63) = image.at<uint8_t>(0, 64) = image.at<uint8_t>(0, 129) = 1;
  const SilhouetteMask mask(image);
  EXPECT_EQ(mask.count(0, 0, 130), 3);
  EXPECT_EQ(mask.count(0, 63, 65), 2);
  EXPECT_EQ(mask.count(0, 64, 64), 0);
  EXPECT_EQ(mask.count(0, 65, 129), 0);
  EXPECT_EQ(mask.count(1, 0, 130), 130);
  EXPECT_EQ(mask.count(1, 1, 128), 127);
}

TEST(SilhouetteMask, RoundTripsImagesOfAnyWidth) {
  // Widths around the 16-pixel steps and 64-pixel words of the packing, any non-zero value on.
  std::mt19937 rng(9);
  for (int width : {1, 15, 16, 17, 63, 64, 65, 127, 128, 129, 780, 781}) {
    cv::Mat image(5, width, CV_8UC1);
    cv::randu(image, 0, 4);  // 0 off; 1, 2, 3 on
    const SilhouetteMask mask(image);
    ASSERT_EQ(cv::countNonZero(mask.toMat() != (image != 0)), 0) << "width " << width;
    ASSERT_EQ(mask.total(), cv::countNonZero(image)) << "width " << width;
    // A region across the word boundaries.
    const cv::Rect roi(width / 3, 1, width - width / 3 - width / 5, 3);
    ASSERT_EQ(cv::countNonZero(mask.toMat(roi) != (image(roi) != 0)), 0) << "width " << width;
    for (int trial = 0; trial < 200; ++trial) {
      const int y = std::uniform_int_distribution<int>(0, 4)(rng);
      int a = std::uniform_int_distribution<int>(0, width)(rng);
      int b = std::uniform_int_distribution<int>(0, width)(rng);
      if (a > b) std::swap(a, b);
      const SilhouetteMask::Row row = mask.row(y);
      ASSERT_EQ(row.count(a, b), cv::countNonZero(image.row(y).colRange(a, b)))
          << "width " << width;
      ASSERT_EQ(row.before(b) - row.before(a), mask.count(y, a, b));
    }
  }
  EXPECT_THROW(SilhouetteMask(cv::Mat::zeros(4, 8, CV_8UC1)).toMat(cv::Rect(4, 0, 5, 4)),
               std::invalid_argument);
}

}  // namespace
}  // namespace mocap
