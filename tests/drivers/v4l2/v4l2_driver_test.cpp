// Tests of the V4L2 driver against the emulated kernel: enumeration, negotiation, the streaming
// ioctl protocol, pixel conversion, drops, corrupt buffers, timestamps, and device loss.
#include <fcntl.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>

#include <opencv2/imgcodecs.hpp>

#include "drivers/v4l2/v4l2_driver.h"
#include "tests/drivers/frame_collector.h"
#include "tests/drivers/v4l2/emulated_v4l2_device.h"

namespace mocap {
namespace {

using std::chrono::milliseconds;
// Generous: only a broken driver ever waits this long.
constexpr milliseconds kTimeout{10'000};

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

std::string joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

// A tiny sensor so pixel values can be checked one by one; padded rows test stride handling.
EmulatedDeviceSpec tinySpec() {
  EmulatedDeviceSpec spec;
  spec.path = "/dev/video0";
  spec.card = "Tiny Sensor";
  spec.row_padding = 8;
  spec.formats = {{V4L2_PIX_FMT_YUYV, {{4, 2, {30}}}},
                  {V4L2_PIX_FMT_GREY, {{4, 2, {30}}}},
                  {V4L2_PIX_FMT_MJPEG, {{16, 16, {30}}}}};
  return spec;
}

CameraConfig configFor(const std::string& device, int width, int height, double fps,
                       const std::string& pixel_format) {
  CameraConfig config;
  config.index = 3;
  config.driver = "v4l2";
  config.device = device;
  config.width = width;
  config.height = height;
  config.fps = fps;
  config.pixel_format = pixel_format;
  return config;
}

class V4l2DriverTest : public ::testing::Test {
 protected:
  V4l2DriverTest() {
    options_.poll_timeout = milliseconds(20);
    options_.reopen_backoff_initial = milliseconds(5);
    options_.reopen_backoff_max = milliseconds(40);
  }

  std::unique_ptr<V4l2Camera> open(const CameraConfig& config) {
    Expected<std::unique_ptr<V4l2Camera>> camera = V4l2Camera::open(kernel_, config, options_);
    EXPECT_TRUE(camera.ok()) << camera.error();
    return camera.ok() ? std::move(camera.value()) : nullptr;
  }

  // Opens, starts, and waits until the emulated device has buffers to fill.
  std::unique_ptr<V4l2Camera> startStreaming(const CameraConfig& config, Collector& collector) {
    std::unique_ptr<V4l2Camera> camera = open(config);
    if (!camera) return nullptr;
    Status started = camera->start(collector.frameSink(), collector.eventSink());
    EXPECT_TRUE(started.ok()) << started.message();
    EXPECT_TRUE(kernel_->waitForQueuedBuffer(camera->info().id, kTimeout));
    return camera;
  }

  // Emits one frame and waits for the driver to deliver the expected total.
  void emitAndReceive(const std::string& path, const EmittedFrame& frame, Collector& collector,
                      size_t expected_total) {
    ASSERT_TRUE(kernel_->waitForQueuedBuffer(path, kTimeout));
    ASSERT_TRUE(kernel_->emitFrame(path, frame));
    ASSERT_TRUE(collector.waitForFrames(expected_total));
  }

  std::shared_ptr<EmulatedV4l2> kernel_ = std::make_shared<EmulatedV4l2>();
  V4l2Options options_;
};

TEST_F(V4l2DriverTest, EnumeratesCaptureNodesWithTheirModes) {
  kernel_->addDevice(webcamSpec("/dev/video0"));
  kernel_->addDevice(metadataNodeSpec("/dev/video1"));
  EmulatedDeviceSpec second = tinySpec();
  second.path = "/dev/video2";
  kernel_->addDevice(second);

  V4l2Driver driver(kernel_, options_);
  const std::vector<CameraInfo> cameras = driver.enumerate();

  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0].driver, "v4l2");
  EXPECT_EQ(cameras[0].id, "/dev/video0");
  EXPECT_EQ(cameras[0].model, "Emulated UVC Camera");
  EXPECT_EQ(cameras[1].id, "/dev/video2");
  EXPECT_EQ(cameras[1].model, "Tiny Sensor");
  auto has = [&](int width, int height, double fps, const std::string& format) {
    return std::any_of(cameras[0].modes.begin(), cameras[0].modes.end(), [&](const VideoMode& m) {
      return m.width == width && m.height == height && m.fps == fps && m.pixel_format == format;
    });
  };
  EXPECT_TRUE(has(640, 480, 30, "YUYV"));
  EXPECT_TRUE(has(640, 480, 15, "YUYV"));
  EXPECT_TRUE(has(320, 240, 30, "YUYV"));
  EXPECT_TRUE(has(640, 480, 30, "GREY"));
  EXPECT_TRUE(has(1280, 720, 60, "MJPG"));
  EXPECT_TRUE(has(1280, 720, 30, "MJPG"));
  EXPECT_EQ(cameras[0].modes.size(), 8u);
  EXPECT_EQ(kernel_->openFileCount("/dev/video0"), 0u);
  EXPECT_EQ(kernel_->openFileCount("/dev/video1"), 0u);
}

TEST_F(V4l2DriverTest, OpensByPathIndexAndCardName) {
  kernel_->addDevice(webcamSpec("/dev/video0"));
  EmulatedDeviceSpec second = tinySpec();
  second.path = "/dev/video1";
  kernel_->addDevice(second);
  V4l2Driver driver(kernel_, options_);

  for (const std::string device : {"/dev/video1", "1", "Tiny Sensor"}) {
    Expected<std::unique_ptr<Camera>> camera = driver.open(configFor(device, 4, 2, 30, "GREY"));
    ASSERT_TRUE(camera.ok()) << device << ": " << camera.error();
    EXPECT_EQ(camera.value()->info().id, "/dev/video1") << device;
    EXPECT_EQ(camera.value()->info().model, "Tiny Sensor") << device;
  }

  Expected<std::unique_ptr<Camera>> missing =
      driver.open(configFor("Nonexistent Cam", 4, 2, 30, ""));
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().find("Nonexistent Cam"), std::string::npos) << missing.error();
  EXPECT_NE(missing.error().find("Tiny Sensor"), std::string::npos) << missing.error();
}

