// A CameraConfig in libcamera's terms, checked against what the camera offers: the stream's pixel
// format and the controls applied at start (frame rate, exposure, gain). Internal to
// drivers/libcamera/ (it pulls in libcamera headers).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <libcamera/libcamera.h>

#include "drivers/camera_driver.h"
#include "drivers/status.h"

namespace mocap::lc {

// "%g": as short as the value allows, for messages.
std::string numberText(double value);

// "640x480 @ 30 fps YUYV"; the rate is left out when 0.
std::string describeMode(unsigned int width, unsigned int height, double fps, uint32_t fourcc);

// The config's pixel format, else the first convertible one offered at the wanted size, else the
// first convertible one offered at all. `offered_text` lists the camera's formats for errors.
Expected<uint32_t> choosePixelFormat(const CameraConfig& config,
                                     const libcamera::StreamFormats& formats,
                                     const libcamera::Size& wanted_size,
                                     const std::string& offered_text, const std::string& label);

// Each adds its control to `controls` when the camera has it, fails when the configured value is
// out of the camera's range, and adds a note to `notes` when the camera lacks the control.

// The configured rate as fixed frame duration limits; returns it, or 0 when the camera has no
// FrameDurationLimits and runs at its own rate. `mode` describes the granted mode for errors.
Expected<double> setFrameRate(const libcamera::ControlInfoMap& available,
                              const CameraConfig& config, const std::string& label,
                              const std::string& mode, libcamera::ControlList& controls,
                              std::vector<std::string>& notes);
Status setExposure(const libcamera::ControlInfoMap& available, const CameraConfig& config,
                   const std::string& label, libcamera::ControlList& controls,
                   std::vector<std::string>& notes);
Status setGain(const libcamera::ControlInfoMap& available, const CameraConfig& config,
               const std::string& label, libcamera::ControlList& controls,
               std::vector<std::string>& notes);

}  // namespace mocap::lc
