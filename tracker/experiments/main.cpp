// mocap-experiment: the reproducible experiments of mocapd, each printing one JSON object on
// stdout. Each experiment lives in its own file and is listed once in kExperiments below.
#include <iostream>
#include <string>

#include "tracker/experiments/commands.h"
#include "tracker/experiments/filter_flags.h"

namespace {

struct Experiment {
  const char* name;
  const char* usage;
  int (*run)(int argc, char** argv);  // argv[1] is the experiment name; flags follow
  bool filter_flags;                  // also takes the filter's options (filter_flags.h)
};

constexpr Experiment kExperiments[] = {
    {"hand", mocap::kHandUsage, mocap::runHandCommand, true},
    {"human", mocap::kHumanUsage, mocap::runHumanCommand, true},
    {"bvh-fit", mocap::kBvhFitUsage, mocap::runBvhFitCommand, false},
    {"silhouette", mocap::kSilhouetteUsage, mocap::runSilhouetteCommand, false},
    {"calibration", mocap::kCalibrationUsage, mocap::runCalibrationCommand, false},
};

void printUsage() {
  std::cerr << "usage: mocap-experiment <experiment> [flags]\n";
  for (const Experiment& e : kExperiments) std::cerr << "  " << e.usage << "\n";
  std::cerr << "  hand and human also take the filter's options:\n"
            << mocap::filterFlagsUsage("       ") << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    printUsage();
    return argc < 2 ? 2 : 0;
  }
  const std::string name = argv[1];
  for (const Experiment& e : kExperiments) {
    if (name != e.name) continue;
    for (int i = 2; i < argc; ++i) {
      const std::string flag = argv[i];
      if (flag == "--help" || flag == "-h") {
        std::cout << "usage: mocap-experiment " << e.usage << "\n";
        if (e.filter_flags) std::cout << mocap::filterFlagsUsage("       ") << "\n";
        return 0;
      }
    }
    try {
      return e.run(argc, argv);
    } catch (const std::exception& error) {
      std::cerr << "mocap-experiment " << name << ": " << error.what() << "\n";
      return 1;
    }
  }
  std::cerr << "mocap-experiment: unknown experiment '" << name << "'\n";
  printUsage();
  return 2;
}