TEST_F(V4l2DriverTest, ReportsTheSizeAndRateTheDeviceGranted) {
  kernel_->addDevice(webcamSpec("/dev/video0"));
  Collector collector;
  std::unique_ptr<V4l2Camera> camera =
      startStreaming(configFor("/dev/video0", 800, 600, 25, "YUYV"), collector);
  ASSERT_TRUE(camera);

  ASSERT_EQ(camera->info().modes.size(), 1u);
  const VideoMode& mode = camera->info().modes[0];
  EXPECT_EQ(mode.width, 640);
  EXPECT_EQ(mode.height, 480);
  EXPECT_EQ(mode.fps, 30);
  EXPECT_EQ(mode.pixel_format, "YUYV");
  EXPECT_EQ(kernel_->currentFormat("/dev/video0").width, 640u);
  EXPECT_TRUE(collector.waitForEvent(
      {"/dev/video0", "requested 800x600 @ 25 fps YUYV", "granted 640x480 @ 30 fps YUYV"}))
      << joined(collector.events());
}

TEST_F(V4l2DriverTest, ImpossiblePixelFormatIsAClearError) {
  EmulatedDeviceSpec spec = webcamSpec("/dev/video0");
  spec.formats.resize(1);  // YUYV only
  kernel_->addDevice(spec);
  V4l2Driver driver(kernel_, options_);

  Expected<std::unique_ptr<Camera>> mjpeg = driver.open(configFor("0", 640, 480, 30, "MJPG"));
  ASSERT_FALSE(mjpeg.ok());
  for (const char* text : {"/dev/video0", "Emulated UVC Camera", "cannot capture 640x480 MJPG",
                           "granted 640x480 YUYV", "offers YUYV"}) {
    EXPECT_NE(mjpeg.error().find(text), std::string::npos) << text << " in: " << mjpeg.error();
  }

  Expected<std::unique_ptr<Camera>> h264 = driver.open(configFor("0", 640, 480, 30, "H264"));
  ASSERT_FALSE(h264.ok());
  EXPECT_NE(h264.error().find("'H264' is not supported"), std::string::npos) << h264.error();
  EXPECT_EQ(kernel_->openFileCount("/dev/video0"), 0u);
}

