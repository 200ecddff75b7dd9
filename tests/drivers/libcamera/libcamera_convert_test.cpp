// Tests of the libcamera driver's camera-free parts: conversion of YUYV, NV12, R8, RGB888/BGR888
// and MJPEG buffers to BGR/gray against known pixel values, the format names and FourCCs (checked
// against libcamera's own definitions), and sensor-sequence gap counting.
#include <gtest/gtest.h>

#include <cstdlib>
#include <vector>

#include <libcamera/formats.h>
#include <opencv2/imgcodecs.hpp>

#include "drivers/libcamera/libcamera_camera.h"
#include "drivers/libcamera/libcamera_convert.h"

namespace mocap {
namespace {

using Bytes = std::vector<uint8_t>;
constexpr auto kBgr = LibcameraImageOutput::kAsCaptured;
constexpr auto kGray = LibcameraImageOutput::kGray;

// YUV (BT.601, video range, as OpenCV converts it) of pure red, white, black and mid gray.
constexpr uint8_t kRedY = 82, kRedU = 90, kRedV = 240;

void expectBgr(const cv::Mat& image, int row, int col, int b, int g, int r, int tolerance = 2) {
  ASSERT_EQ(image.type(), CV_8UC3);
  const cv::Vec3b pixel = image.at<cv::Vec3b>(row, col);
  EXPECT_NEAR(pixel[0], b, tolerance) << "blue at " << row << "," << col;
  EXPECT_NEAR(pixel[1], g, tolerance) << "green at " << row << "," << col;
  EXPECT_NEAR(pixel[2], r, tolerance) << "red at " << row << "," << col;
}

LibcameraImageView viewOf(uint32_t fourcc, int width, int height, size_t stride,
                          std::vector<const Bytes*> planes) {
  LibcameraImageView image{fourcc, width, height, stride, {}};
  for (const Bytes* plane : planes) image.planes.emplace_back(plane->data(), plane->size());
  return image;
}

TEST(LibcameraFormats, FourccsMatchLibcamera) {
  EXPECT_EQ(lcfourcc::kYUYV, libcamera::formats::YUYV.fourcc());
  EXPECT_EQ(lcfourcc::kNV12, libcamera::formats::NV12.fourcc());
  EXPECT_EQ(lcfourcc::kR8, libcamera::formats::R8.fourcc());
  EXPECT_EQ(lcfourcc::kRGB888, libcamera::formats::RGB888.fourcc());
  EXPECT_EQ(lcfourcc::kBGR888, libcamera::formats::BGR888.fourcc());
  EXPECT_EQ(lcfourcc::kMJPEG, libcamera::formats::MJPEG.fourcc());
  for (uint32_t fourcc : convertibleLibcameraFormats()) {
    EXPECT_EQ(libcameraFormatName(fourcc), libcamera::PixelFormat(fourcc).toString());
  }
}

TEST(LibcameraFormats, NamesAndAliases) {
  EXPECT_EQ(libcameraFormatFromName("YUYV"), lcfourcc::kYUYV);
  EXPECT_EQ(libcameraFormatFromName("GREY"), lcfourcc::kR8);
  EXPECT_EQ(libcameraFormatFromName("Y8"), lcfourcc::kR8);
  EXPECT_EQ(libcameraFormatFromName("MJPG"), lcfourcc::kMJPEG);
  EXPECT_EQ(libcameraFormatFromName("SBGGR10"), std::nullopt);
  EXPECT_FALSE(isConvertibleLibcameraFormat(libcamera::formats::SBGGR8.fourcc()));
  EXPECT_EQ(libcameraFormatName(libcamera::formats::SBGGR8.fourcc()), "0x31384142");
  EXPECT_EQ(convertibleLibcameraFormatList(), "R8, YUYV, NV12, RGB888, BGR888, MJPEG");
}

TEST(LibcameraConvert, R8WithStridePadding) {
  const Bytes plane = {10, 20, 99, 99, 30, 40};  // 2x2, stride 4
  const cv::Mat gray = convertLibcameraImage(viewOf(lcfourcc::kR8, 2, 2, 4, {&plane}), kBgr);
  ASSERT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.at<uint8_t>(0, 0), 10);
  EXPECT_EQ(gray.at<uint8_t>(0, 1), 20);
  EXPECT_EQ(gray.at<uint8_t>(1, 0), 30);
  EXPECT_EQ(gray.at<uint8_t>(1, 1), 40);
}

TEST(LibcameraConvert, YuyvToBgrAndGray) {
  // Row 0: red, red; row 1: black, white. Stride 10 (2 bytes of padding per row).
  const Bytes plane = {kRedY, kRedU, kRedY, kRedV, 0, 0, 0, 0, 0, 0,  //
                       16,    128,   235,   128,   0, 0, 0, 0, 0, 0};
  const LibcameraImageView image = viewOf(lcfourcc::kYUYV, 2, 2, 10, {&plane});
  const cv::Mat bgr = convertLibcameraImage(image, kBgr);
  ASSERT_EQ(bgr.size(), cv::Size(2, 2));
  expectBgr(bgr, 0, 0, 0, 0, 255);
  expectBgr(bgr, 0, 1, 0, 0, 255);
  expectBgr(bgr, 1, 0, 0, 0, 0);
  expectBgr(bgr, 1, 1, 255, 255, 255);
  const cv::Mat gray = convertLibcameraImage(image, kGray);
  ASSERT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.at<uint8_t>(0, 0), kRedY);
  EXPECT_EQ(gray.at<uint8_t>(1, 0), 16);
  EXPECT_EQ(gray.at<uint8_t>(1, 1), 235);
}

