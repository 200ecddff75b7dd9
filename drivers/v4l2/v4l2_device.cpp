// One open V4L2 capture node: capability query, modes, negotiation and MMAP streaming buffers.
#include "drivers/v4l2/v4l2_device.h"

#include <fcntl.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

namespace mocap {
namespace {

constexpr uint32_t kCaptureType = V4L2_BUF_TYPE_VIDEO_CAPTURE;

// The kernel fills fixed-size char arrays, NUL-terminated unless the text fills them.
template <size_t N>
std::string fixedString(const __u8 (&text)[N]) {
  const auto* begin = reinterpret_cast<const char*>(text);
  return std::string(begin, strnlen(begin, N));
}

double fpsOf(const v4l2_fract& interval) {
  if (interval.numerator == 0 || interval.denominator == 0) return 0;
  return static_cast<double>(interval.denominator) / interval.numerator;
}

}  // namespace

std::string fourccToString(uint32_t fourcc) {
  std::string text;
  for (int shift = 0; shift < 32; shift += 8) {
    const char c = static_cast<char>((fourcc >> shift) & 0xff);
    if (c != ' ' && c != '\0') text += c;
  }
  return text;
}

std::optional<uint32_t> fourccFromString(const std::string& name) {
  if (name == "MJPEG") return V4L2_PIX_FMT_MJPEG;
  if (name.empty() || name.size() > 4) return std::nullopt;
  const std::string padded = name + std::string(4 - name.size(), ' ');
  return v4l2_fourcc(padded[0], padded[1], padded[2], padded[3]);
}

const std::vector<uint32_t>& convertiblePixelFormats() {
  // Uncompressed first: no decode cost and no compression artefacts on silhouettes.
  static const std::vector<uint32_t> formats = {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_YUYV,
                                                V4L2_PIX_FMT_MJPEG};
  return formats;
}

bool isConvertiblePixelFormat(uint32_t fourcc) {
  const auto& formats = convertiblePixelFormats();
  return std::find(formats.begin(), formats.end(), fourcc) != formats.end();
}

const char* ioctlName(unsigned long request) {
  switch (request) {
    case VIDIOC_QUERYCAP:
      return "VIDIOC_QUERYCAP";
    case VIDIOC_ENUM_FMT:
      return "VIDIOC_ENUM_FMT";
    case VIDIOC_ENUM_FRAMESIZES:
      return "VIDIOC_ENUM_FRAMESIZES";
    case VIDIOC_ENUM_FRAMEINTERVALS:
      return "VIDIOC_ENUM_FRAMEINTERVALS";
    case VIDIOC_G_FMT:
      return "VIDIOC_G_FMT";
    case VIDIOC_S_FMT:
      return "VIDIOC_S_FMT";
    case VIDIOC_TRY_FMT:
      return "VIDIOC_TRY_FMT";
    case VIDIOC_G_PARM:
      return "VIDIOC_G_PARM";
    case VIDIOC_S_PARM:
      return "VIDIOC_S_PARM";
    case VIDIOC_REQBUFS:
      return "VIDIOC_REQBUFS";
    case VIDIOC_QUERYBUF:
      return "VIDIOC_QUERYBUF";
    case VIDIOC_QBUF:
      return "VIDIOC_QBUF";
    case VIDIOC_DQBUF:
      return "VIDIOC_DQBUF";
    case VIDIOC_STREAMON:
      return "VIDIOC_STREAMON";
    case VIDIOC_STREAMOFF:
      return "VIDIOC_STREAMOFF";
    default:
      return "ioctl";
  }
}

std::string errnoText(int error) {
  char buffer[256];
  // The GNU strerror_r returns the message, which may or may not live in the buffer.
  return strerror_r(error, buffer, sizeof buffer);
}

std::string V4l2Device::describe(const std::string& operation, int error) const {
  return path_ + ": " + operation + ": " + errnoText(error);
}

std::string V4l2Device::label() const { return card_.empty() ? path_ : path_ + " (" + card_ + ")"; }

int V4l2Device::xioctl(unsigned long request, void* arg) {
  for (;;) {
    if (syscalls_.ioctl(fd_, request, arg) == 0) return 0;
    if (errno != EINTR) return errno;
  }
}

Status V4l2Device::ioctlStatus(unsigned long request, void* arg) {
  const int error = xioctl(request, arg);
  return error == 0 ? Status::Ok() : Status::Error(describe(ioctlName(request), error));
}

Status V4l2Device::open(const std::string& path) {
  close();
  path_ = path;
  // Non-blocking: the capture thread waits in poll() with a timeout, so stop() stays prompt.
  fd_ = syscalls_.open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) return Status::Error(describe("open", errno));
  v4l2_capability capability{};
  if (Status status = ioctlStatus(VIDIOC_QUERYCAP, &capability); !status.ok()) {
    close();
    return status;
  }
  card_ = fixedString(capability.card);
  device_caps_ = (capability.capabilities & V4L2_CAP_DEVICE_CAPS) ? capability.device_caps
                                                                  : capability.capabilities;
  return Status::Ok();
}