TEST_F(V4l2DriverTest, PicksAFormatListingTheRequestedModeWhenNoneIsNamed) {
  kernel_->addDevice(webcamSpec("/dev/video0"));
  std::unique_ptr<V4l2Camera> hd = open(configFor("0", 1280, 720, 60, ""));
  ASSERT_TRUE(hd);
  EXPECT_EQ(hd->info().modes[0].pixel_format, "MJPG");
  EXPECT_EQ(hd->info().modes[0].fps, 60);
  hd.reset();
  std::unique_ptr<V4l2Camera> vga = open(configFor("0", 640, 480, 30, ""));
  ASSERT_TRUE(vga);
  EXPECT_EQ(vga->info().modes[0].pixel_format, "GREY");
}

// Index of the first call equal to `call` at or after `from`; the log size when there is none.
size_t find(const std::vector<std::string>& calls, const std::string& call, size_t from = 0) {
  return std::find(calls.begin() + static_cast<std::ptrdiff_t>(std::min(from, calls.size())),
                   calls.end(), call) -
         calls.begin();
}

TEST_F(V4l2DriverTest, FollowsTheStreamingIoctlProtocol) {
  kernel_->addDevice(webcamSpec("/dev/video0"));
  {
    Collector collector;
    std::unique_ptr<V4l2Camera> camera =
        startStreaming(configFor("/dev/video0", 640, 480, 30, "YUYV"), collector);
    ASSERT_TRUE(camera);
    for (size_t i = 1; i <= 3; ++i) emitAndReceive("/dev/video0", {}, collector, i);
    expectReturns([&] { camera->stop(); }, "stop()");
  }
  const std::vector<std::string> calls = kernel_->calls("/dev/video0");
  EXPECT_TRUE(kernel_->violations().empty()) << joined(kernel_->violations());
  const size_t open = find(calls, "open");
  const size_t s_fmt = find(calls, "VIDIOC_S_FMT", open);
  const size_t g_fmt = find(calls, "VIDIOC_G_FMT", s_fmt);
  const size_t s_parm = find(calls, "VIDIOC_S_PARM", g_fmt);
  const size_t reqbufs = find(calls, "VIDIOC_REQBUFS", s_parm);
  const size_t querybuf = find(calls, "VIDIOC_QUERYBUF", reqbufs);
  const size_t mmap = find(calls, "mmap", querybuf);
  const size_t qbuf = find(calls, "VIDIOC_QBUF", mmap);
  const size_t streamon = find(calls, "VIDIOC_STREAMON", qbuf);
  const size_t dqbuf = find(calls, "VIDIOC_DQBUF", streamon);
  const size_t requeue = find(calls, "VIDIOC_QBUF", dqbuf);
  const size_t streamoff = find(calls, "VIDIOC_STREAMOFF", requeue);
  const size_t munmap = find(calls, "munmap", streamoff);
  const size_t free_buffers = find(calls, "VIDIOC_REQBUFS", munmap);
  const size_t close = find(calls, "close", free_buffers);
  EXPECT_LT(close, calls.size()) << "protocol out of order:\n" << joined(calls);
  EXPECT_EQ(std::count(calls.begin(), calls.end(), "mmap"), 4);
  EXPECT_EQ(std::count(calls.begin(), calls.begin() + static_cast<std::ptrdiff_t>(streamon),
                       "VIDIOC_QBUF"),
            4);
  EXPECT_EQ(std::count(calls.begin(), calls.end(), "munmap"), 4);
  EXPECT_EQ(std::count(calls.begin(), calls.end(), "VIDIOC_DQBUF"), 3);
  EXPECT_EQ(kernel_->openFileCount("/dev/video0"), 0u);
  EXPECT_EQ(kernel_->mappingCount(), 0u);
}

std::vector<uint8_t> rows(const std::vector<std::vector<uint8_t>>& pixel_rows, size_t stride,
                          uint8_t padding) {
  std::vector<uint8_t> payload;
  for (const auto& row : pixel_rows) {
    payload.insert(payload.end(), row.begin(), row.end());
    payload.insert(payload.end(), stride - row.size(), padding);
  }
  return payload;
}

class V4l2ConversionTest : public V4l2DriverTest {
 protected:
  V4l2ConversionTest() { kernel_->addDevice(tinySpec()); }

