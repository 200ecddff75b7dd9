// The fake driver: device strings, config checks, the shared scene and replay sources.
#include "drivers/fake/fake_driver.h"

#include <charconv>
#include <cmath>
#include <sstream>

namespace mocap {
namespace {

bool parseIndex(const std::string& text, int& value) {
  const char* end = text.data() + text.size();
  const auto [ptr, error] = std::from_chars(text.data(), end, value);
  return !text.empty() && error == std::errc() && ptr == end && value >= 0;
}

bool parseNonNegative(const std::string& text, double& seconds) {
  const char* end = text.data() + text.size();
  const auto [ptr, error] = std::from_chars(text.data(), end, seconds);
  return !text.empty() && error == std::errc() && ptr == end && std::isfinite(seconds) && seconds >= 0;
}

// "<seconds>@<start seconds>[/<every seconds>]" as an outage of `camera`.
Expected<FakeOutage> parseOutage(const std::string& text, int camera, double fps) {
  const std::size_t at = text.find('@');
  const std::size_t slash = text.find('/');
  double duration = 0;
  double start = 0;
  double every = 0;
  if (at == std::string::npos || (slash != std::string::npos && slash < at) ||
      !parseNonNegative(text.substr(0, at), duration) ||
      !parseNonNegative(text.substr(at + 1, slash == std::string::npos ? std::string::npos : slash - at - 1), start) ||
      (slash != std::string::npos && (!parseNonNegative(text.substr(slash + 1), every) || every <= duration))) {
    return Status::Error("'" + text + "' is not <seconds>@<start seconds>[/<every seconds, more than the outage>]");
  }
  FakeOutage outage;
  outage.camera = camera;
  outage.after_frames = static_cast<uint64_t>(std::llround(start * fps));
  outage.duration = std::chrono::nanoseconds(std::llround(duration * 1e9));
  outage.every = std::chrono::nanoseconds(std::llround(every * 1e9));
  return outage;
}

// The faults a scene device's query ("drop_rate=R&stall=...&disconnect=...") gives camera
// `camera`, over the scene's own.
Expected<FakeFaults> parseFaults(const std::string& query, const FakeFaults& scene_faults, int camera, double fps) {
  FakeFaults faults = scene_faults;
  std::istringstream items(query);
  for (std::string item; std::getline(items, item, '&');) {
    const std::size_t equals = item.find('=');
    const std::string key = item.substr(0, equals);
    const std::string value = equals == std::string::npos ? "" : item.substr(equals + 1);
    if (key == "drop_rate") {
      if (!parseNonNegative(value, faults.drop_rate) || faults.drop_rate >= 1)
        return Status::Error("drop_rate '" + value + "' is not a chance in [0, 1)");
    } else if (key == "stall" || key == "disconnect") {
      Expected<FakeOutage> outage = parseOutage(value, camera, fps);
      if (!outage.ok()) return Status::Error(key + ": " + outage.error());
      (key == "stall" ? faults.stall : faults.disconnect) = outage.value();
    } else {
      return Status::Error("unknown fault '" + key + "'; expected drop_rate, stall or disconnect");
    }
  }
  return faults;
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
  if (device.empty() || device == "scene" || device.rfind("scene?", 0) == 0 || device.rfind("scene:", 0) == 0) {
    const std::size_t query = device.find('?');
    const std::string camera_text = device.substr(0, query);
    int camera = config.index;
    if (camera_text.size() > 5 && !parseIndex(camera_text.substr(6), camera)) {
      return Status::Error("fake: device '" + device + "': expected scene:<camera index>");
    }
    return openScene(config, camera, query == std::string::npos ? "" : device.substr(query + 1));
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

Expected<std::unique_ptr<Camera>> FakeDriver::openScene(const CameraConfig& config, int rig_camera,
                                                       const std::string& faults_query) {
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
  Expected<FakeFaults> faults = parseFaults(faults_query, s->options().faults, rig_camera, s->options().fps);
  if (!faults.ok()) return Status::Error("fake: device '" + config.device + "': " + faults.error());
  CameraInfo info{name(), sceneId(rig_camera),
                  "mocapd fake camera " + std::to_string(rig_camera) + " (" + s->model().name + " scene)",
                  {{cam.width, cam.height, s->options().fps, format.value()}}};
  return std::unique_ptr<Camera>(new FakeSceneCamera(s, rig_camera, config, std::move(info), faults.value()));
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
