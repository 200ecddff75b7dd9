// Tests of the Aravis driver: pixel conversion and frame bookkeeping alone, then for real against
// Aravis' own fake cameras: the in-process "Fake" interface, and the GigE Vision fake camera
// process (arv-fake-gv-camera-0.8) over 127.0.0.1, including the camera vanishing mid-stream.
#include <arv.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <future>
#include <thread>

#include "drivers/aravis/aravis_convert.h"
#include "drivers/aravis/aravis_driver.h"
#include "drivers/aravis/aravis_timing.h"
#include "tests/drivers/frame_collector.h"

namespace mocap {
namespace {

using std::chrono::milliseconds;
// Generous: only a broken driver ever waits this long.
constexpr milliseconds kTimeout{15'000};

// Only in-process cameras and direct unicast to 127.0.0.1: GigE Vision discovery would broadcast
// on every network interface, so that interface stays off in this binary.
class AravisInterfaces : public ::testing::Environment {
 public:
  void SetUp() override {
    arv_enable_interface("Fake");
    arv_disable_interface("GigEVision");
  }
};
const auto* const kInterfaces = ::testing::AddGlobalTestEnvironment(new AravisInterfaces);

// Collects what the driver delivers on its thread, for the test thread to wait on.
class Collector : public FrameCollector {
 public:
  Collector() : FrameCollector(kTimeout) {}
};

// Runs a call that must not hang; a hung call ends the test binary, as nothing else can.
void expectReturns(const std::function<void()>& call, const char* what) {
  auto result = std::async(std::launch::async, call);
  if (result.wait_for(kTimeout) != std::future_status::ready) {
    ADD_FAILURE() << what << " did not return within " << kTimeout.count() << " ms";
    std::fflush(nullptr);
    std::_Exit(1);
  }
}

int64_t monotonicNowNs() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

CameraConfig fakeConfig(const std::string& pixel_format = "Mono8") {
  CameraConfig config;
  config.driver = "aravis";
  config.device = "Fake_1";
  config.width = 780;
  config.height = 580;
  config.fps = 25;
  config.pixel_format = pixel_format;
  return config;
}

std::unique_ptr<Camera> openOrFail(AravisDriver& driver, const CameraConfig& config) {
  Expected<std::unique_ptr<Camera>> camera = driver.open(config);
  EXPECT_TRUE(camera.ok()) << camera.error();
  return camera.ok() ? std::move(camera.value()) : nullptr;
}

void expectIncreasingFrames(const std::vector<Frame>& frames, int width, int height, int type) {
  ASSERT_FALSE(frames.empty());
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].image.cols, width);
    EXPECT_EQ(frames[i].image.rows, height);
    EXPECT_EQ(frames[i].image.type(), type);
    EXPECT_FALSE(frames[i].corrupt);
    if (i == 0) continue;
    EXPECT_GT(frames[i].sequence, frames[i - 1].sequence);
    EXPECT_GT(frames[i].timestamp_ns, frames[i - 1].timestamp_ns);
  }
  // In the CLOCK_MONOTONIC domain: not in the future, and from this run (not CLOCK_REALTIME).
  const int64_t now = monotonicNowNs();
  EXPECT_LE(frames.back().timestamp_ns, now);
  EXPECT_GT(frames.front().timestamp_ns, now - int64_t{60} * 1'000'000'000);
}

// ---------------------------------------------------------------------------------------------
// Pixel conversion and bookkeeping, without a camera.

// A uniform colour as each Bayer pattern samples it: the 2x2 tile's pixels at their positions.
std::vector<uint8_t> bayerMosaic(const char* pattern, int width, int height, uint8_t r, uint8_t g,
                                 uint8_t b) {
  std::vector<uint8_t> pixels(static_cast<size_t>(width) * height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const char colour = pattern[(y % 2) * 2 + (x % 2)];
      pixels[static_cast<size_t>(y) * width + x] = colour == 'R' ? r : colour == 'G' ? g : b;
    }
  }
  return pixels;
}

