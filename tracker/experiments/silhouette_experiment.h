// The `silhouette` experiment: learn the background of a generated scene, extract silhouettes of a
// moving person with shadow and illumination drift, and score them against the known truth.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "tracker/vision/silhouette_extractor.h"

namespace mocap {

struct SilhouetteExperimentConfig {
  uint64_t seed = 1;
  int frames = 100;
  int width = 780;
  int height = 580;
  int learn_frames = 30;
  bool gray = false;
  std::string dump_dir;  // non-empty: write image/mask/truth PNGs of the first and last frame
  SilhouetteOptions options;
};

// {"iou" (mean over frames), "shadow_false_positive_rate", "false_negative_rate",
//  "false_positive_rate" (off-body non-shadow pixels called foreground), "ms_per_frame", ...}.
nlohmann::json runSilhouetteExperiment(const SilhouetteExperimentConfig& config);

}  // namespace mocap
