// The unfiltered PNG encoder: what libpng (through OpenCV) decodes is exactly what was encoded.
#include "drivers/record/png_writer.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace mocap {
namespace {

void expectRoundTrip(const cv::Mat& image, int level) {
  std::vector<uint8_t> png;
  ASSERT_TRUE(encodePng(image, level, png));
  const cv::Mat decoded = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  ASSERT_EQ(decoded.type(), image.type());
  ASSERT_EQ(decoded.size(), image.size());
  EXPECT_EQ(cv::norm(decoded, image, cv::NORM_INF), 0.0);
}

TEST(PngWriter, GrayAndColourDecodeToTheSamePixels) {
  cv::RNG rng(4);
  cv::Mat gray(58, 78, CV_8UC1), bgr(58, 78, CV_8UC3);
  rng.fill(gray, cv::RNG::UNIFORM, 0, 256);
  rng.fill(bgr, cv::RNG::UNIFORM, 0, 256);
  for (int level : {0, 1, 9}) {
    expectRoundTrip(gray, level);
    expectRoundTrip(bgr, level);  // stored as RGB, decoded back to BGR
  }
  expectRoundTrip(cv::Mat(580, 780, CV_8UC3, cv::Scalar(10, 20, 30)), 1);
}

TEST(PngWriter, RefusesOtherImageTypes) {
  std::vector<uint8_t> png;
  EXPECT_FALSE(encodePng(cv::Mat(4, 4, CV_16UC1), 1, png));
  EXPECT_FALSE(encodePng(cv::Mat(4, 4, CV_8UC4), 1, png));
  EXPECT_FALSE(encodePng(cv::Mat(), 1, png));
}

}  // namespace
}  // namespace mocap
