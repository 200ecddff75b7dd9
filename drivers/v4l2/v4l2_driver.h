// The V4L2 camera driver (USB/UVC and other single-planar capture devices), registered as "v4l2".
#pragma once

#include <memory>

#include "drivers/camera_driver.h"
#include "drivers/v4l2/v4l2_camera.h"
#include "drivers/v4l2/v4l2_syscalls.h"

namespace mocap {

class V4l2Driver final : public Driver {
 public:
  explicit V4l2Driver(std::shared_ptr<V4l2Syscalls> syscalls, V4l2Options options = {});
  std::string name() const override { return "v4l2"; }
  // Capture-capable nodes only (metadata and output nodes are left out); modes list the sizes
  // and rates of the pixel formats this driver can convert.
  std::vector<CameraInfo> enumerate() override;
  // The returned camera is a V4l2Camera.
  Expected<std::unique_ptr<Camera>> open(const CameraConfig& config) override;

 private:
  std::shared_ptr<V4l2Syscalls> syscalls_;
  V4l2Options options_;
};

// Registers "v4l2" backed by the real kernel.
void registerV4l2Driver(DriverRegistry& registry);

}  // namespace mocap
