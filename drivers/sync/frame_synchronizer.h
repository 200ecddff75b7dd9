// The frame synchronizer: groups the frames of all cameras whose timestamps agree within a
// tolerance into FrameSets, one frame per camera, in time order, with bounded memory, and counts
// every frame it drops and why. Sits between the camera drivers (many threads push) and the
// tracker (one thread pops).
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "drivers/frame.h"
#include "drivers/status.h"

namespace mocap {

// One frame per camera, taken at (nearly) the same instant.
struct FrameSet {
  // Counts every set the synchronizer formed, emitted or not: a gap tells the consumer that sets
  // were skipped or superseded in between.
  uint64_t sequence = 0;
  // Mean of the members' timestamps after each camera's clock offset: the rig's common time base.
  int64_t timestamp_ns = 0;
  // Indexed by camera; empty where the camera gave no frame in time. Frames are as the driver
  // delivered them (own timestamp, pixels shared, never copied).
  std::vector<std::optional<Frame>> frames;

  bool complete() const;
  int presentCount() const;
};

enum class SyncMode {
  // Latest wins: at most one set waits for the consumer; a newer one replaces it. Deadlines run on
  // the clock. push() never waits.
  kLive,
  // Nothing is lost and the output depends only on the frames and advance() calls, not on thread
  // timing: no clock, and push() waits while its camera's buffer is full (the consumer paces the
  // producers).
  kReplay,
};

// What to do with a set that a camera missed (deadline passed or the camera moved past it).
enum class IncompletePolicy { kEmit, kSkip };

enum class DropCause {
  kLate,       // its set was already decided, or it is not newer than its camera's last frame
  kOverflow,   // live: its camera's buffer was full; the oldest frame made room
  kUnmatched,  // between two sets: a camera faster than the rig or out of phase
  kIncompleteSkipped,  // its set missed a camera and the policy is kSkip
  kSuperseded,         // live: its set was not consumed before a newer one was ready
  kClosed,             // pushed after close()
};
inline constexpr std::size_t kDropCauseCount = 6;
const char* dropCauseName(DropCause cause);

struct SyncConfig {
  int camera_count = 2;
  std::chrono::nanoseconds frame_period = std::chrono::milliseconds(40);
  // Largest spread of timestamps within one set. Default: a third of the frame period.
  std::optional<std::chrono::nanoseconds> tolerance;
  // How long after its earliest frame a set may wait for a missing camera. Default: two periods.
  std::optional<std::chrono::nanoseconds> deadline;
  IncompletePolicy incomplete_policy = IncompletePolicy::kEmit;
  SyncMode mode = SyncMode::kLive;
  // Frames held per camera while their set is not yet decided.
  std::size_t frames_per_camera = 8;
  // Replay only: decided sets waiting for the consumer before the producers are held back.
  std::size_t replay_queue_sets = 4;
  // Added to each camera's timestamps to bring them into the common time base; empty: all zero.
  std::vector<std::chrono::nanoseconds> clock_offsets;
  // Live only: now, in the time base of the corrected timestamps. Empty: CLOCK_MONOTONIC, which
  // is what drivers stamp frames with. Tests inject their own.
  std::function<int64_t()> clock;
};

struct CameraSyncStats {
  uint64_t frames_received = 0;
  uint64_t frames_emitted = 0;         // handed to the consumer inside a set
  uint64_t sets_missed = 0;            // sets handed to the consumer without this camera
  uint64_t frames_lost_by_driver = 0;  // sum of Frame::dropped_before: lost before reaching us
  std::size_t frames_buffered = 0;     // held now, undecided or waiting for the consumer
  std::array<uint64_t, kDropCauseCount> dropped{};