TEST(AravisConvert, BayerPatternsDemosaicToTheRightColour) {
  const struct {
    uint32_t format;
    const char* tile;  // row 0 then row 1 of the 2x2 tile, as the PFNC name says
  } cases[] = {{pfnc::kBayerRG8, "RGGB"},
               {pfnc::kBayerGR8, "GRBG"},
               {pfnc::kBayerBG8, "BGGR"},
               {pfnc::kBayerGB8, "GBRG"}};
  for (const auto& bayer : cases) {
    SCOPED_TRACE(arvPixelFormatName(bayer.format));
    const std::vector<uint8_t> mosaic = bayerMosaic(bayer.tile, 16, 12, 200, 100, 30);
    const cv::Mat bgr = convertArvImage({bayer.format, 16, 12, 0, mosaic.data(), mosaic.size()});
    ASSERT_EQ(bgr.type(), CV_8UC3);
    const cv::Vec3b centre = bgr.at<cv::Vec3b>(6, 8);
    EXPECT_NEAR(centre[0], 30, 2);
    EXPECT_NEAR(centre[1], 100, 2);
    EXPECT_NEAR(centre[2], 200, 2);
  }
}

TEST(AravisConvert, Mono8HonoursLinePaddingAndRgb8BecomesBgr) {
  const std::vector<uint8_t> padded = {1, 2, 3, 0xee, 4, 5, 6};  // 3x2, one padding byte per line
  const cv::Mat gray = convertArvImage({pfnc::kMono8, 3, 2, 1, padded.data(), padded.size()});
  ASSERT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.at<uint8_t>(1, 0), 4);
  EXPECT_EQ(gray.at<uint8_t>(1, 2), 6);

  const std::vector<uint8_t> rgb = {10, 20, 30};
  const cv::Mat bgr = convertArvImage({pfnc::kRGB8, 1, 1, 0, rgb.data(), rgb.size()});
  ASSERT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(30, 20, 10));
}

TEST(AravisConvert, ShortPayloadOrUnknownFormatGivesNoImage) {
  const std::vector<uint8_t> pixels(5);
  EXPECT_TRUE(convertArvImage({pfnc::kMono8, 3, 2, 0, pixels.data(), pixels.size()}).empty());
  EXPECT_TRUE(convertArvImage({0x01100007 /* Mono16 */, 1, 1, 0, pixels.data(), 5}).empty());
  EXPECT_EQ(arvPixelFormatName(pfnc::kBayerGB8), "BayerGB8");
}

TEST(AravisTiming, FrameIdGapsWithWrapAround) {
  EXPECT_EQ(framesLostBetween(10, 11), 0u);
  EXPECT_EQ(framesLostBetween(10, 14), 3u);
  EXPECT_EQ(framesLostBetween(65535, 1), 0u);  // GigE Vision 1.x: 65535 wraps to 1
  EXPECT_EQ(framesLostBetween(65534, 2), 2u);  // 65535 and 1 lost
  EXPECT_EQ(framesLostBetween(65535, 0), 0u);  // a camera that uses 0 after all
  EXPECT_EQ(framesLostBetween(0xffffffffffffffffull - 1, 0xffffffffffffffffull), 0u);
  EXPECT_EQ(framesLostBetween(70000, 3), 0u);  // a 64-bit counter restarting, not a wrap
  EXPECT_EQ(framesLostBetween(300, 2), 0u);    // a 16-bit counter restarting
}

TEST(AravisTiming, DeviceClockFollowsTheFastestArrival) {
  DeviceClockMapper clock(8);
  // Device ticks every 40 ms from 1000 s; arrivals 5 ms after, except one frame that came in 1 ms.
  const int64_t offset = 7'000'000'000;
  const int64_t latencies_ms[] = {5, 5, 1, 5, 5};
  int64_t previous = 0;
  for (int i = 0; i < 5; ++i) {
    const uint64_t device = 1'000'000'000'000ull + i * 40'000'000ull;
    const int64_t mapped = clock.map(device, static_cast<int64_t>(device) + offset + latencies_ms[i] * 1'000'000);
    EXPECT_GT(mapped, previous);
    previous = mapped;
    if (i >= 2) {
      EXPECT_EQ(mapped, static_cast<int64_t>(device) + offset + 1'000'000);
    }
  }
  // No device clock: the arrival itself, still never going back.
  EXPECT_EQ(clock.map(0, previous + 10), previous + 10);
  EXPECT_EQ(clock.map(0, previous), previous + 11);
}

