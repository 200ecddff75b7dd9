// The frame synchronizer: windowed grouping of per-camera frame buffers into FrameSets (see the
// header for the rules), with the live flow limiter and the replay back-pressure.
#include "drivers/sync/frame_synchronizer.h"

#include <algorithm>
#include <numeric>
#include <sstream>
#include <string>
#include <utility>

namespace mocap {

namespace {

std::string millis(std::chrono::nanoseconds duration) {
  std::ostringstream text;
  text << static_cast<double>(duration.count()) / 1e6 << " ms";
  return text.str();
}

Status checkConfig(const SyncConfig& config, std::chrono::nanoseconds tolerance,
                   std::chrono::nanoseconds deadline) {
  const std::string where = "frame synchronizer config: ";
  if (config.camera_count < 1) {
    return Status::Error(where + "camera_count = " + std::to_string(config.camera_count) +
                         ", need at least 1");
  }
  if (config.frame_period.count() <= 0) {
    return Status::Error(where + "frame_period = " + millis(config.frame_period) +
                         ", must be positive");
  }
  if (tolerance.count() < 0 || 2 * tolerance >= config.frame_period) {
    return Status::Error(where + "tolerance = " + millis(tolerance) +
                         ", must be at least 0 and below half the frame period (" +
                         millis(config.frame_period) + ")");
  }
  if (deadline.count() <= 0) {
    return Status::Error(where + "deadline = " + millis(deadline) + ", must be positive");
  }
  // A camera's buffer must outlast a set's wait, or overflow (live) or a stuck producer (replay)
  // would pre-empt the deadline.
  const auto buffered_span = static_cast<int64_t>(config.frames_per_camera) * config.frame_period;
  if (buffered_span <= deadline + tolerance) {
    return Status::Error(where + "frames_per_camera = " + std::to_string(config.frames_per_camera) +
                         " frames of " + millis(config.frame_period) +
                         " cannot hold a set until its deadline (" + millis(deadline) +
                         ") plus the tolerance (" + millis(tolerance) + ")");
  }
  if (config.replay_queue_sets < 1) {
    return Status::Error(where + "replay_queue_sets = 0, need at least 1");
  }
  if (!config.clock_offsets.empty() &&
      config.clock_offsets.size() != static_cast<std::size_t>(config.camera_count)) {
    return Status::Error(where + "clock_offsets has " +
                         std::to_string(config.clock_offsets.size()) + " entries for " +
                         std::to_string(config.camera_count) + " cameras");
  }
  return Status::Ok();
}

}  // namespace

bool FrameSet::complete() const {
  return std::all_of(frames.begin(), frames.end(),
                     [](const auto& frame) { return frame.has_value(); });
}

int FrameSet::presentCount() const {
  return static_cast<int>(std::count_if(frames.begin(), frames.end(),
                                        [](const auto& frame) { return frame.has_value(); }));
}

const char* dropCauseName(DropCause cause) {
  switch (cause) {
    case DropCause::kLate:
      return "late";
    case DropCause::kOverflow:
      return "overflow";
    case DropCause::kUnmatched:
      return "unmatched";
    case DropCause::kIncompleteSkipped:
      return "incomplete_skipped";
    case DropCause::kSuperseded:
      return "superseded";
    case DropCause::kClosed:
      return "closed";
  }
  return "unknown";
}

uint64_t CameraSyncStats::droppedTotal() const {
  return std::accumulate(dropped.begin(), dropped.end(), uint64_t{0});
}

Expected<std::unique_ptr<FrameSynchronizer>> FrameSynchronizer::create(SyncConfig config) {
  const auto tolerance = config.tolerance.value_or(config.frame_period / 3);
  const auto deadline = config.deadline.value_or(2 * config.frame_period);
  Status status = checkConfig(config, tolerance, deadline);
  if (!status.ok()) return status;
  config.tolerance = tolerance;
  config.deadline = deadline;
  return std::unique_ptr<FrameSynchronizer>(new FrameSynchronizer(std::move(config)));
}

FrameSynchronizer::FrameSynchronizer(SyncConfig config)
    : config_(std::move(config)),
      period_ns_(config_.frame_period.count()),
      tolerance_ns_(config_.tolerance->count()),
      deadline_ns_(config_.deadline->count()),
      offsets_ns_(static_cast<std::size_t>(config_.camera_count), 0),
      cameras_(static_cast<std::size_t>(config_.camera_count)) {
  for (std::size_t c = 0; c < config_.clock_offsets.size(); ++c) {
    offsets_ns_[c] = config_.clock_offsets[c].count();
  }
  stats_.cameras.resize(static_cast<std::size_t>(config_.camera_count));
}

int64_t FrameSynchronizer::readClock() const {
  if (config_.clock) return config_.clock();
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void FrameSynchronizer::push(Frame&& frame) {
  // The injected clock is the caller's code: read it before taking the lock.
  const bool live = config_.mode == SyncMode::kLive;
  const int64_t clock_now = live ? readClock() : 0;
  std::unique_lock lock(mutex_);
  const int c = frame.camera;
  if (c < 0 || c >= config_.camera_count) {
    ++stats_.frames_from_unknown_camera;
    return;
  }
  auto& camera_stats = stats_.cameras[static_cast<std::size_t>(c)];
  ++camera_stats.frames_received;
  camera_stats.frames_lost_by_driver += frame.dropped_before;
  auto& camera = cameras_[static_cast<std::size_t>(c)];

  if (config_.mode == SyncMode::kReplay) {
    buffer_freed_.wait(
        lock, [&] { return closed_ || camera.pending.size() < config_.frames_per_camera; });
  }
  if (closed_) {
    dropLocked(c, DropCause::kClosed);
    return;
  }

  const int64_t time_ns = frame.timestamp_ns + offsets_ns_[static_cast<std::size_t>(c)];
  camera.stalled = false;
  const bool behind_own_camera = camera.newest_ns && time_ns <= *camera.newest_ns;
  const bool set_already_decided = decided_until_ && time_ns <= *decided_until_;
  if (!behind_own_camera) camera.newest_ns = time_ns;
  if (behind_own_camera || set_already_decided) {
    dropLocked(c, DropCause::kLate);
    return;
  }

  if (camera.pending.size() >= config_.frames_per_camera) {  // live only: replay waited above
    camera.pending.pop_front();
    dropLocked(c, DropCause::kOverflow);
    releaseLocked(c);
  }
  camera.pending.push_back({time_ns, std::move(frame)});
  ++camera_stats.frames_buffered;
  ++stats_.frames_buffered;
  stats_.peak_frames_buffered = std::max(stats_.peak_frames_buffered, stats_.frames_buffered);

  if (live) now_ns_ = std::max(now_ns_, clock_now);
  const bool ready = decideLocked(now_ns_);
  lock.unlock();
  if (ready) set_ready_.notify_one();
}

std::optional<FrameSet> FrameSynchronizer::pop(std::chrono::nanoseconds timeout) {
  using SteadyClock = std::chrono::steady_clock;
  const auto give_up = SteadyClock::now() + timeout;
  std::unique_lock lock(mutex_);
  for (;;) {
    if (config_.mode == SyncMode::kLive) now_ns_ = std::max(now_ns_, readClock());
    decideLocked(now_ns_);
    if (!ready_.empty()) {
      FrameSet set = std::move(ready_.front());
      ready_.pop_front();
      ++stats_.sets_emitted;
      ++(set.complete() ? stats_.sets_complete : stats_.sets_incomplete);
      for (int c = 0; c < config_.camera_count; ++c) {
        auto& camera_stats = stats_.cameras[static_cast<std::size_t>(c)];
        if (set.frames[static_cast<std::size_t>(c)]) {
          ++camera_stats.frames_emitted;
          releaseLocked(c);
        } else {
          ++camera_stats.sets_missed;
        }
      }
      // Replay: the freed queue slot may let held sets through and unblock producers.
      decideLocked(now_ns_);
      return set;
    }
    if (closed_ || SteadyClock::now() >= give_up) return std::nullopt;
    auto wake = give_up;
    const auto earliest_ns = earliestPendingLocked();
    if (config_.mode == SyncMode::kLive && earliest_ns) {
      // Wake when the undecided set's deadline passes: a stalled camera must not hold it longer.
      const auto until_deadline = std::chrono::nanoseconds(*earliest_ns + deadline_ns_ - now_ns_);
      wake = std::min(wake, SteadyClock::now() + std::min(until_deadline, timeout));
    }
    set_ready_.wait_until(lock, wake);
  }
}

void FrameSynchronizer::advance(int64_t now_ns) {
  std::unique_lock lock(mutex_);
  now_ns_ = std::max(now_ns_, now_ns);
  const bool ready = decideLocked(now_ns_);
  lock.unlock();
  if (ready) set_ready_.notify_one();
}

void FrameSynchronizer::close() {
  std::unique_lock lock(mutex_);
  closed_ = true;
  decideLocked(now_ns_);
  lock.unlock();
  set_ready_.notify_all();
  buffer_freed_.notify_all();
}

SyncStats FrameSynchronizer::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

bool FrameSynchronizer::decideLocked(int64_t now_ns) {
  const bool live = config_.mode == SyncMode::kLive;
  bool produced = false;
  bool freed = false;
  std::vector<int> members;
  members.reserve(cameras_.size());
  for (;;) {
    if (config_.mode == SyncMode::kReplay && !closed_ &&
        ready_.size() >= config_.replay_queue_sets) {
      break;
    }
    const std::optional<int64_t> start_ns = earliestPendingLocked();
    if (!start_ns) break;
    const int64_t end_ns = *start_ns + tolerance_ns_;

    members.clear();
    bool waiting = false;
    for (int c = 0; c < config_.camera_count; ++c) {
      const auto& camera = cameras_[static_cast<std::size_t>(c)];
      if (!camera.pending.empty() && camera.pending.front().time_ns <= end_ns) {
        members.push_back(c);
      } else if (!closed_ && !camera.stalled && !camera.deliveredAfter(end_ns)) {
        waiting = true;  // this camera may still deliver a frame for the window
      }
    }
    const bool complete = members.size() == cameras_.size();
    if (!complete && waiting) {
      if (now_ns < *start_ns + deadline_ns_) break;
      // Live: stop waiting for cameras that missed a deadline, so a stall costs one deadline, not
      // one per set. Replay keeps waiting: a camera resuming after a gap must lose no frame.
      for (int c = 0; live && c < config_.camera_count; ++c) {
        auto& camera = cameras_[static_cast<std::size_t>(c)];
        const bool member = std::find(members.begin(), members.end(), c) != members.end();
        if (!member && !camera.deliveredAfter(end_ns)) camera.stalled = true;
      }
    }
    const std::size_t queued_before = ready_.size();
    finishSetLocked(*start_ns, members, complete);
    produced = produced || ready_.size() != queued_before;
    freed = true;
  }
  if (freed && !live) buffer_freed_.notify_all();
  return produced;
}

void FrameSynchronizer::finishSetLocked(int64_t start_ns, const std::vector<int>& members,
                                        bool complete) {
  const int64_t end_ns = start_ns + tolerance_ns_;
  const bool on_rig_grid =
      complete || !last_set_start_ || start_ns - *last_set_start_ >= period_ns_ - tolerance_ns_;
  const auto take = [&](int c) {
    auto& pending = cameras_[static_cast<std::size_t>(c)].pending;
    PendingFrame taken = std::move(pending.front());
    pending.pop_front();
    return taken;
  };
  const auto drop_members = [&](DropCause cause) {
    for (int c : members) {
      take(c);
      dropLocked(c, cause);
      releaseLocked(c);
    }
  };

  if (!on_rig_grid) {
    drop_members(DropCause::kUnmatched);
  } else {
    last_set_start_ = start_ns;
    const uint64_t sequence = next_sequence_++;
    if (!complete && config_.incomplete_policy == IncompletePolicy::kSkip) {
      drop_members(DropCause::kIncompleteSkipped);
      ++stats_.sets_skipped;
    } else {
      FrameSet set;
      set.sequence = sequence;
      set.frames.resize(cameras_.size());
      int64_t spread_sum = 0;  // relative to start_ns, so the sum cannot overflow
      for (int c : members) {
        PendingFrame taken = take(c);
        spread_sum += taken.time_ns - start_ns;
        set.frames[static_cast<std::size_t>(c)] = std::move(taken.frame);
      }
      set.timestamp_ns = start_ns + spread_sum / static_cast<int64_t>(members.size());
      queueSetLocked(std::move(set));
    }
  }
  decided_until_ = end_ns;

  // A camera faster than 1 / tolerance can have a second frame inside the decided window.
  for (int c = 0; c < config_.camera_count; ++c) {
    auto& pending = cameras_[static_cast<std::size_t>(c)].pending;
    while (!pending.empty() && pending.front().time_ns <= end_ns) {
      pending.pop_front();
      dropLocked(c, DropCause::kUnmatched);
      releaseLocked(c);
    }
  }
}

void FrameSynchronizer::queueSetLocked(FrameSet&& set) {
  if (config_.mode == SyncMode::kLive) {
    // Flow limiter: the consumer gets the newest set, never a backlog.
    for (const FrameSet& stale : ready_) {
      ++stats_.sets_superseded;
      for (int c = 0; c < config_.camera_count; ++c) {
        if (stale.frames[static_cast<std::size_t>(c)]) {
          dropLocked(c, DropCause::kSuperseded);
          releaseLocked(c);
        }
      }
    }
    ready_.clear();
  }
  ready_.push_back(std::move(set));
}

void FrameSynchronizer::dropLocked(int camera, DropCause cause) {
  ++stats_.cameras[static_cast<std::size_t>(camera)].dropped[static_cast<std::size_t>(cause)];
}

void FrameSynchronizer::releaseLocked(int camera) {
  --stats_.cameras[static_cast<std::size_t>(camera)].frames_buffered;
  --stats_.frames_buffered;
}

std::optional<int64_t> FrameSynchronizer::earliestPendingLocked() const {
  std::optional<int64_t> earliest_ns;
  for (const auto& camera : cameras_) {
    if (!camera.pending.empty()) {
      earliest_ns = std::min(earliest_ns.value_or(camera.pending.front().time_ns),
                             camera.pending.front().time_ns);
    }
  }
  return earliest_ns;
}

bool FrameSynchronizer::CameraState::deliveredAfter(int64_t time_ns) const {
  return newest_ns && *newest_ns > time_ns;
}

}  // namespace mocap
