// The emulated kernel side of V4L2: node and buffer-queue state machines behind the syscall seam.
#include "tests/drivers/v4l2/emulated_v4l2_device.h"

#include <fcntl.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "drivers/v4l2/v4l2_device.h"

namespace mocap {
namespace {

constexpr uint32_t kCaptureType = V4L2_BUF_TYPE_VIDEO_CAPTURE;
// Buffer i is mapped at offset i << kOffsetShift: unique, page aligned, larger than any buffer.
constexpr int kOffsetShift = 24;

enum class BufferState { kDequeued, kQueued, kDone };

v4l2_fract intervalOf(double fps) {
  if (std::abs(fps - std::round(fps)) < 1e-9) return {1, static_cast<uint32_t>(std::lround(fps))};
  return {1000, static_cast<uint32_t>(std::lround(fps * 1000))};
}

uint32_t bytesPerPixel(uint32_t pixelformat) {
  switch (pixelformat) {
    case V4L2_PIX_FMT_YUYV:
      return 2;
    case V4L2_PIX_FMT_GREY:
      return 1;
    default:
      return 0;  // compressed
  }
}

template <size_t N>
void copyText(__u8 (&field)[N], const std::string& text) {
  std::memset(field, 0, N);
  std::memcpy(field, text.data(), std::min(text.size(), N - 1));
}

std::string errnoName(int error) {
  switch (error) {
    case EINVAL:
      return "EINVAL";
    case EBUSY:
      return "EBUSY";
    case EAGAIN:
      return "EAGAIN";
    case ENODEV:
      return "ENODEV";
    case ENOENT:
      return "ENOENT";
    case EBADF:
      return "EBADF";
    case ENOTTY:
      return "ENOTTY";
    default:
      return std::to_string(error);
  }
}

std::vector<uint8_t> generatedPayload(const v4l2_pix_format& format) {
  std::vector<uint8_t> payload;
  if (format.pixelformat == V4L2_PIX_FMT_MJPEG) {
    cv::Mat gradient(static_cast<int>(format.height), static_cast<int>(format.width), CV_8UC3);
    for (int y = 0; y < gradient.rows; ++y) {
      for (int x = 0; x < gradient.cols; ++x) {
        gradient.at<cv::Vec3b>(y, x) = cv::Vec3b(x & 0xff, y & 0xff, (x + y) & 0xff);
      }
    }
    cv::imencode(".jpg", gradient, payload);
    return payload;
  }
  payload.assign(format.sizeimage, 0);
  for (uint32_t y = 0; y < format.height; ++y) {
    uint8_t* row = payload.data() + y * format.bytesperline;
    for (uint32_t x = 0; x < format.width; ++x) {
      const auto luma = static_cast<uint8_t>((x + y) & 0xff);
      if (format.pixelformat == V4L2_PIX_FMT_GREY) {
        row[x] = luma;
      } else {
        row[2 * x] = luma;
        row[2 * x + 1] = 128;  // neutral chroma
      }
    }
  }
  return payload;
}

// Starts like a JPEG, then holds no decodable image at all.
std::vector<uint8_t> corruptJpegPayload() {
  std::vector<uint8_t> payload = {0xFF, 0xD8};
  payload.insert(payload.end(), 512, 0x5A);
  payload.push_back(0xFF);
  payload.push_back(0xD9);
  return payload;
}

struct EmulatedBuffer {
  std::shared_ptr<std::vector<uint8_t>> memory;
  BufferState state = BufferState::kDequeued;
  uint32_t mapped = 0;
  uint32_t bytesused = 0;
  uint32_t sequence = 0;
  uint32_t flags = 0;
  timeval timestamp{};
};

}  // namespace

// One plug-in of a device: what an open file talks to. A vanished instance stays dead.
struct EmulatedV4l2::Instance {
  EmulatedDeviceSpec spec;
  bool alive = true;
  v4l2_pix_format format{};
  double fps = 0;
  int owner_fd = -1;  // the file that allocated the buffers, as vb2 ties a queue to its owner
  std::vector<EmulatedBuffer> buffers;
  std::deque<uint32_t> queued;
  std::deque<uint32_t> done;
  bool streaming = false;
  uint32_t sequence = 0;
  int64_t clock_ns = 1'000'000'000'000;  // the producer clock: 1000 s after boot
};

struct EmulatedV4l2::Node {
  EmulatedDeviceSpec spec;
  std::shared_ptr<Instance> instance;  // null while unplugged
  std::vector<std::string> calls;
};

struct EmulatedV4l2::OpenFile {
  std::string path;
  std::shared_ptr<Instance> device;
  bool nonblocking = false;
};

struct EmulatedV4l2::Mapping {
  std::string path;
  std::shared_ptr<std::vector<uint8_t>> memory;  // outlives REQBUFS(0), close and unplug
  std::weak_ptr<Instance> device;
  uint32_t index = 0;
  uint32_t count = 0;
};

namespace {

const EmulatedFormat* findFormat(const EmulatedDeviceSpec& spec, uint32_t pixelformat) {
  for (const EmulatedFormat& format : spec.formats) {
    if (format.pixelformat == pixelformat) return &format;
  }
  return nullptr;
}

const EmulatedFrameSize* findSize(const EmulatedFormat& format, uint32_t width, uint32_t height) {
  for (const EmulatedFrameSize& size : format.sizes) {
    if (size.width == width && size.height == height) return &size;
  }
  return nullptr;
}

// The kernel's adjust-not-fail rule: the nearest listed size of a supported format.
v4l2_pix_format adjustedFormat(const EmulatedDeviceSpec& spec, const v4l2_pix_format& requested) {
  const EmulatedFormat* format = findFormat(spec, requested.pixelformat);
  if (format == nullptr) format = &spec.formats.front();
  const EmulatedFrameSize* nearest = &format->sizes.front();
  for (const EmulatedFrameSize& size : format->sizes) {
    const auto distance = [&](const EmulatedFrameSize& s) {
      return std::abs(static_cast<int64_t>(s.width) - requested.width) +
             std::abs(static_cast<int64_t>(s.height) - requested.height);
    };
    if (distance(size) < distance(*nearest)) nearest = &size;
  }
  v4l2_pix_format adjusted{};
  adjusted.pixelformat = format->pixelformat;
  adjusted.width = nearest->width;
  adjusted.height = nearest->height;
  adjusted.field = V4L2_FIELD_NONE;
  adjusted.colorspace = V4L2_COLORSPACE_SRGB;
  const uint32_t bpp = bytesPerPixel(format->pixelformat);
  if (bpp > 0) {
    adjusted.bytesperline = adjusted.width * bpp + spec.row_padding;
    adjusted.sizeimage = adjusted.bytesperline * adjusted.height;
  } else {
    // As UVC does for MJPEG: no line pitch, and a worst-case frame size (headers included).
    adjusted.sizeimage = std::max<uint32_t>(adjusted.width * adjusted.height * 2, 64 * 1024);
  }
  return adjusted;
}

std::vector<double> ratesOf(const EmulatedDeviceSpec& spec, const v4l2_pix_format& format) {
  const EmulatedFormat* listed = findFormat(spec, format.pixelformat);
  const EmulatedFrameSize* size = listed ? findSize(*listed, format.width, format.height) : nullptr;
  return size ? size->fps : std::vector<double>{};
}

}  // namespace

EmulatedDeviceSpec webcamSpec(const std::string& path) {
  EmulatedDeviceSpec spec;
  spec.path = path;
  spec.formats = {
      {V4L2_PIX_FMT_YUYV, {{640, 480, {30, 15}}, {320, 240, {30}}}},
      {V4L2_PIX_FMT_GREY, {{640, 480, {30}}}},
      {V4L2_PIX_FMT_MJPEG, {{1280, 720, {60, 30}}, {640, 480, {60, 30}}}},
  };
  return spec;
}

EmulatedDeviceSpec metadataNodeSpec(const std::string& path) {
  EmulatedDeviceSpec spec;
  spec.path = path;
  spec.device_caps = V4L2_CAP_META_CAPTURE | V4L2_CAP_STREAMING;
  spec.formats = {{v4l2_fourcc('U', 'V', 'C', 'H'), {{0, 0, {}}}}};
  return spec;
}

std::shared_ptr<EmulatedV4l2::Instance> EmulatedV4l2::pluggedIn(const EmulatedDeviceSpec& spec) {
  auto instance = std::make_shared<EmulatedV4l2::Instance>();
  instance->spec = spec;
  v4l2_pix_format first{};
  first.pixelformat = spec.formats.front().pixelformat;
  first.width = spec.formats.front().sizes.front().width;
  first.height = spec.formats.front().sizes.front().height;
  instance->format = adjustedFormat(spec, first);
  const std::vector<double> rates = ratesOf(spec, instance->format);
  instance->fps = rates.empty() ? 0 : rates.front();
  return instance;
}

EmulatedV4l2::EmulatedV4l2() = default;
EmulatedV4l2::~EmulatedV4l2() = default;

void EmulatedV4l2::addDevice(const EmulatedDeviceSpec& spec) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto node = std::make_unique<Node>();
  node->spec = spec;
  node->instance = pluggedIn(spec);
  order_.push_back(spec.path);
  nodes_[spec.path] = std::move(node);
}

