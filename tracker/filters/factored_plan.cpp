// Builds the factored filter's plan: its layers, its budget split between the layers and the
// refinement, and the refinement's plan.
#include "tracker/filters/factored_plan.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mocap {
namespace {

// Every segment's descendants, in model order.
std::vector<std::vector<int>> findDescendants(const BodyModel& model) {
  std::vector<std::vector<int>> descendants(model.segments.size());
  for (std::size_t d = 0; d < model.segments.size(); ++d) {
    for (int a = model.segments[d].parent; a >= 0; a = model.segments[a].parent)
      descendants[a].push_back(static_cast<int>(d));
  }
  return descendants;
}

// One layer per free DOF of each moving segment, in model order (topological: a parent comes
// before its children); a moving segment without free DOFs gets an observation layer.
void buildLayers(const BodyModel& model, const FilterOptions& options, FactoredPlan& plan) {
  for (std::size_t s = 0; s < model.segments.size(); ++s) {
    const Segment& seg = model.segments[s];
    const int si = static_cast<int>(s);
    if (model.isStatic(si)) {
      plan.static_segments.push_back(si);
      continue;
    }
    if (seg.shape.type == ShapeType::kNone)
      throw std::invalid_argument("factored filter: segment '" + seg.name +
                                  "' moves but has no shape, so nothing observes it");
    int free_count = 0;
    for (int d : seg.dofs) {
      if (!model.dofs[d].isFree()) continue;
      plan.layers.push_back(
          {si, d, options.lookahead == FilterOptions::Lookahead::kBody, free_count == 0});
      ++free_count;
    }
    // Moved only by its ancestors: observed once so the chain masks what it explains.
    if (free_count == 0) plan.layers.push_back({si, -1, false, false});
  }
}

}  // namespace

FactoredPlan makeFactoredPlan(const BodyModel& model, const Rig& rig,
                              const FilterOptions& options) {
  FactoredPlan plan;
  plan.descendants = findDescendants(model);
  buildLayers(model, options, plan);
  const int sampling_layers = static_cast<int>(std::count_if(
      plan.layers.begin(), plan.layers.end(), [](const FactoredLayer& l) { return l.dof >= 0; }));
  const int observation_layers = static_cast<int>(plan.layers.size()) - sampling_layers;
  plan.samples = options.samples;
  if (plan.samples <= 0) {
    const double budget = options.evaluations_per_frame * (1 - options.refine.share) -
                          observation_layers * options.keep;
    plan.samples = std::max(
        1, static_cast<int>(std::lround(budget / std::max(1, sampling_layers * options.keep))));
    // An even count never samples the interval's centre (the previous value). With a
    // refinement, which takes what the layers leave, the count is made odd at no loss of budget.
    if (options.refine.share > 0 && plan.samples % 2 == 0) --plan.samples;
  }
  plan.candidates_per_layer = options.keep * plan.samples;
  if (options.refine.share > 0) {
    // The refinement takes what the layers leave of the budget.
    const int layer_evaluations =
        sampling_layers * plan.candidates_per_layer + observation_layers * options.keep;
    int evaluations = std::max(2, options.evaluations_per_frame - layer_evaluations);
    if (options.refine.max_evaluations > 0)
      evaluations = std::min(evaluations, std::max(2, options.refine.max_evaluations));
    std::vector<int> dofs;
    for (const FactoredLayer& layer : plan.layers)
      if (layer.dof >= 0) dofs.push_back(layer.dof);
    plan.refinement =
        makeRefinementPlan(model, options, evaluations, std::move(dofs), plan.descendants);
  }
  for (const CameraModel& c : rig) plan.max_rows = std::max(plan.max_rows, c.height);
  return plan;
}

}  // namespace mocap
