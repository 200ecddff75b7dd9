// Frame-id gap counting and the device-to-monotonic clock mapping of the Aravis driver.
#include "drivers/aravis/aravis_timing.h"

#include <algorithm>

namespace mocap {
namespace {

constexpr uint64_t kMaxBlockId16 = 0xffff;
// How close to the end and start of the 16-bit range two ids must be to count as a wrap rather
// than a restart: more frames than any buffer pool could lose in between.
constexpr uint64_t kWrapMargin = 4096;

}  // namespace

uint64_t framesLostBetween(uint64_t previous_id, uint64_t current_id) {
  if (current_id > previous_id) return current_id - previous_id - 1;
  const bool wrapped_16bit = previous_id <= kMaxBlockId16 &&
                             previous_id > kMaxBlockId16 - kWrapMargin && current_id < kWrapMargin;
  if (!wrapped_16bit) return 0;
  // Ids after 65535 are 1, 2, ...; a camera that (against the standard) sends 0 loses nothing.
  return (kMaxBlockId16 - previous_id) + (current_id > 0 ? current_id - 1 : 0);
}

int64_t DeviceClockMapper::map(uint64_t device_ns, int64_t arrival_ns) {
  int64_t result = arrival_ns;
  if (device_ns != 0) {
    // A device clock that steps back was reset (or is not a clock): start estimating again.
    if (last_device_ns_ && device_ns <= *last_device_ns_) offsets_.clear();
    last_device_ns_ = device_ns;
    offsets_.push_back(arrival_ns - static_cast<int64_t>(device_ns));
    if (offsets_.size() > window_) offsets_.pop_front();
    result = static_cast<int64_t>(device_ns) + *std::min_element(offsets_.begin(), offsets_.end());
  }
  if (last_result_ && result <= *last_result_) result = *last_result_ + 1;
  last_result_ = result;
  return result;
}

void DeviceClockMapper::reset() {
  offsets_.clear();
  last_device_ns_.reset();
  // last_result_ stays: frames after a reopen must still come after the ones before it.
}

}  // namespace mocap