void EmulatedV4l2::log(const std::string& path, const std::string& call, int error) {
  auto node = nodes_.find(path);
  if (node == nodes_.end()) return;
  node->second->calls.push_back(error == 0 ? call : call + " -> " + errnoName(error));
}

int EmulatedV4l2::violation(const std::string& what, int error) {
  violations_.push_back(what + " -> " + errnoName(error));
  return error;
}

bool EmulatedV4l2::emitFrame(const std::string& path, const EmittedFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto node = nodes_.find(path);
  if (node == nodes_.end() || !node->second->instance) return false;
  Instance& device = *node->second->instance;
  if (!device.streaming) return false;
  device.sequence += frame.lost_before;
  const int64_t interval_ns = device.fps > 0 ? std::llround(1e9 / device.fps) : 33'333'333;
  device.clock_ns = frame.timestamp_ns.value_or(device.clock_ns + interval_ns);
  if (device.queued.empty()) {
    ++device.sequence;  // No buffer to fill: the frame is lost, as in the kernel.
    return false;
  }
  const uint32_t index = device.queued.front();
  device.queued.pop_front();
  EmulatedBuffer& buffer = device.buffers[index];
  const std::vector<uint8_t> payload = frame.corrupt_mjpeg     ? corruptJpegPayload()
                                       : frame.payload.empty() ? generatedPayload(device.format)
                                                               : frame.payload;
  const size_t bytes = std::min(payload.size(), buffer.memory->size());
  std::copy_n(payload.begin(), bytes, buffer.memory->begin());
  buffer.bytesused = static_cast<uint32_t>(bytes);
  buffer.sequence = device.sequence++;
  buffer.flags = device.spec.timestamp_flags | (frame.error_flag ? V4L2_BUF_FLAG_ERROR : 0);
  buffer.timestamp.tv_sec = device.clock_ns / 1'000'000'000;
  buffer.timestamp.tv_usec = (device.clock_ns % 1'000'000'000) / 1'000;
  buffer.state = BufferState::kDone;
  device.done.push_back(index);
  changed_.notify_all();
  return true;
}

void EmulatedV4l2::vanish(const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  Node& node = *nodes_.at(path);
  if (node.instance) node.instance->alive = false;
  node.instance = nullptr;
  changed_.notify_all();
}

void EmulatedV4l2::reappear(const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  Node& node = *nodes_.at(path);
  node.instance = pluggedIn(node.spec);
  changed_.notify_all();
}

bool EmulatedV4l2::waitForQueuedBuffer(const std::string& path, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  const Node& node = *nodes_.at(path);
  return changed_.wait_for(lock, timeout, [&] {
    return node.instance && node.instance->streaming && !node.instance->queued.empty();
  });
}

bool EmulatedV4l2::waitForRelease(const std::string& path, std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] {
    const bool file_open = std::any_of(files_.begin(), files_.end(),
                                       [&](const auto& file) { return file.second->path == path; });
    const bool mapped = std::any_of(mappings_.begin(), mappings_.end(),
                                    [&](const auto& map) { return map.second->path == path; });
    return !file_open && !mapped;
  });
}

