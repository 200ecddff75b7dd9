// The libcamera camera driver (cameras behind libcamera's pipeline handlers: UVC, Raspberry Pi,
// IPU3, ...), registered as "libcamera".
#pragma once

#include <memory>

#include "drivers/camera_driver.h"
#include "drivers/libcamera/libcamera_camera.h"

namespace libcamera {
class CameraManager;
}  // namespace libcamera

namespace mocap {

class LibcameraDriver final : public Driver {
 public:
  explicit LibcameraDriver(LibcameraOptions options = {});
  ~LibcameraDriver() override;
  std::string name() const override { return "libcamera"; }
  // Every camera libcamera sees. id is libcamera's camera id, model its Model property; modes
  // list the sizes per convertible pixel format of a VideoRecording configuration (rate 0: libcamera
  // 0.0.3 does not list rates). Empty when there is no camera or libcamera cannot start; see
  // checkCameras() for why.
  std::vector<CameraInfo> enumerate() override;
  // config.device: a libcamera camera id, a model name, an index ("0") into the list enumerate()
  // gives, or empty for the first camera. The returned camera is a LibcameraCamera.
  Expected<std::unique_ptr<Camera>> open(const CameraConfig& config) override;
  // Ok when libcamera sees at least one camera; else an error saying so (and which libcamera), or
  // why the camera manager could not start.
  Status checkCameras();

 private:
  // Starts (or joins) the process-wide camera manager on first use.
  Expected<std::shared_ptr<libcamera::CameraManager>> manager();

  LibcameraOptions options_;
  std::shared_ptr<libcamera::CameraManager> manager_;
};

void registerLibcameraDriver(DriverRegistry& registry);

}  // namespace mocap