// ---------------------------------------------------------------------------------------------
// The in-process Fake camera.

TEST(AravisFake, EnumerationListsTheFakeCameraWithItsModes) {
  AravisDriver driver;
  const std::vector<CameraInfo> cameras = driver.enumerate();
  auto fake = std::find_if(cameras.begin(), cameras.end(),
                           [](const CameraInfo& info) { return info.id == "Fake_1"; });
  ASSERT_NE(fake, cameras.end());
  EXPECT_EQ(fake->driver, "aravis");
  EXPECT_NE(fake->model.find("Fake"), std::string::npos) << fake->model;
  std::vector<std::string> formats;
  for (const VideoMode& mode : fake->modes) {
    EXPECT_GE(mode.width, 780);
    EXPECT_GE(mode.height, 580);
    EXPECT_GE(mode.fps, 25);
    formats.push_back(mode.pixel_format);
  }
  for (const char* expected : {"Mono8", "BayerRG8", "RGB8"}) {
    EXPECT_NE(std::find(formats.begin(), formats.end(), expected), formats.end()) << expected;
  }
}

TEST(AravisFake, StreamsMono8At780x580With25Hz) {
  AravisDriver driver;
  std::unique_ptr<Camera> camera = openOrFail(driver, fakeConfig());
  ASSERT_TRUE(camera);
  ASSERT_EQ(camera->info().modes.size(), 1u);
  EXPECT_EQ(camera->info().modes[0].width, 780);
  EXPECT_EQ(camera->info().modes[0].height, 580);
  EXPECT_DOUBLE_EQ(camera->info().modes[0].fps, 25);
  EXPECT_EQ(camera->info().modes[0].pixel_format, "Mono8");
  Collector collector;
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  EXPECT_TRUE(collector.waitForFrames(10));
  expectReturns([&] { camera->stop(); }, "stop()");
  expectIncreasingFrames(collector.frames(), 780, 580, CV_8UC1);
  auto* aravis_camera = dynamic_cast<AravisCamera*>(camera.get());
  ASSERT_NE(aravis_camera, nullptr);
  EXPECT_GE(aravis_camera->stats().delivered, 10u);
  EXPECT_FALSE(camera->trigger().ok());  // free-running

  // A stopped camera starts again.
  Collector again;
  ASSERT_TRUE(camera->start(again.frameSink(), again.eventSink()).ok());
  EXPECT_TRUE(again.waitForFrames(3));
  expectReturns([&] { camera->stop(); }, "stop() after restart");
  EXPECT_GT(again.frames().front().sequence, collector.frames().back().sequence);
}

TEST(AravisFake, BayerCameraDeliversBgr) {
  AravisDriver driver;
  std::unique_ptr<Camera> camera = openOrFail(driver, fakeConfig("BayerRG8"));
  ASSERT_TRUE(camera);
  Collector collector;
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  EXPECT_TRUE(collector.waitForFrames(3));
  expectReturns([&] { camera->stop(); }, "stop()");
  expectIncreasingFrames(collector.frames(), 780, 580, CV_8UC3);
}

TEST(AravisFake, TwoOpensAreIndependentCameras) {
  AravisDriver driver;
  CameraConfig second_config = fakeConfig();
  second_config.index = 1;
  second_config.width = 640;
  second_config.height = 480;
  std::unique_ptr<Camera> first = openOrFail(driver, fakeConfig());
  std::unique_ptr<Camera> second = openOrFail(driver, second_config);
  ASSERT_TRUE(first && second);
  Collector first_frames, second_frames;
  ASSERT_TRUE(first->start(first_frames.frameSink(), first_frames.eventSink()).ok());
  ASSERT_TRUE(second->start(second_frames.frameSink(), second_frames.eventSink()).ok());
  EXPECT_TRUE(first_frames.waitForFrames(5));
  EXPECT_TRUE(second_frames.waitForFrames(5));
  expectReturns([&] { first->stop(); }, "first stop()");
  expectReturns([&] { second->stop(); }, "second stop()");
  expectIncreasingFrames(first_frames.frames(), 780, 580, CV_8UC1);
  expectIncreasingFrames(second_frames.frames(), 640, 480, CV_8UC1);
  EXPECT_EQ(second_frames.frames().front().camera, 1);
}