TEST(LibcameraConvert, Nv12TwoPlanesAndOnePlane) {
  // 4x2: left 2x2 block red, right 2x2 block mid gray (Y 126 → 128). Stride 6.
  const Bytes y = {kRedY, kRedY, 126, 126, 0, 0,  //
                   kRedY, kRedY, 126, 126};
  const Bytes uv = {kRedU, kRedV, 128, 128};
  const Bytes both = {kRedY, kRedY, 126, 126, 0, 0,  //
                      kRedY, kRedY, 126, 126, 0, 0,  //
                      kRedU, kRedV, 128, 128};
  for (const LibcameraImageView& image :
       {viewOf(lcfourcc::kNV12, 4, 2, 6, {&y, &uv}), viewOf(lcfourcc::kNV12, 4, 2, 6, {&both})}) {
    const cv::Mat bgr = convertLibcameraImage(image, kBgr);
    ASSERT_EQ(bgr.size(), cv::Size(4, 2));
    for (int row = 0; row < 2; ++row) {
      expectBgr(bgr, row, 0, 0, 0, 255);
      expectBgr(bgr, row, 1, 0, 0, 255);
      expectBgr(bgr, row, 2, 128, 128, 128);
      expectBgr(bgr, row, 3, 128, 128, 128);
    }
    const cv::Mat gray = convertLibcameraImage(image, kGray);
    ASSERT_EQ(gray.type(), CV_8UC1);
    EXPECT_EQ(gray.at<uint8_t>(1, 0), kRedY);
    EXPECT_EQ(gray.at<uint8_t>(1, 3), 126);
  }
}

TEST(LibcameraConvert, Rgb888IsBgrInMemoryAndBgr888IsRgb) {
  const Bytes rgb888 = {10, 20, 30, 0};  // 1x1: B, G, R, then padding
  const Bytes bgr888 = {30, 20, 10, 0};  // 1x1: R, G, B, then padding
  expectBgr(convertLibcameraImage(viewOf(lcfourcc::kRGB888, 1, 1, 4, {&rgb888}), kBgr), 0, 0, 10, 20,
            30, 0);
  expectBgr(convertLibcameraImage(viewOf(lcfourcc::kBGR888, 1, 1, 4, {&bgr888}), kBgr), 0, 0, 10, 20,
            30, 0);
  // 0.114 B + 0.587 G + 0.299 R = 21.85
  const cv::Mat gray = convertLibcameraImage(viewOf(lcfourcc::kBGR888, 1, 1, 4, {&bgr888}), kGray);
  ASSERT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.at<uint8_t>(0, 0), 22);
}

TEST(LibcameraConvert, MjpegDecodesAndRejectsGarbage) {
  const cv::Mat source(8, 16, CV_8UC3, cv::Scalar(200, 100, 50));
  Bytes jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", source, jpeg));
  const cv::Mat bgr = convertLibcameraImage(viewOf(lcfourcc::kMJPEG, 16, 8, 0, {&jpeg}), kBgr);
  ASSERT_EQ(bgr.size(), cv::Size(16, 8));
  expectBgr(bgr, 4, 8, 200, 100, 50, 6);
  EXPECT_EQ(convertLibcameraImage(viewOf(lcfourcc::kMJPEG, 16, 8, 0, {&jpeg}), kGray).type(), CV_8UC1);
  // A JPEG of another size than configured is not this stream's frame.
  EXPECT_TRUE(convertLibcameraImage(viewOf(lcfourcc::kMJPEG, 32, 8, 0, {&jpeg}), kBgr).empty());
  const Bytes garbage(64, 0x5a);
  EXPECT_TRUE(convertLibcameraImage(viewOf(lcfourcc::kMJPEG, 16, 8, 0, {&garbage}), kBgr).empty());
}

TEST(LibcameraConvert, RefusesShortOrImpossibleBuffers) {
  const Bytes short_plane(5, 0);  // 2x2 at stride 4 needs 4 + 2 bytes
  EXPECT_TRUE(convertLibcameraImage(viewOf(lcfourcc::kR8, 2, 2, 4, {&short_plane}), kBgr).empty());
  const Bytes yuyv(12, 128);
  EXPECT_TRUE(convertLibcameraImage(viewOf(lcfourcc::kYUYV, 3, 2, 6, {&yuyv}), kBgr).empty())
      << "odd width";
  EXPECT_TRUE(convertLibcameraImage(viewOf(lcfourcc::kYUYV, 2, 2, 2, {&yuyv}), kBgr).empty())
      << "stride shorter than a row";
  const Bytes y_only(8, 16);
  EXPECT_TRUE(convertLibcameraImage(viewOf(lcfourcc::kNV12, 4, 2, 4, {&y_only}), kBgr).empty())
      << "NV12 without its UV plane";
  EXPECT_TRUE(
      convertLibcameraImage(viewOf(libcamera::formats::SBGGR8.fourcc(), 2, 2, 2, {&yuyv}), kBgr).empty());
  EXPECT_TRUE(convertLibcameraImage(viewOf(lcfourcc::kR8, 2, 2, 2, {}), kBgr).empty());
}

TEST(LibcameraSequence, GapsCountLostFrames) {
  EXPECT_EQ(libcameraFramesLost(5, 6), 0u);
  EXPECT_EQ(libcameraFramesLost(5, 8), 2u);
  EXPECT_EQ(libcameraFramesLost(0xffffffffu, 1), 1u) << "wrap-around";
  EXPECT_EQ(libcameraFramesLost(10, 3), 0u) << "sensor restarted";
  EXPECT_EQ(libcameraFramesLost(7, 7), 0u) << "repeated";
}

}  // namespace
}  // namespace mocap
