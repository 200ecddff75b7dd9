// Benchmarks of the tracker's hot path on the paper's hand setup (3 cameras at 780x580):
// one factored-filter step of 375 particle evaluations, one Condensation step of 375 particles, and
// one segment likelihood evaluation (rasterize one finger segment in 3 cameras and count it against
// the masked silhouettes), and that evaluation's two halves separately. On the human body (the CMU
// walk, 2 cameras at 780x580, set up as `mocap-experiment human` does): one factored step of 2000
// evaluations with the experiment's defaults (without and with the full-body refinement) and with
// the paper's options. The hand step also with a refinement. Threads: the Arg. The defaults' cost
// curves: BM_HumanStepCost.
#include <algorithm>
#include <map>
#include <memory>
#include <thread>
#include <utility>

#include <benchmark/benchmark.h>

#include "tracker/experiments/hand_experiment.h"
#include "tracker/experiments/human_experiment.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/motion.h"
#include "tracker/motion/retarget.h"
#include "tracker/sim/scene.h"

namespace mocap {
namespace {

// A body tracked along a motion: the rendered ground-truth silhouettes of every frame.
struct TrackingSetup {
  BodyModel model;
  Rig rig;
  Motion motion;
  std::vector<std::vector<SilhouetteMask>> frames;
  TrackingSetup(BodyModel body, Rig cameras, Motion poses)
      : model(std::move(body)), rig(std::move(cameras)), motion(std::move(poses)) {
    SceneRenderer renderer(model, rig);
    for (const auto& q : motion) {
      frames.emplace_back();
      for (const cv::Mat& image : renderer.renderSilhouettes(q)) frames.back().emplace_back(image);
    }
  }
};

TrackingSetup& setup() {
  static TrackingSetup s(builtinHandModel(), handRig(3), generateMotion(builtinHandModel(), 50, 1));
  return s;
}

// One filter step per iteration, tracking the motion forward and wrapping around (the jump back
// costs nothing here). Threads: the Arg.
void trackSteps(benchmark::State& state, const TrackingSetup& s, const char* method,
                const FilterOptions& options) {
  WorkerPool pool(static_cast<int>(state.range(0)));
  auto filter = makeFilter(method, s.model, s.rig, options, pool);
  filter->reset(s.motion[0]);
  std::size_t f = 0;
  long evaluations = 0;
  for (auto _ : state) {
    evaluations += filter->step(s.frames[f]).evaluations;
    f = (f + 1) % s.frames.size();
  }
  state.counters["evals_per_step"] =
      benchmark::Counter(static_cast<double>(evaluations) / state.iterations());
}

void filterStep(benchmark::State& state, const char* method, double refine_share = 0,
                int refine_max = 0) {
  FilterOptions options;
  options.refine.share = refine_share;
  options.refine.max_evaluations = refine_max;
  trackSteps(state, setup(), method, options);
}

void BM_FactoredStep375(benchmark::State& state) { filterStep(state, "factored"); }
// With the full-body refinement taking a fifth of the budget (`hand --refine 0.2`).
void BM_FactoredStep375Refined(benchmark::State& state) { filterStep(state, "factored", 0.2); }
// The same with the refinement capped at 30 evaluations (`--refine 0.2 --refine-max 30`): the
// configuration that meets both the accuracy and the 1 ms targets (docs/hand.md).
void BM_FactoredStep375RefineMax30(benchmark::State& state) {
  filterStep(state, "factored", 0.2, 30);
}
void BM_CondensationStep375(benchmark::State& state) { filterStep(state, "condensation"); }
BENCHMARK(BM_FactoredStep375)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_FactoredStep375Refined)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_FactoredStep375RefineMax30)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();
BENCHMARK(BM_CondensationStep375)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();

// One particle evaluation of the factored filter: the index middle phalanx (frame 10) against the
// silhouette minus what the palm and its parent phalanx already explain, in all 3 cameras.
struct PhalanxSetup {
  TrackingSetup& s = setup();
  KinematicsData kin{s.model};
  ShapeRasterizer rasterizer{LikelihoodParams().points_per_circle};
  const int middle = s.model.segmentIndex("index_2");
  std::vector<std::vector<RowSpan>> storage =
      std::vector<std::vector<RowSpan>>(3 * s.rig.size(), std::vector<RowSpan>(580));
  std::vector<std::vector<Footprint>> explained{s.rig.size()};  // palm, proximal phalanx
  std::vector<Footprint> footprints;                            // the middle phalanx
  RowSpan* spans[kMaxCameras];                                  // where it is rasterized anew

  PhalanxSetup() {
    forwardKinematics(s.model, kin, s.motion[10]);
    const int palm = 0, proximal = s.model.segmentIndex("index_1");
    for (std::size_t c = 0; c < s.rig.size(); ++c) {
      for (int k : {palm, proximal})
        explained[c].push_back(rasterize(k, c, storage[3 * c + (k == palm ? 0 : 1)].data()));
      spans[c] = storage[3 * c + 2].data();
      footprints.push_back(rasterize(middle, c, spans[c]));
    }
  }
  Footprint rasterize(int segment, std::size_t camera, RowSpan* out) {
    return rasterizer.rasterize(s.model.segments[segment].shape, kin.world[segment], s.rig[camera],
                                out);
  }
};