std::vector<std::string> EmulatedV4l2::calls(const std::string& path) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return nodes_.at(path)->calls;
}

std::vector<std::string> EmulatedV4l2::violations() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return violations_;
}

size_t EmulatedV4l2::openFileCount(const std::string& path) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::count_if(files_.begin(), files_.end(),
                       [&](const auto& file) { return file.second->path == path; });
}

size_t EmulatedV4l2::mappingCount() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return mappings_.size();
}

v4l2_pix_format EmulatedV4l2::currentFormat(const std::string& path) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const Node& node = *nodes_.at(path);
  return node.instance ? node.instance->format : v4l2_pix_format{};
}

std::vector<std::string> EmulatedV4l2::listDeviceNodes() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> present;
  for (const std::string& path : order_) {
    if (nodes_.at(path)->instance) present.push_back(path);
  }
  return present;
}

int EmulatedV4l2::open(const std::string& path, int flags) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto node = nodes_.find(path);
  if (node == nodes_.end() || !node->second->instance) {
    log(path, "open", ENOENT);
    errno = ENOENT;
    return -1;
  }
  const int fd = next_fd_++;
  files_[fd] =
      std::make_unique<OpenFile>(OpenFile{path, node->second->instance, (flags & O_NONBLOCK) != 0});
  log(path, "open", 0);
  return fd;
}

