// The Aravis camera driver (GigE Vision and USB3 Vision cameras through libaravis), registered as
// "aravis".
#pragma once

#include <memory>

#include "drivers/aravis/aravis_camera.h"
#include "drivers/camera_driver.h"

namespace mocap {

class AravisDriver final : public Driver {
 public:
  explicit AravisDriver(AravisOptions options = {});
  std::string name() const override { return "aravis"; }
  // Every device the enabled Aravis interfaces see (GigE Vision discovery broadcasts on every
  // network interface). id is Aravis' device id (e.g. "Basler-21234567"), model "vendor model";
  // modes list, per convertible pixel format, the largest region and the highest rate the camera
  // allows with its current settings. A camera another application controls has no modes.
  std::vector<CameraInfo> enumerate() override;
  // config.device: an Aravis device id, a serial number, an IPv4 address (opened directly, no
  // broadcast), a GigE Vision user-defined name or MAC, or empty for the first camera. The
  // returned camera is an AravisCamera.
  Expected<std::unique_ptr<Camera>> open(const CameraConfig& config) override;

 private:
  AravisOptions options_;
};

void registerAravisDriver(DriverRegistry& registry);

}  // namespace mocap
