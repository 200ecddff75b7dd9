// mocap-experiment: the reproducible experiments of mocapd, each printing one JSON object.
//   mocap-experiment hand [--method factored|condensation] [--evals N] [--frames N] [--seed S]
//                         [--cameras N] [--motion FILE.csv] [--model FILE.yaml] [--threads N]
//                         [--keep K] [--samples S] [--injection SHARE] [--beta B] [--describe]
#include <iostream>

#include "tracker/experiments/args.h"
#include "tracker/experiments/hand_experiment.h"

namespace {

constexpr const char* kUsage =
    "usage: mocap-experiment hand [--method factored|condensation] [--evals N] [--frames N]\n"
    "                             [--seed S] [--cameras N] [--motion FILE.csv] [--model FILE.yaml]\n"
    "                             [--threads N] [--keep K] [--samples S] [--injection SHARE]\n"
    "                             [--beta B] [--describe]\n";

int runHand(int argc, char** argv) {
  const mocap::Args args(argc, argv, 2,
                         {"method", "evals", "frames", "seed", "cameras", "motion", "model",
                          "threads", "keep", "samples", "injection", "beta"},
                         {"describe"});
  if (args.has("describe")) {
    const mocap::BodyModel model = args.has("model") ? mocap::loadBodyModel(args.text("model", ""))
                                                     : mocap::builtinHandModel();
    std::cout << mocap::describeModel(model).dump(2) << "\n";
    return 0;
  }
  mocap::HandExperimentConfig config;
  config.method = args.text("method", "factored");
  config.evaluations = static_cast<int>(args.integer("evals", 375, 1, 10'000'000));
  config.frames = static_cast<int>(args.integer("frames", 200, 1, 1'000'000));
  config.seed = static_cast<uint64_t>(args.integer("seed", 1, 0, 1L << 62));
  config.cameras = static_cast<int>(args.integer("cameras", 3, 1, 16));
  config.motion_path = args.text("motion", "");
  config.model_path = args.text("model", "");
  config.threads = static_cast<int>(args.integer("threads", 0, 0, 256));
  config.filter.keep = static_cast<int>(args.integer("keep", config.filter.keep, 1, 100000));
  config.filter.samples = static_cast<int>(args.integer("samples", 0, 0, 100000));
  config.filter.injection_share =
      args.real("injection", config.filter.injection_share, 0.0, 0.99);
  config.filter.likelihood.beta = args.real("beta", config.filter.likelihood.beta, 1e-9, 1e3);
  std::cout << mocap::runHandExperiment(config).dump(2) << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::cerr << kUsage;
    return argc < 2 ? 2 : 0;
  }
  const std::string experiment = argv[1];
  try {
    if (experiment == "hand") return runHand(argc, argv);
    std::cerr << "mocap-experiment: unknown experiment '" << experiment << "'\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "mocap-experiment " << experiment << ": " << e.what() << "\n";
    return 1;
  }
}