int EmulatedV4l2::close(int fd) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto file = files_.find(fd);
  if (file == files_.end()) {
    errno = violation("close of unknown fd " + std::to_string(fd), EBADF);
    return -1;
  }
  Instance& device = *file->second->device;
  if (device.owner_fd == fd) {
    // Closing the owner releases its queue; mapped memory lives on until munmap.
    streamOff(device);
    device.buffers.clear();
    device.owner_fd = -1;
  }
  log(file->second->path, "close", 0);
  files_.erase(file);
  changed_.notify_all();
  return 0;
}

int EmulatedV4l2::ioctl(int fd, unsigned long request, void* arg) {
  std::unique_lock<std::mutex> lock(mutex_);
  auto file = files_.find(fd);
  if (file == files_.end()) {
    errno = violation(std::string(ioctlName(request)) + " on unknown fd", EBADF);
    return -1;
  }
  const std::string path = file->second->path;
  const int error =
      file->second->device->alive ? dispatch(lock, fd, *file->second, request, arg) : ENODEV;
  log(path, ioctlName(request), error);
  if (error != 0) {
    errno = error;
    return -1;
  }
  return 0;
}

int EmulatedV4l2::dispatch(std::unique_lock<std::mutex>& lock, int fd, OpenFile& file,
                           unsigned long request, void* arg) {
  Instance& device = *file.device;
  const EmulatedDeviceSpec& spec = device.spec;
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto& capability = *static_cast<v4l2_capability*>(arg);
      capability = {};
      copyText(capability.driver, "emulated");
      copyText(capability.card, spec.card);
      copyText(capability.bus_info, "usb-emulated-" + spec.path);
      capability.version = (6 << 16) | (1 << 8);  // kernel 6.1, as KERNEL_VERSION encodes it
      capability.device_caps = spec.device_caps;
      capability.capabilities = spec.device_caps | V4L2_CAP_DEVICE_CAPS;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto& description = *static_cast<v4l2_fmtdesc*>(arg);
      if (description.type != kCaptureType || description.index >= spec.formats.size()) {
        return EINVAL;
      }
      const uint32_t pixelformat = spec.formats[description.index].pixelformat;
      description.pixelformat = pixelformat;
      description.flags = pixelformat == V4L2_PIX_FMT_MJPEG ? V4L2_FMT_FLAG_COMPRESSED : 0;
      copyText(description.description, fourccToString(pixelformat));
      return 0;
    }
    case VIDIOC_ENUM_FRAMESIZES: {
      auto& size = *static_cast<v4l2_frmsizeenum*>(arg);
      const EmulatedFormat* format = findFormat(spec, size.pixel_format);
      if (format == nullptr || size.index >= format->sizes.size()) return EINVAL;
      size.type = V4L2_FRMSIZE_TYPE_DISCRETE;
      size.discrete = {format->sizes[size.index].width, format->sizes[size.index].height};
      return 0;
    }
    case VIDIOC_ENUM_FRAMEINTERVALS: {
      auto& interval = *static_cast<v4l2_frmivalenum*>(arg);
      const EmulatedFormat* format = findFormat(spec, interval.pixel_format);
      const EmulatedFrameSize* size =
          format ? findSize(*format, interval.width, interval.height) : nullptr;
      if (size == nullptr || interval.index >= size->fps.size()) return EINVAL;
      interval.type = V4L2_FRMIVAL_TYPE_DISCRETE;
      interval.discrete = intervalOf(size->fps[interval.index]);
      return 0;
    }
    case VIDIOC_G_FMT: {
      auto& format = *static_cast<v4l2_format*>(arg);
      if (format.type != kCaptureType) return EINVAL;
      format.fmt.pix = device.format;
      return 0;
    }
    case VIDIOC_S_FMT:
    case VIDIOC_TRY_FMT:
      return setFormat(device, *static_cast<v4l2_format*>(arg), request == VIDIOC_S_FMT);
    case VIDIOC_G_PARM: {
      auto& parm = *static_cast<v4l2_streamparm*>(arg);
      if (parm.type != kCaptureType) return EINVAL;
      parm.parm.capture = {};
      parm.parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
      parm.parm.capture.timeperframe = intervalOf(device.fps);
      return 0;
    }
    case VIDIOC_S_PARM:
      return setParm(device, *static_cast<v4l2_streamparm*>(arg));
    case VIDIOC_REQBUFS:
      return requestBuffers(device, fd, *static_cast<v4l2_requestbuffers*>(arg));
    case VIDIOC_QUERYBUF:
      return queryBuffer(device, *static_cast<v4l2_buffer*>(arg));
    case VIDIOC_QBUF:
      return queueBuffer(device, fd, *static_cast<v4l2_buffer*>(arg));
    case VIDIOC_DQBUF:
      return dequeueBuffer(lock, file.device, fd, file, *static_cast<v4l2_buffer*>(arg));
    case VIDIOC_STREAMON:
      if (*static_cast<int*>(arg) != static_cast<int>(kCaptureType)) return EINVAL;
      return streamOn(device, fd);
    case VIDIOC_STREAMOFF:
      if (*static_cast<int*>(arg) != static_cast<int>(kCaptureType)) return EINVAL;
      if (device.owner_fd >= 0 && device.owner_fd != fd) {
        return violation("VIDIOC_STREAMOFF by a file that does not own the queue", EBUSY);
      }
      streamOff(device);
      return 0;
    default:
      return ENOTTY;
  }
}

