// The emulation's MMAP buffer queue: VIDIOC_REQBUFS, QUERYBUF, QBUF, DQBUF, STREAMON/OFF, and
// the mmap, munmap and poll calls on it, as vb2 behaves.
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>

#include "tests/drivers/v4l2/emulated_v4l2_device.h"
#include "tests/drivers/v4l2/emulated_v4l2_internal.h"

namespace mocap {

using v4l2_emulation::BufferState;
using v4l2_emulation::EmulatedBuffer;
using v4l2_emulation::kCaptureType;
using v4l2_emulation::kOffsetShift;

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
