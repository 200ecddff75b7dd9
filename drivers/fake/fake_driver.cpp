// The fake driver: device strings, config checks, the shared scene and replay sources.
#include "drivers/fake/fake_driver.h"

#include <charconv>
#include <cmath>

namespace mocap {
namespace {

bool parseIndex(const std::string& text, int& value) {
  const char* end = text.data() + text.size();
  const auto [ptr, error] = std::from_chars(text.data(), end, value);
  return !text.empty() && error == std::errc() && ptr == end && value >= 0;
}

std::string sceneId(int camera) { return "scene:" + std::to_string(camera); }

// The output format a config asks for, or an error naming it.
Expected<std::string> outputFormat(const CameraConfig& config, const std::string& source_format) {
  if (config.pixel_format.empty()) return source_format;
  if (config.pixel_format == kPixelGray || config.pixel_format == kPixelBgr) return config.pixel_format;
  return Status::Error("fake: camera '" + config.device + "': pixel_format '" + config.pixel_format +
                       "' is not supported; use " + kPixelGray + " or " + kPixelBgr);
}

Status checkSize(const CameraConfig& config, int width, int height, const std::string& what) {
  if (config.width == width && config.height == height) return Status::Ok();
  return Status::Error("fake: camera '" + config.device + "': configured " + std::to_string(config.width) + "x" +
                       std::to_string(config.height) + ", but " + what + " is " + std::to_string(width) + "x" +
                       std::to_string(height));
}

}  // namespace

FakeDriver::FakeDriver(FakeDriverOptions options) : options_(std::move(options)) {}

Expected<std::shared_ptr<FakeScene>> FakeDriver::scene() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!scene_) {
    Expected<std::shared_ptr<FakeScene>> created = FakeScene::create(options_.scene);
    if (!created.ok()) return Status::Error(created.error());
    scene_ = created.value();
  }
  return scene_;
}

std::vector<CameraInfo> FakeDriver::enumerate() {
  Expected<std::shared_ptr<FakeScene>> built = scene();
  if (!built.ok()) return {};
  const FakeScene& s = *built.value();
  const std::string format = s.options().gray ? kPixelGray : kPixelBgr;
  std::vector<CameraInfo> cameras;
  for (std::size_t c = 0; c < s.rig().size(); ++c) {
    const CameraModel& cam = s.rig()[c];
    cameras.push_back({name(), sceneId(static_cast<int>(c)),
                       "mocapd fake camera " + std::to_string(c) + " (" + s.model().name + " scene)",
                       {{cam.width, cam.height, s.options().fps, format}}});
  }
  return cameras;
}

Expected<std::unique_ptr<Camera>> FakeDriver::open(const CameraConfig& config) {
  if (config.trigger != TriggerMode::kFreeRun) {
    return Status::Error("fake: camera '" + config.device + "': fake cameras only free-run");
  }
  const std::string& device = config.device;
  if (device.empty() || device == "scene") return openScene(config, config.index);
  if (device.rfind("scene:", 0) == 0) {
    int camera = 0;
    if (!parseIndex(device.substr(6), camera)) {
      return Status::Error("fake: device '" + device + "': expected scene:<camera index>");
    }
    return openScene(config, camera);
  }
  if (device.rfind("replay:", 0) == 0) {
    const std::string rest = device.substr(7);
    const std::size_t colon = rest.rfind(':');
    int camera = 0;
    if (colon == std::string::npos || colon == 0 || !parseIndex(rest.substr(colon + 1), camera)) {
      return Status::Error("fake: device '" + device + "': expected replay:<session directory>:<camera index>");
    }
    return openReplay(config, rest.substr(0, colon), camera);
  }
  return Status::Error("fake: device '" + device +
                       "' is not scene:<camera index> or replay:<session directory>:<camera index>");
}

Expected<std::unique_ptr<Camera>> FakeDriver::openScene(const CameraConfig& config, int rig_camera) {
  Expected<std::shared_ptr<FakeScene>> built = scene();
  if (!built.ok()) return Status::Error(built.error());
  std::shared_ptr<FakeScene> s = built.value();
  if (rig_camera < 0 || static_cast<std::size_t>(rig_camera) >= s->rig().size()) {
    return Status::Error("fake: device '" + config.device + "': the scene has cameras 0.." +
                         std::to_string(s->rig().size() - 1));
  }
  const CameraModel& cam = s->rig()[rig_camera];
  if (Status status = checkSize(config, cam.width, cam.height, "scene camera " + std::to_string(rig_camera)); !status.ok()) {
    return status;
  }
  if (std::abs(config.fps - s->options().fps) > 1e-6) {
    return Status::Error("fake: camera '" + config.device + "': configured " + std::to_string(config.fps) +
                         " fps, but the scene runs at " + std::to_string(s->options().fps));
  }
  Expected<std::string> format = outputFormat(config, s->options().gray ? kPixelGray : kPixelBgr);
  if (!format.ok()) return Status::Error(format.error());
  CameraInfo info{name(), sceneId(rig_camera),
                  "mocapd fake camera " + std::to_string(rig_camera) + " (" + s->model().name + " scene)",
                  {{cam.width, cam.height, s->options().fps, format.value()}}};
  return std::unique_ptr<Camera>(new FakeSceneCamera(s, rig_camera, config, std::move(info)));
}

Expected<std::unique_ptr<Camera>> FakeDriver::openReplay(const CameraConfig& config, const std::string& session,
                                                         int camera) {
  std::shared_ptr<ReplaySource> source;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    source = replays_[session].lock();
    if (!source) {
      Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(session, options_.replay.read);
      if (!reader.ok()) return Status::Error("fake: replay: " + reader.error());
      source = std::make_shared<ReplaySource>(std::shared_ptr<const SessionReader>(std::move(reader.value())));
      replays_[session] = source;
    }
  }
  const std::vector<SessionCamera>& cameras = source->reader().cameras();
  if (static_cast<std::size_t>(camera) >= cameras.size()) {
    return Status::Error("fake: device '" + config.device + "': the session has cameras 0.." +
                         std::to_string(cameras.size() - 1));
  }
  const SessionCamera& recorded = cameras[camera];
  if (Status status = checkSize(config, recorded.width, recorded.height, "the recorded camera"); !status.ok()) {
    return status;
  }
  Expected<std::string> format = outputFormat(config, recorded.pixel_format);
  if (!format.ok()) return Status::Error(format.error());
  CameraInfo info{name(), config.device, "replay of " + recorded.name + " from " + session,
                  {{recorded.width, recorded.height, recorded.fps, format.value()}}};
  return std::unique_ptr<Camera>(new FakeReplayCamera(source, camera, config, std::move(info), options_.replay));
}

void registerFakeDriver(DriverRegistry& registry) {
  registry.add("fake", [] { return std::make_unique<FakeDriver>(); });
}

}  // namespace mocap