int EmulatedV4l2::setFormat(Instance& device, v4l2_format& format, bool apply) {
  if (format.type != kCaptureType) return EINVAL;
  const v4l2_pix_format adjusted = adjustedFormat(device.spec, format.fmt.pix);
  if (apply) {
    // vb2_is_busy: the format fixes the buffer size, so it cannot change under allocated buffers.
    if (!device.buffers.empty()) return violation("VIDIOC_S_FMT with buffers allocated", EBUSY);
    device.format = adjusted;
    const std::vector<double> rates = ratesOf(device.spec, adjusted);
    if (std::find(rates.begin(), rates.end(), device.fps) == rates.end()) {
      device.fps = rates.empty() ? 0 : rates.front();
    }
  }
  format.fmt.pix = adjusted;
  return 0;
}

int EmulatedV4l2::setParm(Instance& device, v4l2_streamparm& parm) {
  if (parm.type != kCaptureType) return EINVAL;
  const v4l2_fract requested = parm.parm.capture.timeperframe;
  const std::vector<double> rates = ratesOf(device.spec, device.format);
  if (requested.numerator != 0 && requested.denominator != 0 && !rates.empty()) {
    const double wanted = static_cast<double>(requested.denominator) / requested.numerator;
    device.fps = *std::min_element(rates.begin(), rates.end(), [&](double a, double b) {
      return std::abs(a - wanted) < std::abs(b - wanted);
    });
  }
  parm.parm.capture = {};
  parm.parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
  parm.parm.capture.timeperframe = intervalOf(device.fps);
  return 0;
}

int EmulatedV4l2::requestBuffers(Instance& device, int fd, v4l2_requestbuffers& request) {
  if (request.type != kCaptureType || request.memory != V4L2_MEMORY_MMAP) {
    return violation("VIDIOC_REQBUFS with an unsupported type or memory", EINVAL);
  }
  if (device.owner_fd >= 0 && device.owner_fd != fd) {
    return violation("VIDIOC_REQBUFS on a queue another file owns", EBUSY);
  }
  if (device.streaming) return violation("VIDIOC_REQBUFS while streaming", EBUSY);
  for (const EmulatedBuffer& buffer : device.buffers) {
    if (buffer.mapped > 0) return violation("VIDIOC_REQBUFS while buffers are mapped", EBUSY);
  }
  device.buffers.clear();
  device.queued.clear();
  device.done.clear();
  request.capabilities = V4L2_BUF_CAP_SUPPORTS_MMAP;
  if (request.count == 0) {
    device.owner_fd = -1;
    return 0;
  }
  request.count = std::clamp(request.count, device.spec.min_buffers, device.spec.max_buffers);
  device.buffers.resize(request.count);
  for (EmulatedBuffer& buffer : device.buffers) {
    buffer.memory = std::make_shared<std::vector<uint8_t>>(device.format.sizeimage);
  }
  device.owner_fd = fd;
  return 0;
}

