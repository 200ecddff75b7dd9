// The process-wide libcamera CameraManager, finding cameras by the name a config gives, and
// describing them for enumeration. Internal to drivers/libcamera/ (it pulls in libcamera headers).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <libcamera/libcamera.h>

#include "drivers/camera_driver.h"
#include "drivers/status.h"

namespace mocap::lc {

// libcamera allows one started CameraManager per process, so every driver instance and every
// camera shares this one; it is stopped when the last holder lets go. Fails with libcamera's
// return code as text.
Expected<std::shared_ptr<libcamera::CameraManager>> sharedCameraManager();

// "libcamera <version>" for messages.
std::string versionLabel();

// `device`: a libcamera camera id, a model name, an index into the manager's camera list ("0"),
// or empty for the first camera. The error names what was asked and lists what exists.
Expected<std::shared_ptr<libcamera::Camera>> findCamera(libcamera::CameraManager& manager,
                                                        const std::string& device);

// "[0] id (model), [1] ..." or "no camera found".
std::string cameraList(libcamera::CameraManager& manager);

std::string cameraModel(const libcamera::Camera& camera);

// Every camera the manager sees, with the sizes per convertible pixel format that a
// VideoRecording (else Viewfinder) configuration offers.
std::vector<CameraInfo> listCameras(libcamera::CameraManager& manager, const std::string& driver_name);

// strerror of a negative libcamera return code.
std::string errorText(int ret);

}  // namespace mocap::lc
