// An emulation of the kernel side of V4L2 for tests: capture nodes speaking the real ioctl
// protocol with the structs of <linux/videodev2.h> (capabilities, format enumeration, the
// kernel's adjust-not-fail negotiation, MMAP buffer queues, poll), behind the driver's syscall
// seam. Frames appear only when the test emits them; faults (drops, error-flagged buffers,
// corrupt JPEG, a vanishing device) are injected on demand. Every call is logged per node, and
// calls a correct client never makes (double QBUF, REQBUFS while streaming, ...) are recorded as
// protocol violations.
#pragma once

#include <linux/videodev2.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "drivers/v4l2/v4l2_syscalls.h"

namespace mocap {

struct EmulatedFrameSize {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<double> fps;  // the discrete rates this size supports
};

struct EmulatedFormat {
  uint32_t pixelformat = 0;
  std::vector<EmulatedFrameSize> sizes;
};

struct EmulatedDeviceSpec {
  std::string path = "/dev/video0";
  std::string card = "Emulated UVC Camera";
  uint32_t device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
  std::vector<EmulatedFormat> formats;
  uint32_t timestamp_flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  uint32_t row_padding = 0;  // bytes beyond width * bytes-per-pixel in each row of raw formats
  uint32_t min_buffers = 2;
  uint32_t max_buffers = 32;
};

// A typical UVC webcam: YUYV 640x480 (30, 15 fps) and 320x240 (30 fps), GREY 640x480 (30 fps),
// MJPG 1280x720 and 640x480 (60, 30 fps).
EmulatedDeviceSpec webcamSpec(const std::string& path = "/dev/video0");
// A UVC metadata node, as every UVC camera exposes next to its capture node.
EmulatedDeviceSpec metadataNodeSpec(const std::string& path);

struct EmittedFrame {
  std::vector<uint8_t> payload;         // empty: a generated pattern in the current format
  std::optional<int64_t> timestamp_ns;  // empty: the producer clock, advanced one frame interval
  uint32_t lost_before = 0;             // sequence numbers skipped before this frame (drops)
  bool error_flag = false;              // V4L2_BUF_FLAG_ERROR
  bool corrupt_mjpeg = false;           // payload replaced by a JPEG that cannot be decoded
};

class EmulatedV4l2 final : public V4l2Syscalls {
 public:
  EmulatedV4l2();
  ~EmulatedV4l2() override;
  void addDevice(const EmulatedDeviceSpec& spec);

  // The sensor finishes a frame: fills the oldest queued buffer and moves it to the done queue.
  // False when the node is not streaming or no buffer was queued (the frame is lost, and its
  // sequence number with it, as in the kernel).
  bool emitFrame(const std::string& path, const EmittedFrame& frame = {});
  // Unplug: every call on open files fails with ENODEV, open() with ENOENT; mapped memory stays
  // valid until munmap, as in the kernel.
  void vanish(const std::string& path);
  // Plug back in: a fresh device (default format, no buffers, sequence from 0).
  void reappear(const std::string& path);

  // Waits until the node streams with at least one buffer queued, i.e. emitFrame() would land.
  bool waitForQueuedBuffer(const std::string& path, std::chrono::milliseconds timeout);
  // Waits until no file of the node is open and no buffer memory is mapped.
  bool waitForRelease(const std::string& path, std::chrono::milliseconds timeout);

  // The calls seen on a node, in order: "open", "VIDIOC_S_FMT", "mmap", ..., with " -> ERRNO"
  // appended to failures.
  std::vector<std::string> calls(const std::string& path) const;
  std::vector<std::string> violations() const;
  size_t openFileCount(const std::string& path) const;
  size_t mappingCount() const;
  v4l2_pix_format currentFormat(const std::string& path) const;

  std::vector<std::string> listDeviceNodes() override;
  int open(const std::string& path, int flags) override;
  int close(int fd) override;
  int ioctl(int fd, unsigned long request, void* arg) override;
  void* mmap(size_t length, int prot, int flags, int fd, off_t offset) override;
  int munmap(void* address, size_t length) override;
  int poll(pollfd* fds, nfds_t count, int timeout_ms) override;

 private:
  struct Instance;
  struct Node;
  struct OpenFile;
  struct Mapping;

  // Each returns 0 or an errno; called with mutex_ held.
  int dispatch(std::unique_lock<std::mutex>& lock, int fd, OpenFile& file, unsigned long request,
               void* arg);
  static std::shared_ptr<Instance> pluggedIn(const EmulatedDeviceSpec& spec);
  int setFormat(Instance& device, v4l2_format& format, bool apply);
  int setParm(Instance& device, v4l2_streamparm& parm);
  int requestBuffers(Instance& device, int fd, v4l2_requestbuffers& request);
  int queryBuffer(Instance& device, v4l2_buffer& buffer);
  int queueBuffer(Instance& device, int fd, v4l2_buffer& buffer);
  int dequeueBuffer(std::unique_lock<std::mutex>& lock, std::shared_ptr<Instance> device, int fd,
                    OpenFile& file, v4l2_buffer& buffer);
  int streamOn(Instance& device, int fd);
  void streamOff(Instance& device);
  short pollEvents(int fd) const;
  int violation(const std::string& what, int error);
  void log(const std::string& path, const std::string& call, int error);

  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<std::string> order_;  // node paths in the order they were added
  std::map<std::string, std::unique_ptr<Node>> nodes_;
  std::map<int, std::unique_ptr<OpenFile>> files_;
  std::map<void*, std::unique_ptr<Mapping>> mappings_;
  std::vector<std::string> violations_;
  int next_fd_ = 100;
};

}  // namespace mocap
