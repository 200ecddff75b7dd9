// Choosing the stream's pixel format and the start controls for a libcamera camera from its
// CameraConfig, with messages naming the requested and the possible values.
#include "drivers/libcamera/libcamera_settings.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <utility>

#include "drivers/libcamera/libcamera_convert.h"

namespace mocap::lc {
namespace {

// [min, max] of a scalar numeric control, or nothing when the pipeline does not give one.
std::optional<std::pair<double, double>> numericRange(const libcamera::ControlInfo& info) {
  auto scalar = [](const libcamera::ControlValue& value) -> std::optional<double> {
    if (value.isArray()) return std::nullopt;
    switch (value.type()) {
      case libcamera::ControlTypeInteger32:
        return value.get<int32_t>();
      case libcamera::ControlTypeInteger64:
        return static_cast<double>(value.get<int64_t>());
      case libcamera::ControlTypeFloat:
        return value.get<float>();
      default:
        return std::nullopt;
    }
  };
  const std::optional<double> min = scalar(info.min());
  const std::optional<double> max = scalar(info.max());
  if (!min || !max) return std::nullopt;
  return std::make_pair(*min, *max);
}

const libcamera::ControlInfo* findControl(const libcamera::ControlInfoMap& controls,
                                          const libcamera::ControlId& id) {
  const auto found = controls.find(id.id());
  return found == controls.end() ? nullptr : &found->second;
}

}  // namespace

std::string numberText(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

std::string describeMode(unsigned int width, unsigned int height, double fps, uint32_t fourcc) {
  return std::to_string(width) + "x" + std::to_string(height) +
         (fps > 0 ? " @ " + numberText(fps) + " fps" : "") + " " + libcameraFormatName(fourcc);
}

Expected<uint32_t> choosePixelFormat(const CameraConfig& config,
                                     const libcamera::StreamFormats& formats,
                                     const libcamera::Size& wanted_size,
                                     const std::string& offered_text, const std::string& label) {
  const std::vector<libcamera::PixelFormat> offered = formats.pixelformats();
  auto isOffered = [&](uint32_t fourcc) {
    return std::any_of(offered.begin(), offered.end(), [&](const libcamera::PixelFormat& format) {
      return format.fourcc() == fourcc;
    });
  };
  if (!config.pixel_format.empty()) {
    const uint32_t fourcc = *libcameraFormatFromName(config.pixel_format);
    if (!isOffered(fourcc)) {
      return Status::Error(label + ": pixel format " + libcameraFormatName(fourcc) +
                           " not offered; the camera offers " + offered_text);
    }
    return fourcc;
  }
  uint32_t fourcc = 0;
  int best_rank = 2;
  for (uint32_t candidate : convertibleLibcameraFormats()) {
    if (!isOffered(candidate)) continue;
    const libcamera::PixelFormat format(candidate);
    const std::vector<libcamera::Size> sizes = formats.sizes(format);
    const bool fits = std::find(sizes.begin(), sizes.end(), wanted_size) != sizes.end() ||
                      (sizes.empty() && formats.range(format).contains(wanted_size));
    const int rank = fits ? 0 : 1;
    if (rank < best_rank) {
      best_rank = rank;
      fourcc = candidate;
    }
  }
  if (fourcc == 0) {
    return Status::Error(label + ": offers only " + offered_text + "; mocapd converts " +
                         convertibleLibcameraFormatList());
  }
  return fourcc;
}

Expected<double> setFrameRate(const libcamera::ControlInfoMap& available,
                              const CameraConfig& config, const std::string& label,
                              const std::string& mode, libcamera::ControlList& controls,
                              std::vector<std::string>& notes) {
  const libcamera::ControlInfo* info =
      findControl(available, libcamera::controls::FrameDurationLimits);
  if (!info) {
    notes.push_back(
        "frame rate not settable (no FrameDurationLimits); the camera runs at its own rate");
    return 0.0;
  }
  // Frame durations are in microseconds: the shortest gives the highest rate.
  if (const auto range = numericRange(*info); range && range->first > 0 && range->second > 0) {
    const double fps_min = 1e6 / range->second;
    const double fps_max = 1e6 / range->first;
    if (config.fps < fps_min * 0.999 || config.fps > fps_max * 1.001) {
      return Status::Error(label + ": " + numberText(config.fps) + " fps is not possible at " +
                           mode + ": " + numberText(fps_min) + ".." + numberText(fps_max));
    }
  }
  const auto duration_us = static_cast<int64_t>(std::llround(1e6 / config.fps));
  controls.set(libcamera::controls::FrameDurationLimits, {duration_us, duration_us});
  return config.fps;
}

Status setExposure(const libcamera::ControlInfoMap& available, const CameraConfig& config,
                   const std::string& label, libcamera::ControlList& controls,
                   std::vector<std::string>& notes) {
  if (!config.exposure_us) return Status::Ok();
  const libcamera::ControlInfo* info = findControl(available, libcamera::controls::ExposureTime);
  if (!info) {
    notes.push_back("exposure_us not applied: the camera has no ExposureTime control");
    return Status::Ok();
  }
  const auto range = numericRange(*info);
  if (range && (*config.exposure_us < range->first || *config.exposure_us > range->second)) {
    return Status::Error(label + ": exposure_us " + numberText(*config.exposure_us) +
                         " is not possible: " + numberText(range->first) + ".." +
                         numberText(range->second));
  }
  if (findControl(available, libcamera::controls::AeEnable)) {
    controls.set(libcamera::controls::AeEnable, false);
  }
  controls.set(libcamera::controls::ExposureTime,
               static_cast<int32_t>(std::lround(*config.exposure_us)));
  return Status::Ok();
}

Status setGain(const libcamera::ControlInfoMap& available, const CameraConfig& config,
               const std::string& label, libcamera::ControlList& controls,
               std::vector<std::string>& notes) {
  if (!config.gain_db) return Status::Ok();
  // libcamera's AnalogueGain is a linear factor.
  const libcamera::ControlInfo* info = findControl(available, libcamera::controls::AnalogueGain);
  if (!info) {
    notes.push_back("gain_db not applied: the camera has no AnalogueGain control");
    return Status::Ok();
  }
  const double gain = std::pow(10.0, *config.gain_db / 20.0);
  const auto range = numericRange(*info);
  if (range && range->first > 0 && (gain < range->first * 0.999 || gain > range->second * 1.001)) {
    return Status::Error(label + ": gain_db " + numberText(*config.gain_db) +
                         " is not possible: " + numberText(20 * std::log10(range->first)) + ".." +
                         numberText(20 * std::log10(range->second)) + " dB");
  }
  if (findControl(available, libcamera::controls::AeEnable)) {
    controls.set(libcamera::controls::AeEnable, false);
  }
  controls.set(libcamera::controls::AnalogueGain, static_cast<float>(gain));
  return Status::Ok();
}

}  // namespace mocap::lc