  // Streams one payload in the given format and returns the delivered frame.
  Frame convert(const std::string& format, const std::vector<uint8_t>& payload, int width,
                int height) {
    Collector collector;
    std::unique_ptr<V4l2Camera> camera =
        startStreaming(configFor("/dev/video0", width, height, 30, format), collector);
    EXPECT_TRUE(camera);
    if (!camera) return {};
    EmittedFrame frame;
    frame.payload = payload;
    EXPECT_TRUE(kernel_->emitFrame("/dev/video0", frame));
    EXPECT_TRUE(collector.waitForFrames(1));
    camera->stop();
    const std::vector<Frame> frames = collector.frames();
    return frames.empty() ? Frame{} : frames[0];
  }
};

// Two YUYV pixel pairs per row: pure red (BT.601 limited range) and mid grey.
std::vector<uint8_t> redAndGreyYuyv() {
  const std::vector<uint8_t> row = {81, 90, 81, 240, 126, 128, 126, 128};
  return rows({row, row}, 4 * 2 + 8, 0xEE);
}

TEST_F(V4l2ConversionTest, YuyvBecomesBgr) {
  const Frame frame = convert("YUYV", redAndGreyYuyv(), 4, 2);
  ASSERT_EQ(frame.image.type(), CV_8UC3);
  ASSERT_EQ(frame.image.size(), cv::Size(4, 2));
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 2; ++x) {
      const cv::Vec3b red = frame.image.at<cv::Vec3b>(y, x);
      EXPECT_LE(red[0], 2);
      EXPECT_LE(red[1], 2);
      EXPECT_GE(red[2], 253);
      const cv::Vec3b grey = frame.image.at<cv::Vec3b>(y, x + 2);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(grey[c], 128, 1) << "channel " << c;
    }
  }
  EXPECT_FALSE(frame.corrupt);
}

TEST_F(V4l2ConversionTest, YuyvBecomesGrayFromLuma) {
  options_.output = V4l2ImageOutput::kGray;
  const Frame frame = convert("YUYV", redAndGreyYuyv(), 4, 2);
  ASSERT_EQ(frame.image.type(), CV_8UC1);
  const cv::Mat expected = (cv::Mat_<uint8_t>(2, 4) << 81, 81, 126, 126, 81, 81, 126, 126);
  EXPECT_EQ(cv::norm(frame.image, expected, cv::NORM_INF), 0);
}

TEST_F(V4l2ConversionTest, GreyKeepsPixelsAndDropsRowPadding) {
  const std::vector<uint8_t> payload = rows({{1, 2, 3, 4}, {250, 251, 252, 253}}, 4 + 8, 0xEE);
  const Frame frame = convert("GREY", payload, 4, 2);
  ASSERT_EQ(frame.image.type(), CV_8UC1);
  const cv::Mat expected = (cv::Mat_<uint8_t>(2, 4) << 1, 2, 3, 4, 250, 251, 252, 253);
  EXPECT_EQ(cv::norm(frame.image, expected, cv::NORM_INF), 0);
  EXPECT_EQ(frame.camera, 3);
}

TEST_F(V4l2ConversionTest, MjpegIsDecoded) {
  const cv::Mat solid(16, 16, CV_8UC3, cv::Scalar(200, 50, 10));
  std::vector<uint8_t> jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", solid, jpeg, {cv::IMWRITE_JPEG_QUALITY, 100}));
  const Frame frame = convert("MJPG", jpeg, 16, 16);
  ASSERT_EQ(frame.image.type(), CV_8UC3);
  ASSERT_EQ(frame.image.size(), cv::Size(16, 16));
  EXPECT_LE(cv::norm(frame.image, solid, cv::NORM_INF), 4);
  EXPECT_FALSE(frame.corrupt);
}

TEST_F(V4l2ConversionTest, ShortRawPayloadIsDeliveredAsCorrupt) {
  const Frame frame = convert("GREY", {9, 9, 9}, 4, 2);
  ASSERT_EQ(frame.image.size(), cv::Size(4, 2));
  EXPECT_TRUE(frame.corrupt);
  EXPECT_EQ(frame.image.at<uint8_t>(0, 2), 9);
  EXPECT_EQ(frame.image.at<uint8_t>(1, 0), 0);
}

