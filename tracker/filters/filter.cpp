// What the filters share: the factory, the proposal interval and the weighted estimate.
#include "tracker/filters/filter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mocap {

std::unique_ptr<PoseFilter> makeFilter(const std::string& method, const BodyModel& model,
                                       const Rig& rig, const FilterOptions& options,
                                       WorkerPool& pool) {
  if (rig.empty() || rig.size() > kMaxCameras)
    throw std::invalid_argument("filter: the rig must have 1 to " + std::to_string(kMaxCameras) +
                                " cameras");
  if (method == "factored") return makeFactoredFilter(model, rig, options, pool);
  if (method == "condensation") return makeCondensationFilter(model, rig, options, pool);
  if (method == "annealed") return makeAnnealedFilter(model, rig, options, pool);
  throw std::invalid_argument("unknown filter method '" + method +
                              "' (expected factored, condensation or annealed)");
}

void resampleSystematic(const std::vector<double>& log_weights,
                        std::vector<Eigen::VectorXd>& particles,
                        std::vector<Eigen::VectorXd>& scratch, std::mt19937_64& rng) {
  const std::size_t n = particles.size();
  const double best = *std::max_element(log_weights.begin(), log_weights.end());
  std::vector<double> cdf(n);
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) cdf[i] = sum += std::exp(log_weights[i] - best);
  const double offset = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
  scratch.resize(n);
  std::size_t j = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double target = (i + offset) / n * sum;
    while (j + 1 < n && cdf[j] < target) ++j;
    scratch[i] = particles[j];
  }
  particles.swap(scratch);
}

void diffuseUniform(const BodyModel& model, Eigen::VectorXd& q, std::mt19937_64& rng) {
  for (std::size_t d = 0; d < model.dofs.size(); ++d) {
    const auto [lo, hi] = proposalInterval(model.dofs[d], q[d]);
    if (hi > lo) q[d] = std::uniform_real_distribution<double>(lo, hi)(rng);
  }
}

void weightedEstimate(const std::vector<const Eigen::VectorXd*>& particles,
                      const std::vector<double>& log_weights, FrameEstimate& out) {
  const double best = *std::max_element(log_weights.begin(), log_weights.end());
  out.best_log_weight = best;
  std::vector<double> w(log_weights.size());
  double sum = 0;
  for (std::size_t i = 0; i < w.size(); ++i) sum += w[i] = std::exp(log_weights[i] - best);
  out.q = Eigen::VectorXd::Zero(particles[0]->size());
  for (std::size_t i = 0; i < w.size(); ++i) out.q += (w[i] / sum) * *particles[i];
  double spread = 0;
  for (std::size_t i = 0; i < w.size(); ++i)
    spread += (w[i] / sum) * (*particles[i] - out.q).squaredNorm();
  out.spread = std::sqrt(spread);
}

}  // namespace mocap
