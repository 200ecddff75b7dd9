// The emulation's format negotiation: the formats, sizes and rates a spec lists, the kernel's
// adjust-not-fail rule, and VIDIOC_S_FMT / VIDIOC_TRY_FMT / VIDIOC_S_PARM.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "tests/drivers/v4l2/emulated_v4l2_device.h"
#include "tests/drivers/v4l2/emulated_v4l2_internal.h"

namespace mocap {
namespace v4l2_emulation {
namespace {

uint32_t bytesPerPixel(uint32_t pixelformat) {
  switch (pixelformat) {
    case V4L2_PIX_FMT_YUYV:
      return 2;
    case V4L2_PIX_FMT_GREY:
      return 1;
    default:
      return 0;  // compressed
  }
}

}  // namespace

v4l2_fract intervalOf(double fps) {
  if (std::abs(fps - std::round(fps)) < 1e-9) return {1, static_cast<uint32_t>(std::lround(fps))};
  return {1000, static_cast<uint32_t>(std::lround(fps * 1000))};
}

const EmulatedFormat* findFormat(const EmulatedDeviceSpec& spec, uint32_t pixelformat) {
  for (const EmulatedFormat& format : spec.formats) {
    if (format.pixelformat == pixelformat) return &format;
  }
  return nullptr;
}

const EmulatedFrameSize* findSize(const EmulatedFormat& format, uint32_t width, uint32_t height) {
  for (const EmulatedFrameSize& size : format.sizes) {
    if (size.width == width && size.height == height) return &size;
  }
  return nullptr;
}

v4l2_pix_format adjustedFormat(const EmulatedDeviceSpec& spec, const v4l2_pix_format& requested) {
  const EmulatedFormat* format = findFormat(spec, requested.pixelformat);
  if (format == nullptr) format = &spec.formats.front();
  const EmulatedFrameSize* nearest = &format->sizes.front();
  for (const EmulatedFrameSize& size : format->sizes) {
    const auto distance = [&](const EmulatedFrameSize& s) {
      return std::abs(static_cast<int64_t>(s.width) - requested.width) +
             std::abs(static_cast<int64_t>(s.height) - requested.height);
    };
    if (distance(size) < distance(*nearest)) nearest = &size;
  }
  v4l2_pix_format adjusted{};
  adjusted.pixelformat = format->pixelformat;
  adjusted.width = nearest->width;
  adjusted.height = nearest->height;
  adjusted.field = V4L2_FIELD_NONE;
  adjusted.colorspace = V4L2_COLORSPACE_SRGB;
  const uint32_t bpp = bytesPerPixel(format->pixelformat);
  if (bpp > 0) {
    adjusted.bytesperline = adjusted.width * bpp + spec.row_padding;
    adjusted.sizeimage = adjusted.bytesperline * adjusted.height;
  } else {
    // As UVC does for MJPEG: no line pitch, and a worst-case frame size (headers included).
    adjusted.sizeimage = std::max<uint32_t>(adjusted.width * adjusted.height * 2, 64 * 1024);
  }
  return adjusted;
}

std::vector<double> ratesOf(const EmulatedDeviceSpec& spec, const v4l2_pix_format& format) {
  const EmulatedFormat* listed = findFormat(spec, format.pixelformat);
  const EmulatedFrameSize* size = listed ? findSize(*listed, format.width, format.height) : nullptr;
  return size ? size->fps : std::vector<double>{};
}

}  // namespace v4l2_emulation

using v4l2_emulation::adjustedFormat;
using v4l2_emulation::intervalOf;
using v4l2_emulation::kCaptureType;
using v4l2_emulation::ratesOf;

int EmulatedV4l2::setFormat(Instance& device, v4l2_format& format, bool apply) {
  if (format.type != kCaptureType) return EINVAL;
  const v4l2_pix_format adjusted = adjustedFormat(device.spec, format.fmt.pix);
  if (apply) {
    // vb2_is_busy: the format fixes the buffer size, so it cannot change under allocated buffers.
    if (!device.buffers.empty()) return violation("VIDIOC_S_FMT with buffers allocated", EBUSY);
    device.format = adjusted;
    const std::vector<double> rates = ratesOf(device.spec, adjusted);
    if (std::find(rates.begin(), rates.end(), device.fps) == rates.end()) {
      device.fps = rates.empty() ? 0 : rates.front();
    }
  }
  format.fmt.pix = adjusted;
  return 0;
}

int EmulatedV4l2::setParm(Instance& device, v4l2_streamparm& parm) {
  if (parm.type != kCaptureType) return EINVAL;
  const v4l2_fract requested = parm.parm.capture.timeperframe;
  const std::vector<double> rates = ratesOf(device.spec, device.format);
  if (requested.numerator != 0 && requested.denominator != 0 && !rates.empty()) {
    const double wanted = static_cast<double>(requested.denominator) / requested.numerator;
    device.fps = *std::min_element(rates.begin(), rates.end(), [&](double a, double b) {
      return std::abs(a - wanted) < std::abs(b - wanted);
    });
  }
  parm.parm.capture = {};
  parm.parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
  parm.parm.capture.timeperframe = intervalOf(device.fps);
  return 0;
}

}  // namespace mocap
