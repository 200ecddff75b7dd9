// The refinement's restart move (FilterOptions::refine_restart_share): one limb a frame, in turn,
// redrawn from random angles of its root segment over their whole range. A limb settled on the
// wrong part of the silhouette (one leg on the other's) scores better than any pose a few steps
// away, so no local step leaves it.
#pragma once

#include <random>
#include <vector>

#include <Eigen/Core>

#include "tracker/model/body_model.h"

namespace mocap {

class PoseSearch;
struct MoveScratch;

struct RestartLimb {
  std::vector<int> root_dofs;  // the limb root's free rotation DOFs
  std::vector<int> dofs;       // every free rotation DOF of the limb
};

// Limbs: segments with at least two free rotations whose parent has several children (the legs,
// the arms, the chest and the head of the human; none in the hand, whose fingers bend one way).
// `descendants`: every segment's descendants, in model order.
std::vector<RestartLimb> findRestartLimbs(const BodyModel& model,
                                          const std::vector<std::vector<int>>& descendants);

// Restarts `limb` from `draws` random draws of its root segment's angles (from `rng`), searches
// around the best draw on all the limb's angles (up to 3 poses per draw), and keeps the result
// in q and `best` if it beats the pose; otherwise the evaluator goes back to q. Every pose tried
// counts against the search's budget.
void restartLimb(const BodyModel& model, const RestartLimb& limb, int draws, PoseSearch& search,
                 MoveScratch& scratch, std::mt19937_64& rng, Eigen::VectorXd& q, double& best);

}  // namespace mocap
