// A V4L2 capture device as a mocap Camera: negotiation at open, a capture thread that polls,
// dequeues, converts and requeues MMAP buffers, and reopening with backoff when the device
// vanishes.
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

#include "drivers/camera_driver.h"
#include "drivers/v4l2/v4l2_convert.h"
#include "drivers/v4l2/v4l2_device.h"
#include "drivers/v4l2/v4l2_syscalls.h"

namespace mocap {

struct V4l2Options {
  uint32_t buffer_count = 4;
  V4l2ImageOutput output = V4l2ImageOutput::kBgr;
  // Upper bound on how long stop() waits for the capture thread to notice.
  std::chrono::milliseconds poll_timeout{100};
  // Reopen delays after the device vanished: doubled after each failed attempt, up to the max.
  std::chrono::milliseconds reopen_backoff_initial{250};
  std::chrono::milliseconds reopen_backoff_max{8000};
};

// Counters since open, readable from any thread.
struct V4l2CameraStats {
  uint64_t delivered = 0;
  uint64_t dropped = 0;      // sequence gaps reported by the device
  uint64_t corrupt = 0;      // delivered but flagged (V4L2_BUF_FLAG_ERROR or a short payload)
  uint64_t undecodable = 0;  // payloads that gave no image (corrupt JPEG): skipped
  uint64_t reopens = 0;
};

// Finds the node a config's `device` names: a path ("/dev/video2"), an index ("2" is
// /dev/video2), a card name as VIDIOC_QUERYCAP reports it, or empty for the first capture device.
Expected<std::string> resolveV4l2Device(V4l2Syscalls& syscalls, const std::string& device);

class V4l2Camera final : public Camera {
 public:
  // Opens and negotiates format and rate. Fails, naming the device and the requested and granted
  // values, when the device cannot deliver a convertible pixel format or the one the config names.
  static Expected<std::unique_ptr<V4l2Camera>> open(std::shared_ptr<V4l2Syscalls> syscalls,
                                                    const CameraConfig& config,
                                                    const V4l2Options& options);
  ~V4l2Camera() override;

  // After open, modes holds exactly the negotiated mode (the size the device granted).
  const CameraInfo& info() const override { return info_; }
  Status start(FrameSink frames, DriverEventSink events) override;
  void stop() override;
  V4l2CameraStats stats() const;

 private:
  V4l2Camera(std::shared_ptr<V4l2Syscalls> syscalls, const CameraConfig& config,
             const V4l2Options& options);
  // Resolves, opens and negotiates; on the first open it fixes the mode all later reopens must get.
  Status openAndNegotiate();
  Status chooseAndSetFormat();
  void captureLoop();
  // One poll/dequeue/convert/requeue round; a failed device is reported and closed.
  void captureOnce();
  void deliver(const DequeuedBuffer& buffer, std::optional<Frame>& frame);
  int64_t timestampOf(const DequeuedBuffer& buffer);
  void loseDevice(const std::string& reason);
  // Waits out the backoff and reopens until it works (true) or stop() is called (false).
  bool reopenWithBackoff();
  void report(const std::string& message);

  std::shared_ptr<V4l2Syscalls> syscalls_;
  const CameraConfig config_;
  const V4l2Options options_;
  V4l2Device device_;
  CameraInfo info_;
  NegotiatedFormat format_;
  std::string negotiation_note_;  // told to the event sink at start when the device adjusted

  std::thread thread_;
  FrameSink frames_;
  DriverEventSink events_;
  std::mutex stop_mutex_;
  std::condition_variable stop_signal_;
  std::atomic<bool> stopping_{false};

  // Capture-thread state: the frame sequence continues across reopens.
  uint64_t next_sequence_ = 0;
  std::optional<uint32_t> last_device_sequence_;
  uint32_t lost_since_delivery_ = 0;
  bool reported_clock_fallback_ = false;

  std::atomic<uint64_t> delivered_{0};
  std::atomic<uint64_t> dropped_{0};
  std::atomic<uint64_t> corrupt_{0};
  std::atomic<uint64_t> undecodable_{0};
  std::atomic<uint64_t> reopens_{0};
};

}  // namespace mocap