TEST(AravisFake, SoftwareTriggerFiresOneFramePerTrigger) {
  AravisDriver driver;
  CameraConfig config = fakeConfig();
  config.trigger = TriggerMode::kSoftware;
  std::unique_ptr<Camera> camera = openOrFail(driver, config);
  ASSERT_TRUE(camera);
  Collector collector;
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  for (size_t i = 1; i <= 3; ++i) {
    const Status fired = camera->trigger();
    EXPECT_TRUE(fired.ok()) << fired.message();
    EXPECT_TRUE(collector.waitForFrames(i)) << "no frame after trigger " << i;
  }
  expectReturns([&] { camera->stop(); }, "stop()");
  expectIncreasingFrames(collector.frames(), 780, 580, CV_8UC1);
}

TEST(AravisFake, BadConfigurationsGiveClearErrors) {
  AravisDriver driver;
  auto errorOf = [&](const CameraConfig& config) {
    Expected<std::unique_ptr<Camera>> camera = driver.open(config);
    EXPECT_FALSE(camera.ok());
    return camera.ok() ? std::string() : camera.error();
  };
  CameraConfig unknown = fakeConfig();
  unknown.device = "NoSuchCamera";
  std::string error = errorOf(unknown);
  EXPECT_NE(error.find("NoSuchCamera"), std::string::npos) << error;
  EXPECT_NE(error.find("Fake_1"), std::string::npos) << error;  // lists what it found

  CameraConfig too_wide = fakeConfig();
  too_wide.width = 5000;
  error = errorOf(too_wide);
  EXPECT_NE(error.find("width 5000 is not possible"), std::string::npos) << error;

  CameraConfig too_fast = fakeConfig();
  too_fast.fps = 5000;
  error = errorOf(too_fast);
  EXPECT_NE(error.find("5000 fps is not possible"), std::string::npos) << error;

  CameraConfig unsupported = fakeConfig("Mono16");
  error = errorOf(unsupported);
  EXPECT_NE(error.find("not supported by mocapd"), std::string::npos) << error;

  CameraConfig unoffered = fakeConfig("YUV422_8");
  error = errorOf(unoffered);
  EXPECT_NE(error.find("the camera offers"), std::string::npos) << error;

  CameraConfig bad_line = fakeConfig();
  bad_line.trigger = TriggerMode::kHardwareLine;
  bad_line.trigger_line = "Line7";
  error = errorOf(bad_line);
  EXPECT_NE(error.find("Line7"), std::string::npos) << error;
  EXPECT_NE(error.find("Line0"), std::string::npos) << error;  // what the camera offers
}

TEST(AravisFake, HardwareLineTriggerIsAccepted) {
  AravisDriver driver;
  CameraConfig config = fakeConfig();
  config.trigger = TriggerMode::kHardwareLine;
  config.trigger_line = "Line0";
  std::unique_ptr<Camera> camera = openOrFail(driver, config);
  ASSERT_TRUE(camera);
  EXPECT_FALSE(camera->trigger().ok());  // not a software-triggered camera
}

// ---------------------------------------------------------------------------------------------
// The GigE Vision fake camera, a separate process answering on 127.0.0.1.

std::string findFakeGvCamera() {
  const char* name = "arv-fake-gv-camera-0.8";
  if (const char* path = std::getenv("PATH")) {
    std::string directories = path;
    size_t start = 0;
    while (start <= directories.size()) {
      const size_t end = std::min(directories.find(':', start), directories.size());
      const std::filesystem::path candidate =
          std::filesystem::path(directories.substr(start, end - start)) / name;
      if (access(candidate.c_str(), X_OK) == 0) return candidate;
      start = end + 1;
    }
  }
  const std::string fallback = std::string("/usr/bin/") + name;
  return access(fallback.c_str(), X_OK) == 0 ? fallback : "";
}