  uint64_t droppedBy(DropCause cause) const { return dropped[static_cast<std::size_t>(cause)]; }
  uint64_t droppedTotal() const;
};

struct SyncStats {
  uint64_t sets_emitted = 0;  // handed to the consumer: complete + incomplete
  uint64_t sets_complete = 0;
  uint64_t sets_incomplete = 0;
  uint64_t sets_skipped = 0;                // incomplete, dropped by IncompletePolicy::kSkip
  uint64_t sets_superseded = 0;             // live: replaced before the consumer took them
  uint64_t frames_from_unknown_camera = 0;  // Frame::camera outside [0, camera_count)
  std::size_t frames_buffered = 0;
  std::size_t peak_frames_buffered = 0;  // high-water mark: the memory bound, observed
  std::vector<CameraSyncStats> cameras;
};

// Thread use: push() from any number of driver threads at once; pop() from one consumer thread;
// advance(), close() and stats() from any thread.
//
// Grouping: the earliest undecided frame opens a window [t, t + tolerance]; each camera's earliest
// frame inside it joins the set. The set is decided as soon as every camera has a frame in it, or
// every missing camera has already delivered a later frame, or now >= t + deadline. Live: a
// missing camera that let a deadline pass is treated as stalled, and later sets do not wait for it
// until it delivers again (its first frame back may then come too late for its set). An incomplete
// set that starts less than (period - tolerance) after the previous set is not a set of the rig but
// a stray frame (a faster camera, or one out of phase); its frames are dropped as kUnmatched.
//
// Time: live mode reads the clock on every push() and pop(), and pop() wakes up at the next
// deadline, so a stalled camera delays sets by at most the deadline. Replay mode has no clock:
// a replay source that has delivered everything up to recorded time t calls advance(t) (a promise
// that no earlier frame follows), which lets deadlines pass in recorded time; a camera whose
// recording has a gap or ends early then does not hold the others. close() decides everything.
// Because replay push() waits on a full buffer, a source that feeds several cameras from one
// thread must interleave them in timestamp order, or it can end up waiting on itself (until
// close()); so can one whose clock offsets put a camera further ahead than its buffer spans.
class FrameSynchronizer {
 public:
  // Checks the config and names the field at fault.
  static Expected<std::unique_ptr<FrameSynchronizer>> create(SyncConfig config);

  FrameSynchronizer(const FrameSynchronizer&) = delete;
  FrameSynchronizer& operator=(const FrameSynchronizer&) = delete;

  // Takes a frame (a FrameSink can forward to it). Live: never waits beyond a short lock. Replay:
  // waits while this camera's buffer is full, until the consumer pops, advance() or close().
  void push(Frame&& frame);

  // The next set in time order, waiting up to `timeout` for one. Empty on timeout, or once closed
  // and drained.
  std::optional<FrameSet> pop(std::chrono::nanoseconds timeout);

  // Lets deadlines pass up to `now_ns` (corrected time base), whatever the mode.
  void advance(int64_t now_ns);

  // End of stream: decides every held frame now (as if every deadline had passed), wakes blocked
  // push() and pop() calls; later pushes are dropped as kClosed. pop() still drains what is left.
  void close();

  SyncStats stats() const;
  const SyncConfig& config() const { return config_; }  // tolerance and deadline filled in

 private:
  struct PendingFrame {
    int64_t time_ns;  // corrected timestamp
    Frame frame;
  };
  struct CameraState {
    std::deque<PendingFrame> pending;  // corrected time ascending, all after decided_until_
    std::optional<int64_t> newest_ns;  // newest corrected timestamp received
    bool stalled = false;

    bool deliveredAfter(int64_t time_ns) const;  // a later frame came: it has nothing for time_ns
  };

  explicit FrameSynchronizer(SyncConfig config);

  int64_t readClock() const;
  // Decides every set that can be decided at `now_ns`; returns true if a set became ready.
  bool decideLocked(int64_t now_ns);
  void finishSetLocked(int64_t start_ns, const std::vector<int>& members, bool complete);
  void queueSetLocked(FrameSet&& set);
  void dropLocked(int camera, DropCause cause);
  // A held frame leaves the synchronizer (dropped or handed to the consumer).
  void releaseLocked(int camera);
  // Start of the earliest undecided window: the oldest held frame, in the corrected time base.
  std::optional<int64_t> earliestPendingLocked() const;

  const SyncConfig config_;
  const int64_t period_ns_;
  const int64_t tolerance_ns_;
  const int64_t deadline_ns_;
  std::vector<int64_t> offsets_ns_;

  mutable std::mutex mutex_;
  std::condition_variable set_ready_;     // wakes the consumer
  std::condition_variable buffer_freed_;  // wakes replay producers
  std::vector<CameraState> cameras_;
  std::deque<FrameSet> ready_;
  std::optional<int64_t> decided_until_;   // end of the last decided window
  std::optional<int64_t> last_set_start_;  // start of the last set of the rig (emitted or not)
  int64_t now_ns_ = std::numeric_limits<int64_t>::min();  // latest from the clock or advance()
  uint64_t next_sequence_ = 0;
  bool closed_ = false;
  SyncStats stats_;
};

}  // namespace mocap
