// A capture check to run by hand: opens one Aravis camera, captures for a while and prints every
// frame's sequence number and timestamp, then the rate and the losses. For example, with
// `arv-fake-gv-camera-0.8 -i 127.0.0.1` running:
//   aravis_capture_check --device 127.0.0.1 --seconds 2 --width 780 --height 580 --fps 25
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/aravis/aravis_driver.h"

namespace {

struct Arguments {
  mocap::CameraConfig config;
  double seconds = 2.0;
};

bool parse(int argc, char** argv, Arguments& arguments) {
  mocap::CameraConfig& config = arguments.config;
  config.driver = "aravis";
  config.device = "127.0.0.1";
  config.pixel_format = "Mono8";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const char* value = argv[i + 1];
    if (flag == "--device") config.device = value;
    else if (flag == "--seconds") arguments.seconds = std::atof(value);
    else if (flag == "--width") config.width = std::atoi(value);
    else if (flag == "--height") config.height = std::atoi(value);
    else if (flag == "--fps") config.fps = std::atof(value);
    else if (flag == "--pixel-format") config.pixel_format = value;
    else return false;
  }
  return argc % 2 == 1;
}

}  // namespace

int main(int argc, char** argv) {
  Arguments arguments;
  if (!parse(argc, argv, arguments)) {
    std::fprintf(stderr,
                 "usage: %s [--device ID|IPv4] [--seconds S] [--width W] [--height H] [--fps F] "
                 "[--pixel-format NAME]\n",
                 argv[0]);
    return 2;
  }
  mocap::AravisDriver driver;
  mocap::Expected<std::unique_ptr<mocap::Camera>> camera = driver.open(arguments.config);
  if (!camera.ok()) {
    std::fprintf(stderr, "open failed: %s\n", camera.error().c_str());
    return 1;
  }
  const mocap::VideoMode& mode = camera.value()->info().modes.front();
  std::printf("camera %s (%s): %dx%d %s @ %g fps\n", camera.value()->info().id.c_str(),
              camera.value()->info().model.c_str(), mode.width, mode.height,
              mode.pixel_format.c_str(), mode.fps);

  std::mutex mutex;
  std::vector<mocap::Frame> frames;
  mocap::Status started = camera.value()->start(
      [&](mocap::Frame&& frame) {
        std::lock_guard<std::mutex> lock(mutex);
        frame.image.release();  // only the bookkeeping is printed
        frames.push_back(std::move(frame));
      },
      [](int, const std::string& message) { std::printf("event: %s\n", message.c_str()); });
  if (!started.ok()) {
    std::fprintf(stderr, "start failed: %s\n", started.message().c_str());
    return 1;
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(arguments.seconds));
  camera.value()->stop();

  std::printf("%8s %20s %10s %8s %8s\n", "sequence", "timestamp_ns", "delta_ms", "dropped", "corrupt");
  uint64_t dropped = 0, corrupt = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const double delta_ms =
        i ? static_cast<double>(frames[i].timestamp_ns - frames[i - 1].timestamp_ns) / 1e6 : 0.0;
    std::printf("%8llu %20lld %10.3f %8u %8d\n",
                static_cast<unsigned long long>(frames[i].sequence),
                static_cast<long long>(frames[i].timestamp_ns), delta_ms, frames[i].dropped_before,
                frames[i].corrupt ? 1 : 0);
    dropped += frames[i].dropped_before;
    corrupt += frames[i].corrupt ? 1 : 0;
  }
  const double span_s =
      frames.size() > 1
          ? static_cast<double>(frames.back().timestamp_ns - frames.front().timestamp_ns) / 1e9
          : 0.0;
  const auto stats = dynamic_cast<mocap::AravisCamera&>(*camera.value()).stats();
  std::printf("frames %zu in %.3f s (first to last timestamp): %.2f fps; dropped %llu, corrupt %llu, "
              "failed %llu, reopens %llu\n",
              frames.size(), span_s, span_s > 0 ? static_cast<double>(frames.size() - 1) / span_s : 0.0,
              static_cast<unsigned long long>(dropped), static_cast<unsigned long long>(corrupt),
              static_cast<unsigned long long>(stats.failed),
              static_cast<unsigned long long>(stats.reopens));
  return frames.empty() ? 1 : 0;
}
