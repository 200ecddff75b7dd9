// One open V4L2 capture node, spoken to through the syscall seam: capability query, mode
// enumeration, format and frame-rate negotiation, and the MMAP streaming buffers. Every error names
// the node, the ioctl and strerror(errno).
#pragma once

#include <linux/videodev2.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "drivers/camera_driver.h"
#include "drivers/status.h"
#include "drivers/v4l2/v4l2_syscalls.h"

namespace mocap {

std::string fourccToString(uint32_t fourcc);
// Accepts a FourCC ("YUYV", "GREY", "MJPG") and the alias "MJPEG"; nullopt otherwise.
std::optional<uint32_t> fourccFromString(const std::string& name);
// The pixel formats this driver can turn into frames, best first when the config names none.
const std::vector<uint32_t>& convertiblePixelFormats();
bool isConvertiblePixelFormat(uint32_t fourcc);
const char* ioctlName(unsigned long request);
std::string errnoText(int error);

// What the device granted after S_FMT / S_PARM adjusted the request.
struct NegotiatedFormat {
  uint32_t pixelformat = 0;
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t bytesperline = 0;
  uint32_t sizeimage = 0;
  double fps = 0;  // 0 when the device cannot set or report its frame interval
};

// A filled buffer, valid until it is requeued.
struct DequeuedBuffer {
  uint32_t index = 0;
  const uint8_t* data = nullptr;
  size_t bytesused = 0;
  uint32_t sequence = 0;
  uint32_t flags = 0;
  timeval timestamp{};
};

class V4l2Device {
 public:
  explicit V4l2Device(V4l2Syscalls& syscalls) : syscalls_(syscalls) {}
  ~V4l2Device() { close(); }
  V4l2Device(const V4l2Device&) = delete;
  V4l2Device& operator=(const V4l2Device&) = delete;

  // Opens the node non-blocking and queries its capabilities.
  Status open(const std::string& path);
  bool isOpen() const { return fd_ >= 0; }
  // Single-planar video capture with streaming I/O: what this driver can use.
  bool canCapture() const;
  const std::string& path() const { return path_; }
  const std::string& card() const { return card_; }
  // "/dev/video0 (Card Name)", for messages.
  std::string label() const;

  // Every pixel format the device lists, convertible or not.
  std::vector<uint32_t> pixelFormats();
  // Sizes and rates of the convertible formats (ENUM_FMT, ENUM_FRAMESIZES, ENUM_FRAMEINTERVALS).
  std::vector<VideoMode> modes();

  // S_FMT then G_FMT: the device adjusts rather than refuses, so the result says what it granted.
  Expected<NegotiatedFormat> setFormat(uint32_t pixelformat, uint32_t width, uint32_t height);
  // S_PARM; returns the interval the device rounded to, as fps (0 if it cannot set a rate).
  Expected<double> setFrameRate(double fps);

  // REQBUFS, QUERYBUF and mmap each buffer, QBUF all, STREAMON.
  Status startStreaming(uint32_t buffer_count);
  bool isStreaming() const { return streaming_; }
  // poll() for a filled buffer; returns the poll result and sets errno like poll().
  int waitForBuffer(int timeout_ms, short& revents);
  // 0 or the errno of VIDIOC_DQBUF (EAGAIN: nothing ready yet).
  int dequeue(DequeuedBuffer& buffer);
  // 0 or the errno of VIDIOC_QBUF.
  int requeue(uint32_t index);
  // STREAMOFF, munmap, REQBUFS(0), close: best effort, for a device that may already be gone.
  void close();

  // "/dev/video0: VIDIOC_DQBUF: No such device".
  std::string describe(const std::string& operation, int error) const;

 private:
  struct MappedBuffer {
    void* address = nullptr;
    size_t length = 0;
  };
  // ioctl retried on EINTR; 0 or errno.
  int xioctl(unsigned long request, void* arg);
  Status ioctlStatus(unsigned long request, void* arg);
  void releaseBuffers();

  V4l2Syscalls& syscalls_;
  int fd_ = -1;
  std::string path_;
  std::string card_;
  uint32_t device_caps_ = 0;
  std::vector<MappedBuffer> buffers_;
  bool streaming_ = false;
};

}  // namespace mocap
