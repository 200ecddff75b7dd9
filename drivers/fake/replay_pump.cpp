// The replay pump: merges the cameras of a session in time order and feeds a replay-mode
// synchronizer from one thread.
#include "drivers/fake/replay_pump.h"

#include <algorithm>
#include <chrono>
#include <thread>
#include <tuple>

namespace mocap {
namespace {

struct Scheduled {
  int64_t corrected_ns;
  std::size_t set_index;
  int camera;
};

}  // namespace

Status pumpSession(const SessionReader& reader, FrameSynchronizer& sync, const ReplayPumpOptions& options) {
  const SyncConfig& config = sync.config();
  const int cameras = static_cast<int>(reader.cameras().size());
  const auto finish = [&](Status status) {
    if (options.close_at_end) sync.close();
    return status;
  };
  if (config.camera_count != cameras) {
    return finish(Status::Error("replay of " + reader.path().string() + ": the session has " + std::to_string(cameras) +
                                " cameras, the synchronizer " + std::to_string(config.camera_count)));
  }
  const auto offsetOf = [&](int camera) -> int64_t {
    return config.clock_offsets.empty() ? 0 : config.clock_offsets[camera].count();
  };
  std::vector<Scheduled> schedule;
  const std::vector<SessionSet>& sets = reader.sets();
  for (std::size_t i = 0; i < sets.size(); ++i) {
    for (int c = 0; c < cameras; ++c) {
      if (sets[i].frames[c]) schedule.push_back({sets[i].frames[c]->timestamp_ns + offsetOf(c), i, c});
    }
  }
  std::stable_sort(schedule.begin(), schedule.end(), [](const Scheduled& a, const Scheduled& b) {
    return std::tie(a.corrected_ns, a.set_index, a.camera) < std::tie(b.corrected_ns, b.set_index, b.camera);
  });
  if (schedule.empty()) return finish(Status::Ok());

  // Later passes move forward by the recording's span plus one period, like the replay cameras.
  double fastest = 0;
  for (const SessionCamera& camera : reader.cameras()) fastest = std::max(fastest, camera.fps);
  const int64_t span = schedule.back().corrected_ns - schedule.front().corrected_ns + static_cast<int64_t>(1e9 / fastest);
  std::vector<uint64_t> sequences_per_loop(cameras, 0);
  for (const SessionSet& set : sets) {
    for (int c = 0; c < cameras; ++c) {
      if (set.frames[c]) sequences_per_loop[c] = std::max(sequences_per_loop[c], set.frames[c]->camera_sequence + 1);
    }
  }
  const auto start = std::chrono::steady_clock::now();
  for (int loop = 0; loop < options.loops; ++loop) {
    for (const Scheduled& item : schedule) {
      if (options.stop && options.stop->load()) return finish(Status::Ok());
      const int64_t corrected = item.corrected_ns + loop * span;
      if (options.real_time) {
        std::this_thread::sleep_until(start + std::chrono::nanoseconds(corrected - schedule.front().corrected_ns));
      }
      Expected<Frame> frame = options.silhouettes
                                  ? reader.readFrameSilhouette(item.set_index, item.camera)
                                  : reader.readFrame(item.set_index, item.camera);
      if (!frame.ok()) return finish(Status::Error(frame.error()));
      frame.value().timestamp_ns += loop * span;
      frame.value().sequence += static_cast<uint64_t>(loop) * sequences_per_loop[item.camera];
      sync.push(std::move(frame.value()));
      sync.advance(corrected);
    }
  }
  return finish(Status::Ok());
}

}  // namespace mocap
