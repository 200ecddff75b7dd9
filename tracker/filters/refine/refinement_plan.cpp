// Builds the refinement's plan: each move finds what it needs in the model.
#include "tracker/filters/refine/refinement_plan.h"

#include <cmath>
#include <utility>

namespace mocap {

RefinementPlan makeRefinementPlan(const BodyModel& model, const FilterOptions& options,
                                  int evaluations, std::vector<int> dofs,
                                  const std::vector<std::vector<int>>& descendants) {
  RefinementPlan plan;
  plan.evaluations = evaluations;
  plan.dofs = std::move(dofs);
  plan.held.resize(plan.dofs.size());
  if (options.refine.hold) plan.held = findHeldChildren(model, plan.dofs);
  if (options.refine.plant || options.refine.unexplained || options.refine.uncross > 0)
    plan.legs = findLegs(model);
  if (options.refine.swap.enabled)
    plan.swap = findSwappedLegs(model, options.refine.swap.knees_only, "refine_swap");
  if (options.refine.restart_share > 0) plan.restart_limbs = findRestartLimbs(model, descendants);
  if (options.refine.facing_prior > 0)
    plan.facing = makeFacingPrior(model, options.refine.facing_prior);
  plan.crossed = findCrossedLegs(model, options.refine.uncross);
  // Each draw is followed by up to 3 poses of local search.
  plan.restart_draws =
      static_cast<int>(std::lround(options.refine.restart_share * evaluations / 4));
  return plan;
}

}  // namespace mocap
