// Condensation (Isard & Blake 1998) as the paper's baseline: resample the whole particle set by
// weight, diffuse every DOF with the same uniform proposal the factored filter uses, and weigh each
// particle by the full-body likelihood (the product of the same per-segment factors, masked chain
// included). One particle evaluation is one full-body particle.
#include <cmath>
#include <random>
#include <stdexcept>

#include "tracker/filter.h"
#include "tracker/kinematics.h"

namespace mocap {
namespace {

struct WorkerScratch {
  WorkerScratch(const BodyModel& model, const Rig& rig, int points_per_circle, int max_rows)
      : kinematics(model),
        rasterizer(points_per_circle),
        spans(model.segments.size() * rig.size() * max_rows),
        footprints(rig.size()),
        explained(rig.size()) {}
  KinematicsData kinematics;
  ShapeRasterizer rasterizer;
  std::vector<RowSpan> spans;  // per segment, per camera, max_rows each
  std::vector<Footprint> footprints;
  std::vector<std::vector<Footprint>> explained;  // per camera
};

class CondensationFilter final : public PoseFilter {
 public:
  CondensationFilter(const BodyModel& model, const Rig& rig, const FilterOptions& options,
                     WorkerPool& pool)
      : model_(model), rig_(rig), options_(options), pool_(pool), rng_(options.seed) {
    for (const CameraModel& c : rig) max_rows_ = std::max(max_rows_, c.height);
    for (int w = 0; w < pool.size(); ++w)
      scratch_.emplace_back(model, rig, options.likelihood.points_per_circle, max_rows_);
    for (std::size_t s = 0; s < model.segments.size(); ++s)
      if (model.segments[s].shape.type != ShapeType::kNone) drawn_.push_back(static_cast<int>(s));
  }

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
    if (masks.size() != rig_.size())
      throw std::invalid_argument("condensation: expected one mask per camera");
    if (particles_.empty()) reset(model_.neutralPose());
    resample();
    diffuse();
    const int n = static_cast<int>(particles_.size());
    pool_.parallelFor(n, [&](int i, int worker) {
      log_weights_[i] = evaluate(particles_[i], masks, scratch_[worker]);
    });
    FrameEstimate estimate;
    estimate.evaluations = n;
    estimate.segment_renders = static_cast<long>(n) * static_cast<long>(drawn_.size());
    std::vector<const Eigen::VectorXd*> qs;
    for (const Eigen::VectorXd& q : particles_) qs.push_back(&q);
    weightedEstimate(qs, log_weights_, estimate);
    return estimate;
  }

 private:
  // Systematic resampling: one uniform offset, N equally spaced pointers into the CDF.
  void resample() {
    const std::size_t n = particles_.size();
    const double best = *std::max_element(log_weights_.begin(), log_weights_.end());
    std::vector<double> cdf(n);
    double sum = 0;
    for (std::size_t i = 0; i < n; ++i) cdf[i] = sum += std::exp(log_weights_[i] - best);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const double offset = unit(rng_);
    std::vector<Eigen::VectorXd> next(n);
    std::size_t j = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double target = (i + offset) / n * sum;
      while (j + 1 < n && cdf[j] < target) ++j;
      next[i] = particles_[j];
    }
    particles_.swap(next);
  }

  void diffuse() {
    for (Eigen::VectorXd& q : particles_) {
      for (std::size_t d = 0; d < model_.dofs.size(); ++d) {
        const auto [lo, hi] = proposalInterval(model_.dofs[d], q[d]);
        q[d] = std::uniform_real_distribution<double>(lo, hi)(rng_);
      }
    }
  }

  double evaluate(const Eigen::VectorXd& q, const std::vector<SilhouetteMask>& masks,
                  WorkerScratch& scratch) const {
    forwardKinematics(model_, scratch.kinematics, q);
    for (auto& e : scratch.explained) e.clear();
    PixelCounts total;
    RowSpan* spans[kMaxCameras];
    for (std::size_t k = 0; k < drawn_.size(); ++k) {
      const int s = drawn_[k];
      for (std::size_t c = 0; c < rig_.size(); ++c)
        spans[c] = &scratch.spans[(k * rig_.size() + c) * max_rows_];
      total += observeSegment(model_.segments[s].shape, scratch.kinematics.world[s], rig_, masks,
                              scratch.rasterizer, spans, scratch.footprints.data(),
                              scratch.explained);
      for (std::size_t c = 0; c < rig_.size(); ++c)
        scratch.explained[c].push_back(scratch.footprints[c]);
    }
    return logLikelihood(options_.likelihood, total);
  }

  const BodyModel& model_;
  const Rig& rig_;
  FilterOptions options_;
  WorkerPool& pool_;
  std::mt19937_64 rng_;
  int max_rows_ = 0;
  std::vector<int> drawn_;  // segments with a shape, in topological order
  std::vector<WorkerScratch> scratch_;
  std::vector<Eigen::VectorXd> particles_;
  std::vector<double> log_weights_;
};

}  // namespace

std::unique_ptr<PoseFilter> makeCondensationFilter(const BodyModel& model, const Rig& rig,
                                                   const FilterOptions& options, WorkerPool& pool) {
  return std::make_unique<CondensationFilter>(model, rig, options, pool);
}

}  // namespace mocap
