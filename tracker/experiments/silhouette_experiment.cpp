// The `silhouette` experiment and its mocap-experiment command.
#include "tracker/experiments/silhouette_experiment.h"

#include <chrono>
#include <filesystem>
#include <iostream>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tracker/cli/args.h"
#include "tracker/experiments/commands.h"
#include "tracker/sim/test_scene.h"

namespace mocap {

namespace {

void dumpFrame(const std::string& dir, int t, const TestSceneFrame& frame, const cv::Mat& mask) {
  std::filesystem::create_directories(dir);
  const std::string stem = dir + "/frame_" + std::to_string(t);
  if (!cv::imwrite(stem + "_image.png", frame.image) || !cv::imwrite(stem + "_mask.png", mask) ||
      !cv::imwrite(stem + "_body.png", frame.body) ||
      !cv::imwrite(stem + "_shadow.png", frame.shadow))
    throw std::runtime_error(dir + ": cannot write PNG files");
}

}  // namespace

nlohmann::json runSilhouetteExperiment(const SilhouetteExperimentConfig& config) {
  if (config.frames < 1 || config.learn_frames < 1)
    throw std::invalid_argument("frames and learn_frames must be positive");
  TestSceneOptions scene_options;
  scene_options.width = config.width;
  scene_options.height = config.height;
  scene_options.color = !config.gray;
  scene_options.seed = config.seed;
  SilhouetteTestScene scene(scene_options);

  TestSceneFrame frame;
  BackgroundLearner learner;
  for (int i = 0; i < config.learn_frames; ++i) {
    scene.render(0, false, frame);
    learner.add(frame.image);
  }
  SilhouetteExtractor extractor(learner.model(), config.options);

  double iou_sum = 0, seconds = 0;
  long body_pixels = 0, missed = 0, shadow_pixels = 0, shadow_called = 0, other_pixels = 0,
       other_called = 0;
  for (int t = 0; t < config.frames; ++t) {
    scene.render(t, true, frame);
    const auto start = std::chrono::steady_clock::now();
    if (!extractor.extract(frame.image)) throw std::runtime_error(extractor.lastError());
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    const cv::Mat& mask = extractor.foreground();
    const long body = cv::countNonZero(frame.body);
    const long found = cv::countNonZero(mask);
    const long both = cv::countNonZero(mask & frame.body);
    iou_sum += static_cast<double>(both) / std::max(1L, body + found - both);
    body_pixels += body;
    missed += body - both;
    shadow_pixels += cv::countNonZero(frame.shadow);
    shadow_called += cv::countNonZero(mask & frame.shadow);
    const long off_body = frame.body.total() - body - cv::countNonZero(frame.shadow);
    other_pixels += off_body;
    other_called += found - both - cv::countNonZero(mask & frame.shadow);
    if (!config.dump_dir.empty() && (t == 0 || t == config.frames - 1))
      dumpFrame(config.dump_dir, t, frame, mask);
  }
  const double n = config.frames;
  return {{"experiment", "silhouette"},
          {"seed", config.seed},
          {"frames", config.frames},
          {"width", config.width},
          {"height", config.height},
          {"color", !config.gray},
          {"iou", iou_sum / n},
          {"shadow_false_positive_rate",
           static_cast<double>(shadow_called) / std::max(1L, shadow_pixels)},
          {"false_negative_rate", static_cast<double>(missed) / std::max(1L, body_pixels)},
          {"false_positive_rate", static_cast<double>(other_called) / std::max(1L, other_pixels)},
          {"final_gain", extractor.gain()},
          {"ms_per_frame", 1000.0 * seconds / n}};
}

int runSilhouetteCommand(int argc, char** argv) {
  const Args args(argc, argv, 2, kSilhouetteUsage);
  SilhouetteExperimentConfig config;
  config.seed = static_cast<uint64_t>(args.integer("seed", 1, 0, 1L << 40));
  config.frames = static_cast<int>(args.integer("frames", 100, 1, 100000));
  config.width = static_cast<int>(args.integer("width", 780, 64, 8192));
  config.height = static_cast<int>(args.integer("height", 580, 48, 8192));
  config.learn_frames = static_cast<int>(args.integer("learn", 30, 1, 10000));
  config.gray = args.has("gray");
  config.dump_dir = args.text("dump", "");
  config.options.threshold_sigmas =
      static_cast<float>(args.real("threshold", config.options.threshold_sigmas, 0.5, 50));
  config.options.shadow_texture_sigmas = static_cast<float>(
      args.real("texture-sigmas", config.options.shadow_texture_sigmas, 0.1, 50));
  config.options.shadow_texture_contrast = static_cast<float>(
      args.real("texture-contrast", config.options.shadow_texture_contrast, 0, 1000));
  config.options.suppress_shadows = !args.has("no-shadows");
  config.options.adaptive = !args.has("no-adaptive");
  std::cout << runSilhouetteExperiment(config).dump(2) << std::endl;
  return 0;
}

}  // namespace mocap
