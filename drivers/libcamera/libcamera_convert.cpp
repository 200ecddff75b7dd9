// Conversion of libcamera buffers to the gray or BGR cv::Mat every mocap Frame carries: stride-aware
// views over the mapped planes and one OpenCV conversion, MJPEG by cv::imdecode.
#include "drivers/libcamera/libcamera_convert.h"

#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace mocap {
namespace {

struct FormatEntry {
  uint32_t fourcc;
  const char* name;
};

const FormatEntry kFormats[] = {
    {lcfourcc::kR8, "R8"},         {lcfourcc::kYUYV, "YUYV"},     {lcfourcc::kNV12, "NV12"},
    {lcfourcc::kRGB888, "RGB888"}, {lcfourcc::kBGR888, "BGR888"}, {lcfourcc::kMJPEG, "MJPEG"},
};

const FormatEntry* findFormat(uint32_t fourcc) {
  for (const FormatEntry& entry : kFormats) {
    if (entry.fourcc == fourcc) return &entry;
  }
  return nullptr;
}

// True when `plane` holds `rows` rows of `row_bytes` spaced `stride` apart (the last row needs no
// padding after it).
bool holdsRows(std::span<const uint8_t> plane, size_t rows, size_t row_bytes, size_t stride) {
  return rows > 0 && stride >= row_bytes && plane.size() >= stride * (rows - 1) + row_bytes;
}

// cv::Mat does not write through these headers; the const_cast only fits OpenCV's constructor.
cv::Mat view(std::span<const uint8_t> plane, int rows, int cols, int type, size_t stride) {
  return cv::Mat(rows, cols, type, const_cast<uint8_t*>(plane.data()), stride);
}

cv::Mat convertRaw(const LibcameraImageView& image, LibcameraImageOutput output) {
  const auto width = static_cast<size_t>(image.width);
  const auto height = static_cast<size_t>(image.height);
  const bool gray = output == LibcameraImageOutput::kGray;
  cv::Mat result;
  switch (image.fourcc) {
    case lcfourcc::kR8:
      if (!holdsRows(image.planes[0], height, width, image.stride)) return {};
      return view(image.planes[0], image.height, image.width, CV_8UC1, image.stride).clone();
    case lcfourcc::kYUYV:
      if (width % 2 != 0 || !holdsRows(image.planes[0], height, width * 2, image.stride)) return {};
      cv::cvtColor(view(image.planes[0], image.height, image.width, CV_8UC2, image.stride), result,
                   gray ? cv::COLOR_YUV2GRAY_YUYV : cv::COLOR_YUV2BGR_YUYV);
      return result;
    case lcfourcc::kNV12: {
      if (width % 2 != 0 || height % 2 != 0) return {};
      std::span<const uint8_t> y = image.planes[0];
      std::span<const uint8_t> uv;
      if (image.planes.size() >= 2) {
        uv = image.planes[1];
      } else if (y.size() > image.stride * height) {
        uv = y.subspan(image.stride * height);
      }
      if (!holdsRows(y, height, width, image.stride) ||
          !holdsRows(uv, height / 2, width, image.stride)) {
        return {};
      }
      const cv::Mat y_view = view(y, image.height, image.width, CV_8UC1, image.stride);
      if (gray) return y_view.clone();
      cv::cvtColorTwoPlane(y_view, view(uv, image.height / 2, image.width / 2, CV_8UC2, image.stride),
                           result, cv::COLOR_YUV2BGR_NV12);
      return result;
    }
    case lcfourcc::kRGB888:
    case lcfourcc::kBGR888: {
      if (!holdsRows(image.planes[0], height, width * 3, image.stride)) return {};
      const cv::Mat pixels = view(image.planes[0], image.height, image.width, CV_8UC3, image.stride);
      const bool bgr_in_memory = image.fourcc == lcfourcc::kRGB888;
      if (gray) {
        cv::cvtColor(pixels, result, bgr_in_memory ? cv::COLOR_BGR2GRAY : cv::COLOR_RGB2GRAY);
      } else if (bgr_in_memory) {
        result = pixels.clone();
      } else {
        cv::cvtColor(pixels, result, cv::COLOR_RGB2BGR);
      }
      return result;
    }
    default:
      return {};
  }
}

}  // namespace

const std::vector<uint32_t>& convertibleLibcameraFormats() {
  static const std::vector<uint32_t> codes = [] {
    std::vector<uint32_t> all;
    for (const FormatEntry& entry : kFormats) all.push_back(entry.fourcc);
    return all;
  }();
  return codes;
}

bool isConvertibleLibcameraFormat(uint32_t fourcc) { return findFormat(fourcc); }

std::string libcameraFormatName(uint32_t fourcc) {
  if (const FormatEntry* entry = findFormat(fourcc)) return entry->name;
  char hex[16];
  std::snprintf(hex, sizeof hex, "0x%08x", fourcc);
  return hex;
}

std::optional<uint32_t> libcameraFormatFromName(const std::string& name) {
  if (name == "GREY" || name == "Y8") return lcfourcc::kR8;
  if (name == "MJPG") return lcfourcc::kMJPEG;
  for (const FormatEntry& entry : kFormats) {
    if (name == entry.name) return entry.fourcc;
  }
  return std::nullopt;
}

std::string convertibleLibcameraFormatList() {
  std::string list;
  for (const FormatEntry& entry : kFormats) list += (list.empty() ? "" : ", ") + std::string(entry.name);
  return list;
}

cv::Mat convertLibcameraImage(const LibcameraImageView& image, LibcameraImageOutput output) {
  if (!findFormat(image.fourcc) || image.width <= 0 || image.height <= 0 || image.planes.empty() ||
      !image.planes[0].data()) {
    return {};
  }
  if (image.fourcc != lcfourcc::kMJPEG) return convertRaw(image, output);
  try {
    const cv::Mat encoded(1, static_cast<int>(image.planes[0].size()), CV_8UC1,
                          const_cast<uint8_t*>(image.planes[0].data()));
    cv::Mat decoded = cv::imdecode(
        encoded, output == LibcameraImageOutput::kGray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
    if (decoded.cols != image.width || decoded.rows != image.height) return {};
    return decoded;
  } catch (const cv::Exception&) {
    // A damaged JPEG can make the decoder throw; it counts as a frame without an image.
    return {};
  }
}

}  // namespace mocap
