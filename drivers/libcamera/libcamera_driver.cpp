// The libcamera driver: the shared camera manager, enumeration, opening cameras, registration by
// name.
#include "drivers/libcamera/libcamera_driver.h"

#include "drivers/libcamera/libcamera_device.h"

namespace mocap {

LibcameraDriver::LibcameraDriver(LibcameraOptions options) : options_(options) {}

LibcameraDriver::~LibcameraDriver() = default;

Expected<std::shared_ptr<libcamera::CameraManager>> LibcameraDriver::manager() {
  if (!manager_) {
    Expected<std::shared_ptr<libcamera::CameraManager>> started = lc::sharedCameraManager();
    if (!started.ok()) return Status::Error(started.error());
    manager_ = started.value();
  }
  return manager_;
}

std::vector<CameraInfo> LibcameraDriver::enumerate() {
  Expected<std::shared_ptr<libcamera::CameraManager>> cameras = manager();
  if (!cameras.ok()) return {};
  return lc::listCameras(*cameras.value(), name());
}

Status LibcameraDriver::checkCameras() {
  Expected<std::shared_ptr<libcamera::CameraManager>> cameras = manager();
  if (!cameras.ok()) return Status::Error(cameras.error());
  if (cameras.value()->cameras().empty()) {
    return Status::Error(lc::versionLabel() +
                         ": no camera found (no pipeline handler matched a device on this machine)");
  }
  return Status::Ok();
}

Expected<std::unique_ptr<Camera>> LibcameraDriver::open(const CameraConfig& config) {
  // Configs libcamera can never honour are refused before the camera manager starts.
  if (Status status = checkLibcameraConfig(config); !status.ok()) return status;
  Expected<std::shared_ptr<libcamera::CameraManager>> cameras = manager();
  if (!cameras.ok()) return Status::Error(cameras.error());
  Expected<std::unique_ptr<LibcameraCamera>> camera =
      LibcameraCamera::open(config, options_, cameras.value());
  if (!camera.ok()) return Status::Error(camera.error());
  return std::unique_ptr<Camera>(std::move(camera.value()));
}

void registerLibcameraDriver(DriverRegistry& registry) {
  registry.add("libcamera", [] { return std::make_unique<LibcameraDriver>(); });
}

}  // namespace mocap
