// The pose filters behind one interface: the factored particle filter (paper §5, the default),
// Condensation and the annealed particle filter as baselines. All share the body model, the
// likelihood and the proposal (uniform on an interval of +-max_speed around the previous value),
// and count particle evaluations the paper's way.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "tracker/filters/filter_options.h"
#include "tracker/filters/worker_pool.h"
#include "tracker/likelihood/likelihood.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

struct FrameEstimate {
  Eigen::VectorXd q;  // pose estimate: weighted mean of the particle set
  double spread = 0;  // weighted RMS distance of the particles from q (DOF units)
  double best_log_weight = 0;
  long evaluations = 0;      // particle evaluations spent this frame (the paper's count)
  long segment_renders = 0;  // segment rasterizations (the compute actually spent)
  bool cut_short = false;    // optional work (the refinement) ended early: see PoseFilter::setYield
  // False when the filter has no pose to give: an acquiring filter that found no subject in the
  // frame (q is then meaningless). Every filter given a starting pose always has one.
  bool found = true;
  // silhouetteFit (tracker/search/acquire.h) of q, when the filter measured it (an acquiring filter
  // does); NaN otherwise.
  double silhouette_fit = std::numeric_limits<double>::quiet_NaN();
};

class PoseFilter {
 public:
  virtual ~PoseFilter() = default;
  virtual std::string name() const = 0;
  // Starts tracking from a known pose.
  virtual void reset(const Eigen::VectorXd& q0) = 0;
  // One frame: masks[c] is camera c's silhouette, cameras in rig order.
  virtual FrameEstimate step(const std::vector<SilhouetteMask>& masks) = 0;
  // For live use: a check the filter makes during a step's optional work (the factored filter's
  // refinement, between DOFs); once it returns true that work ends, so a newer frame is not kept
  // waiting or dropped. The step's result then depends on timing: leave it unset (empty) for
  // repeatable runs. Filters without optional work ignore it.
  virtual void setYield(std::function<bool()> newer_frame_waiting) { (void)newer_frame_waiting; }
};

// method: "factored", "condensation" or "annealed". The model, rig and pool are borrowed and must
// outlive the filter. Throws std::invalid_argument on an unknown method or unusable options.
std::unique_ptr<PoseFilter> makeFilter(const std::string& method, const BodyModel& model,
                                       const Rig& rig, const FilterOptions& options,
                                       WorkerPool& pool);

std::unique_ptr<PoseFilter> makeFactoredFilter(const BodyModel& model, const Rig& rig,
                                               const FilterOptions& options, WorkerPool& pool);
std::unique_ptr<PoseFilter> makeCondensationFilter(const BodyModel& model, const Rig& rig,
                                                   const FilterOptions& options, WorkerPool& pool);

std::unique_ptr<PoseFilter> makeAnnealedFilter(const BodyModel& model, const Rig& rig,
                                               const FilterOptions& options, WorkerPool& pool);

// Systematic resampling: replaces `particles` by a draw proportional to exp(log_weights) (one
// uniform offset, N equally spaced pointers into the CDF). `scratch` is the caller's buffer, kept
// between frames so no particle is reallocated.
void resampleSystematic(const std::vector<double>& log_weights,
                        std::vector<Eigen::VectorXd>& particles,
                        std::vector<Eigen::VectorXd>& scratch, std::mt19937_64& rng);

// Moves every DOF of q to a uniform sample of its proposal interval (see proposalInterval).
void diffuseUniform(const BodyModel& model, Eigen::VectorXd& q, std::mt19937_64& rng);

// Shared by the filters: the weighted mean and spread of a set of DOF vectors with log-weights.
void weightedEstimate(const std::vector<const Eigen::VectorXd*>& particles,
                      const std::vector<double>& log_weights, FrameEstimate& out);

}  // namespace mocap