void BM_SegmentLikelihood(benchmark::State& state) {
  PhalanxSetup p;
  std::vector<Footprint> footprints(p.s.rig.size());
  for (auto _ : state) {
    const PixelCounts counts =
        observeSegment(p.s.model.segments[p.middle].shape, p.kin.world[p.middle], p.s.rig,
                       p.s.frames[10], p.rasterizer, p.spans, footprints.data(), p.explained);
    benchmark::DoNotOptimize(counts);
  }
}
BENCHMARK(BM_SegmentLikelihood)->Unit(benchmark::kNanosecond);

// The two halves of BM_SegmentLikelihood: scan conversion of the phalanx in 3 cameras, and
// counting its (fixed) footprints against the masked silhouettes.
void BM_SegmentRasterize(benchmark::State& state) {
  PhalanxSetup p;
  for (auto _ : state) {
    for (std::size_t c = 0; c < p.s.rig.size(); ++c) {
      const Footprint f = p.rasterize(p.middle, c, p.spans[c]);
      benchmark::DoNotOptimize(f);
    }
  }
}
BENCHMARK(BM_SegmentRasterize)->Unit(benchmark::kNanosecond);

void BM_SegmentCount(benchmark::State& state) {
  PhalanxSetup p;
  for (auto _ : state) {
    PixelCounts counts;
    for (std::size_t c = 0; c < p.s.rig.size(); ++c)
      counts += countFootprint(p.s.frames[10][c], p.footprints[c], p.explained[c].data(),
                               static_cast<int>(p.explained[c].size()));
    benchmark::DoNotOptimize(counts);
  }
}
BENCHMARK(BM_SegmentCount)->Unit(benchmark::kNanosecond);

// The human experiment's set-up: the built-in body fitted to the walk's skeleton, 30 frames of the
// walk retargeted at 25 Hz (as the reference run --frames 30), the lab rig of `cameras` cameras
// around that path (2 unless said).
TrackingSetup& humanSetup(int cameras = 2) {
  static std::map<int, std::unique_ptr<TrackingSetup>> setups;
  std::unique_ptr<TrackingSetup>& s = setups[cameras];
  if (!s) {
    const Bvh bvh = loadBvh(std::string(MOCAP_SHARED_DIR) + "/data/motion/cmu_131_01_walk.bvh");
    BodyModel model = fitModelToBvh(builtinHumanModel(), bvh.skeleton);
    Motion motion = retargetBvh(model, bvh.skeleton, bvh.motion, 25, 30).motion;
    Rig rig = labRig(cameras, model, motion);
    s = std::make_unique<TrackingSetup>(std::move(model), std::move(rig), std::move(motion));
  }
  return *s;
}

void humanStep(benchmark::State& state, FilterOptions options) {
  options.evaluations_per_frame = 2000;
  trackSteps(state, humanSetup(), "factored", options);
}

// The cost curves of docs/speed.md: the defaults' step against evaluations, cameras and threads
// (the Args, in that order), each swept from the 2000-evaluation, 2-camera, 1-thread point.
void BM_HumanStepCost(benchmark::State& state) {
  FilterOptions options = humanFilterDefaults();
  options.evaluations_per_frame = static_cast<int>(state.range(0));
  WorkerPool pool(static_cast<int>(state.range(2)));
  const TrackingSetup& s = humanSetup(static_cast<int>(state.range(1)));
  auto filter = makeFilter("factored", s.model, s.rig, options, pool);
  filter->reset(s.motion[0]);
  std::size_t f = 0;
  for (auto _ : state) {
    filter->step(s.frames[f]);
    f = (f + 1) % s.frames.size();
  }
}
void costCurveArgs(benchmark::internal::Benchmark* b) {
  for (int evals : {500, 1000, 2000, 4000, 8000}) b->Args({evals, 2, 1});
  for (int cameras : {1, 3, 4, 6, 8}) b->Args({2000, cameras, 1});
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (int threads = 2; threads <= cores; ++threads) b->Args({2000, 2, threads});
}
BENCHMARK(BM_HumanStepCost)
    ->Apply(costCurveArgs)
    ->ArgNames({"evals", "cameras", "threads"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// `mocap-experiment human`'s defaults without the refinement: whole-body look-ahead, segment
// injection, 5 % injected.
void BM_HumanFactoredStep2000(benchmark::State& state) {
  FilterOptions options = humanFilterDefaults();
  options.refine.share = 0;
  humanStep(state, options);
}
// The experiment's full defaults: the same with the refinement taking 40 % of the budget.
void BM_HumanFactoredStep2000Refined(benchmark::State& state) {
  humanStep(state, humanFilterDefaults());
}
// The paper's options: no look-ahead, DOF injection, 2 % injected, no refinement.
void BM_HumanFactoredStep2000Paper(benchmark::State& state) { humanStep(state, FilterOptions()); }
BENCHMARK(BM_HumanFactoredStep2000)->Arg(1)->Arg(2)->Unit(benchmark::kMicrosecond)->UseRealTime();
BENCHMARK(BM_HumanFactoredStep2000Refined)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();
BENCHMARK(BM_HumanFactoredStep2000Paper)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime();

}  // namespace
}  // namespace mocap

BENCHMARK_MAIN();
