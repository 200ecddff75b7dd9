// The refinement's trial machinery: scoring, keeping or dropping a pose, coordinate steps and the
// local search that ends the refinement's moves.
#include "tracker/filters/refine/pose_search.h"

#include <algorithm>

namespace mocap {

PoseSearch::PoseSearch(const BodyModel& model, const FilterOptions& options,
                       const FacingPrior& facing, const CrossedLegs& crossed,
                       IncrementalBodyEvaluator& evaluator)
    : model_(model), options_(options), facing_(facing), crossed_(crossed), evaluator_(evaluator) {}

double PoseSearch::start(const Eigen::VectorXd& q, const std::vector<SilhouetteMask>& masks,
                         int budget) {
  budget_ = budget;
  return logLikelihood(options_.likelihood, evaluator_.reset(q, masks)) - facing_.cost(q) -
         crossed_.cost(evaluator_.kinematics());
}

double PoseSearch::trialScore(const Eigen::VectorXd& pose) {
  --budget_;
  return logLikelihood(options_.likelihood, evaluator_.trial(pose)) - facing_.cost(pose) -
         crossed_.cost(evaluator_.kinematics());
}

bool PoseSearch::tryPose(const Eigen::VectorXd& pose, Eigen::VectorXd& at, double& value) {
  const double score = trialScore(pose);
  if (score <= value) {
    evaluator_.reject();
    return false;
  }
  evaluator_.accept();
  value = score;
  at = pose;
  return true;
}

bool PoseSearch::stepDof(int d, double& step, Eigen::VectorXd& at, double& value, int reserve,
                         const Adjust& adjust) {
  const Dof& dof = model_.dofs[d];
  Eigen::VectorXd& tried = tried_;
  for (const double signed_step : {step, -step}) {
    if (budget_ <= reserve) break;
    tried = at;
    tried[d] = std::clamp(at[d] + signed_step, dof.min, dof.max);
    if (tried[d] == at[d]) continue;
    if (adjust) adjust(at, tried);
    if (tryPose(tried, at, value)) {
      step = 1.5 * signed_step;
      return true;
    }
  }
  step *= 0.5;
  return false;
}

void PoseSearch::searchAndKeep(const std::vector<int>& dofs, int poses, double margin,
                               Eigen::VectorXd& local, double local_value, Eigen::VectorXd& q,
                               double& best) {
  std::vector<double>& steps = steps_;
  steps.clear();
  for (int d : dofs) steps.push_back(kFirstRefineStep * model_.dofs[d].max_speed);
  const int search_start = budget_;
  for (int swept_from = -1;
       search_start - budget_ < poses && budget_ > 1 && budget_ != swept_from;) {
    swept_from = budget_;
    for (std::size_t j = 0; j < dofs.size() && budget_ > 1; ++j)
      stepDof(dofs[j], steps[j], local, local_value, 1);
  }
  if (local_value > best + margin) {
    best = local_value;
    q = local;
    return;
  }
  trialScore(q);
  evaluator_.accept();
}

}  // namespace mocap
