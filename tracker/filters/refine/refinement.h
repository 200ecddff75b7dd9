// The factored filter's full-body refinement (FilterOptions::refine_share): after the layers, a
// pattern search on the full-body likelihood from the best particle, preceded each frame by the
// moves a local search cannot make (restart a limb, swap the legs, chase the unexplained
// silhouette, uncross the feet) and helped by the hold and plant steps and the priors. Each pose
// tried counts as one full-body evaluation, but only the segments it moves are re-rasterized
// (IncrementalBodyEvaluator, exact).
#pragma once

#include <functional>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "tracker/filters/filter.h"
#include "tracker/filters/incremental_body.h"
#include "tracker/filters/refine/chase_unexplained.h"
#include "tracker/filters/refine/pose_search.h"
#include "tracker/filters/refine/refinement_plan.h"

namespace mocap {

class Refinement {
 public:
  // All borrowed; they must outlive the refinement.
  Refinement(const BodyModel& model, const Rig& rig, const FilterOptions& options,
             const RefinementPlan& plan, WorkerPool& pool);

  // Refines q (the best particle) against `masks` with the plan's evaluations, drawing from `rng`
  // (the filter's), and adds what it spent to `estimate`. Once `yield` (if set) returns true,
  // checked between DOFs, it stops and sets estimate.cut_short.
  void run(const std::vector<SilhouetteMask>& masks, const std::function<bool()>& yield,
           std::mt19937_64& rng, Eigen::VectorXd& q, FrameEstimate& estimate);

 private:
  // The moves that run before the pattern search, each kept only if it beats the pose.
  void runMoves(const std::vector<SilhouetteMask>& masks, std::mt19937_64& rng, Eigen::VectorXd& q,
                double& best);
  // Hooke and Jeeves: each DOF in layer order takes one step (see PoseSearch::stepDof), then the
  // whole sweep's change is tried once more, until the budget is spent or no step moves.
  void patternSearch(const std::function<bool()>& yield, Eigen::VectorXd& q, double& best,
                     FrameEstimate& estimate);
  // A refined DOF's step that failed both ways, tried again with its held children or planted
  // feet, if it has either.
  void stepHeldOrPlanted(std::size_t i, Eigen::VectorXd& q, double& best);

  const BodyModel& model_;
  const Rig& rig_;
  const FilterOptions& options_;
  const RefinementPlan& plan_;
  IncrementalBodyEvaluator evaluator_;
  PoseSearch search_;

  long restart_turn_ = 0;           // the next limb to restart, modulo their count
  std::vector<double> steps_;       // per refined DOF
  std::vector<double> hold_steps_;  // per refined DOF, of its held or planted step
  Eigen::VectorXd tried_, sweep_start_;
  MoveScratch move_;  // scratch of the restart, the swap and the uncrossing
  ChaseData chase_;
  LegData plant_;  // scratch of the planted steps and the uncrossing
};

}  // namespace mocap
