// The V4L2 driver: enumeration of capture nodes, opening cameras, registration by name.
#include "drivers/v4l2/v4l2_driver.h"

#include "drivers/v4l2/v4l2_device.h"

namespace mocap {

V4l2Driver::V4l2Driver(std::shared_ptr<V4l2Syscalls> syscalls, V4l2Options options)
    : syscalls_(std::move(syscalls)), options_(options) {}

std::vector<CameraInfo> V4l2Driver::enumerate() {
  std::vector<CameraInfo> cameras;
  for (const std::string& path : syscalls_->listDeviceNodes()) {
    V4l2Device device(*syscalls_);
    // Nodes we may not open (permissions, busy) are not cameras we could use either.
    if (!device.open(path).ok() || !device.canCapture()) continue;
    cameras.push_back({name(), path, device.card(), device.modes()});
  }
  return cameras;
}

Expected<std::unique_ptr<Camera>> V4l2Driver::open(const CameraConfig& config) {
  Expected<std::unique_ptr<V4l2Camera>> camera = V4l2Camera::open(syscalls_, config, options_);
  if (!camera.ok()) return Status::Error(camera.error());
  return std::unique_ptr<Camera>(std::move(camera.value()));
}

void registerV4l2Driver(DriverRegistry& registry) {
  registry.add("v4l2", [] { return std::make_unique<V4l2Driver>(makeSystemV4l2Syscalls()); });
}

}  // namespace mocap