bool V4l2Device::canCapture() const {
  return (device_caps_ & V4L2_CAP_VIDEO_CAPTURE) && (device_caps_ & V4L2_CAP_STREAMING);
}

std::vector<uint32_t> V4l2Device::pixelFormats() {
  std::vector<uint32_t> formats;
  for (uint32_t index = 0;; ++index) {
    v4l2_fmtdesc description{};
    description.index = index;
    description.type = kCaptureType;
    if (xioctl(VIDIOC_ENUM_FMT, &description) != 0) break;
    formats.push_back(description.pixelformat);
  }
  return formats;
}

std::vector<VideoMode> V4l2Device::modes() {
  std::vector<VideoMode> modes;
  auto addSize = [&](uint32_t pixelformat, uint32_t width, uint32_t height) {
    VideoMode mode{static_cast<int>(width), static_cast<int>(height), 0,
                   fourccToString(pixelformat)};
    bool listed_interval = false;
    for (uint32_t index = 0;; ++index) {
      v4l2_frmivalenum interval{};
      interval.index = index;
      interval.pixel_format = pixelformat;
      interval.width = width;
      interval.height = height;
      if (xioctl(VIDIOC_ENUM_FRAMEINTERVALS, &interval) != 0) break;
      listed_interval = true;
      if (interval.type == V4L2_FRMIVAL_TYPE_DISCRETE) {
        mode.fps = fpsOf(interval.discrete);
        modes.push_back(mode);
      } else {
        // Stepwise or continuous: the shortest interval is the fastest rate.
        mode.fps = fpsOf(interval.stepwise.min);
        modes.push_back(mode);
        break;
      }
    }
    if (!listed_interval) modes.push_back(mode);
  };
  for (uint32_t pixelformat : pixelFormats()) {
    if (!isConvertiblePixelFormat(pixelformat)) continue;
    for (uint32_t index = 0;; ++index) {
      v4l2_frmsizeenum size{};
      size.index = index;
      size.pixel_format = pixelformat;
      if (xioctl(VIDIOC_ENUM_FRAMESIZES, &size) != 0) break;
      if (size.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
        addSize(pixelformat, size.discrete.width, size.discrete.height);
      } else {
        // A range: its two ends tell the user what to ask for.
        addSize(pixelformat, size.stepwise.min_width, size.stepwise.min_height);
        addSize(pixelformat, size.stepwise.max_width, size.stepwise.max_height);
        break;
      }
    }
  }
  return modes;
}

Expected<NegotiatedFormat> V4l2Device::setFormat(uint32_t pixelformat, uint32_t width,
                                                 uint32_t height) {
  v4l2_format format{};
  format.type = kCaptureType;
  format.fmt.pix.pixelformat = pixelformat;
  format.fmt.pix.width = width;
  format.fmt.pix.height = height;
  format.fmt.pix.field = V4L2_FIELD_NONE;
  if (Status status = ioctlStatus(VIDIOC_S_FMT, &format); !status.ok()) return status;
  // Read back what the device now holds rather than trusting the S_FMT reply alone.
  format = {};
  format.type = kCaptureType;
  if (Status status = ioctlStatus(VIDIOC_G_FMT, &format); !status.ok()) return status;
  NegotiatedFormat granted;
  granted.pixelformat = format.fmt.pix.pixelformat;
  granted.width = format.fmt.pix.width;
  granted.height = format.fmt.pix.height;
  granted.bytesperline = format.fmt.pix.bytesperline;
  granted.sizeimage = format.fmt.pix.sizeimage;
  return granted;
}

