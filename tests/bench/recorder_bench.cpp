// The recorder's throughput: 2 cameras at 780x580 (fake-scene images with sensor noise, BGR and
// gray), per durability policy; and whether it keeps up with a live 25 Hz stream without dropping.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include <benchmark/benchmark.h>

#include "drivers/fake/fake_scene.h"
#include "drivers/record/recorder.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
constexpr int kDistinctSets = 16;

// Pre-rendered sets, so only the recorder is measured.
std::vector<FrameSet> renderSets(bool gray) {
  FakeSceneOptions options;
  options.gray = gray;
  std::shared_ptr<FakeScene> scene = FakeScene::create(options).value();
  FakeRenderScratch scratch(scene->model(), 580);
  std::vector<FrameSet> sets(kDistinctSets);
  for (int n = 0; n < kDistinctSets; ++n) {
    sets[n].frames.resize(2);
    for (int c = 0; c < 2; ++c) {
      Frame f;
      f.camera = c;
      scene->render(c, static_cast<uint64_t>(n), scratch, f.image);
      sets[n].frames[c] = std::move(f);
    }
  }
  return sets;
}

fs::path benchRoot() {
  const fs::path root = fs::temp_directory_path() / ("mocap_recorder_bench_" + std::to_string(::getpid()));
  fs::create_directories(root);
  return root;
}

std::vector<SessionCamera> cameras(bool gray) {
  const std::string format = gray ? kPixelGray : kPixelBgr;
  return {{"cam0", 780, 580, format, 25}, {"cam1", 780, 580, format, 25}};
}

// Args: gray (0/1), durability (0 process crash, 1 power loss). Writes 100 sets with a queue that
// holds them all: the writer's sustained rate, in sets/s.
void BM_RecorderThroughput(benchmark::State& state) {
  const bool gray = state.range(0) == 1;
  const Durability durability = state.range(1) == 1 ? Durability::kPowerLoss : Durability::kProcessCrash;
  const std::vector<FrameSet> sets = renderSets(gray);
  const fs::path root = benchRoot();
  constexpr int kSets = 100;
  int run = 0;
  for (auto _ : state) {
    Recorder recorder(root, {.queue_sets = kSets, .durability = durability});
    const auto start = std::chrono::steady_clock::now();
    if (!recorder.open("run" + std::to_string(run++), {}, cameras(gray)).ok()) state.SkipWithError("open failed");
    for (int n = 0; n < kSets; ++n) {
      FrameSet set = sets[n % kDistinctSets];
      set.sequence = static_cast<uint64_t>(n);
      recorder.write(set);
    }
    (void)recorder.close();
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    state.SetIterationTime(seconds);
    state.counters["sets_per_s"] = kSets / seconds;
    state.counters["dropped"] = static_cast<double>(recorder.stats().sets_dropped);
  }
  fs::remove_all(root);
  state.SetLabel(std::string(gray ? "gray" : "bgr") + (durability == Durability::kPowerLoss ? " power-loss" : " process-crash"));
}
BENCHMARK(BM_RecorderThroughput)
    ->Args({0, 1})->Args({1, 1})->Args({0, 0})
    ->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);

// 4 s of a live 25 Hz BGR stream with the default options: sets dropped must be 0.
void BM_RecorderLive25Hz(benchmark::State& state) {
  const std::vector<FrameSet> sets = renderSets(false);
  const fs::path root = benchRoot();
  constexpr int kSets = 100;
  for (auto _ : state) {
    Recorder recorder(root);
    if (!recorder.open("live", {}, cameras(false)).ok()) state.SkipWithError("open failed");
    const auto start = std::chrono::steady_clock::now();
    for (int n = 0; n < kSets; ++n) {
      std::this_thread::sleep_until(start + std::chrono::milliseconds(40) * n);
      FrameSet set = sets[n % kDistinctSets];
      set.sequence = static_cast<uint64_t>(n);
      recorder.write(set);
    }
    (void)recorder.close();
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    state.counters["written"] = static_cast<double>(recorder.stats().sets_written);
    state.counters["dropped"] = static_cast<double>(recorder.stats().sets_dropped);
    fs::remove_all(root / "live");
  }
  fs::remove_all(root);
}
BENCHMARK(BM_RecorderLive25Hz)->Iterations(1)->UseManualTime()->Unit(benchmark::kSecond);

}  // namespace
}  // namespace mocap

BENCHMARK_MAIN();