// The fake camera process, killed and reaped whatever happens to the test.
class FakeGvCameraProcess {
 public:
  explicit FakeGvCameraProcess(const std::string& binary) {
    pid_ = fork();
    if (pid_ == 0) {
      // Dies with the test binary even if the binary crashes before the destructor runs.
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      execl(binary.c_str(), binary.c_str(), "-i", "127.0.0.1", static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  FakeGvCameraProcess(const FakeGvCameraProcess&) = delete;
  FakeGvCameraProcess& operator=(const FakeGvCameraProcess&) = delete;
  ~FakeGvCameraProcess() { kill(); }
  bool started() const { return pid_ > 0; }
  void kill() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
};

CameraConfig gvConfig() {
  CameraConfig config = fakeConfig();
  config.device = "127.0.0.1";
  return config;
}

AravisOptions gvOptions() {
  AravisOptions options;
  options.gv_packet_socket = false;  // loopback: the driver turns it off anyway
  options.stall_timeout = milliseconds(1500);
  options.reopen_backoff_initial = milliseconds(200);
  options.reopen_backoff_max = milliseconds(1000);
  return options;
}

// Opens the camera once the process answers; retries until kTimeout.
std::unique_ptr<Camera> openWhenAnswering(AravisDriver& driver) {
  const auto deadline = std::chrono::steady_clock::now() + kTimeout;
  std::string last_error;
  while (std::chrono::steady_clock::now() < deadline) {
    Expected<std::unique_ptr<Camera>> camera = driver.open(gvConfig());
    if (camera.ok()) return std::move(camera.value());
    last_error = camera.error();
    std::this_thread::sleep_for(milliseconds(200));
  }
  ADD_FAILURE() << "the fake GigE Vision camera never answered: " << last_error;
  return nullptr;
}

class AravisFakeGv : public ::testing::Test {
 protected:
  void SetUp() override {
    binary_ = findFakeGvCamera();
    if (binary_.empty()) {
      GTEST_SKIP() << "arv-fake-gv-camera-0.8 is not installed (Debian package aravis-tools-cli)";
    }
  }
  std::string binary_;
};

TEST_F(AravisFakeGv, CapturesOverLoopback) {
  FakeGvCameraProcess process(binary_);
  ASSERT_TRUE(process.started());
  AravisDriver driver(gvOptions());
  std::unique_ptr<Camera> camera = openWhenAnswering(driver);
  ASSERT_TRUE(camera);
  EXPECT_EQ(camera->info().id, "127.0.0.1");
  Collector collector;
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  EXPECT_TRUE(collector.waitForFrames(10));
  expectReturns([&] { camera->stop(); }, "stop()");
  expectIncreasingFrames(collector.frames(), 780, 580, CV_8UC1);
}

TEST_F(AravisFakeGv, VanishedCameraIsReportedAndReopened) {
  auto process = std::make_unique<FakeGvCameraProcess>(binary_);
  ASSERT_TRUE(process->started());
  AravisDriver driver(gvOptions());
  std::unique_ptr<Camera> camera = openWhenAnswering(driver);
  ASSERT_TRUE(camera);
  Collector collector;
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  ASSERT_TRUE(collector.waitForFrames(5));

  process->kill();
  EXPECT_TRUE(collector.waitForEvent("camera lost")) << "events: " << collector.events().size();

  process = std::make_unique<FakeGvCameraProcess>(binary_);
  EXPECT_TRUE(collector.waitForEvent("camera reopened"));
  const size_t before = collector.frameCount();
  EXPECT_TRUE(collector.waitForFrames(before + 5));

  // Gone again, and stopped while the driver is trying to reopen it.
  process->kill();
  expectReturns([&] { camera->stop(); }, "stop() with the camera gone");
  const std::vector<Frame> frames = collector.frames();
  for (size_t i = 1; i < frames.size(); ++i) {
    EXPECT_GT(frames[i].sequence, frames[i - 1].sequence);
    EXPECT_GT(frames[i].timestamp_ns, frames[i - 1].timestamp_ns);
  }
  EXPECT_GE(dynamic_cast<AravisCamera&>(*camera).stats().reopens, 1u);
}

}  // namespace
}  // namespace mocap