int EmulatedV4l2::queryBuffer(Instance& device, v4l2_buffer& buffer) {
  if (buffer.type != kCaptureType || buffer.memory != V4L2_MEMORY_MMAP) {
    return violation("VIDIOC_QUERYBUF with an unsupported type or memory", EINVAL);
  }
  if (buffer.index >= device.buffers.size()) {
    return violation("VIDIOC_QUERYBUF of buffer " + std::to_string(buffer.index), EINVAL);
  }
  const EmulatedBuffer& state = device.buffers[buffer.index];
  buffer.length = static_cast<uint32_t>(state.memory->size());
  buffer.m.offset = buffer.index << kOffsetShift;
  buffer.bytesused = state.bytesused;
  buffer.sequence = state.sequence;
  buffer.timestamp = state.timestamp;
  buffer.flags = device.spec.timestamp_flags | (state.mapped ? V4L2_BUF_FLAG_MAPPED : 0) |
                 (state.state == BufferState::kQueued ? V4L2_BUF_FLAG_QUEUED : 0) |
                 (state.state == BufferState::kDone ? V4L2_BUF_FLAG_DONE : 0);
  return 0;
}

int EmulatedV4l2::queueBuffer(Instance& device, int fd, v4l2_buffer& buffer) {
  if (device.owner_fd != fd) return violation("VIDIOC_QBUF by a file that owns no buffers", EBUSY);
  if (buffer.type != kCaptureType || buffer.memory != V4L2_MEMORY_MMAP) {
    return violation("VIDIOC_QBUF with an unsupported type or memory", EINVAL);
  }
  if (buffer.index >= device.buffers.size()) {
    return violation("VIDIOC_QBUF of buffer " + std::to_string(buffer.index), EINVAL);
  }
  EmulatedBuffer& state = device.buffers[buffer.index];
  if (state.state != BufferState::kDequeued) {
    return violation(
        "VIDIOC_QBUF of buffer " + std::to_string(buffer.index) + ", which is already queued",
        EINVAL);
  }
  state.state = BufferState::kQueued;
  device.queued.push_back(buffer.index);
  buffer.flags = device.spec.timestamp_flags | V4L2_BUF_FLAG_QUEUED |
                 (state.mapped ? V4L2_BUF_FLAG_MAPPED : 0);
  changed_.notify_all();
  return 0;
}

int EmulatedV4l2::dequeueBuffer(std::unique_lock<std::mutex>& lock,
                                std::shared_ptr<Instance> device, int fd, OpenFile& file,
                                v4l2_buffer& buffer) {
  if (device->owner_fd != fd)
    return violation("VIDIOC_DQBUF by a file that owns no buffers", EBUSY);
  if (buffer.type != kCaptureType || buffer.memory != V4L2_MEMORY_MMAP) {
    return violation("VIDIOC_DQBUF with an unsupported type or memory", EINVAL);
  }
  const bool nonblocking = file.nonblocking;
  for (;;) {
    if (!device->alive) return ENODEV;
    if (files_.count(fd) == 0) return EBADF;
    if (!device->streaming) return violation("VIDIOC_DQBUF while not streaming", EINVAL);
    if (!device->done.empty()) break;
    if (nonblocking) return EAGAIN;
    changed_.wait(lock);
  }
  const uint32_t index = device->done.front();
  device->done.pop_front();
  EmulatedBuffer& state = device->buffers[index];
  state.state = BufferState::kDequeued;
  buffer.index = index;
  buffer.bytesused = state.bytesused;
  buffer.length = static_cast<uint32_t>(state.memory->size());
  buffer.m.offset = index << kOffsetShift;
  buffer.sequence = state.sequence;
  buffer.flags = state.flags | (state.mapped ? V4L2_BUF_FLAG_MAPPED : 0);
  buffer.timestamp = state.timestamp;
  buffer.field = V4L2_FIELD_NONE;
  return 0;
}