Expected<double> V4l2Device::setFrameRate(double fps) {
  v4l2_streamparm parameters{};
  parameters.type = kCaptureType;
  if (xioctl(VIDIOC_G_PARM, &parameters) != 0 ||
      !(parameters.parm.capture.capability & V4L2_CAP_TIMEPERFRAME)) {
    return 0.0;  // The device runs at its own rate and does not let us choose it.
  }
  if (fps > 0) {
    // Milli-frame precision keeps rates like 29.97 exact enough for rounding to a listed one.
    parameters.parm.capture.timeperframe.numerator = 1000;
    parameters.parm.capture.timeperframe.denominator =
        static_cast<uint32_t>(std::lround(fps * 1000));
    if (Status status = ioctlStatus(VIDIOC_S_PARM, &parameters); !status.ok()) return status;
  }
  return fpsOf(parameters.parm.capture.timeperframe);
}

Status V4l2Device::startStreaming(uint32_t buffer_count) {
  v4l2_requestbuffers request{};
  request.count = buffer_count;
  request.type = kCaptureType;
  request.memory = V4L2_MEMORY_MMAP;
  if (Status status = ioctlStatus(VIDIOC_REQBUFS, &request); !status.ok()) return status;
  buffers_.resize(request.count);
  if (request.count < 2) {
    releaseBuffers();
    return Status::Error(path_ + ": VIDIOC_REQBUFS granted " + std::to_string(request.count) +
                         " buffers; streaming needs at least 2");
  }
  for (uint32_t index = 0; index < request.count; ++index) {
    v4l2_buffer buffer{};
    buffer.index = index;
    buffer.type = kCaptureType;
    buffer.memory = V4L2_MEMORY_MMAP;
    if (Status status = ioctlStatus(VIDIOC_QUERYBUF, &buffer); !status.ok()) {
      releaseBuffers();
      return status;
    }
    void* address =
        syscalls_.mmap(buffer.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buffer.m.offset);
    if (address == MAP_FAILED) {
      const int error = errno;
      releaseBuffers();
      return Status::Error(describe("mmap", error));
    }
    buffers_[index] = {address, buffer.length};
  }
  for (uint32_t index = 0; index < request.count; ++index) {
    if (const int error = requeue(index); error != 0) {
      releaseBuffers();
      return Status::Error(describe("VIDIOC_QBUF", error));
    }
  }
  int type = kCaptureType;
  if (Status status = ioctlStatus(VIDIOC_STREAMON, &type); !status.ok()) {
    releaseBuffers();
    return status;
  }
  streaming_ = true;
  return Status::Ok();
}

int V4l2Device::waitForBuffer(int timeout_ms, short& revents) {
  pollfd descriptor{fd_, POLLIN, 0};
  const int ready = syscalls_.poll(&descriptor, 1, timeout_ms);
  revents = descriptor.revents;
  return ready;
}

int V4l2Device::dequeue(DequeuedBuffer& out) {
  v4l2_buffer buffer{};
  buffer.type = kCaptureType;
  buffer.memory = V4L2_MEMORY_MMAP;
  if (const int error = xioctl(VIDIOC_DQBUF, &buffer); error != 0) return error;
  if (buffer.index >= buffers_.size()) return EINVAL;
  const MappedBuffer& mapped = buffers_[buffer.index];
  out.index = buffer.index;
  out.data = static_cast<const uint8_t*>(mapped.address);
  out.bytesused = std::min<size_t>(buffer.bytesused, mapped.length);
  out.sequence = buffer.sequence;
  out.flags = buffer.flags;
  out.timestamp = buffer.timestamp;
  return 0;
}

int V4l2Device::requeue(uint32_t index) {
  v4l2_buffer buffer{};
  buffer.index = index;
  buffer.type = kCaptureType;
  buffer.memory = V4L2_MEMORY_MMAP;
  return xioctl(VIDIOC_QBUF, &buffer);
}

void V4l2Device::releaseBuffers() {
  if (streaming_) {
    int type = kCaptureType;
    xioctl(VIDIOC_STREAMOFF, &type);
    streaming_ = false;
  }
  if (buffers_.empty()) return;
  for (const MappedBuffer& buffer : buffers_) {
    if (buffer.address != nullptr) syscalls_.munmap(buffer.address, buffer.length);
  }
  buffers_.clear();
  // Frees the kernel's buffers now rather than at close; harmless when the device is gone.
  v4l2_requestbuffers request{};
  request.count = 0;
  request.type = kCaptureType;
  request.memory = V4L2_MEMORY_MMAP;
  xioctl(VIDIOC_REQBUFS, &request);
}

void V4l2Device::close() {
  if (fd_ < 0) return;
  releaseBuffers();
  syscalls_.close(fd_);
  fd_ = -1;
  device_caps_ = 0;
}

}  // namespace mocap
