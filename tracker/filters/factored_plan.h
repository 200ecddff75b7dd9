// The factored filter's plan, built once from the model, the rig and the options and const after:
// the DBN's layers in topological order, the segments no DOF moves, every segment's descendants,
// the samples per interval and the refinement's plan. The per-frame particles and the per-worker
// scratch live in the filter (the model/data split of tracker/model/kinematics.h).
#pragma once

#include <vector>

#include "tracker/filters/filter.h"
#include "tracker/filters/refine/refinement_plan.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

// One layer of the DBN: a DOF (the hidden node) and the observation of the segment it moves.
struct FactoredLayer {
  int segment = -1;
  int dof = -1;            // -1: observation only (a DOF-less segment moved by its ancestors)
  bool lookahead = false;  // ranked by a look-ahead (see FilterOptions::Lookahead)
  bool first_dof = false;  // the segment's first sampled DOF
};

struct FactoredPlan {
  std::vector<FactoredLayer> layers;
  std::vector<int> static_segments;           // placed once per frame, shared by all particles
  std::vector<std::vector<int>> descendants;  // per segment, in model order
  int samples = 0;                            // S, per kept particle and layer
  int candidates_per_layer = 0;               // K * S
  int max_rows = 0;                           // the tallest camera's, for span buffers
  RefinementPlan refinement;                  // evaluations 0: no refinement
};

// Throws std::invalid_argument on unusable options or a model the filter cannot observe.
FactoredPlan makeFactoredPlan(const BodyModel& model, const Rig& rig, const FilterOptions& options);

}  // namespace mocap
