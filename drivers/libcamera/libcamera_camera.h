// A libcamera camera as a mocap Camera: configuration at open (size, pixel format, frame rate,
// exposure, gain), requests over allocator buffers, a worker thread converting completed requests
// to gray/BGR and re-queuing them, sequence-gap bookkeeping, and reopening with backoff when the
// camera is disconnected.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "drivers/camera_driver.h"
#include "drivers/libcamera/libcamera_convert.h"

namespace libcamera {
class CameraManager;
class Request;
}  // namespace libcamera

namespace mocap {

struct LibcameraOptions {
  // Requests (each with its own buffer) in flight: frames the camera can get ahead of the worker.
  // libcamera may raise it to the pipeline's minimum.
  unsigned int buffer_count = 6;
  LibcameraImageOutput output = LibcameraImageOutput::kAsCaptured;
  // Upper bound on how long stop() waits for the worker to notice.
  std::chrono::milliseconds wait_timeout{100};
  // Reopen delays after a disconnection: doubled after each failed attempt, up to the max.
  std::chrono::milliseconds reopen_backoff_initial{250};
  std::chrono::milliseconds reopen_backoff_max{8000};
};

// Counters since open, readable from any thread.
struct LibcameraCameraStats {
  uint64_t delivered = 0;
  uint64_t dropped = 0;    // sensor sequence gaps: frames the camera produced that we never got
  uint64_t corrupt = 0;    // buffers libcamera flagged FrameError: delivered, flagged corrupt
  uint64_t failed = 0;     // buffers with no usable image (unconvertible, re-queue failed): skipped
  uint64_t cancelled = 0;  // requests cancelled while streaming (not by our own stop)
  uint64_t reopens = 0;
};

// Frames lost between two sensor sequence numbers (32-bit, wrapping). A sequence that goes
// backwards or repeats (a restarted sensor) counts as no loss.
uint32_t libcameraFramesLost(uint32_t previous, uint32_t current);

// Checks a config for what this driver can never do, before any camera is touched.
Status checkLibcameraConfig(const CameraConfig& config);

// One acquisition of the camera: configuration, allocator, requests, mapped buffers. Defined in
// libcamera_camera.cpp so this header stays free of libcamera.
struct LibcameraSession;

class LibcameraCamera final : public Camera {
 public:
  // Acquires and configures the camera the config names (see LibcameraDriver). Fails with a
  // message naming the camera and the requested and possible values, or libcamera's return code.
  static Expected<std::unique_ptr<LibcameraCamera>> open(
      const CameraConfig& config, const LibcameraOptions& options,
      std::shared_ptr<libcamera::CameraManager> manager);
  ~LibcameraCamera() override;

  // After open, modes holds exactly the configured mode.
  const CameraInfo& info() const override { return info_; }
  Status start(FrameSink frames, DriverEventSink events) override;
  void stop() override;
  LibcameraCameraStats stats() const;

 private:
  LibcameraCamera(const CameraConfig& config, const LibcameraOptions& options,
                  std::shared_ptr<libcamera::CameraManager> manager);
  // Acquires and configures the camera; the first open also fills info_ and fixes the camera id,
  // pixel format and size every reopen must get again.
  Status openSession();
  Status configure(LibcameraSession& session);
  Status startStream(LibcameraSession& session);
  void closeSession();
  void workerLoop();
  void processRequest(libcamera::Request& request);
  void loseCamera(const std::string& reason);
  // Waits out the backoff and reopens until it works (true) or stop() is called (false).
  bool reopenWithBackoff();
  void report(const std::string& message);
  // libcamera's signals, on its camera manager thread: only queue and wake the worker.
  void onRequestCompleted(libcamera::Request* request);
  void onDisconnected();

  const CameraConfig config_;
  const LibcameraOptions options_;
  // Declared first so it outlives the session's camera.
  const std::shared_ptr<libcamera::CameraManager> manager_;
  CameraInfo info_;
  std::string camera_id_;           // what reopens look up: the id the first open resolved
  uint32_t fourcc_ = 0;             // fixed by the first open
  std::string configuration_note_;  // told to the event sink at start (settings adjusted)

  // Owned by the opener, then by the worker thread while streaming.
  std::unique_ptr<LibcameraSession> session_;

  std::thread thread_;
  FrameSink frames_;
  DriverEventSink events_;
  // Guards the hand-over from libcamera's thread and stop(): completed requests, the disconnected
  // flag, and the wake-up of the worker (also during backoff).
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<libcamera::Request*> completed_;
  bool disconnected_ = false;
  bool closing_ = false;  // our own Camera::stop() is cancelling the requests
  std::atomic<bool> stopping_{false};

  // Worker state: the frame sequence continues across reopens.
  uint64_t next_sequence_ = 0;
  std::optional<uint32_t> last_sensor_sequence_;
  uint32_t lost_since_delivery_ = 0;

  std::atomic<uint64_t> delivered_{0};
  std::atomic<uint64_t> dropped_{0};
  std::atomic<uint64_t> corrupt_{0};
  std::atomic<uint64_t> failed_{0};
  std::atomic<uint64_t> cancelled_{0};
  std::atomic<uint64_t> reopens_{0};
};

}  // namespace mocap
