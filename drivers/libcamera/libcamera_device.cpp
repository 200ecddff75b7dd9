// The shared CameraManager, camera lookup by id / model / index, and enumeration of modes.
#include "drivers/libcamera/libcamera_device.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>
#include <mutex>

#include "drivers/libcamera/libcamera_convert.h"

namespace mocap::lc {
namespace {

bool isIndex(const std::string& text) {
  return !text.empty() && text.size() < 6 &&
         std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
}

std::vector<VideoMode> cameraModes(libcamera::Camera& camera) {
  std::unique_ptr<libcamera::CameraConfiguration> configuration =
      camera.generateConfiguration({libcamera::StreamRole::VideoRecording});
  if (!configuration || configuration->empty()) {
    configuration = camera.generateConfiguration({libcamera::StreamRole::Viewfinder});
  }
  std::vector<VideoMode> modes;
  if (!configuration || configuration->empty()) return modes;
  const libcamera::StreamFormats& formats = configuration->at(0).formats();
  for (const libcamera::PixelFormat& format : formats.pixelformats()) {
    if (!isConvertibleLibcameraFormat(format.fourcc())) continue;
    std::vector<libcamera::Size> sizes = formats.sizes(format);
    // A continuous range lists no discrete sizes: its largest stands for it.
    if (sizes.empty()) sizes.push_back(formats.range(format).max);
    for (const libcamera::Size& size : sizes) {
      modes.push_back({static_cast<int>(size.width), static_cast<int>(size.height), 0,
                       libcameraFormatName(format.fourcc())});
    }
  }
  return modes;
}

}  // namespace

Expected<std::shared_ptr<libcamera::CameraManager>> sharedCameraManager() {
  static std::mutex mutex;
  static std::weak_ptr<libcamera::CameraManager> shared;
  std::lock_guard<std::mutex> lock(mutex);
  if (std::shared_ptr<libcamera::CameraManager> manager = shared.lock()) return manager;
  // libcamera logs INFO lines to stderr on every start; a daemon wants only its errors (an explicit
  // LIBCAMERA_LOG_LEVELS from the environment still wins).
  setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", 0);
  auto manager = std::make_unique<libcamera::CameraManager>();
  if (const int ret = manager->start(); ret < 0) {
    return Status::Error(versionLabel() + ": starting the camera manager: " + errorText(ret));
  }
  std::shared_ptr<libcamera::CameraManager> started(manager.release(),
                                                    [](libcamera::CameraManager* done) {
                                                      done->stop();
                                                      delete done;
                                                    });
  shared = started;
  return started;
}

std::string versionLabel() { return "libcamera " + libcamera::CameraManager::version(); }

std::string errorText(int ret) { return std::strerror(-ret); }

std::string cameraModel(const libcamera::Camera& camera) {
  const std::optional<std::string> model = camera.properties().get(libcamera::properties::Model);
  return model ? *model : std::string();
}

std::string cameraList(libcamera::CameraManager& manager) {
  const std::vector<std::shared_ptr<libcamera::Camera>> cameras = manager.cameras();
  if (cameras.empty()) return "no camera found";
  std::string list;
  for (size_t i = 0; i < cameras.size(); ++i) {
    const std::string model = cameraModel(*cameras[i]);
    list += (i ? ", [" : "[") + std::to_string(i) + "] " + cameras[i]->id() +
            (model.empty() ? "" : " (" + model + ")");
  }
  return list;
}

Expected<std::shared_ptr<libcamera::Camera>> findCamera(libcamera::CameraManager& manager,
                                                        const std::string& device) {
  const std::vector<std::shared_ptr<libcamera::Camera>> cameras = manager.cameras();
  if (device.empty() && !cameras.empty()) return cameras.front();
  if (!device.empty()) {
    if (std::shared_ptr<libcamera::Camera> camera = manager.get(device)) return camera;
    for (const std::shared_ptr<libcamera::Camera>& camera : cameras) {
      if (cameraModel(*camera) == device) return camera;
    }
    if (isIndex(device) && std::stoul(device) < cameras.size()) return cameras[std::stoul(device)];
  }
  const std::string asked = device.empty()  ? "the first camera (device is empty)"
                            : isIndex(device) ? "camera index " + device
                                              : "camera '" + device + "'";
  return Status::Error("libcamera: cannot open " + asked + ": " + versionLabel() +
                       (cameras.empty() ? " found no camera" : " has " + cameraList(manager)));
}

std::vector<CameraInfo> listCameras(libcamera::CameraManager& manager, const std::string& driver_name) {
  std::vector<CameraInfo> infos;
  for (const std::shared_ptr<libcamera::Camera>& camera : manager.cameras()) {
    infos.push_back({driver_name, camera->id(), cameraModel(*camera), cameraModes(*camera)});
  }
  return infos;
}

}  // namespace mocap::lc
