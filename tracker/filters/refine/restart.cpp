// The restart move: which limbs restart, and one restart of a limb.
#include "tracker/filters/refine/restart.h"

#include <cmath>

#include "tracker/filters/refine/pose_search.h"

namespace mocap {

std::vector<RestartLimb> findRestartLimbs(const BodyModel& model,
                                          const std::vector<std::vector<int>>& descendants) {
  std::vector<RestartLimb> limbs;
  std::vector<int> children(model.segments.size(), 0);
  for (const Segment& seg : model.segments)
    if (seg.parent >= 0) ++children[seg.parent];
  for (std::size_t s = 0; s < model.segments.size(); ++s) {
    const Segment& seg = model.segments[s];
    if (seg.parent < 0 || children[seg.parent] < 2) continue;
    RestartLimb limb;
    const auto rotations = [&](int segment, std::vector<int>& out) {
      for (int d : model.segments[segment].dofs)
        if (model.dofs[d].isFree() && model.dofs[d].type == DofType::kRotation) out.push_back(d);
    };
    rotations(static_cast<int>(s), limb.root_dofs);
    if (limb.root_dofs.size() < 2) continue;
    limb.dofs = limb.root_dofs;
    for (int d : descendants[s]) rotations(d, limb.dofs);
    limbs.push_back(limb);
  }
  return limbs;
}

void restartLimb(const BodyModel& model, const RestartLimb& limb, int draws, PoseSearch& search,
                 MoveScratch& scratch, std::mt19937_64& rng, Eigen::VectorXd& q, double& best) {
  Eigen::VectorXd& tried = scratch.tried;
  Eigen::VectorXd& local = scratch.local;
  double local_value = -INFINITY;
  for (int k = 0; k < draws && search.budget() > 2; ++k) {
    tried = q;
    for (int d : limb.root_dofs)
      tried[d] = std::uniform_real_distribution<double>(model.dofs[d].min, model.dofs[d].max)(rng);
    const double value = search.trialScore(tried);
    search.evaluator().reject();
    if (value > local_value) {
      local_value = value;
      local = tried;
    }
  }
  if (local_value == -INFINITY || search.budget() <= 2) return;
  search.trialScore(local);
  search.evaluator().accept();
  // Up to 3 poses of search per draw on the limb's angles.
  search.searchAndKeep(limb.dofs, 3 * draws, 0, local, local_value, q, best);
}

}  // namespace mocap
