// The simulated hand experiment of the paper (§7): a 15-DOF hand-like model moving along a known
// motion, rendered into virtual cameras, tracked, and scored by the paper's relative error.
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "tracker/filters/filter.h"
#include "tracker/model/body_model.h"
#include "tracker/model/builtin_models.h"
#include "tracker/model/camera.h"

namespace mocap {

struct HandExperimentConfig {
  std::string method = "factored";
  int evaluations = 375;
  int frames = 200;
  uint64_t seed = 1;
  int cameras = 3;
  std::string motion_path;  // CSV; empty: generated from the seed
  std::string model_path;   // YAML; empty: the built-in hand
  int threads = 0;          // 0: hardware threads
  FilterOptions filter;     // evaluations and seed are taken from the fields above
};

// Runs the experiment and returns its JSON summary. Throws std::runtime_error / invalid_argument
// with a message naming the bad input.
nlohmann::json runHandExperiment(const HandExperimentConfig& config);

// {"dofs": [{"name", "min", "max", "max_speed"}...], "joints": [...]} (radians, per frame).
nlohmann::json describeModel(const BodyModel& model);

}  // namespace mocap
