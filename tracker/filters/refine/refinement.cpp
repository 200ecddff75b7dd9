// The full-body refinement: its moves, then its pattern search over every free DOF.
#include "tracker/filters/refine/refinement.h"

#include "tracker/filters/refine/hold.h"
#include "tracker/filters/refine/plant.h"
#include "tracker/filters/refine/restart.h"
#include "tracker/filters/refine/swap.h"
#include "tracker/model/kinematics.h"

namespace mocap {

Refinement::Refinement(const BodyModel& model, const Rig& rig, const FilterOptions& options,
                       const RefinementPlan& plan, WorkerPool& pool)
    : model_(model),
      rig_(rig),
      options_(options),
      plan_(plan),
      evaluator_(model, rig, options.likelihood.points_per_circle, &pool),
      search_(model, options, plan.facing, plan.crossed, evaluator_),
      steps_(plan.dofs.size()),
      hold_steps_(plan.dofs.size()),
      chase_(model),
      plant_(model) {}

void Refinement::run(const std::vector<SilhouetteMask>& masks, const std::function<bool()>& yield,
                     std::mt19937_64& rng, Eigen::VectorXd& q, FrameEstimate& estimate) {
  const long renders_before = evaluator_.renders();
  double best = search_.start(q, masks, plan_.evaluations - 1);
  for (std::size_t i = 0; i < plan_.dofs.size(); ++i) {
    steps_[i] = kFirstRefineStep * model_.dofs[plan_.dofs[i]].max_speed;
    hold_steps_[i] = steps_[i];
  }
  runMoves(masks, rng, q, best);
  patternSearch(yield, q, best, estimate);
  const int spent = plan_.evaluations - search_.budget();
  estimate.evaluations += spent;
  estimate.segment_renders += evaluator_.renders() - renders_before;
}

void Refinement::runMoves(const std::vector<SilhouetteMask>& masks, std::mt19937_64& rng,
                          Eigen::VectorXd& q, double& best) {
  if (plan_.restart_draws > 0 && !plan_.restart_limbs.empty()) {
    const RestartLimb& limb = plan_.restart_limbs[restart_turn_++ % plan_.restart_limbs.size()];
    restartLimb(model_, limb, plan_.restart_draws, search_, move_, rng, q, best);
  }
  if (!plan_.swap.pairs.empty())
    swapLegs(model_, plan_.swap, options_.likelihood.beta * options_.refine.swap.margin, search_,
             move_, q, best);
  if (options_.refine.unexplained)
    chaseUnexplained(model_, rig_, plan_.legs, masks, search_, chase_, q, best);
  if (plan_.crossed.weight > 0)
    uncrossLegs(model_, plan_.crossed, plan_.legs, plant_, search_, move_, q, best);
}

void Refinement::patternSearch(const std::function<bool()>& yield, Eigen::VectorXd& q, double& best,
                               FrameEstimate& estimate) {
  Eigen::VectorXd& tried = tried_;
  Eigen::VectorXd& sweep_start = sweep_start_;
  while (search_.budget() > 0 && !estimate.cut_short) {
    sweep_start = q;
    const int budget_before_sweep = search_.budget();
    for (std::size_t i = 0; i < plan_.dofs.size() && search_.budget() > 0; ++i) {
      if (yield && yield()) {
        estimate.cut_short = true;
        break;
      }
      if (search_.stepDof(plan_.dofs[i], steps_[i], q, best, 0)) continue;
      stepHeldOrPlanted(i, q, best);
    }
    // Every step has shrunk below what moves a DOF (or every DOF sits at a limit): nothing
    // left to try, so stop rather than loop forever on the unspent budget.
    if (search_.budget() == budget_before_sweep) break;
    if (search_.budget() > 0 && q != sweep_start && !estimate.cut_short) {
      tried = 2 * q - sweep_start;
      clampToLimits(model_, tried);
      search_.tryPose(tried, q, best);
    }
  }
}

void Refinement::stepHeldOrPlanted(std::size_t i, Eigen::VectorXd& q, double& best) {
  const int d = plan_.dofs[i];
  if (!plan_.held[i].empty()) {
    const std::vector<HeldChild>& held = plan_.held[i];
    search_.stepDof(d, hold_steps_[i], q, best, 0,
                    [&](const Eigen::VectorXd& at, Eigen::VectorXd& tried) {
                      holdChildren(model_, held, at, tried);
                    });
  } else if (options_.refine.plant && !plan_.legs.empty() && model_.dofs[d].segment == 0 &&
             model_.dofs[d].type == DofType::kTranslation) {
    search_.stepDof(d, hold_steps_[i], q, best, 0,
                    [&](const Eigen::VectorXd& at, Eigen::VectorXd& tried) {
                      plantFeet(model_, plan_.legs, plant_, at, tried);
                    });
  }
}

}  // namespace mocap
