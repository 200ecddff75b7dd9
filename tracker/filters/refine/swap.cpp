// The swap move: which DOFs the legs exchange, and one exchange with its local search.
#include "tracker/filters/refine/swap.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "tracker/filters/refine/pose_search.h"

namespace mocap {

LegSwap findSwappedLegs(const BodyModel& model, bool knees_only, const std::string& option) {
  const auto fail = [&](const std::string& why) {
    throw std::invalid_argument("factored filter: " + option + ": " + why);
  };
  if (model.feet.size() != 2)
    fail("the body model names " + std::to_string(model.feet.size()) + " feet, not two");
  std::vector<int> legs[2], knees[2];
  for (int f = 0; f < 2; ++f) {
    const int foot = model.segmentIndex(model.feet[f]);
    const int knee = model.segments[foot].parent;
    for (int s : {model.segments[knee].parent, knee, foot})
      for (int d : model.segments[s].dofs)
        if (model.dofs[d].isFree()) {
          legs[f].push_back(d);
          if (s == knee) knees[f].push_back(d);
        }
  }
  if (legs[0].size() != legs[1].size() || knees[0].size() != knees[1].size())
    fail("the legs of '" + model.feet[0] + "' and '" + model.feet[1] +
         "' do not have the same free DOFs per segment (" + std::to_string(legs[0].size()) +
         " and " + std::to_string(legs[1].size()) + ")");
  LegSwap swap;
  const std::vector<int>* exchanged = knees_only ? knees : legs;
  for (std::size_t k = 0; k < exchanged[0].size(); ++k)
    swap.pairs.push_back({exchanged[0][k], exchanged[1][k]});
  for (std::size_t k = 0; k < legs[0].size(); ++k) {
    swap.dofs.push_back(legs[0][k]);
    swap.dofs.push_back(legs[1][k]);
  }
  return swap;
}

void swapLegs(const BodyModel& model, const LegSwap& swap, double margin, PoseSearch& search,
              MoveScratch& scratch, Eigen::VectorXd& q, double& best,
              const std::function<void(Eigen::VectorXd&)>& adjust) {
  if (search.budget() <= 2) return;
  Eigen::VectorXd& local = scratch.local;
  local = q;
  for (const auto& [a, b] : swap.pairs) {
    local[a] = std::clamp(q[b], model.dofs[a].min, model.dofs[a].max);
    local[b] = std::clamp(q[a], model.dofs[b].min, model.dofs[b].max);
  }
  if (adjust) adjust(local);
  const double local_value = search.trialScore(local);
  search.evaluator().accept();
  // Up to 2 poses per leg angle.
  search.searchAndKeep(swap.dofs, 2 * static_cast<int>(swap.dofs.size()), margin, local,
                       local_value, q, best);
}

}  // namespace mocap
