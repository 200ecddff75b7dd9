// mocap-experiment bvh-fit: how faithfully the human model, fitted to a CMU subject, follows the
// subject's motion after retargeting (the ground truth of the human experiments): fitted bone
// lengths, per-point IK residuals in millimetres, and the DOFs whose speed limits the motion
// breaks.
#include <algorithm>
#include <iostream>

#include <nlohmann/json.hpp>

#include "tracker/cli/args.h"
#include "tracker/experiments/commands.h"
#include "tracker/experiments/human_experiment.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/retarget.h"

namespace mocap {

int runBvhFitCommand(int argc, char** argv) {
  const Args args(argc, argv, 2, kBvhFitUsage);
  if (!args.has("motion")) throw std::invalid_argument("--motion FILE.bvh is required");
  const Bvh bvh = loadBvh(args.text("motion", ""));
  const BodyModel model =
      args.has("model") ? loadBodyModel(args.text("model", "")) : builtinHumanModel();
  const int max_frames = static_cast<int>(args.integer("frames", 0, 0, 10'000'000));
  const double rate = args.real("rate", 25, 1e-3, 1e4);

  const BodyModel fitted = fitModelToBvh(model, bvh.skeleton);
  const RetargetResult result = retargetBvh(fitted, bvh.skeleton, bvh.motion, rate, max_frames);

  nlohmann::json bones = nlohmann::json::object();
  const std::vector<BoneLength> subject = subjectBoneLengths(model, bvh.skeleton);
  const std::vector<BoneLength> model_bones = modelBoneLengths(fitted);
  for (std::size_t b = 0; b < subject.size(); ++b)
    bones[model_bones[b].name] = {{"fitted_m", model_bones[b].length},
                                  {"subject_m", subject[b].length}};

  nlohmann::json per_point = nlohmann::json::object();
  double sum = 0, worst = 0;
  const std::size_t frames = result.residual_mm.size();
  for (std::size_t p = 0; p < fitted.points.size(); ++p) {
    double point_sum = 0, point_max = 0;
    for (const std::vector<double>& frame : result.residual_mm) {
      point_sum += frame[p];
      point_max = std::max(point_max, frame[p]);
    }
    per_point[fitted.points[p].name] = {{"mean_mm", frames ? point_sum / frames : 0.0},
                                        {"max_mm", point_max}};
    sum += point_sum;
    worst = std::max(worst, point_max);
  }

  nlohmann::json speed = nlohmann::json::array();
  for (const SpeedExcess& e : result.speed_excess)
    speed.push_back({{"dof", e.dof},
                     {"frames", e.frames},
                     {"worst_per_frame", e.worst},
                     {"max_speed", e.max_speed}});

  const nlohmann::json summary = {
      {"experiment", "bvh-fit"},
      {"motion", args.text("motion", "")},
      {"bvh_frames", bvh.motion.frames.size()},
      {"bvh_frame_time", bvh.motion.frame_time},
      {"frames", frames},
      {"rate", rate},
      {"mirrored", result.mirrored},
      {"bone_lengths", bones},
      {"residual_mm",
       {{"mean", frames ? sum / (frames * fitted.points.size()) : 0.0},
        {"max", worst},
        {"per_point", per_point}}},
      {"speed_limit_exceeded", speed},
  };
  std::cout << summary.dump(2) << "\n";
  return 0;
}

}  // namespace mocap
