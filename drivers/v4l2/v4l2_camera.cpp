// The V4L2 Camera: negotiation, the capture thread, frame bookkeeping and reopen-with-backoff.
#include "drivers/v4l2/v4l2_camera.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <span>

#include "drivers/thread_name.h"

namespace mocap {
namespace {

bool isDigits(const std::string& text) {
  return !text.empty() &&
         std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::string formatList(const std::vector<uint32_t>& formats) {
  std::string text;
  for (uint32_t format : formats) text += (text.empty() ? "" : ", ") + fourccToString(format);
  return text.empty() ? "none" : text;
}

std::string describeMode(uint32_t width, uint32_t height, double fps, const std::string& format) {
  char rate[32];
  std::snprintf(rate, sizeof rate, "%g", fps);
  std::string text = std::to_string(width) + "x" + std::to_string(height);
  if (fps > 0) text += std::string(" @ ") + rate + " fps";
  return format.empty() ? text : text + " " + format;
}

}  // namespace

Expected<std::string> resolveV4l2Device(V4l2Syscalls& syscalls, const std::string& device) {
  if (!device.empty() && device.front() == '/') return device;
  if (isDigits(device)) return "/dev/video" + device;
  std::string seen;
  for (const std::string& path : syscalls.listDeviceNodes()) {
    V4l2Device node(syscalls);
    if (!node.open(path).ok() || !node.canCapture()) continue;
    if (device.empty() || node.card() == device) return path;
    seen += (seen.empty() ? "" : ", ") + node.label();
  }
  if (device.empty()) return Status::Error("v4l2: no video capture device found");
  return Status::Error("v4l2: no capture device named '" + device +
                       "'; found: " + (seen.empty() ? "none" : seen));
}

V4l2Camera::V4l2Camera(std::shared_ptr<V4l2Syscalls> syscalls, const CameraConfig& config,
                       const V4l2Options& options)
    : syscalls_(std::move(syscalls)), config_(config), options_(options), device_(*syscalls_) {}

Expected<std::unique_ptr<V4l2Camera>> V4l2Camera::open(std::shared_ptr<V4l2Syscalls> syscalls,
                                                       const CameraConfig& config,
                                                       const V4l2Options& options) {
  if (config.trigger != TriggerMode::kFreeRun) {
    return Status::Error("v4l2: camera '" + config.device + "': V4L2 cameras only free-run");
  }
  std::unique_ptr<V4l2Camera> camera(new V4l2Camera(std::move(syscalls), config, options));
  if (Status status = camera->openAndNegotiate(); !status.ok()) return status;
  return camera;
}

V4l2Camera::~V4l2Camera() {
  stop();
  device_.close();
}

Status V4l2Camera::openAndNegotiate() {
  Expected<std::string> path = resolveV4l2Device(*syscalls_, config_.device);
  if (!path.ok()) return Status::Error(path.error());
  if (Status status = device_.open(path.value()); !status.ok()) return status;
  if (!device_.canCapture()) {
    const std::string label = device_.label();
    device_.close();
    return Status::Error(label + " is not a video capture device with streaming I/O");
  }
  if (Status status = chooseAndSetFormat(); !status.ok()) {
    device_.close();
    return status;
  }
  return Status::Ok();
}

Status V4l2Camera::chooseAndSetFormat() {
  const std::vector<uint32_t> offered = device_.pixelFormats();
  const bool first_open = format_.pixelformat == 0;
  uint32_t wanted = format_.pixelformat;
  if (first_open && !config_.pixel_format.empty()) {
    const std::optional<uint32_t> named = fourccFromString(config_.pixel_format);
    if (!named || !isConvertiblePixelFormat(*named)) {
      return Status::Error("v4l2: pixel format '" + config_.pixel_format +
                           "' is not supported by mocapd; use one of " +
                           formatList(convertiblePixelFormats()));
    }
    wanted = *named;
  } else if (first_open) {
    // Prefer a format listing the exact size at the requested rate, then the exact size, then
    // any; ties go to the order of convertiblePixelFormats().
    int best_rank = 3;
    const std::vector<VideoMode> modes = device_.modes();
    for (uint32_t candidate : convertiblePixelFormats()) {
      if (std::find(offered.begin(), offered.end(), candidate) == offered.end()) continue;
      int rank = 2;
      for (const VideoMode& mode : modes) {
        if (mode.pixel_format != fourccToString(candidate) || mode.width != config_.width ||
            mode.height != config_.height) {
          continue;
        }
        const bool fast_enough = mode.fps == 0 || mode.fps + 0.01 >= config_.fps;
        rank = std::min(rank, fast_enough ? 0 : 1);
      }
      if (rank < best_rank) {
        best_rank = rank;
        wanted = candidate;
      }
    }
    if (wanted == 0) {
      return Status::Error(device_.label() + ": offers only " + formatList(offered) +
                           "; mocapd converts " + formatList(convertiblePixelFormats()));
    }
  }
  const std::string wanted_name = fourccToString(wanted);
  const uint32_t width = first_open ? static_cast<uint32_t>(config_.width) : format_.width;
  const uint32_t height = first_open ? static_cast<uint32_t>(config_.height) : format_.height;
  Expected<NegotiatedFormat> granted = device_.setFormat(wanted, width, height);
  if (!granted.ok()) return Status::Error(granted.error());
  NegotiatedFormat format = granted.value();
  const std::string requested_text = describeMode(width, height, 0, wanted_name);
  const std::string granted_text =
      describeMode(format.width, format.height, 0, fourccToString(format.pixelformat));
  if (format.pixelformat != wanted) {
    return Status::Error(device_.label() + ": cannot capture " + requested_text +
                         "; the device granted " + granted_text + " (it offers " +
                         formatList(offered) + ")");
  }
  if (!first_open && (format.width != format_.width || format.height != format_.height)) {
    return Status::Error(device_.label() + ": came back granting " + granted_text + " instead of " +
                         requested_text);
  }
  Expected<double> fps = device_.setFrameRate(first_open ? config_.fps : format_.fps);
  if (!fps.ok()) return Status::Error(fps.error());
  format.fps = fps.value();
  if (!first_open) return Status::Ok();

  format_ = format;
  info_ = {
      "v4l2",
      device_.path(),
      device_.card(),
      {{static_cast<int>(format.width), static_cast<int>(format.height), format.fps, wanted_name}}};
  const bool size_adjusted = format.width != width || format.height != height;
  const bool rate_adjusted = format.fps > 0 && std::abs(format.fps - config_.fps) > 0.01;
  if (size_adjusted || rate_adjusted) {
    negotiation_note_ = device_.label() + ": requested " +
                        describeMode(width, height, config_.fps, wanted_name) + ", granted " +
                        describeMode(format.width, format.height, format.fps, wanted_name);
  }
  if (config_.exposure_us || config_.gain_db) {
    negotiation_note_ += std::string(negotiation_note_.empty() ? "" : "; ") + device_.label() +
                         ": exposure_us and gain_db are not applied by the v4l2 driver";
  }
  return Status::Ok();
}

Status V4l2Camera::start(FrameSink frames, DriverEventSink events) {
  if (thread_.joinable()) return Status::Error(info_.id + ": already started");
  if (!device_.isOpen()) {
    if (Status status = openAndNegotiate(); !status.ok()) return status;
  }
  if (Status status = device_.startStreaming(options_.buffer_count); !status.ok()) {
    device_.close();
    return status;
  }
  frames_ = std::move(frames);
  events_ = std::move(events);
  last_device_sequence_.reset();
  stopping_ = false;
  thread_ = std::thread([this] {
    nameThisThread("mocapd-camera");
    captureLoop();
  });
  return Status::Ok();
}

void V4l2Camera::stop() {
  {
    // Under the lock so a backoff wait cannot miss the wake-up.
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stopping_ = true;
  }
  stop_signal_.notify_all();
  if (thread_.joinable()) thread_.join();
}

V4l2CameraStats V4l2Camera::stats() const {
  return {delivered_.load(), dropped_.load(), corrupt_.load(), undecodable_.load(),
          reopens_.load()};
}

void V4l2Camera::report(const std::string& message) {
  if (events_) events_(config_.index, message);
}

void V4l2Camera::captureLoop() {
  if (!negotiation_note_.empty()) report(negotiation_note_);
  while (!stopping_) {
    if (!device_.isStreaming() && !reopenWithBackoff()) break;
    captureOnce();
  }
  // STREAMOFF, munmap and close on the thread that owned the device while streaming.
  device_.close();
}

void V4l2Camera::captureOnce() {
  short revents = 0;
  const int ready = device_.waitForBuffer(static_cast<int>(options_.poll_timeout.count()), revents);
  if (ready < 0) {
    if (errno != EINTR) loseDevice(device_.describe("poll", errno));
    return;
  }
  if (ready == 0) return;  // Timeout: go round to check stopping_.
  DequeuedBuffer buffer;
  const int dequeue_error = device_.dequeue(buffer);
  if (dequeue_error == EAGAIN || dequeue_error == EINTR) {
    // Readable without a buffer only happens spuriously; an error flag with nothing to dequeue
    // means the queue is broken and only a reopen will fix it.
    if (revents & (POLLERR | POLLHUP)) {
      loseDevice(device_.path() + ": poll reported an error with no buffer to dequeue");
    }
    return;
  }
  if (dequeue_error != 0) {
    loseDevice(device_.describe("VIDIOC_DQBUF", dequeue_error));
    return;
  }
  std::optional<Frame> frame;
  deliver(buffer, frame);
  // Requeue before calling the sink: the frame owns a copy, and the device gets its buffer back
  // as early as possible.
  if (const int error = device_.requeue(buffer.index); error != 0) {
    loseDevice(device_.describe("VIDIOC_QBUF", error));
  }
  if (frame) {
    ++delivered_;
    if (frames_) frames_(std::move(*frame));
  }
}

int64_t V4l2Camera::timestampOf(const DequeuedBuffer& buffer) {
  // With V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC the kernel stamps the buffer from CLOCK_MONOTONIC, the
  // clock every Frame uses. The event it marks depends on V4L2_BUF_FLAG_TSTAMP_SRC_*: SOE is the
  // start of exposure (uvcvideo reports this), EOF (the default) is when the last byte of the frame
  // arrived, after exposure and readout. It is passed on unchanged: the offset is constant per
  // camera, and guessing exposure and readout time would only add error.
  if ((buffer.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC) {
    return static_cast<int64_t>(buffer.timestamp.tv_sec) * 1'000'000'000 +
           static_cast<int64_t>(buffer.timestamp.tv_usec) * 1'000;
  }
  // Unknown or copied timestamps are in no clock we know: fall back to the dequeue time, which is
  // CLOCK_MONOTONIC on Linux but late by at least the readout and the queueing.
  if (!reported_clock_fallback_) {
    reported_clock_fallback_ = true;
    report(device_.label() + ": buffers carry no monotonic timestamp; using the dequeue time");
  }
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void V4l2Camera::deliver(const DequeuedBuffer& buffer, std::optional<Frame>& frame) {
  // Device sequence numbers count every frame the sensor produced, so a gap is frames lost (no
  // free buffer, USB bandwidth, ...). A backwards step is a restart, not a loss.
  uint32_t gap = 0;
  if (last_device_sequence_) {
    const uint32_t step = buffer.sequence - *last_device_sequence_ - 1;
    if (step < 0x80000000u) gap = step;
  }
  last_device_sequence_ = buffer.sequence;
  const uint64_t sequence = next_sequence_ + gap;
  next_sequence_ = sequence + 1;
  dropped_ += gap;
  lost_since_delivery_ += gap;

  ConvertedPayload converted = convertPayload(
      format_, std::span<const uint8_t>(buffer.data, buffer.bytesused), options_.output);
  if (converted.image.empty()) {
    // Nothing to show (undecodable JPEG): skip it, and count it as lost before the next frame.
    ++undecodable_;
    ++lost_since_delivery_;
    return;
  }
  frame.emplace();
  frame->camera = config_.index;
  frame->sequence = sequence;
  frame->timestamp_ns = timestampOf(buffer);
  frame->dropped_before = lost_since_delivery_;
  frame->corrupt = (buffer.flags & V4L2_BUF_FLAG_ERROR) || converted.incomplete;
  frame->image = std::move(converted.image);
  lost_since_delivery_ = 0;
  if (frame->corrupt) ++corrupt_;
}

void V4l2Camera::loseDevice(const std::string& reason) {
  report("camera lost: " + reason + "; reopening");
  device_.close();
}

bool V4l2Camera::reopenWithBackoff() {
  std::chrono::milliseconds delay = options_.reopen_backoff_initial;
  std::string last_failure;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(stop_mutex_);
      if (stop_signal_.wait_for(lock, delay, [this] { return stopping_.load(); })) return false;
    }
    Status status = openAndNegotiate();
    if (status.ok()) status = device_.startStreaming(options_.buffer_count);
    if (status.ok()) {
      ++reopens_;
      // Device sequence numbers restart at STREAMON; ours continue.
      last_device_sequence_.reset();
      report("camera reopened: " + device_.label());
      return true;
    }
    device_.close();
    // One event per distinct failure: a camera unplugged for an hour must not flood the log.
    if (status.message() != last_failure) {
      last_failure = status.message();
      report("camera still unavailable: " + last_failure);
    }
    delay = std::min(delay * 2, options_.reopen_backoff_max);
  }
}

}  // namespace mocap
