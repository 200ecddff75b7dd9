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

#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/likelihood/likelihood.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/filters/worker_pool.h"

namespace mocap {

struct FilterOptions {
  // Particle evaluations per frame, as the paper counts them: one per candidate per layer for the
  // factored filter (15 layers x 25 = 375 for the hand), one per full-body particle otherwise.
  int evaluations_per_frame = 375;
  int keep = 5;                   // factored: K best candidates kept per layer
  int samples = 0;                // factored: S samples per interval; 0 = derived from the budget
  double injection_share = 0.02;  // factored: share of candidates from the static distribution
  // factored: what an injected candidate redraws over the whole range. kDof is the paper: the
  // layer's DOF. kSegment: at a segment's first DOF layer, all its joint angles at once (and the
  // layer's DOF elsewhere): a limb lost inside the trunk's silhouette scores no better one DOF
  // away, and only comes back when its angles land near the truth together.
  enum class Injection { kDof, kSegment };
  Injection injection = Injection::kDof;
  // factored: what a layer ranks its candidates by. kNone is the paper: the layer's own segment
  // against the silhouette minus what earlier segments explain. Greedy, it lets a segment slide
  // over silhouette that belongs to segments observed later (a big root or trunk steals the limbs'
  // pixels). kRoot ranks the root's layers by the whole body at its previous relative pose;
  // kSubtree ranks every layer by its segment and all its descendants at their previous relative
  // pose; kBody ranks every layer by the whole body: what is already placed, the candidate's
  // subtree, and every other segment not yet placed at its previous relative pose (so one leg does
  // not take the other leg's pixels). Either way a particle's weight keeps only the segment's own
  // factor, so the product of factors along the chain stays the paper's likelihood.
  enum class Lookahead { kNone, kRoot, kSubtree, kBody };
  Lookahead lookahead = Lookahead::kNone;
  // factored: the estimate is the weighted mean of the kept particles, or the best of them.
  bool estimate_best = false;
  // factored: share of the budget spent after the layers on a local search of the whole body: a
  // pattern search over every DOF on the full-body likelihood, one evaluation per pose tried,
  // starting from the best particle. The layers place each DOF with the segments not yet placed
  // standing where they were a frame ago; this corrects what that greedy order got wrong.
  double refine_share = 0;
  // factored, with a refinement: at most this many of its evaluations per frame (0: all the
  // layers leave; 1 counts as 2, the starting pose and one trial), for a step that must fit a
  // time budget; the rest of the budget goes unspent.
  int refine_max_evaluations = 0;
  double refine_step = 0.5;  // the pattern search's first step, in speed limits of each DOF
  // factored, with a refinement: a rotation DOF whose segment has ball-joint children (three
  // rotations about distinct axes) that fails both ways is tried once more both ways with those
  // children's angles re-solved so they keep their world orientation. Turning the pelvis then
  // leaves the legs and the trunk pointing where they did: a body tracked with its pelvis turned
  // the wrong way has its limbs twisted to fit, and no single joint angle can undo that.
  bool refine_hold = false;
  // factored, with a refinement: a step of the pelvis's position that fails both ways is tried
  // once more both ways with the hips and knees of the model's `feet` re-solved so the feet stay
  // where they are. Squatting, kneeling or shifting weight moves the pelvis over planted feet; a
  // pelvis step alone swings the feet through the floor, and no single leg angle follows it.
  bool refine_plant = false;
  // factored, with a refinement: each frame, after the restarts and before the pattern search, the
  // two legs (each of the model's two `feet` with its parent and grandparent) exchange their joint
  // angles, and the exchanged pose is searched locally on the legs' angles (up to 2 poses per leg
  // angle). It replaces the pose if it scores refine_swap_margin silhouette pixels better (that
  // many times the likelihood's beta). Two silhouettes often fit both ways round (which leg is in
  // front), no step of one leg gets from one to the other, and the margin keeps the tracker from
  // flipping between the two on a small difference.
  bool refine_swap = false;
  double refine_swap_margin = 500;
  // With refine_swap: exchange only the knees' angles (the feet's parents), then search the legs as
  // above. A kneel tracked with the wrong knee bent is this, with the hips right.
  bool refine_swap_knees_only = false;
  // factored, with a refinement: the share of the refinement's evaluations that, before the
  // pattern search, restart one limb (the next in turn each frame: legs, arms, chest, head) from
  // random draws of its root segment's angles over their whole range (a quarter of that share);
  // the best draw is searched locally on all the limb's angles (up to 3 poses per draw) and kept
  // if it beats the pose. A limb settled on the wrong part of the silhouette (one leg on the
  // other's) scores better than any pose a few steps away, so no local step leaves it. 0: off.
  double refine_restart_share = 0;
  // factored, with a refinement, for a model with `feet`: each frame, after the restarts and
  // swaps, the silhouette the pose leaves unexplained is chased (unexplained.h). In each camera the
  // largest blob's centroid gives a ray, and each leg's knee, then ankle, is moved by its hip and
  // knee angles to the ray's point nearest it if that point is below the hip (world z up), one
  // evaluation each; the best is searched locally on its leg's angles but the facing twists (up
  // to 2 poses per angle) and kept if it beats the pose. A leg lost inside the trunk explains
  // nothing new and costs nothing, so no local step pulls it out; the blob it left says where it
  // went.
  bool refine_unexplained = false;
  // factored, with a refinement: the weight of a prior that the pelvis faces where the legs do,
  // for a model that names its legs' twists (BodyModel::facing_twists): the refinement scores a
  // pose by its log-likelihood minus W (c / s)^2, c the mean of those twists (each signed by its
  // axis against the first's) and s the first's speed limit. Two silhouettes barely show which way
  // the pelvis faces, and a pelvis turned the wrong way scores as well with the hips twisted back,
  // so without it the heading drifts by tens of degrees over a walk. Unlike a prior on the
  // heading's change, it does not hold back a subject who turns. 0: off.
  double refine_facing_prior = 0;
  int annealing_layers = 5;  // annealed: number of annealing layers per frame
  uint64_t seed = 1;
  LikelihoodParams likelihood;
};

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

// "none", "root", "subtree" or "body"; throws std::invalid_argument otherwise.
FilterOptions::Lookahead parseLookahead(const std::string& name);

// "dof" or "segment"; throws std::invalid_argument otherwise.
FilterOptions::Injection parseInjection(const std::string& name);

// The factored filter's options for the human body, chosen on the walk (seeds 1-3; see
// docs/human.md): look-ahead over the whole body, 5 % of the candidates injected with a segment's
// angles at once, and 40 % of the budget on the full-body refinement, which also turns segments
// with their ball-joint children held and restarts one limb per frame with 14 % of the refinement
// (32 random draws at 2000 evaluations; walk seeds 1-6), and scores poses with the facing prior
// (weight 16; walk and hop seeds 7-24, checked on 61-96). The paper has no look-ahead, injects one
// DOF into 2 % and does not refine.
FilterOptions humanFilterDefaults();
// The paper's budget for the full 31-DOF body (§8), the experiments' and the daemon's default.
inline constexpr int kHumanEvaluations = 2000;

}  // namespace mocap