int EmulatedV4l2::streamOn(Instance& device, int fd) {
  if (device.owner_fd != fd) return violation("VIDIOC_STREAMON without buffers", EINVAL);
  if (device.streaming) return 0;
  device.streaming = true;
  device.sequence = 0;
  changed_.notify_all();
  return 0;
}

void EmulatedV4l2::streamOff(Instance& device) {
  // STREAMOFF hands every buffer back to the application, filled or not.
  device.streaming = false;
  for (EmulatedBuffer& buffer : device.buffers) buffer.state = BufferState::kDequeued;
  device.queued.clear();
  device.done.clear();
  device.sequence = 0;
  changed_.notify_all();
}

void* EmulatedV4l2::mmap(size_t length, int prot, int flags, int fd, off_t offset) {
  std::lock_guard<std::mutex> lock(mutex_);
  (void)prot;
  auto file = files_.find(fd);
  if (file == files_.end()) {
    errno = violation("mmap of unknown fd", EBADF);
    return MAP_FAILED;
  }
  const std::string& path = file->second->path;
  Instance& device = *file->second->device;
  int error = 0;
  const auto index = static_cast<uint32_t>(offset >> kOffsetShift);
  if (!device.alive) {
    error = ENODEV;
  } else if (!(flags & MAP_SHARED)) {
    error = violation("mmap without MAP_SHARED", EINVAL);
  } else if ((offset & ((off_t{1} << kOffsetShift) - 1)) != 0 || index >= device.buffers.size()) {
    error = violation("mmap of an offset no buffer has", EINVAL);
  } else if (length > device.buffers[index].memory->size()) {
    error = violation("mmap longer than the buffer", EINVAL);
  }
  log(path, "mmap", error);
  if (error != 0) {
    errno = error;
    return MAP_FAILED;
  }
  EmulatedBuffer& buffer = device.buffers[index];
  void* address = buffer.memory->data();
  auto& mapping = mappings_[address];
  if (!mapping) {
    mapping =
        std::make_unique<Mapping>(Mapping{path, buffer.memory, file->second->device, index, 0});
  }
  ++mapping->count;
  ++buffer.mapped;
  return address;
}

int EmulatedV4l2::munmap(void* address, size_t length) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto found = mappings_.find(address);
  if (found == mappings_.end() || length > found->second->memory->size()) {
    errno = violation("munmap of memory that is not a mapped buffer", EINVAL);
    return -1;
  }
  Mapping& mapping = *found->second;
  if (auto device = mapping.device.lock();
      device && mapping.index < device->buffers.size() &&
      device->buffers[mapping.index].memory == mapping.memory) {
    --device->buffers[mapping.index].mapped;
  }
  log(mapping.path, "munmap", 0);
  if (--mapping.count == 0) mappings_.erase(found);
  changed_.notify_all();
  return 0;
}

short EmulatedV4l2::pollEvents(int fd) const {
  auto file = files_.find(fd);
  if (file == files_.end()) return POLLNVAL;
  const Instance& device = *file->second->device;
  if (!device.alive) return POLLERR | POLLHUP;
  // As vb2_core_poll: an error while not streaming or with nothing queued to fill.
  if (!device.streaming) return POLLERR;
  if (!device.done.empty()) return POLLIN | POLLRDNORM;
  if (device.queued.empty()) return POLLERR;
  return 0;
}

int EmulatedV4l2::poll(pollfd* fds, nfds_t count, int timeout_ms) {
  std::unique_lock<std::mutex> lock(mutex_);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  for (;;) {
    int ready = 0;
    for (nfds_t i = 0; i < count; ++i) {
      fds[i].revents = static_cast<short>(pollEvents(fds[i].fd) &
                                          (fds[i].events | POLLERR | POLLHUP | POLLNVAL));
      if (fds[i].revents != 0) ++ready;
    }
    if (ready > 0 || timeout_ms == 0) return ready;
    if (timeout_ms < 0) {
      changed_.wait(lock);
    } else if (changed_.wait_until(lock, deadline) == std::cv_status::timeout) {
      timeout_ms = 0;  // One last look, then report the timeout.
    }
  }
}

}  // namespace mocap
