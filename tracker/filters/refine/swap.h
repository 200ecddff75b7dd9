// The refinement's swap move (FilterOptions::refine_swap): the two legs exchange their joint
// angles (or only the knees'), the exchanged pose is searched locally on the legs' angles and
// replaces the pose if it scores a margin better. Two silhouettes often fit both ways round
// (which leg is in front), and no step of one leg gets from one to the other.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"

namespace mocap {

class PoseSearch;
struct MoveScratch;

struct LegSwap {
  std::vector<std::pair<int, int>> pairs;  // the DOFs exchanged: one leg's, the other's
  std::vector<int> dofs;                   // the DOFs searched after: both legs', interleaved
};

// Each foot's leg (its grandparent, parent and itself), DOF by DOF in model order, paired with the
// other's: all of them searched, the knees' alone exchanged with `knees_only`. Throws
// std::invalid_argument naming `option` (the filter option that asked) unless the model has two
// feet with the same free DOFs per segment.
LegSwap findSwappedLegs(const BodyModel& model, bool knees_only, const std::string& option);

// The pose with the legs' angles exchanged (then changed by `adjust`, if set), searched locally on
// them (up to 2 poses per leg angle); kept in q and `best` if it beats the pose by `margin`
// (log-likelihood), otherwise the evaluator goes back to q.
void swapLegs(const BodyModel& model, const LegSwap& swap, double margin, PoseSearch& search,
              MoveScratch& scratch, Eigen::VectorXd& q, double& best,
              const std::function<void(Eigen::VectorXd&)>& adjust = {});

}  // namespace mocap
