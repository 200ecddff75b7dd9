// State and helpers shared by the parts of EmulatedV4l2 (device lifecycle, format negotiation,
// buffer queue): the per-node structs and the kernel's format rules. Internal to the emulation.
#pragma once

#include <linux/videodev2.h>

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "tests/drivers/v4l2/emulated_v4l2_device.h"

namespace mocap {
namespace v4l2_emulation {

constexpr uint32_t kCaptureType = V4L2_BUF_TYPE_VIDEO_CAPTURE;
// Buffer i is mapped at offset i << kOffsetShift: unique, page aligned, larger than any buffer.
constexpr int kOffsetShift = 24;

enum class BufferState { kDequeued, kQueued, kDone };

struct EmulatedBuffer {
  std::shared_ptr<std::vector<uint8_t>> memory;
  BufferState state = BufferState::kDequeued;
  uint32_t mapped = 0;
  uint32_t bytesused = 0;
  uint32_t sequence = 0;
  uint32_t flags = 0;
  timeval timestamp{};
};

v4l2_fract intervalOf(double fps);
const EmulatedFormat* findFormat(const EmulatedDeviceSpec& spec, uint32_t pixelformat);
const EmulatedFrameSize* findSize(const EmulatedFormat& format, uint32_t width, uint32_t height);
// The kernel's adjust-not-fail rule: the nearest listed size of a supported format.
v4l2_pix_format adjustedFormat(const EmulatedDeviceSpec& spec, const v4l2_pix_format& requested);
// The discrete rates the spec lists for the format's pixel format and size.
std::vector<double> ratesOf(const EmulatedDeviceSpec& spec, const v4l2_pix_format& format);

}  // namespace v4l2_emulation

// One plug-in of a device: what an open file talks to. A vanished instance stays dead.
struct EmulatedV4l2::Instance {
  EmulatedDeviceSpec spec;
  bool alive = true;
  v4l2_pix_format format{};
  double fps = 0;
  int owner_fd = -1;  // the file that allocated the buffers, as vb2 ties a queue to its owner
  std::vector<v4l2_emulation::EmulatedBuffer> buffers;
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

}  // namespace mocap
