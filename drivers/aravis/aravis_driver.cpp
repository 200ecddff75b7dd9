// The Aravis driver: enumeration, opening cameras, registration by name.
#include "drivers/aravis/aravis_driver.h"

#include "drivers/aravis/aravis_device.h"

namespace mocap {

AravisDriver::AravisDriver(AravisOptions options) : options_(options) {}

std::vector<CameraInfo> AravisDriver::enumerate() { return aravis::listCameras(name()); }

Expected<std::unique_ptr<Camera>> AravisDriver::open(const CameraConfig& config) {
  Expected<std::unique_ptr<AravisCamera>> camera = AravisCamera::open(config, options_);
  if (!camera.ok()) return Status::Error(camera.error());
  return std::unique_ptr<Camera>(std::move(camera.value()));
}

void registerAravisDriver(DriverRegistry& registry) {
  registry.add("aravis", [] { return std::make_unique<AravisDriver>(); });
}

}  // namespace mocap
