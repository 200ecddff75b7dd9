// Pixel conversion of V4L2 payloads: YUYV and GREY by stride-aware views, MJPEG by cv::imdecode.
#include "drivers/v4l2/v4l2_convert.h"

#include <algorithm>
#include <cstring>
#include <exception>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace mocap {
namespace {

// A raw image as the device laid it out; a short payload is zero-filled and flagged.
ConvertedPayload rawView(const NegotiatedFormat& format, std::span<const uint8_t> payload,
                         int mat_type, size_t bytes_per_pixel, std::vector<uint8_t>& padded) {
  const size_t stride = std::max<size_t>(format.bytesperline, format.width * bytes_per_pixel);
  const size_t needed = stride * format.height;
  ConvertedPayload result;
  const uint8_t* pixels = payload.data();
  if (payload.size() < needed) {
    padded.assign(needed, 0);
    std::copy(payload.begin(), payload.end(), padded.begin());
    pixels = padded.data();
    result.incomplete = true;
  }
  result.image = cv::Mat(static_cast<int>(format.height), static_cast<int>(format.width), mat_type,
                         const_cast<uint8_t*>(pixels), stride);
  return result;
}

// libjpeg decodes a truncated stream with a grey tail and only a warning, so look for the end
// marker (cameras may pad after it) to tell a whole frame from a damaged one.
bool hasJpegEndMarker(std::span<const uint8_t> payload) {
  constexpr size_t kSearchWindow = 4096;
  const size_t start = payload.size() > kSearchWindow ? payload.size() - kSearchWindow : 0;
  for (size_t i = payload.size(); i >= start + 2; --i) {
    if (payload[i - 2] == 0xFF && payload[i - 1] == 0xD9) return true;
  }
  return false;
}

ConvertedPayload decodeMjpeg(const NegotiatedFormat& format, std::span<const uint8_t> payload,
                             V4l2ImageOutput output) {
  ConvertedPayload result;
  if (payload.size() < 4 || payload[0] != 0xFF || payload[1] != 0xD8) return result;
  const cv::Mat encoded(1, static_cast<int>(payload.size()), CV_8UC1,
                        const_cast<uint8_t*>(payload.data()));
  const int flags = output == V4l2ImageOutput::kGray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR;
  try {
    result.image = cv::imdecode(encoded, flags);
  } catch (const std::exception&) {
    result.image.release();  // No exception leaves the frame path.
  }
  // A frame of another size would break every consumer that trusts the negotiated mode.
  if (result.image.cols != static_cast<int>(format.width) ||
      result.image.rows != static_cast<int>(format.height)) {
    result.image.release();
    return result;
  }
  result.incomplete = !hasJpegEndMarker(payload);
  return result;
}

}  // namespace

ConvertedPayload convertPayload(const NegotiatedFormat& format, std::span<const uint8_t> payload,
                                V4l2ImageOutput output) {
  std::vector<uint8_t> padded;
  try {
    switch (format.pixelformat) {
      case V4L2_PIX_FMT_GREY: {
        ConvertedPayload result = rawView(format, payload, CV_8UC1, 1, padded);
        result.image = result.image.clone();
        return result;
      }
      case V4L2_PIX_FMT_YUYV: {
        ConvertedPayload result = rawView(format, payload, CV_8UC2, 2, padded);
        cv::Mat converted;
        cv::cvtColor(
            result.image, converted,
            output == V4l2ImageOutput::kGray ? cv::COLOR_YUV2GRAY_YUYV : cv::COLOR_YUV2BGR_YUYV);
        result.image = converted;
        return result;
      }
      case V4L2_PIX_FMT_MJPEG:
        return decodeMjpeg(format, payload, output);
      default:
        return {};
    }
  } catch (const std::exception&) {
    return {};
  }
}

}  // namespace mocap
