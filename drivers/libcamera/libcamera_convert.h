// Pixel formats the libcamera driver turns into mocap images (8-bit gray or BGR), by their
// libcamera FourCC codes (libcamera::PixelFormat::fourcc(), which are DRM FourCCs). Free of
// libcamera headers so it can be tested without libcamera or a camera.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace mocap {

namespace lcfourcc {
constexpr uint32_t make(char a, char b, char c, char d) {
  return static_cast<uint32_t>(a) | static_cast<uint32_t>(b) << 8 | static_cast<uint32_t>(c) << 16 |
         static_cast<uint32_t>(d) << 24;
}
inline constexpr uint32_t kYUYV = make('Y', 'U', 'Y', 'V');
inline constexpr uint32_t kNV12 = make('N', 'V', '1', '2');
inline constexpr uint32_t kR8 = make('R', '8', ' ', ' ');
// DRM naming: RGB888 is B, G, R in memory (OpenCV's BGR); BGR888 is R, G, B in memory.
inline constexpr uint32_t kRGB888 = make('R', 'G', '2', '4');
inline constexpr uint32_t kBGR888 = make('B', 'G', '2', '4');
inline constexpr uint32_t kMJPEG = make('M', 'J', 'P', 'G');
}  // namespace lcfourcc

// In order of preference when the config does not decide: cheapest conversion first, MJPEG last
// (decoding costs most and is lossy).
const std::vector<uint32_t>& convertibleLibcameraFormats();
bool isConvertibleLibcameraFormat(uint32_t fourcc);
// libcamera's own name ("YUYV", "NV12", "R8", "RGB888", "BGR888", "MJPEG"), or the FourCC in hex.
std::string libcameraFormatName(uint32_t fourcc);
// A config's pixel_format as a convertible FourCC: libcamera's names, plus "GREY"/"Y8" for R8 and
// "MJPG" for MJPEG. Empty when mocapd cannot convert it.
std::optional<uint32_t> libcameraFormatFromName(const std::string& name);
// "YUYV, NV12, ..." for error messages.
std::string convertibleLibcameraFormatList();

// What the driver hands downstream: gray from gray formats and BGR from colour ones, or always
// gray (cheaper, and all silhouette extraction needs).
enum class LibcameraImageOutput { kAsCaptured, kGray };

// One completed buffer as mapped memory. NV12 has the Y plane then the interleaved UV plane,
// either as two planes or as one plane holding both (UV starting at stride × height); every other
// format has one plane. `stride` is the bytes per row of the first plane (and of NV12's UV plane);
// for MJPEG it is unused and the plane holds exactly the bytes used.
struct LibcameraImageView {
  uint32_t fourcc = 0;
  int width = 0;
  int height = 0;
  size_t stride = 0;
  std::vector<std::span<const uint8_t>> planes;
};

// The result owns its pixels, so the buffer can be re-queued at once. Empty when the format is not
// convertible, the geometry is impossible (odd width for YUYV/NV12, stride < row), a plane is
// shorter than the geometry says, or a JPEG does not decode. Never throws.
cv::Mat convertLibcameraImage(const LibcameraImageView& image, LibcameraImageOutput output);

}  // namespace mocap