TEST_F(V4l2DriverTest, CorruptMjpegIsSkippedCountedAndReportedAsLoss) {
  kernel_->addDevice(tinySpec());
  Collector collector;
  std::unique_ptr<V4l2Camera> camera =
      startStreaming(configFor("0", 16, 16, 30, "MJPG"), collector);
  ASSERT_TRUE(camera);
  emitAndReceive("/dev/video0", {}, collector, 1);
  EmittedFrame corrupt;
  corrupt.corrupt_mjpeg = true;
  ASSERT_TRUE(kernel_->emitFrame("/dev/video0", corrupt));
  emitAndReceive("/dev/video0", {}, collector, 2);

  const std::vector<Frame> frames = collector.frames();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(frames[1].sequence, 2u);
  EXPECT_EQ(frames[1].dropped_before, 1u);
  EXPECT_FALSE(frames[1].corrupt);
  EXPECT_EQ(camera->stats().undecodable, 1u);
  EXPECT_EQ(camera->stats().delivered, 2u);
}

TEST_F(V4l2DriverTest, SequenceGapsBecomeDroppedBefore) {
  kernel_->addDevice(tinySpec());
  Collector collector;
  std::unique_ptr<V4l2Camera> camera = startStreaming(configFor("0", 4, 2, 30, "GREY"), collector);
  ASSERT_TRUE(camera);
  EmittedFrame after_drops;
  after_drops.lost_before = 3;
  emitAndReceive("/dev/video0", {}, collector, 1);
  emitAndReceive("/dev/video0", after_drops, collector, 2);
  emitAndReceive("/dev/video0", {}, collector, 3);

  const std::vector<Frame> frames = collector.frames();
  EXPECT_EQ(frames[0].sequence, 0u);
  EXPECT_EQ(frames[1].sequence, 4u);
  EXPECT_EQ(frames[2].sequence, 5u);
  EXPECT_EQ(frames[0].dropped_before, 0u);
  EXPECT_EQ(frames[1].dropped_before, 3u);
  EXPECT_EQ(frames[2].dropped_before, 0u);
  EXPECT_EQ(camera->stats().dropped, 3u);
}

TEST_F(V4l2DriverTest, ErrorFlaggedBuffersAreMarkedCorrupt) {
  kernel_->addDevice(tinySpec());
  Collector collector;
  std::unique_ptr<V4l2Camera> camera = startStreaming(configFor("0", 4, 2, 30, "GREY"), collector);
  ASSERT_TRUE(camera);
  EmittedFrame damaged;
  damaged.error_flag = true;
  emitAndReceive("/dev/video0", damaged, collector, 1);
  emitAndReceive("/dev/video0", {}, collector, 2);

  const std::vector<Frame> frames = collector.frames();
  EXPECT_TRUE(frames[0].corrupt);
  EXPECT_FALSE(frames[1].corrupt);
  EXPECT_EQ(frames[0].image.size(), cv::Size(4, 2));
  EXPECT_EQ(camera->stats().corrupt, 1u);
}

TEST_F(V4l2DriverTest, MonotonicTimevalBecomesNanoseconds) {
  kernel_->addDevice(tinySpec());
  Collector collector;
  std::unique_ptr<V4l2Camera> camera = startStreaming(configFor("0", 4, 2, 30, "GREY"), collector);
  ASSERT_TRUE(camera);
  EmittedFrame stamped;
  stamped.timestamp_ns = 12'345'678'901'234;
  emitAndReceive("/dev/video0", stamped, collector, 1);
  emitAndReceive("/dev/video0", {}, collector, 2);  // the producer clock: one 30 fps interval on

  const std::vector<Frame> frames = collector.frames();
  EXPECT_EQ(frames[0].timestamp_ns, 12'345'678'901'000);  // timeval keeps microseconds
  EXPECT_EQ(frames[1].timestamp_ns, 12'345'712'234'000);
}

TEST_F(V4l2DriverTest, TimestampsInAnUnknownClockFallBackToDequeueTime) {
  EmulatedDeviceSpec spec = tinySpec();
  spec.timestamp_flags = V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN;
  kernel_->addDevice(spec);
  Collector collector;
  std::unique_ptr<V4l2Camera> camera = startStreaming(configFor("0", 4, 2, 30, "GREY"), collector);
  ASSERT_TRUE(camera);
  const auto now_ns = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  };
  EmittedFrame stamped;
  stamped.timestamp_ns = 5'000;  // meaningless in CLOCK_MONOTONIC
  const int64_t before = now_ns();
  emitAndReceive("/dev/video0", stamped, collector, 1);
  const int64_t after = now_ns();

  const int64_t timestamp = collector.frames()[0].timestamp_ns;
  EXPECT_GE(timestamp, before);
  EXPECT_LE(timestamp, after);
  EXPECT_TRUE(collector.waitForEvent({"no monotonic timestamp"})) << joined(collector.events());
}

