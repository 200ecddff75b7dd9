// Cost of the frame synchronizer per frame: 8 cameras push 780x580 frames (one shared image, so
// only the synchronizer's own work is timed, no pixel copies) and the consumer pops each set.
// CPU share of one core at 8 x 25 Hz = time per frame x 200 frames/s.
#include <chrono>
#include <cstdint>

#include <benchmark/benchmark.h>
#include <opencv2/core/mat.hpp>

#include "drivers/sync/frame_synchronizer.h"

namespace {

using namespace std::chrono_literals;

void pushAndConsume(benchmark::State& state, mocap::SyncMode mode) {
  const int cameras = static_cast<int>(state.range(0));
  mocap::SyncConfig config;
  config.camera_count = cameras;
  config.frame_period = 40ms;
  config.mode = mode;
  auto created = mocap::FrameSynchronizer::create(config);
  if (!created.ok()) {
    state.SkipWithError(created.error().c_str());
    return;
  }
  mocap::FrameSynchronizer& sync = *created.value();
  const cv::Mat image(580, 780, CV_8UC1, cv::Scalar(128));
  // Live mode reads CLOCK_MONOTONIC; start the stream there so deadlines behave as in the daemon.
  int64_t timestamp = std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::steady_clock::now().time_since_epoch())
                          .count();
  uint64_t sequence = 0;
  for (auto _ : state) {
    for (int c = 0; c < cameras; ++c) {
      mocap::Frame frame;
      frame.camera = c;
      frame.sequence = sequence;
      frame.timestamp_ns = timestamp;
      frame.image = image;
      sync.push(std::move(frame));
    }
    auto set = sync.pop(0ns);
    benchmark::DoNotOptimize(set);
    if (!set || !set->complete()) {
      state.SkipWithError("a period did not give one complete set");
      return;
    }
    ++sequence;
    timestamp += 40'000'000;
  }
  state.SetItemsProcessed(state.iterations() * cameras);
}

void BM_LivePushAndPop(benchmark::State& state) { pushAndConsume(state, mocap::SyncMode::kLive); }
void BM_ReplayPushAndPop(benchmark::State& state) {
  pushAndConsume(state, mocap::SyncMode::kReplay);
}

BENCHMARK(BM_LivePushAndPop)->Arg(8);
BENCHMARK(BM_ReplayPushAndPop)->Arg(8);

}  // namespace

BENCHMARK_MAIN();
