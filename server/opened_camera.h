// A camera of the daemon's rig as the pipeline and its components see it.
#pragma once

#include <memory>

#include "drivers/camera_driver.h"

namespace mocap {

// A camera of the rig: the configuration it was opened with, what its driver says of it, and the
// camera itself (null when a recorded session stands in for it).
struct OpenedCamera {
  CameraConfig config;
  CameraInfo info;
  std::unique_ptr<Camera> camera;
};

}  // namespace mocap
