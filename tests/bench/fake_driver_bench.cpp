// The fake driver's cost: rendering one set (2 cameras, 780x580, BGR) of the default scene, and
// the CPU share of two real-time scene cameras at 25 Hz. Budget: 25 % of one core at 25 Hz is
// 10 ms per set, 5 ms per camera-frame.
#include <sys/resource.h>

#include <atomic>
#include <chrono>
#include <thread>

#include <benchmark/benchmark.h>

#include "drivers/fake/fake_driver.h"

namespace mocap {
namespace {

double processCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec + 1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

FakeSceneOptions benchScene(bool gray) {
  FakeSceneOptions options;  // the default: built-in hand, 2 cameras, 780x580, 25 Hz
  options.gray = gray;
  return options;
}

// One set = both cameras' images of one frame, rendered on one thread.
void BM_FakeSceneRenderSet(benchmark::State& state) {
  std::shared_ptr<FakeScene> scene = FakeScene::create(benchScene(state.range(0) == 1)).value();
  FakeRenderScratch scratch(scene->model(), 580);
  cv::Mat images[2];
  uint64_t sequence = 0;
  for (auto _ : state) {
    for (int c = 0; c < 2; ++c) scene->render(c, sequence, scratch, images[c]);
    benchmark::DoNotOptimize(images[1].data);
    ++sequence;
  }
  state.SetLabel(state.range(0) == 1 ? "gray" : "bgr");
}
BENCHMARK(BM_FakeSceneRenderSet)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

// Two scene cameras on their own threads, paced at 25 Hz for 4 s: the process's CPU time over the
// wall time is the share of one core the fake driver takes live.
void BM_FakeDriverLive25Hz(benchmark::State& state) {
  for (auto _ : state) {
    FakeDriver driver({.scene = benchScene(false), .replay = {}});
    driver.scene().value();  // built before the clock starts: model and background set-up are one-off
    std::atomic<uint64_t> frames{0};
    std::vector<std::unique_ptr<Camera>> cameras;
    for (int c = 0; c < 2; ++c) {
      CameraConfig config;
      config.index = c;
      config.device = "scene:" + std::to_string(c);
      cameras.push_back(std::move(driver.open(config).value()));
    }
    const double cpu_start = processCpuSeconds();
    const auto wall_start = std::chrono::steady_clock::now();
    for (auto& camera : cameras) (void)camera->start([&](Frame&&) { ++frames; }, nullptr);
    std::this_thread::sleep_for(std::chrono::seconds(4));
    for (auto& camera : cameras) camera->stop();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    const double cpu = processCpuSeconds() - cpu_start;
    state.SetIterationTime(wall);
    state.counters["core_share"] = cpu / wall;
    state.counters["cpu_ms_per_set"] = 1e3 * cpu / (static_cast<double>(frames.load()) / 2);
    state.counters["frames_per_s"] = static_cast<double>(frames.load()) / wall;
  }
}
BENCHMARK(BM_FakeDriverLive25Hz)->Iterations(1)->UseManualTime()->Unit(benchmark::kSecond);

}  // namespace
}  // namespace mocap

BENCHMARK_MAIN();
