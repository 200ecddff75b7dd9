// The simulated hand experiment.
#include "tracker/experiments/hand_experiment.h"

#include <chrono>
#include <cmath>
#include <iostream>

#include "tracker/experiments/commands.h"
#include "tracker/experiments/filter_flags.h"
#include "tracker/experiments/metrics.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/motion.h"
#include "tracker/sim/scene.h"

namespace mocap {

nlohmann::json describeModel(const BodyModel& model) {
  nlohmann::json dofs = nlohmann::json::array();
  for (const Dof& d : model.dofs)
    dofs.push_back({{"name", d.name}, {"min", d.min}, {"max", d.max}, {"max_speed", d.max_speed}});
  nlohmann::json joints = nlohmann::json::array();
  for (const BodyPoint& p : model.points) joints.push_back(p.name);
  return {{"dofs", dofs}, {"joints", joints}};
}

nlohmann::json runHandExperiment(const HandExperimentConfig& config) {
  const BodyModel model =
      config.model_path.empty() ? builtinHandModel() : loadBodyModel(config.model_path);
  const Rig rig = handRig(config.cameras);
  const Motion motion = config.motion_path.empty()
                            ? generateMotion(model, config.frames, config.seed)
                            : loadMotionCsv(config.motion_path, model);
  const int frames = std::min<int>(config.frames, static_cast<int>(motion.size()));

  FilterOptions options = config.filter;
  options.evaluations_per_frame = config.evaluations;
  options.seed = config.seed;
  WorkerPool pool(config.threads);
  std::unique_ptr<PoseFilter> filter = makeFilter(config.method, model, rig, options, pool);
  filter->reset(motion[0]);

  SceneRenderer renderer(model, rig);
  KinematicsData kin(model);
  std::vector<cv::Mat> images;
  std::vector<SilhouetteMask> masks(rig.size());
  PointTrack truth, tracked;
  long evaluations = 0, renders = 0;
  double tracking_seconds = 0;
  for (int f = 0; f < frames; ++f) {
    renderer.renderSilhouettes(motion[f], images);
    for (std::size_t c = 0; c < rig.size(); ++c) masks[c] = SilhouetteMask(images[c]);
    const auto start = std::chrono::steady_clock::now();
    const FrameEstimate estimate = filter->step(masks);
    tracking_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    evaluations += estimate.evaluations;
    renders += estimate.segment_renders;
    forwardKinematics(model, kin, motion[f]);
    truth.push_back(pointPositions(model, kin));
    forwardKinematics(model, kin, estimate.q);
    tracked.push_back(pointPositions(model, kin));
  }

  const std::vector<double> relative = relativeErrorPerPoint(truth, tracked);
  nlohmann::json per_joint = nlohmann::json::object();
  double sum = 0;
  int moving = 0;
  for (std::size_t p = 0; p < relative.size(); ++p) {
    if (relative[p] < 0) continue;  // a point that never moves has no amplitude to divide by
    per_joint[model.points[p].name] = relative[p];
    sum += relative[p];
    ++moving;
  }
  const int tip = model.pointIndex("index_tip");
  return {
      {"experiment", "hand"},
      {"method", config.method},
      {"frames", frames},
      {"cameras", static_cast<int>(rig.size())},
      {"seed", config.seed},
      {"threads", pool.size()},
      {"refine", config.method == "factored" ? config.filter.refine.share : 0.0},
      {"refine_max", config.method == "factored" ? config.filter.refine.max_evaluations : 0},
      {"evals_per_frame", static_cast<double>(evaluations) / frames},
      {"segment_renders_per_frame", static_cast<double>(renders) / frames},
      {"mean_relative_error", moving ? sum / moving : 0.0},
      {"per_joint_relative_error", per_joint},
      {"forefinger_tip_relative_error",
       tip >= 0 && relative[tip] >= 0 ? nlohmann::json(relative[tip]) : nlohmann::json()},
      {"seconds_per_frame", tracking_seconds / frames},
  };
}

}  // namespace mocap

namespace mocap {

int runHandCommand(int argc, char** argv) {
  const Args args(argc, argv, 2, std::string(kHandUsage) + "\n" + filterFlagsUsage("       "));
  if (args.has("describe")) {
    const BodyModel model =
        args.has("model") ? loadBodyModel(args.text("model", "")) : builtinHandModel();
    std::cout << describeModel(model).dump(2) << "\n";
    return 0;
  }
  HandExperimentConfig config;
  config.method = args.text("method", "factored");
  config.evaluations = static_cast<int>(args.integer("evals", 375, 1, 10'000'000));
  config.frames = static_cast<int>(args.integer("frames", 200, 1, 1'000'000));
  config.seed = static_cast<uint64_t>(args.integer("seed", 1, 0, 1L << 62));
  config.cameras = static_cast<int>(args.integer("cameras", 3, 1, 16));
  config.motion_path = args.text("motion", "");
  config.model_path = args.text("model", "");
  config.threads = static_cast<int>(args.integer("threads", 0, 0, 256));
  readFilterFlags(args, config.filter);
  std::cout << runHandExperiment(config).dump(2) << "\n";
  return 0;
}

}  // namespace mocap
