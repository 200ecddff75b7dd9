// What the factored filter's full-body refinement works on, found once from the model and the
// options: the DOFs it sweeps, and what each of its moves needs (held children, legs, the swap's
// DOF pairs, the limbs to restart, the facing prior, the crossed feet's cost). Const once built;
// the per-frame state and scratch live in Refinement.
#pragma once

#include <vector>

#include "tracker/filters/filter.h"
#include "tracker/filters/refine/facing_prior.h"
#include "tracker/filters/refine/hold.h"
#include "tracker/filters/refine/legs.h"
#include "tracker/filters/refine/restart.h"
#include "tracker/filters/refine/swap.h"
#include "tracker/filters/refine/uncross.h"
#include "tracker/model/body_model.h"

namespace mocap {

struct RefinementPlan {
  int evaluations = 0;                       // per frame; 0: no refinement
  std::vector<int> dofs;                     // the free DOFs, in layer order
  std::vector<std::vector<HeldChild>> held;  // per refined DOF (FilterOptions::refine_hold)
  std::vector<Leg> legs;                     // refine_plant, refine_unexplained, refine_uncross
  LegSwap swap;                              // FilterOptions::refine_swap
  std::vector<RestartLimb> restart_limbs;    // FilterOptions::refine_restart_share
  int restart_draws = 0;                     // per restart
  FacingPrior facing;                        // FilterOptions::refine_facing_prior
  CrossedLegs crossed;                       // FilterOptions::refine_uncross
};

// The plan of a refinement of `evaluations` per frame over `dofs` (the layers' free DOFs, in
// order); `descendants`: every segment's, in model order. Throws std::invalid_argument on options
// the model cannot serve.
RefinementPlan makeRefinementPlan(const BodyModel& model, const FilterOptions& options,
                                  int evaluations, std::vector<int> dofs,
                                  const std::vector<std::vector<int>>& descendants);

}  // namespace mocap
