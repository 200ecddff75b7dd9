// Silhouette extraction per 780x580 frame on one thread, BGR and gray, on generated frames of a
// moving person with a cast shadow (the full per-frame path: gain, classification, shadows, cleanup,
// adaptation and the bit-packed SilhouetteMask). Prints JSON: the median, mean and spread of 5
// runs of each, unless other benchmark flags are given.
// --frames=N runs each once over exactly N frames instead: instruction counts (callgrind) that do
// not depend on how fast the run was.
#include <string>
#include <string_view>
#include <vector>

#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "tracker/sim/test_scene.h"
#include "tracker/vision/silhouette_extractor.h"

namespace mocap {
namespace {

struct Recorded {
  BackgroundModel background;
  std::vector<cv::Mat> frames;
};

Recorded record(bool color) {
  TestSceneOptions options;
  options.color = color;
  SilhouetteTestScene scene(options);
  TestSceneFrame frame;
  BackgroundLearner learner;
  for (int i = 0; i < 30; ++i) {
    scene.render(0, false, frame);
    learner.add(frame.image);
  }
  Recorded recorded{learner.model(), {}};
  for (int t = 0; t < 32; ++t) {
    scene.render(t, true, frame);
    recorded.frames.push_back(frame.image.clone());
  }
  return recorded;
}

void extractSilhouette(benchmark::State& state, bool color) {
  static const Recorded bgr = record(true), gray = record(false);
  const Recorded& recorded = color ? bgr : gray;
  SilhouetteExtractor extractor(recorded.background);
  std::size_t i = 0;
  for (auto _ : state) {
    extractor.extract(recorded.frames[i++ % recorded.frames.size()]);
    benchmark::DoNotOptimize(extractor.silhouette());
  }
  state.counters["ms_per_frame"] = benchmark::Counter(
      static_cast<double>(state.iterations()) * 1e-3,
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

}  // namespace
}  // namespace mocap

int main(int argc, char** argv) {
  // One core: OpenCV's own threads off (0: every OpenCV call runs on the calling thread).
  cv::setNumThreads(0);
  // Defaults first: flags given on the command line come later and win.
  std::string defaults[] = {"--benchmark_repetitions=5", "--benchmark_report_aggregates_only=true",
                            "--benchmark_format=json"};
  std::vector<char*> args{argv[0]};
  for (std::string& flag : defaults) args.push_back(flag.data());
  long frames = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string_view flag = argv[i], frames_flag = "--frames=";
    if (flag.starts_with(frames_flag))
      frames = std::stol(std::string(flag.substr(frames_flag.size())));
    else
      args.push_back(argv[i]);
  }
  for (const bool color : {true, false}) {
    auto* run = benchmark::RegisterBenchmark(
        color ? "extractSilhouette/bgr_780x580" : "extractSilhouette/gray_780x580",
        mocap::extractSilhouette, color);
    run->Unit(benchmark::kMillisecond);
    if (frames > 0) run->Iterations(frames)->Repetitions(1);
  }
  int count = static_cast<int>(args.size());
  benchmark::Initialize(&count, args.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
