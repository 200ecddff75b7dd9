// Pixel formats the Aravis driver turns into mocap images (8-bit gray or BGR), by their GenICam
// PFNC codes, which are the values of Aravis' ArvPixelFormat. Free of Aravis headers so it can be
// tested alone.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace mocap {

namespace pfnc {
inline constexpr uint32_t kMono8 = 0x01080001;
inline constexpr uint32_t kBayerGR8 = 0x01080008;
inline constexpr uint32_t kBayerRG8 = 0x01080009;
inline constexpr uint32_t kBayerGB8 = 0x0108000a;
inline constexpr uint32_t kBayerBG8 = 0x0108000b;
inline constexpr uint32_t kRGB8 = 0x02180014;
inline constexpr uint32_t kBGR8 = 0x02180015;
}  // namespace pfnc

// In order of preference when neither the config nor the camera's current setting decides.
const std::vector<uint32_t>& convertibleArvPixelFormats();
bool isConvertibleArvPixelFormat(uint32_t pixel_format);
// The PFNC name ("BayerRG8"), or the code in hex for a format this driver does not know.
std::string arvPixelFormatName(uint32_t pixel_format);
// "Mono8, BayerRG8, ..." for error messages.
std::string convertibleArvPixelFormatList();

// One image payload as Aravis delivers it: rows of pixels, each followed by `line_padding` bytes.
struct ArvImageView {
  uint32_t pixel_format = 0;
  int width = 0;
  int height = 0;
  size_t line_padding = 0;
  const uint8_t* data = nullptr;
  size_t size = 0;
};

// Mono8 → CV_8UC1; RGB8, BGR8 and the four 8-bit Bayer patterns → CV_8UC3 BGR. The result owns
// its pixels. Empty when the format is not convertible or the payload is shorter than the
// geometry says.
cv::Mat convertArvImage(const ArvImageView& image);

}  // namespace mocap
