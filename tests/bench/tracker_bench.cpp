// Benchmarks of the tracker's hot path on the paper's hand setup (3 cameras at 780x580):
// one factored-filter step of 375 particle evaluations, one Condensation step of 375 particles, and
// one segment likelihood evaluation (rasterize one finger segment in 3 cameras and count it against
// the masked silhouettes), and that evaluation's two halves separately. Threads: the Arg.
#include <benchmark/benchmark.h>

#include "tracker/experiments/hand_experiment.h"
#include "tracker/kinematics.h"
#include "tracker/motion.h"
#include "tracker/scene.h"

namespace mocap {
namespace {

struct HandSetup {
  BodyModel model = builtinHandModel();
  Rig rig = handRig(3);
  Motion motion = generateMotion(model, 50, 1);
  std::vector<std::vector<SilhouetteMask>> frames;
  HandSetup() {
    SceneRenderer renderer(model, rig);
    for (const auto& q : motion) {
      frames.emplace_back();
      for (const cv::Mat& image : renderer.renderSilhouettes(q)) frames.back().emplace_back(image);
    }
  }
};

HandSetup& setup() {
  static HandSetup s;
  return s;
}

void filterStep(benchmark::State& state, const char* method) {
  HandSetup& s = setup();
  WorkerPool pool(static_cast<int>(state.range(0)));
  FilterOptions options;
  auto filter = makeFilter(method, s.model, s.rig, options, pool);
  filter->reset(s.motion[0]);
  std::size_t f = 0;
  long evaluations = 0;
  for (auto _ : state) {
    // Track the motion forward, wrapping around (the jump back costs nothing here).
    evaluations += filter->step(s.frames[f]).evaluations;
    f = (f + 1) % s.frames.size();
  }
  state.counters["evals_per_step"] =
      benchmark::Counter(static_cast<double>(evaluations) / state.iterations());
}

void BM_FactoredStep375(benchmark::State& state) { filterStep(state, "factored"); }
void BM_CondensationStep375(benchmark::State& state) { filterStep(state, "condensation"); }
BENCHMARK(BM_FactoredStep375)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_CondensationStep375)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();

// One particle evaluation of the factored filter: the index middle phalanx against the silhouette
// minus what the palm and its parent phalanx already explain, in all 3 cameras.
void BM_SegmentLikelihood(benchmark::State& state) {
  HandSetup& s = setup();
  KinematicsData kin(s.model);
  forwardKinematics(s.model, kin, s.motion[10]);
  ShapeRasterizer rasterizer(LikelihoodParams().points_per_circle);
  const int palm = 0, proximal = s.model.segmentIndex("index_1"), middle = s.model.segmentIndex("index_2");
  std::vector<std::vector<RowSpan>> storage(3 * s.rig.size(), std::vector<RowSpan>(580));
  std::vector<std::vector<Footprint>> explained(s.rig.size());
  for (std::size_t c = 0; c < s.rig.size(); ++c) {
    explained[c].push_back(rasterizer.rasterize(s.model.segments[palm].shape, kin.world[palm],
                                                s.rig[c], storage[3 * c].data()));
    explained[c].push_back(rasterizer.rasterize(s.model.segments[proximal].shape,
                                                kin.world[proximal], s.rig[c],
                                                storage[3 * c + 1].data()));
  }
  RowSpan* spans[kMaxCameras];
  for (std::size_t c = 0; c < s.rig.size(); ++c) spans[c] = storage[3 * c + 2].data();
  std::vector<Footprint> footprints(s.rig.size());
  for (auto _ : state) {
    const PixelCounts counts =
        observeSegment(s.model.segments[middle].shape, kin.world[middle], s.rig, s.frames[10],
                       rasterizer, spans, footprints.data(), explained);
    benchmark::DoNotOptimize(counts);
  }
}
BENCHMARK(BM_SegmentLikelihood)->Unit(benchmark::kNanosecond);

// The two halves of BM_SegmentLikelihood: scan conversion of the phalanx in 3 cameras, and
// counting its (fixed) footprints against the masked silhouettes.
void BM_SegmentRasterize(benchmark::State& state) {
  HandSetup& s = setup();
  KinematicsData kin(s.model);
  forwardKinematics(s.model, kin, s.motion[10]);
  ShapeRasterizer rasterizer(LikelihoodParams().points_per_circle);
  const int middle = s.model.segmentIndex("index_2");
  std::vector<RowSpan> storage(580);
  for (auto _ : state) {
    for (const CameraModel& camera : s.rig) {
      const Footprint f = rasterizer.rasterize(s.model.segments[middle].shape, kin.world[middle],
                                               camera, storage.data());
      benchmark::DoNotOptimize(f);
    }
  }
}
BENCHMARK(BM_SegmentRasterize)->Unit(benchmark::kNanosecond);

void BM_SegmentCount(benchmark::State& state) {
  HandSetup& s = setup();
  KinematicsData kin(s.model);
  forwardKinematics(s.model, kin, s.motion[10]);
  ShapeRasterizer rasterizer(LikelihoodParams().points_per_circle);
  const int palm = 0, proximal = s.model.segmentIndex("index_1");
  const int middle = s.model.segmentIndex("index_2");
  std::vector<std::vector<RowSpan>> storage(3 * s.rig.size(), std::vector<RowSpan>(580));
  std::vector<std::vector<Footprint>> explained(s.rig.size());
  std::vector<Footprint> footprints;
  for (std::size_t c = 0; c < s.rig.size(); ++c) {
    explained[c].push_back(rasterizer.rasterize(s.model.segments[palm].shape, kin.world[palm],
                                                s.rig[c], storage[3 * c].data()));
    explained[c].push_back(rasterizer.rasterize(s.model.segments[proximal].shape,
                                                kin.world[proximal], s.rig[c],
                                                storage[3 * c + 1].data()));
    footprints.push_back(rasterizer.rasterize(s.model.segments[middle].shape, kin.world[middle],
                                              s.rig[c], storage[3 * c + 2].data()));
  }
  for (auto _ : state) {
    PixelCounts counts;
    for (std::size_t c = 0; c < s.rig.size(); ++c)
      counts += countFootprint(s.frames[10][c], footprints[c], explained[c].data(),
                               static_cast<int>(explained[c].size()));
    benchmark::DoNotOptimize(counts);
  }
}
BENCHMARK(BM_SegmentCount)->Unit(benchmark::kNanosecond);

}  // namespace
}  // namespace mocap

BENCHMARK_MAIN();
