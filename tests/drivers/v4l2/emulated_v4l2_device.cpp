// The emulated kernel side of V4L2: devices plugged in and out, frames emitted by the test, open,
// close and ioctl dispatch. Format negotiation and the buffer queue have files of their own.
#include "tests/drivers/v4l2/emulated_v4l2_device.h"

#include <fcntl.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "drivers/v4l2/v4l2_device.h"
#include "tests/drivers/v4l2/emulated_v4l2_internal.h"

namespace mocap {
namespace {

using v4l2_emulation::adjustedFormat;
using v4l2_emulation::BufferState;
using v4l2_emulation::EmulatedBuffer;
using v4l2_emulation::findFormat;
using v4l2_emulation::findSize;
using v4l2_emulation::intervalOf;
using v4l2_emulation::kCaptureType;
using v4l2_emulation::ratesOf;

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

}  // namespace mocap
