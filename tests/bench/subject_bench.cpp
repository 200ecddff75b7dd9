// Rendering a simulated subject into one 780x580 camera of the lab rig on one thread, per frame:
// the binary silhouette alone, and the person layer (mask, shaded colours, depth) the colour
// scenes composite. The posing (retargeting and building the surface) is timed apart.
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "tracker/model/builtin_models.h"
#include "tracker/motion/motion.h"
#include "tracker/sim/scene.h"
#include "tracker/sim/subject_render.h"

namespace mocap {
namespace {

struct Setup {
  BodyModel model = builtinHumanModel();
  Motion motion = generateMotion(model, 64, 3);
  // Framed on a subject standing in place: as large in the image as the lab rig shows one.
  Rig rig = labRig(2, model, {model.neutralPose()});
  std::vector<PosedSubject> poses;

  Setup() {
    for (Eigen::VectorXd& q : motion)
      for (const char* dof : {"root_tx", "root_ty", "root_tz"}) q[model.dofIndex(dof)] = 0;
    // Every clothing variant, in turn.
    for (std::size_t f = 0; f < motion.size(); ++f) {
      SubjectParams params = drawSubjectParams(f);
      params.clothing.lower = static_cast<LowerGarment>(f % 4);
      params.clothing.coat = f % 5 == 0;
      params.clothing.long_hair = f % 3 == 0;
      const Subject subject(params, subjectJointsAt(model, model.neutralPose()));
      poses.emplace_back();
      subject.pose(subjectJointsAt(model, motion[f]), poses.back());
      poses.back().clothing = nullptr;  // the subject goes out of scope: default colours
    }
  }
};

const Setup& setup() {
  static const Setup s;
  return s;
}

void perFrame(benchmark::State& state) {
  state.counters["ms_per_frame"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * 1e-3,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void subjectSilhouette(benchmark::State& state) {
  cv::setNumThreads(1);
  const Setup& s = setup();
  SubjectRasterizer rasterizer;
  cv::Mat mask;
  std::size_t i = 0;
  for (auto _ : state) {
    rasterizer.renderSilhouette(s.poses[i % s.poses.size()], s.rig[i % 2], mask);
    ++i;
    benchmark::DoNotOptimize(mask.data);
  }
  perFrame(state);
}

void subjectLayer(benchmark::State& state) {
  cv::setNumThreads(1);
  const Setup& s = setup();
  SubjectRasterizer rasterizer;
  PersonLayer layer;
  std::size_t i = 0;
  for (auto _ : state) {
    rasterizer.renderLayer(s.poses[i % s.poses.size()], s.rig[i % 2], layer);
    ++i;
    benchmark::DoNotOptimize(layer.colour.data);
  }
  perFrame(state);
}

void subjectPose(benchmark::State& state) {
  const Setup& s = setup();
  const Subject subject(drawSubjectParams(1), subjectJointsAt(s.model, s.model.neutralPose()));
  const SubjectJoints driver = subjectJointsAt(s.model, s.motion[0]);
  PosedSubject posed;
  for (auto _ : state) {
    subject.pose(driver, posed);
    benchmark::DoNotOptimize(posed.primitives.data());
  }
}

BENCHMARK(subjectSilhouette)->Unit(benchmark::kMillisecond);
BENCHMARK(subjectLayer)->Unit(benchmark::kMillisecond);
BENCHMARK(subjectPose)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace mocap

BENCHMARK_MAIN();
