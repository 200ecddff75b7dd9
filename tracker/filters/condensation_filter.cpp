// Condensation (Isard & Blake 1998) as the paper's baseline: resample the whole particle set by
// weight, diffuse every DOF with the same uniform proposal the factored filter uses, and weigh each
// particle by the full-body likelihood (the product of the same per-segment factors, masked chain
// included). One particle evaluation is one full-body particle.
#include <cmath>
#include <random>
#include <stdexcept>

#include "tracker/filters/filter.h"
#include "tracker/likelihood/full_body.h"

namespace mocap {
namespace {

class CondensationFilter final : public PoseFilter {
 public:
  CondensationFilter(const BodyModel& model, const Rig& rig, const FilterOptions& options,
                     WorkerPool& pool)
      : model_(model),
        options_(options),
        pool_(pool),
        rng_(options.seed),
        evaluator_(model, rig, options.likelihood.points_per_circle, pool.size()) {}

  std::string name() const override { return "condensation"; }

  void reset(const Eigen::VectorXd& q0) override {
    if (q0.size() != static_cast<long>(model_.dofs.size()))
      throw std::invalid_argument("condensation: initial pose has the wrong number of DOFs");
    Eigen::VectorXd q = q0;
    clampToLimits(model_, q);
    particles_.assign(options_.evaluations_per_frame, q);
    log_weights_.assign(particles_.size(), 0.0);
  }

  FrameEstimate step(const std::vector<SilhouetteMask>& masks) override {
    if (particles_.empty()) reset(model_.neutralPose());
    resampleSystematic(log_weights_, particles_, resampled_, rng_);
    for (Eigen::VectorXd& q : particles_) diffuseUniform(model_, q, rng_);
    const int n = static_cast<int>(particles_.size());
    pool_.parallelFor(n, [&](int i, int worker) {
      log_weights_[i] =
          logLikelihood(options_.likelihood, evaluator_.evaluate(particles_[i], masks, worker));
    });
    FrameEstimate estimate;
    estimate.evaluations = n;
    estimate.segment_renders = static_cast<long>(n) * evaluator_.drawnSegments();
    std::vector<const Eigen::VectorXd*> qs;
    for (const Eigen::VectorXd& q : particles_) qs.push_back(&q);
    weightedEstimate(qs, log_weights_, estimate);
    return estimate;
  }

 private:
  const BodyModel& model_;
  FilterOptions options_;
  WorkerPool& pool_;
  std::mt19937_64 rng_;
  FullBodyEvaluator evaluator_;
  std::vector<Eigen::VectorXd> particles_, resampled_;
  std::vector<double> log_weights_;
};

}  // namespace

std::unique_ptr<PoseFilter> makeCondensationFilter(const BodyModel& model, const Rig& rig,
                                                   const FilterOptions& options, WorkerPool& pool) {
  validateFilterOptions(options);
  return std::make_unique<CondensationFilter>(model, rig, options, pool);
}

}  // namespace mocap
