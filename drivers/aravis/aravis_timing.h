// Frame bookkeeping for Aravis streams, free of Aravis headers so it can be tested alone: frames
// lost between two frame ids, and device timestamps mapped onto CLOCK_MONOTONIC.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>

namespace mocap {

// Frames the camera produced between two delivered frame ids. GigE Vision 1.x block ids are 16-bit
// and wrap from 65535 back to 1 (0 is reserved), GigE Vision 2 extended ids and USB3 Vision ids are
// 64-bit. A step back that is not a 16-bit wrap is a restart of the counter: nothing lost.
uint64_t framesLostBetween(uint64_t previous_id, uint64_t current_id);

// Maps a camera's own clock onto CLOCK_MONOTONIC.
//
// The device timestamp is latched by the camera (for GigE Vision and USB3 Vision most cameras
// latch it at the start of exposure, some at frame start / trigger): the best event to put on a
// Frame, but in a clock with an unknown offset and a slightly different rate. The host side of each
// frame is its arrival time: Aravis' buffer system timestamp (CLOCK_REALTIME when the first packet
// of the frame arrived), converted to CLOCK_MONOTONIC, or, lacking it, the time the driver took the
// buffer. arrival - device = offset + transport latency, and the latency is never negative, so the
// smallest (arrival - device) over a sliding window is the offset plus the smallest latency seen:
// jitter-free, and the window follows the slow drift between the two clocks. The result marks the
// device's timestamp event, late by that minimum transport latency (constant for a camera model,
// so cameras of one model stay mutually consistent).
class DeviceClockMapper {
 public:
  explicit DeviceClockMapper(size_t window = 64) : window_(window) {}
  // device_ns: the buffer's device timestamp (0 when the camera gives none); arrival_ns: the
  // frame's arrival on CLOCK_MONOTONIC. Returns the frame's CLOCK_MONOTONIC time, never earlier
  // than the previous result (the minimum can fall when a faster frame arrives).
  int64_t map(uint64_t device_ns, int64_t arrival_ns);
  // The camera restarted (reopen): its clock may have been reset.
  void reset();

 private:
  size_t window_;
  std::deque<int64_t> offsets_;  // arrival - device, newest last
  std::optional<uint64_t> last_device_ns_;
  std::optional<int64_t> last_result_;
};

}  // namespace mocap