TEST_F(V4l2DriverTest, VanishedDeviceIsReportedReopenedAndFramesResume) {
  kernel_->addDevice(tinySpec());
  Collector collector;
  std::unique_ptr<V4l2Camera> camera = startStreaming(configFor("0", 4, 2, 30, "GREY"), collector);
  ASSERT_TRUE(camera);
  emitAndReceive("/dev/video0", {}, collector, 1);
  emitAndReceive("/dev/video0", {}, collector, 2);

  kernel_->vanish("/dev/video0");
  EXPECT_TRUE(collector.waitForEvent({"camera lost", "/dev/video0", "No such device"}))
      << joined(collector.events());
  // Everything of the dead device is given back before it comes back.
  EXPECT_TRUE(kernel_->waitForRelease("/dev/video0", kTimeout));
  kernel_->reappear("/dev/video0");
  EXPECT_TRUE(collector.waitForEvent({"camera reopened", "/dev/video0"}))
      << joined(collector.events());
  emitAndReceive("/dev/video0", {}, collector, 3);
  emitAndReceive("/dev/video0", {}, collector, 4);

  const std::vector<Frame> frames = collector.frames();
  EXPECT_EQ(frames[2].sequence, 2u);
  EXPECT_EQ(frames[3].sequence, 3u);
  EXPECT_EQ(frames[2].image.size(), cv::Size(4, 2));
  EXPECT_EQ(camera->stats().reopens, 1u);
  expectReturns([&] { camera->stop(); }, "stop() after a reopen");
  EXPECT_TRUE(kernel_->violations().empty()) << joined(kernel_->violations());
  EXPECT_EQ(kernel_->openFileCount("/dev/video0"), 0u);
  EXPECT_EQ(kernel_->mappingCount(), 0u);
}

TEST_F(V4l2DriverTest, StopReturnsWhileWaitingToReopen) {
  options_.reopen_backoff_initial = std::chrono::hours(1);
  options_.reopen_backoff_max = std::chrono::hours(1);
  kernel_->addDevice(tinySpec());
  Collector collector;
  std::unique_ptr<V4l2Camera> camera = startStreaming(configFor("0", 4, 2, 30, "GREY"), collector);
  ASSERT_TRUE(camera);
  kernel_->vanish("/dev/video0");
  ASSERT_TRUE(collector.waitForEvent({"camera lost"})) << joined(collector.events());
  expectReturns([&] { camera->stop(); }, "stop() during the reopen backoff");
}

TEST_F(V4l2DriverTest, StopReturnsWhenNoFramesArrive) {
  options_.poll_timeout = milliseconds(100);
  kernel_->addDevice(tinySpec());
  Collector collector;
  std::unique_ptr<V4l2Camera> camera = startStreaming(configFor("0", 4, 2, 30, "GREY"), collector);
  ASSERT_TRUE(camera);
  expectReturns([&] { camera->stop(); }, "stop() with no frames");
  EXPECT_TRUE(collector.frames().empty());
  EXPECT_EQ(kernel_->openFileCount("/dev/video0"), 0u);
}

TEST_F(V4l2DriverTest, RestartsAfterStopAndTheSequenceContinues) {
  kernel_->addDevice(tinySpec());
  Collector collector;
  std::unique_ptr<V4l2Camera> camera = startStreaming(configFor("0", 4, 2, 30, "GREY"), collector);
  ASSERT_TRUE(camera);
  emitAndReceive("/dev/video0", {}, collector, 1);
  camera->stop();
  ASSERT_TRUE(camera->start(collector.frameSink(), collector.eventSink()).ok());
  emitAndReceive("/dev/video0", {}, collector, 2);
  EXPECT_EQ(collector.frames()[1].sequence, 1u);
  camera->stop();
  EXPECT_TRUE(kernel_->violations().empty()) << joined(kernel_->violations());
}

