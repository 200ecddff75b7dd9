// The annealed particle filter (Deutscher, Blake & Reid, CVPR 2000) as a baseline. Each frame runs
// M annealing layers over N = budget / M particles. The first layer draws from the same uniform
// proposal as the other filters; every layer weighs the particles by the full-body likelihood
// raised to a power chosen so that about half of them survive (the paper's particle survival rate
// alpha = 0.5), resamples, and diffuses with Gaussian noise that shrinks by alpha per layer. The
// estimate is the weighted mean of the last layer.
#include <cmath>
#include <random>
#include <stdexcept>

#include "tracker/filters/filter.h"
#include "tracker/likelihood/full_body.h"

namespace mocap {
namespace {

constexpr double kSurvivalRate = 0.5;

// Effective share of particles, 1 / (N sum w^2), for weights exp(power * energy) normalized.
double survivalShare(const std::vector<double>& log_likelihood, double power) {
  const double best = *std::max_element(log_likelihood.begin(), log_likelihood.end());
  double sum = 0, sum_sq = 0;
  for (double l : log_likelihood) {
    const double w = std::exp(power * (l - best));
    sum += w;
    sum_sq += w * w;
  }
  return sum * sum / (sum_sq * static_cast<double>(log_likelihood.size()));
}

// The power in [0, 1] (tempering the likelihood) whose survival share is closest to the target:
// bisection, as the share falls monotonically with the power.
double temperingPower(const std::vector<double>& log_likelihood) {
  if (survivalShare(log_likelihood, 1.0) >= kSurvivalRate) return 1.0;
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 40; ++i) {
    const double mid = 0.5 * (lo + hi);
    (survivalShare(log_likelihood, mid) > kSurvivalRate ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

class AnnealedFilter final : public PoseFilter {
 public:
  AnnealedFilter(const BodyModel& model, const Rig& rig, const FilterOptions& options,
                 WorkerPool& pool)
      : model_(model),
        options_(options),
        pool_(pool),
        rng_(options.seed),
        evaluator_(model, rig, options.likelihood.points_per_circle, pool.size()) {
    particle_count_ = std::max(1, options.evaluations_per_frame / options.annealing_layers);
  }

  std::string name() const override { return "annealed"; }

  void reset(const Eigen::VectorXd& q0) override {
    if (q0.size() != static_cast<long>(model_.dofs.size()))
      throw std::invalid_argument("annealed filter: initial pose has the wrong number of DOFs");
    Eigen::VectorXd q = q0;
    clampToLimits(model_, q);
    particles_.assign(particle_count_, q);
  }

  FrameEstimate step(const std::vector<SilhouetteMask>& masks) override {
    if (particles_.empty()) reset(model_.neutralPose());
    const int n = static_cast<int>(particles_.size());
    std::vector<double> log_likelihood(n), log_weights(n);
    for (Eigen::VectorXd& q : particles_) diffuseUniform(model_, q, rng_);
    FrameEstimate estimate;
    for (int layer = 0; layer < options_.annealing_layers; ++layer) {
      if (layer > 0) {
        resampleSystematic(log_weights, particles_, resampled_, rng_);
        const double scale = std::pow(kSurvivalRate, layer);
        for (Eigen::VectorXd& q : particles_) diffuseGaussian(q, scale);
      }
      pool_.parallelFor(n, [&](int i, int worker) {
        log_likelihood[i] =
            logLikelihood(options_.likelihood, evaluator_.evaluate(particles_[i], masks, worker));
      });
      const double power = temperingPower(log_likelihood);
      for (int i = 0; i < n; ++i) log_weights[i] = power * log_likelihood[i];
      estimate.evaluations += n;
      estimate.segment_renders += static_cast<long>(n) * evaluator_.drawnSegments();
    }
    std::vector<const Eigen::VectorXd*> qs;
    for (const Eigen::VectorXd& q : particles_) qs.push_back(&q);
    weightedEstimate(qs, log_weights, estimate);
    // The next frame starts from a draw of this frame's posterior.
    resampleSystematic(log_weights, particles_, resampled_, rng_);
    return estimate;
  }

 private:
  // Gaussian noise with a standard deviation of `scale` times each DOF's speed limit, kept in
  // limits.
  void diffuseGaussian(Eigen::VectorXd& q, double scale) {
    std::normal_distribution<double> normal(0.0, 1.0);
    for (std::size_t d = 0; d < model_.dofs.size(); ++d) {
      const Dof& dof = model_.dofs[d];
      if (!dof.isFree()) continue;
      q[d] = std::clamp(q[d] + scale * dof.max_speed * normal(rng_), dof.min, dof.max);
    }
  }

  const BodyModel& model_;
  FilterOptions options_;
  WorkerPool& pool_;
  std::mt19937_64 rng_;
  FullBodyEvaluator evaluator_;
  int particle_count_ = 0;
  std::vector<Eigen::VectorXd> particles_, resampled_;
};

}  // namespace

std::unique_ptr<PoseFilter> makeAnnealedFilter(const BodyModel& model, const Rig& rig,
                                               const FilterOptions& options, WorkerPool& pool) {
  validateFilterOptions(options);
  return std::make_unique<AnnealedFilter>(model, rig, options, pool);
}

}  // namespace mocap
