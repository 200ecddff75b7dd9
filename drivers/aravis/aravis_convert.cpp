// Conversion of Aravis image payloads to the gray or BGR cv::Mat every mocap Frame carries.
#include "drivers/aravis/aravis_convert.h"

#include <cstdio>

#include <opencv2/imgproc.hpp>

namespace mocap {
namespace {

struct FormatEntry {
  uint32_t code;
  const char* name;
  int channels;        // bytes per pixel in the payload
  int bgr_conversion;  // cv::cvtColor code to BGR, or -1 to copy as is
};

// OpenCV names a Bayer pattern after the second row's second and third pixels, GenICam after the
// first row's first two, so each GenICam pattern maps to OpenCV's "opposite" name.
const FormatEntry kFormats[] = {
    {pfnc::kMono8, "Mono8", 1, -1},
    {pfnc::kBayerRG8, "BayerRG8", 1, cv::COLOR_BayerBG2BGR},
    {pfnc::kBayerGR8, "BayerGR8", 1, cv::COLOR_BayerGB2BGR},
    {pfnc::kBayerBG8, "BayerBG8", 1, cv::COLOR_BayerRG2BGR},
    {pfnc::kBayerGB8, "BayerGB8", 1, cv::COLOR_BayerGR2BGR},
    {pfnc::kRGB8, "RGB8", 3, cv::COLOR_RGB2BGR},
    {pfnc::kBGR8, "BGR8", 3, -1},
};

const FormatEntry* findFormat(uint32_t code) {
  for (const FormatEntry& entry : kFormats) {
    if (entry.code == code) return &entry;
  }
  return nullptr;
}

}  // namespace

const std::vector<uint32_t>& convertibleArvPixelFormats() {
  static const std::vector<uint32_t> codes = [] {
    std::vector<uint32_t> all;
    for (const FormatEntry& entry : kFormats) all.push_back(entry.code);
    return all;
  }();
  return codes;
}

bool isConvertibleArvPixelFormat(uint32_t pixel_format) { return findFormat(pixel_format); }

std::string arvPixelFormatName(uint32_t pixel_format) {
  if (const FormatEntry* entry = findFormat(pixel_format)) return entry->name;
  char hex[16];
  std::snprintf(hex, sizeof hex, "0x%08x", pixel_format);
  return hex;
}

std::string convertibleArvPixelFormatList() {
  std::string list;
  for (const FormatEntry& entry : kFormats) list += (list.empty() ? "" : ", ") + std::string(entry.name);
  return list;
}

cv::Mat convertArvImage(const ArvImageView& image) {
  const FormatEntry* format = findFormat(image.pixel_format);
  if (!format || image.width <= 0 || image.height <= 0 || !image.data) return {};
  const size_t row_bytes = static_cast<size_t>(image.width) * format->channels;
  const size_t stride = row_bytes + image.line_padding;
  // The last row needs no padding after it.
  if (image.size < stride * (image.height - 1) + row_bytes) return {};
  // cv::Mat does not write through this header; the const_cast only fits OpenCV's constructor.
  const cv::Mat payload(image.height, image.width, format->channels == 1 ? CV_8UC1 : CV_8UC3,
                        const_cast<uint8_t*>(image.data), stride);
  if (format->bgr_conversion < 0) return payload.clone();
  cv::Mat bgr;
  cv::cvtColor(payload, bgr, format->bgr_conversion);
  return bgr;
}

}  // namespace mocap
