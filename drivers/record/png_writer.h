// A PNG encoder for recorded frames: standard PNG (8-bit gray or RGB), rows stored unfiltered and
// deflated with zlib's run-length strategy. libpng's per-row filter search costs ~25 ms on a noisy
// 780x580 colour frame, too slow for two cameras at 25 Hz; without it a frame takes a few ms.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace mocap {

// Encodes `image` (CV_8UC1 gray, or CV_8UC3 BGR, stored as RGB) into `out`. `level` is zlib's
// compression level (0-9). Returns false for another image type or a zlib failure.
bool encodePng(const cv::Mat& image, int level, std::vector<uint8_t>& out);

}  // namespace mocap