TEST_F(V4l2DriverTest, RegistersUnderItsName) {
  DriverRegistry registry;
  registerV4l2Driver(registry);
  std::unique_ptr<Driver> driver = registry.create("v4l2");
  ASSERT_TRUE(driver);
  EXPECT_EQ(driver->name(), "v4l2");
}

// The emulator must refuse what the kernel refuses, or the protocol test above proves nothing.
TEST(EmulatedV4l2Test, EnforcesTheBufferQueueRules) {
  EmulatedV4l2 kernel;
  kernel.addDevice(tinySpec());
  const int fd = kernel.open("/dev/video0", O_RDWR | O_NONBLOCK);
  ASSERT_GE(fd, 0);
  v4l2_requestbuffers request{};
  request.count = 1;
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  ASSERT_EQ(kernel.ioctl(fd, VIDIOC_REQBUFS, &request), 0);
  EXPECT_EQ(request.count, 2u);  // raised to the minimum

  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  buffer.index = 5;
  EXPECT_EQ(kernel.ioctl(fd, VIDIOC_QBUF, &buffer), -1);
  EXPECT_EQ(errno, EINVAL);
  buffer.index = 0;
  ASSERT_EQ(kernel.ioctl(fd, VIDIOC_QBUF, &buffer), 0);
  EXPECT_EQ(kernel.ioctl(fd, VIDIOC_QBUF, &buffer), -1);
  EXPECT_EQ(errno, EINVAL);

  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  ASSERT_EQ(kernel.ioctl(fd, VIDIOC_STREAMON, &type), 0);
  EXPECT_EQ(kernel.ioctl(fd, VIDIOC_DQBUF, &buffer), -1);
  EXPECT_EQ(errno, EAGAIN);
  EXPECT_EQ(kernel.ioctl(fd, VIDIOC_REQBUFS, &request), -1);
  EXPECT_EQ(errno, EBUSY);
  ASSERT_TRUE(kernel.emitFrame("/dev/video0"));
  ASSERT_EQ(kernel.ioctl(fd, VIDIOC_DQBUF, &buffer), 0);
  EXPECT_EQ(buffer.index, 0u);
  EXPECT_EQ(buffer.sequence, 0u);
  ASSERT_EQ(kernel.ioctl(fd, VIDIOC_QBUF, &buffer), 0);

  // STREAMOFF hands the queued buffer back: queueing it again is legal.
  ASSERT_EQ(kernel.ioctl(fd, VIDIOC_STREAMOFF, &type), 0);
  EXPECT_EQ(kernel.ioctl(fd, VIDIOC_QBUF, &buffer), 0);
  EXPECT_EQ(kernel.violations().size(), 3u) << joined(kernel.violations());

  kernel.vanish("/dev/video0");
  EXPECT_EQ(kernel.ioctl(fd, VIDIOC_STREAMON, &type), -1);
  EXPECT_EQ(errno, ENODEV);
  EXPECT_EQ(kernel.open("/dev/video0", O_RDWR), -1);
  EXPECT_EQ(errno, ENOENT);
  EXPECT_EQ(kernel.close(fd), 0);
}

TEST(EmulatedV4l2Test, AdjustsFormatsInsteadOfFailing) {
  EmulatedV4l2 kernel;
  kernel.addDevice(webcamSpec("/dev/video0"));
  const int fd = kernel.open("/dev/video0", O_RDWR);
  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  format.fmt.pix.pixelformat = V4L2_PIX_FMT_H264;
  format.fmt.pix.width = 1000;
  format.fmt.pix.height = 700;
  ASSERT_EQ(kernel.ioctl(fd, VIDIOC_TRY_FMT, &format), 0);
  EXPECT_EQ(format.fmt.pix.pixelformat, V4L2_PIX_FMT_YUYV);
  EXPECT_EQ(format.fmt.pix.width, 640u);
  EXPECT_EQ(format.fmt.pix.bytesperline, 1280u);
  EXPECT_EQ(format.fmt.pix.sizeimage, 1280u * 480u);

  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  parm.parm.capture.timeperframe = {1, 20};
  ASSERT_EQ(kernel.ioctl(fd, VIDIOC_S_PARM, &parm), 0);
  EXPECT_EQ(parm.parm.capture.timeperframe.denominator, 15u);
  kernel.close(fd);
}

}  // namespace
}  // namespace mocap
