// The refinement's trial machinery, shared by its sweep and its moves: a pose is scored on the
// incremental full-body evaluator (log-likelihood less the priors) as one evaluation of the
// frame's budget, then kept as the evaluator's current pose or dropped.
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "tracker/filters/filter.h"
#include "tracker/filters/incremental_body.h"
#include "tracker/filters/refine/facing_prior.h"
#include "tracker/filters/refine/uncross.h"

namespace mocap {

// The pattern search's first step, in speed limits of each DOF.
inline constexpr double kFirstRefineStep = 0.5;

// Scratch of a move that draws poses and searches around the best: the pose being tried and the
// best found so far.
struct MoveScratch {
  Eigen::VectorXd tried, local;
};

class PoseSearch {
 public:
  // Re-solves DOFs of `tried` (a step away from `at`) that the step should not disturb.
  using Adjust = std::function<void(const Eigen::VectorXd& at, Eigen::VectorXd& tried)>;

  // All borrowed; they must outlive the search.
  PoseSearch(const BodyModel& model, const FilterOptions& options, const FacingPrior& facing,
             const CrossedLegs& crossed, IncrementalBodyEvaluator& evaluator);

  // Makes q the evaluator's current pose against `masks`, with `budget` evaluations to spend
  // after it, and returns q's score.
  double start(const Eigen::VectorXd& q, const std::vector<SilhouetteMask>& masks, int budget);
  int budget() const { return budget_; }
  IncrementalBodyEvaluator& evaluator() { return evaluator_; }

  // The score of `pose`, as the evaluator's trial (to accept or reject), counted as one
  // evaluation of the budget: its log-likelihood less the facing prior and the crossed feet's
  // cost.
  double trialScore(const Eigen::VectorXd& pose);
  // Scores `pose` as one evaluation of the budget. If it beats `value`, it becomes the evaluator's
  // current pose, `at` and `value`; otherwise the evaluator goes back to `at`.
  bool tryPose(const Eigen::VectorXd& pose, Eigen::VectorXd& at, double& value);
  // One step of DOF d from `at` each way while the budget is above `reserve`, the signed `step`
  // first (the direction that last worked), each trial passed through `adjust` if it is set: a
  // step that improves is taken and grows by half; if neither does, the step halves.
  bool stepDof(int d, double& step, Eigen::VectorXd& at, double& value, int reserve,
               const Adjust& adjust = {});
  // The second half of a restart, a swap and a chase. `local`, the evaluator's current pose,
  // scoring `local_value`, is searched by coordinate steps on `dofs` as the refinement takes them,
  // for up to `poses` evaluations with one kept back to restore the pose; a sweep that tries
  // nothing (every step too small to move a DOF) ends it. The result replaces q if it beats `best`
  // by `margin` (log-likelihood); otherwise the evaluator goes back to q.
  void searchAndKeep(const std::vector<int>& dofs, int poses, double margin, Eigen::VectorXd& local,
                     double local_value, Eigen::VectorXd& q, double& best);

 private:
  const BodyModel& model_;
  const FilterOptions& options_;
  const FacingPrior& facing_;
  const CrossedLegs& crossed_;
  IncrementalBodyEvaluator& evaluator_;
  int budget_ = 0;
  Eigen::VectorXd tried_;      // scratch of stepDof()
  std::vector<double> steps_;  // scratch of searchAndKeep()
};

}  // namespace mocap
