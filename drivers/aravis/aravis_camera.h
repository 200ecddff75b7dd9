// A GigE Vision / USB3 Vision camera (through Aravis) as a mocap Camera: configuration at open
// (pixel format, region, rate, exposure, gain, trigger), a capture thread popping buffers from an
// ArvStream, conversion to gray/BGR, frame-id gap and clock bookkeeping, and reopening with backoff
// when the camera vanishes.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "drivers/aravis/aravis_timing.h"
#include "drivers/camera_driver.h"

namespace mocap {

struct AravisOptions {
  // Buffers in the stream's pool: frames the camera can get ahead of the capture thread.
  uint32_t buffer_count = 8;
  // Upper bound on how long stop() waits for the capture thread to notice.
  std::chrono::milliseconds pop_timeout{100};
  // No frame for this long (and for at least 10 frame periods) while free-running means the
  // camera or its stream is gone; in trigger modes it only prompts a liveness read of the camera.
  std::chrono::milliseconds stall_timeout{3000};
  // Reopen delays after the camera vanished: doubled after each failed attempt, up to the max.
  std::chrono::milliseconds reopen_backoff_initial{250};
  std::chrono::milliseconds reopen_backoff_max{8000};
  // GigE Vision: receive through a packet socket when Aravis can (faster, needs CAP_NET_RAW).
  // Always off for a camera on the loopback interface, where it cannot see the stream.
  bool gv_packet_socket = true;
};

// Counters since open, readable from any thread.
struct AravisCameraStats {
  uint64_t delivered = 0;
  uint64_t dropped = 0;  // frame-id gaps: frames the camera sent that never arrived
  uint64_t corrupt = 0;  // delivered but incomplete (missing packets, timeout): flagged corrupt
  uint64_t failed = 0;   // buffers with no usable image (aborted, size mismatch): skipped
  uint64_t reopens = 0;
};

// One open of the device: the ArvCamera, its stream and the control-lost connection. Defined in
// aravis_camera.cpp so this header stays free of GLib.
struct AravisSession;

class AravisCamera final : public Camera {
 public:
  // Opens the device the config names (see AravisDriver) and configures it. Fails with a message
  // naming the camera and the requested and possible values, or Aravis' own GError message.
  static Expected<std::unique_ptr<AravisCamera>> open(const CameraConfig& config,
                                                      const AravisOptions& options);
  ~AravisCamera() override;

  // After open, modes holds exactly the configured mode.
  const CameraInfo& info() const override { return info_; }
  Status start(FrameSink frames, DriverEventSink events) override;
  void stop() override;
  // Executes TriggerSoftware; only in TriggerMode::kSoftware, while the camera is open.
  Status trigger() override;
  AravisCameraStats stats() const;

 private:
  AravisCamera(const CameraConfig& config, const AravisOptions& options);
  // Opens the device and applies the configuration; on the first open it also fills info_ and
  // fixes the device id, pixel format and mode every reopen must get again.
  Status openSession();
  Status configure(AravisSession& session);
  Status startStream(AravisSession& session);
  void closeSession();
  void captureLoop();
  // One pop (or timeout) of the stream; a lost camera is reported and closed.
  void captureOnce();
  void handleStall();
  void loseCamera(const std::string& reason);
  // Waits out the backoff and reopens until it works (true) or stop() is called (false).
  bool reopenWithBackoff();
  void report(const std::string& message);

  const CameraConfig config_;
  const AravisOptions options_;
  CameraInfo info_;
  std::string device_id_;           // what reopens open: the id the first open resolved
  uint32_t pixel_format_ = 0;       // fixed by the first open
  std::string configuration_note_;  // told to the event sink at start (settings not applied)

  // Written only by the thread that owns the camera (the opener, then the capture thread), under
  // session_mutex_ so trigger() can use the camera from another thread.
  std::unique_ptr<AravisSession> session_;
  mutable std::mutex session_mutex_;

  std::thread thread_;
  FrameSink frames_;
  DriverEventSink events_;
  std::mutex stop_mutex_;
  std::condition_variable stop_signal_;
  std::atomic<bool> stopping_{false};

  // Capture-thread state: the frame sequence continues across reopens.
  uint64_t next_sequence_ = 0;
  std::optional<uint64_t> last_frame_id_;
  uint32_t lost_since_delivery_ = 0;
  DeviceClockMapper clock_;
  std::chrono::steady_clock::time_point last_activity_;

  std::atomic<uint64_t> delivered_{0};
  std::atomic<uint64_t> dropped_{0};
  std::atomic<uint64_t> corrupt_{0};
  std::atomic<uint64_t> failed_{0};
  std::atomic<uint64_t> reopens_{0};
};

}  // namespace mocap
