// The factored particle filter of Rose, Saboune & Charpillet (AAAI-08, §5 Fig. 2, §7, §8.3).
//
// The DBN is walked in topological order: one layer per DOF (the hidden node), each followed by the
// observation of the segment that DOF moves. A layer completes every kept particle with S equally
// spaced samples of the DOF's uniform proposal (deterministic interval sampling), a small share of
// candidates drawn instead from the DOF's whole range (static particle injection; optionally all
// of a segment's angles at once, FilterOptions::Injection), weighs each candidate by its segment's
// masked-chain likelihood and keeps the K best without uniformizing their weights. A particle
// remembers, per segment, the node holding that segment's world pose and footprints, so later
// layers extend its chain and mask what it already explains. Optionally a layer ranks its
// candidates by a look-ahead over more of the body (FilterOptions::Lookahead) while each particle's
// weight keeps only the paper's factor.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

#include "tracker/filters/filter.h"
#include "tracker/filters/incremental_body.h"
#include "tracker/model/kinematics.h"
#include "tracker/likelihood/unexplained.h"

namespace mocap {
namespace {

struct Layer {
  int segment = -1;
  int dof = -1;            // -1: observation only (a DOF-less segment moved by its ancestors)
  bool lookahead = false;  // ranked by a look-ahead (see FilterOptions::Lookahead)
  bool first_dof = false;  // the segment's first sampled DOF
};

// A segment placed in one particle's chain: its world pose and footprints (one per camera).
struct Node {
  Eigen::Isometry3d pose;
  int first_footprint = 0;  // index into node_footprints_
};

struct Particle {
  Eigen::VectorXd q;
  double log_weight = 0;
  std::vector<int> node;  // per segment: index into nodes_, -1 until observed this frame
};

struct Candidate {
  Eigen::VectorXd q;
  double log_weight = 0;  // parent's weight times this layer's segment factor
  double selection = 0;   // what the layer ranks by: log_weight, or the whole-body look-ahead
  int parent = 0;
  Eigen::Isometry3d pose;
};

// A child segment whose joint is three rotations about distinct coordinate axes (sign * e_axis).
struct HeldChild {
  int segment = -1;
  int axis[3];
  double sign[3];
};

// For FilterOptions::refine_plant and refine_unexplained: a leg of the model's `feet`: the foot
// segment, the DOFs that place it (its hip and knee), the segments from the root down to it (all
// that places it) and every free rotation of its grandparent, parent and itself; the model's
// facing twists left out of both.
constexpr int kMaxPlantDofs = 12;  // two joints of at most 6 DOFs each
struct Leg {
  int segment = -1;
  std::vector<int> dofs;
  std::vector<int> chain;
  std::vector<int> rotations;
};

// For Lookahead::kBody, per parent particle and layer: the segments it has not placed yet (outside
// the layer's subtree) at their previous pose, after the placed ones.
struct RestOfBody {
  RestOfBody(std::size_t cameras, std::size_t segments, int max_rows)
      : explained(cameras), spans(segments * cameras * max_rows) {}
  std::vector<std::vector<Footprint>> explained;  // per camera: placed, then rest
  std::vector<RowSpan> spans;                     // the rest's footprints
  PixelCounts counts;                             // of the rest
  long renders = 0;
};

struct WorkerScratch {
  WorkerScratch(const BodyModel& model, int points_per_circle, std::size_t cameras,
                std::size_t segments, int max_rows)
      : kinematics(model),
        rasterizer(points_per_circle),
        explained(cameras),
        footprints(cameras),
        poses(segments),
        lookahead_spans(segments * cameras * max_rows) {}
  KinematicsData kinematics;
  ShapeRasterizer rasterizer;
  std::vector<std::vector<Footprint>> explained;  // per camera
  std::vector<Footprint> footprints;              // per camera, of the descendant being looked at
  std::vector<Eigen::Isometry3d> poses;           // per segment, for the look-ahead
  std::vector<RowSpan> lookahead_spans;           // per descendant, per camera, max_rows each
  std::vector<int> placed;                        // first footprint of each explained node
};

class FactoredFilter final : public PoseFilter {
 public:
  FactoredFilter(const BodyModel& model, const Rig& rig, const FilterOptions& options,
                 WorkerPool& pool)
      : model_(model), rig_(rig), options_(options), pool_(pool), rng_(options.seed) {
    if (options.keep < 1) throw std::invalid_argument("factored filter: keep must be >= 1");
    if (options.injection_share < 0 || options.injection_share >= 1)
      throw std::invalid_argument("factored filter: injection share must be in [0, 1)");
    findDescendants();
    buildLayers();
    const int sampling_layers = static_cast<int>(
        std::count_if(layers_.begin(), layers_.end(), [](const Layer& l) { return l.dof >= 0; }));
    const int observation_layers = static_cast<int>(layers_.size()) - sampling_layers;
    samples_ = options.samples;
    if (options.refine_share < 0 || options.refine_share >= 1)
      throw std::invalid_argument("factored filter: refine share must be in [0, 1)");
    if (options.refine_max_evaluations < 0)
      throw std::invalid_argument("factored filter: refine_max_evaluations must be >= 0");
    if (options.refine_facing_prior < 0)
      throw std::invalid_argument("factored filter: facing prior must be >= 0");
    if (samples_ <= 0) {
      const double budget = options.evaluations_per_frame * (1 - options.refine_share) -
                            observation_layers * options.keep;
      samples_ = std::max(
          1, static_cast<int>(std::lround(budget / std::max(1, sampling_layers * options.keep))));
      // An even count never samples the interval's centre (the previous value). With a
      // refinement, which takes what the layers leave, the count is made odd at no loss of budget.
      if (options.refine_share > 0 && samples_ % 2 == 0) --samples_;
    }
    candidates_per_layer_ = options.keep * samples_;
    if (options.refine_share > 0) {
      // The refinement takes what the layers leave of the budget.
      const int layer_evaluations =
          sampling_layers * candidates_per_layer_ + observation_layers * options.keep;
      refine_evaluations_ = std::max(2, options.evaluations_per_frame - layer_evaluations);
      if (options.refine_max_evaluations > 0)
        refine_evaluations_ =
            std::min(refine_evaluations_, std::max(2, options.refine_max_evaluations));
      for (const Layer& layer : layers_)
        if (layer.dof >= 0) refine_dofs_.push_back(layer.dof);
      refine_steps_.resize(refine_dofs_.size());
      refine_held_.resize(refine_dofs_.size());
      refine_hold_steps_.resize(refine_dofs_.size());
      if (options.refine_hold) findHeldChildren();
      if (options.refine_plant || options.refine_unexplained) findLegs();
      if (options.refine_swap) findSwappedLegs();
      if (options.refine_restart_share > 0) findRestartLimbs();
      if (options.refine_facing_prior > 0) findFacingTwists();
      // Each draw is followed by up to 3 poses of local search.
      restart_draws_ =
          static_cast<int>(std::lround(options.refine_restart_share * refine_evaluations_ / 4));
      refiner_ = std::make_unique<IncrementalBodyEvaluator>(
          model, rig, options.likelihood.points_per_circle, &pool);
    }

    for (const CameraModel& c : rig) max_rows_ = std::max(max_rows_, c.height);
    candidates_.resize(candidates_per_layer_);
    candidate_spans_.resize(static_cast<std::size_t>(candidates_per_layer_) * rig.size() *
                            max_rows_);
    candidate_footprints_.resize(static_cast<std::size_t>(candidates_per_layer_) * rig.size());
    candidate_counts_.resize(candidate_footprints_.size());
    const std::size_t max_nodes = model.segments.size() + layers_.size() * options.keep;
    nodes_.reserve(max_nodes);
    node_footprints_.reserve(max_nodes * rig.size());
    // Reserved once: footprints point into this arena, so it must never reallocate.
    span_arena_.resize(max_nodes * rig.size() * max_rows_);
    for (int w = 0; w < pool.size(); ++w)
      scratch_.emplace_back(model, options.likelihood.points_per_circle, rig.size(),
                            model.segments.size(), max_rows_);
    for (int k = 0; k < options.keep; ++k)
      rest_.emplace_back(rig.size(), model.segments.size(), max_rows_);
  }

  std::string name() const override { return "factored"; }

  void setYield(std::function<bool()> newer_frame_waiting) override {
    yield_ = std::move(newer_frame_waiting);
  }

  void reset(const Eigen::VectorXd& q0) override {
    if (q0.size() != static_cast<long>(model_.dofs.size()))
      throw std::invalid_argument("factored filter: initial pose has the wrong number of DOFs");
    // One particle: the first layer spreads the whole budget over it.
    particles_.assign(1, Particle{q0, 0.0, std::vector<int>(model_.segments.size(), -1)});
    clampToLimits(model_, particles_[0].q);
  }

  FrameEstimate step(const std::vector<SilhouetteMask>& masks) override {
    if (masks.size() != rig_.size())
      throw std::invalid_argument("factored filter: expected one mask per camera");
    if (particles_.empty()) reset(model_.neutralPose());
    FrameEstimate estimate;
    startFrame(estimate);
    double injection_debt = 0;
    for (const Layer& layer : layers_) {
      const int count = generateCandidates(layer, injection_debt);
      if (layer.lookahead && options_.lookahead == FilterOptions::Lookahead::kBody) {
        const int parents = static_cast<int>(particles_.size());
        pool_.parallelFor(parents, [&](int p, int worker) { placeRest(layer, p, masks, worker); });
        for (const RestOfBody& rest : rest_) estimate.segment_renders += rest.renders;
      }
      groupSamePoses(layer, count);
      pool_.parallelFor(static_cast<int>(pose_groups_.size()),
                        [&](int g, int worker) { evaluateGroup(layer, g, count, masks, worker); });
      estimate.evaluations += count;
      estimate.segment_renders +=
          static_cast<long>(pose_groups_.size()) +
          static_cast<long>(count) * (layer.lookahead ? descendants_[layer.segment].size() : 0);
      keepBest(layer, count);
    }
    if (refiner_) refine(masks, estimate);
    finishFrame(estimate);
    return estimate;
  }

 private:
  void buildLayers() {
    for (std::size_t s = 0; s < model_.segments.size(); ++s) {
      const Segment& seg = model_.segments[s];
      const int si = static_cast<int>(s);
      if (model_.isStatic(si)) {
        static_segments_.push_back(si);
        continue;
      }
      if (seg.shape.type == ShapeType::kNone)
        throw std::invalid_argument("factored filter: segment '" + seg.name +
                                    "' moves but has no shape, so nothing observes it");
      int free_count = 0;
      for (int d : seg.dofs) {
        if (!model_.dofs[d].isFree()) continue;
        layers_.push_back({si, d, usesLookahead(si), free_count == 0});
        ++free_count;
      }
      // Moved only by its ancestors: observed once so the chain masks what it explains.
      if (free_count == 0) layers_.push_back({si, -1, false, false});
    }
  }

  bool usesLookahead(int s) const {
    switch (options_.lookahead) {
      case FilterOptions::Lookahead::kNone:
        return false;
      case FilterOptions::Lookahead::kRoot:
        return model_.segments[s].parent < 0;
      case FilterOptions::Lookahead::kSubtree:
        return !descendants_[s].empty();
      case FilterOptions::Lookahead::kBody:
        return true;
    }
    return false;
  }

  // Every segment's descendants, in model order.
  void findDescendants() {
    descendants_.assign(model_.segments.size(), {});
    for (std::size_t d = 0; d < model_.segments.size(); ++d) {
      for (int a = model_.segments[d].parent; a >= 0; a = model_.segments[a].parent)
        descendants_[a].push_back(static_cast<int>(d));
    }
  }

  Footprint* candidateFootprints(int i) { return &candidate_footprints_[i * rig_.size()]; }
  RowSpan* candidateSpans(int i, std::size_t camera) {
    return &candidate_spans_[(i * rig_.size() + camera) * max_rows_];
  }

  // Normalizes the carried weights, and places the static segments (identical in every particle)
  // once in the node arena.
  void startFrame(FrameEstimate& estimate) {
    nodes_.clear();
    node_footprints_.clear();
    arena_used_ = 0;
    double max_lw = -INFINITY;
    for (const Particle& p : particles_) max_lw = std::max(max_lw, p.log_weight);
    double sum = 0;
    for (const Particle& p : particles_) sum += std::exp(p.log_weight - max_lw);
    const double log_norm = max_lw + std::log(sum);
    for (Particle& p : particles_) {
      p.log_weight -= log_norm;
      std::fill(p.node.begin(), p.node.end(), -1);
    }
    if (static_segments_.empty()) return;
    KinematicsData& kin = scratch_[0].kinematics;  // workers are idle between layers
    forwardKinematics(model_, kin, particles_[0].q);
    ShapeRasterizer& rasterizer = scratch_[0].rasterizer;
    for (int s : static_segments_) {
      const int node = addNode(kin.world[s]);
      for (std::size_t c = 0; c < rig_.size(); ++c) {
        RowSpan* spans = &span_arena_[arena_used_];
        Footprint f = rasterizer.rasterize(model_.segments[s].shape, kin.world[s], rig_[c], spans);
        arena_used_ += static_cast<std::size_t>(f.y1 - f.y0);
        node_footprints_[nodes_[node].first_footprint + c] = f;
      }
      estimate.segment_renders += 1;
      for (Particle& p : particles_) p.node[s] = node;
    }
  }

  int addNode(const Eigen::Isometry3d& pose) {
    nodes_.push_back({pose, static_cast<int>(node_footprints_.size())});
    node_footprints_.resize(node_footprints_.size() + rig_.size());
    return static_cast<int>(nodes_.size()) - 1;
  }

  // Completes the kept particles (sorted best first) with deterministic interval samples of the
  // layer's DOF; the last candidates (those of the weakest particle) are replaced by injected
  // samples over the DOF's whole range.
  int generateCandidates(const Layer& layer, double& injection_debt) {
    const int parents = static_cast<int>(particles_.size());
    int count = 0;
    if (layer.dof < 0) {
      for (int p = 0; p < parents; ++p) {
        Candidate& c = candidates_[count++];
        c.q = particles_[p].q;
        c.parent = p;
        c.log_weight = particles_[p].log_weight;
      }
      return count;
    }
    const Dof& dof = model_.dofs[layer.dof];
    for (int p = 0; p < parents; ++p) {
      // The budget is shared evenly; the better particles take the remainder.
      const int share = candidates_per_layer_ / parents + (p < candidates_per_layer_ % parents);
      const auto [lo, hi] = proposalInterval(dof, particles_[p].q[layer.dof]);
      for (int j = 0; j < share; ++j) {
        Candidate& c = candidates_[count++];
        c.q = particles_[p].q;
        c.q[layer.dof] = share == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * j / (share - 1);
        c.parent = p;
        c.log_weight = particles_[p].log_weight;
      }
    }
    // Positions have no bounded static distribution (a root uniform over a 20 m room lands off
    // every camera, where an empty footprint outscores a misplaced body): inject joint angles only,
    // carrying the share over to the next rotation layer.
    injection_debt += options_.injection_share * count;
    if (dof.type == DofType::kTranslation) return count;
    const int injected = std::min(count, static_cast<int>(injection_debt));
    injection_debt -= injected;
    const bool whole_segment =
        options_.injection == FilterOptions::Injection::kSegment && layer.first_dof;
    for (int k = 0; k < injected; ++k) {
      Eigen::VectorXd& q = candidates_[count - 1 - k].q;
      if (!whole_segment) {
        q[layer.dof] = std::uniform_real_distribution<double>(dof.min, dof.max)(rng_);
        continue;
      }
      for (int d : model_.segments[layer.segment].dofs) {
        const Dof& angle = model_.dofs[d];
        if (angle.isFree() && angle.type != DofType::kTranslation)
          q[d] = std::uniform_real_distribution<double>(angle.min, angle.max)(rng_);
      }
    }
    return count;
  }

  // Candidates whose segment lands at the same pose (the same parent segment node and the same
  // values of the segment's DOFs) share one rasterization, and one node if several are kept. This
  // is common: kept particles often agree on the layer's DOF and on their ancestors, and then
  // their samples coincide (two thirds of a hand layer's candidates, half of a human one's).
  void groupSamePoses(const Layer& layer, int count) {
    const Segment& seg = model_.segments[layer.segment];
    pose_groups_.clear();
    pose_group_.resize(count);
    auto parent_node = [&](int i) {
      return seg.parent < 0 ? -1 : particles_[candidates_[i].parent].node[seg.parent];
    };
    for (int i = 0; i < count; ++i) {
      const Eigen::VectorXd& q = candidates_[i].q;
      const int node = parent_node(i);
      std::size_t g = 0;
      for (; g < pose_groups_.size(); ++g) {
        const int first = pose_groups_[g];
        const Eigen::VectorXd& other = candidates_[first].q;
        if (parent_node(first) == node &&
            std::all_of(seg.dofs.begin(), seg.dofs.end(), [&](int d) { return q[d] == other[d]; }))
          break;
      }
      if (g == pose_groups_.size()) pose_groups_.push_back(i);
      pose_group_[i] = static_cast<int>(g);
    }
  }

  void evaluateGroup(const Layer& layer, int g, int count, const std::vector<SilhouetteMask>& masks,
                     int worker) {
    const int first = pose_groups_[g];
    evaluate(layer, first, -1, masks, worker);
    for (int i = first + 1; i < count; ++i)
      if (pose_group_[i] == g) evaluate(layer, i, first, masks, worker);
  }

  // Scores candidate i; `same_pose` is an already placed candidate whose segment pose (and so
  // footprints) it shares, or -1.
  void evaluate(const Layer& layer, int i, int same_pose, const std::vector<SilhouetteMask>& masks,
                int worker) {
    Candidate& cand = candidates_[i];
    const Particle& parent = particles_[cand.parent];
    const int s = layer.segment;
    const int parent_segment = model_.segments[s].parent;
    if (same_pose < 0) {
      const Eigen::Isometry3d local = localTransform(model_, s, cand.q);
      cand.pose = parent_segment < 0 ? local : nodes_[parent.node[parent_segment]].pose * local;
    } else {
      cand.pose = candidates_[same_pose].pose;
    }

    WorkerScratch& scratch = scratch_[worker];
    // The parent's placed segments are found once, then copied per camera (no push_back per
    // footprint: this runs for every candidate).
    std::vector<int>& placed = scratch.placed;
    placed.clear();
    for (std::size_t j = 0; j < parent.node.size(); ++j) {
      if (static_cast<int>(j) == s || parent.node[j] < 0) continue;
      placed.push_back(nodes_[parent.node[j]].first_footprint);
    }
    for (std::size_t c = 0; c < rig_.size(); ++c) {
      std::vector<Footprint>& explained = scratch.explained[c];
      explained.resize(placed.size());
      for (std::size_t k = 0; k < placed.size(); ++k)
        explained[k] = node_footprints_[placed[k] + c];
    }
    // Counts kept per camera, so candidates of the same pose recount only the rows their chain
    // covers.
    PixelCounts counts;
    Footprint* footprints = candidateFootprints(i);
    PixelCounts* camera_counts = &candidate_counts_[i * rig_.size()];
    if (same_pose < 0) {
      RowSpan* spans[kMaxCameras];
      for (std::size_t c = 0; c < rig_.size(); ++c) spans[c] = candidateSpans(i, c);
      counts = observeSegment(model_.segments[s].shape, cand.pose, rig_, masks, scratch.rasterizer,
                              spans, footprints, scratch.explained, camera_counts);
    } else {
      for (std::size_t c = 0; c < rig_.size(); ++c) {
        footprints[c] = candidateFootprints(same_pose)[c];
        camera_counts[c] = recountFootprint(
            masks[c], footprints[c], candidate_counts_[same_pose * rig_.size() + c],
            scratch.explained[c].data(), static_cast<int>(scratch.explained[c].size()));
        counts += camera_counts[c];
      }
    }
    cand.log_weight += logLikelihood(options_.likelihood, counts);
    cand.selection = cand.log_weight;
    if (!layer.lookahead) return;
    if (options_.lookahead != FilterOptions::Lookahead::kBody) {
      cand.selection =
          parent.log_weight +
          logLikelihood(options_.likelihood, counts + lookAhead(s, cand, i, masks, scratch));
      return;
    }
    // The whole body: the parent's placed segments and the rest at their previous pose (counted
    // once per parent), then this candidate's segment and subtree over what those explain.
    const RestOfBody& rest = rest_[cand.parent];
    PixelCounts total = rest.counts;
    for (std::size_t c = 0; c < rig_.size(); ++c) {
      scratch.explained[c] = rest.explained[c];
      total += countFootprint(masks[c], candidateFootprints(i)[c], scratch.explained[c].data(),
                              static_cast<int>(scratch.explained[c].size()));
    }
    cand.selection =
        parent.log_weight +
        logLikelihood(options_.likelihood, total + lookAhead(s, cand, i, masks, scratch));
  }

  // For kBody: places every segment of parent particle p that is neither placed this frame nor in
  // the layer segment's subtree at its previous relative pose, and counts them after the placed
  // ones. The same for all of p's candidates, so done once per parent.
  void placeRest(const Layer& layer, int p, const std::vector<SilhouetteMask>& masks, int worker) {
    const Particle& parent = particles_[p];
    RestOfBody& rest = rest_[p];
    WorkerScratch& scratch = scratch_[worker];
    forwardKinematics(model_, scratch.kinematics, parent.q);
    rest.counts = PixelCounts();
    rest.renders = 0;
    for (std::size_t c = 0; c < rig_.size(); ++c) {
      rest.explained[c].clear();
      for (std::size_t j = 0; j < parent.node.size(); ++j) {
        if (static_cast<int>(j) == layer.segment || parent.node[j] < 0) continue;
        rest.explained[c].push_back(node_footprints_[nodes_[parent.node[j]].first_footprint + c]);
      }
    }
    const std::vector<int>& below = descendants_[layer.segment];
    RowSpan* spans[kMaxCameras];
    int k = 0;
    for (std::size_t j = 0; j < model_.segments.size(); ++j) {
      const int o = static_cast<int>(j);
      if (o == layer.segment || parent.node[o] >= 0 ||
          model_.segments[o].shape.type == ShapeType::kNone ||
          std::find(below.begin(), below.end(), o) != below.end())
        continue;
      for (std::size_t c = 0; c < rig_.size(); ++c)
        spans[c] = &rest.spans[(k * rig_.size() + c) * max_rows_];
      rest.counts +=
          observeSegment(model_.segments[o].shape, scratch.kinematics.world[o], rig_, masks,
                         scratch.rasterizer, spans, scratch.footprints.data(), rest.explained);
      for (std::size_t c = 0; c < rig_.size(); ++c)
        rest.explained[c].push_back(scratch.footprints[c]);
      ++rest.renders;
      ++k;
    }
  }

  // The descendants of the candidate's segment at their previous relative pose, each counted
  // through the masked chain after the segment itself and the descendants before it.
  PixelCounts lookAhead(int s, const Candidate& cand, int i,
                        const std::vector<SilhouetteMask>& masks, WorkerScratch& scratch) {
    for (std::size_t c = 0; c < rig_.size(); ++c)
      scratch.explained[c].push_back(candidateFootprints(i)[c]);
    scratch.poses[s] = cand.pose;
    PixelCounts total;
    RowSpan* spans[kMaxCameras];
    const std::vector<int>& below = descendants_[s];
    for (std::size_t k = 0; k < below.size(); ++k) {
      const int d = below[k];
      scratch.poses[d] =
          scratch.poses[model_.segments[d].parent] * localTransform(model_, d, cand.q);
      for (std::size_t c = 0; c < rig_.size(); ++c)
        spans[c] = &scratch.lookahead_spans[(k * rig_.size() + c) * max_rows_];
      total +=
          observeSegment(model_.segments[d].shape, scratch.poses[d], rig_, masks,
                         scratch.rasterizer, spans, scratch.footprints.data(), scratch.explained);
      for (std::size_t c = 0; c < rig_.size(); ++c)
        scratch.explained[c].push_back(scratch.footprints[c]);
    }
    return total;
  }

  // Keeps the K heaviest candidates (ties to the earlier one, so the result never depends on
  // thread timing) and moves their footprints into the frame's node arena.
  void keepBest(const Layer& layer, int count) {
    order_.resize(count);
    std::iota(order_.begin(), order_.end(), 0);
    const int kept = std::min(options_.keep, count);
    std::partial_sort(order_.begin(), order_.begin() + kept, order_.end(), [&](int a, int b) {
      const double wa = candidates_[a].selection, wb = candidates_[b].selection;
      return wa > wb || (wa == wb && a < b);
    });
    next_particles_.resize(kept);
    group_node_.assign(pose_groups_.size(), -1);
    for (int k = 0; k < kept; ++k) {
      const Candidate& cand = candidates_[order_[k]];
      Particle& out = next_particles_[k];
      out.q = cand.q;
      out.log_weight = cand.log_weight;
      out.node = particles_[cand.parent].node;
      // Particles kept at the same segment pose share one node.
      int& node = group_node_[pose_group_[order_[k]]];
      if (node < 0) {
        node = addNode(cand.pose);
        const Footprint* from = candidateFootprints(order_[k]);
        for (std::size_t c = 0; c < rig_.size(); ++c) {
          Footprint f = from[c];
          RowSpan* dst = &span_arena_[arena_used_];
          std::copy(f.spans, f.spans + (f.y1 - f.y0), dst);
          arena_used_ += static_cast<std::size_t>(f.y1 - f.y0);
          f.spans = dst;
          node_footprints_[nodes_[node].first_footprint + c] = f;
        }
      }
      out.node[layer.segment] = node;
    }
    particles_.swap(next_particles_);
  }

  // Pattern search on the full-body likelihood from the best particle (Hooke and Jeeves): each
  // free DOF in layer order takes one step, first in the direction that last worked, then in the
  // other; a step that improves the pose is taken and grows by half, one that does not in either
  // direction halves. After each sweep over the DOFs, the whole sweep's change is tried once more
  // (the pattern move, which follows DOFs that move together). The result replaces the best
  // particle, so the next frame starts from it. Each trial pose counts as one full-body evaluation,
  // but only the segments it moves are re-rasterized (IncrementalBodyEvaluator, exact).
  void refine(const std::vector<SilhouetteMask>& masks, FrameEstimate& estimate) {
    Eigen::VectorXd& q = particles_[0].q;
    const long renders_before = refiner_->renders();
    double best = logLikelihood(options_.likelihood, refiner_->reset(q, masks)) - facingPrior(q);
    int budget = refine_evaluations_ - 1;
    for (std::size_t i = 0; i < refine_dofs_.size(); ++i) {
      refine_steps_[i] = options_.refine_step * model_.dofs[refine_dofs_[i]].max_speed;
      refine_hold_steps_[i] = refine_steps_[i];
    }
    Eigen::VectorXd& tried = refine_trial_;
    Eigen::VectorXd& sweep_start = refine_sweep_start_;
    if (restart_draws_ > 0) restartLimb(q, best, budget);
    if (!swap_pairs_.empty()) swapLegs(q, best, budget);
    if (options_.refine_unexplained) chaseUnexplained(masks, q, best, budget);
    while (budget > 0 && !estimate.cut_short) {
      sweep_start = q;
      const int budget_before_sweep = budget;
      for (std::size_t i = 0; i < refine_dofs_.size() && budget > 0; ++i) {
        if (yield_ && yield_()) {
          estimate.cut_short = true;
          break;
        }
        const int d = refine_dofs_[i];
        if (stepDof(d, refine_steps_[i], nullptr, q, best, budget, 0)) continue;
        if (!refine_held_[i].empty())
          stepDof(d, refine_hold_steps_[i], &refine_held_[i], q, best, budget, 0);
        else if (options_.refine_plant && !legs_.empty() && model_.dofs[d].segment == 0 &&
                 model_.dofs[d].type == DofType::kTranslation)
          stepDof(d, refine_hold_steps_[i], nullptr, q, best, budget, 0, true);
      }
      // Every step has shrunk below what moves a DOF (or every DOF sits at a limit): nothing
      // left to try, so stop rather than loop forever on the unspent budget.
      if (budget == budget_before_sweep) break;
      if (budget > 0 && q != sweep_start && !estimate.cut_short) {
        tried = 2 * q - sweep_start;
        clampToLimits(model_, tried);
        tryPose(tried, q, best, budget);
      }
    }
    const int spent = refine_evaluations_ - budget;
    estimate.evaluations += spent;
    estimate.segment_renders += refiner_->renders() - renders_before;
  }

  // Scores `pose` as one evaluation of `budget`. If it beats `value`, it becomes the evaluator's
  // current pose, `at` and `value`; otherwise the evaluator goes back to `at`.
  bool tryPose(const Eigen::VectorXd& pose, Eigen::VectorXd& at, double& value, int& budget) {
    const double score = trialScore(pose, budget);
    if (score <= value) {
      refiner_->reject();
      return false;
    }
    refiner_->accept();
    value = score;
    at = pose;
    return true;
  }

  // The refinement's score of `pose`, as the evaluator's trial (to accept or reject), counted as
  // one evaluation of `budget`: its log-likelihood less the facing prior.
  double trialScore(const Eigen::VectorXd& pose, int& budget) {
    --budget;
    return logLikelihood(options_.likelihood, refiner_->trial(pose)) - facingPrior(pose);
  }

  // One step of DOF d from `at` each way while the budget is above `reserve`, the signed `step`
  // first (the direction that last worked), optionally with the segment's ball-joint children
  // held or the feet planted: a step that improves is taken and grows by half; if neither does,
  // the step halves.
  bool stepDof(int d, double& step, const std::vector<HeldChild>* held, Eigen::VectorXd& at,
               double& value, int& budget, int reserve, bool plant = false) {
    const Dof& dof = model_.dofs[d];
    Eigen::VectorXd& tried = refine_trial_;
    for (const double signed_step : {step, -step}) {
      if (budget <= reserve) break;
      tried = at;
      tried[d] = std::clamp(at[d] + signed_step, dof.min, dof.max);
      if (tried[d] == at[d]) continue;
      if (held) holdChildren(at, tried, *held);
      if (plant) plantFeet(at, tried);
      if (tryPose(tried, at, value, budget)) {
        step = 1.5 * signed_step;
        return true;
      }
    }
    step *= 0.5;
    return false;
  }

  // For FilterOptions::refine_hold: per refined rotation DOF, the children of its segment whose
  // joint is three rotations about distinct coordinate axes (so any orientation has its angles).
  void findHeldChildren() {
    for (std::size_t i = 0; i < refine_dofs_.size(); ++i) {
      const Dof& dof = model_.dofs[refine_dofs_[i]];
      if (dof.type != DofType::kRotation) continue;
      for (std::size_t c = 0; c < model_.segments.size(); ++c) {
        const Segment& child = model_.segments[c];
        if (child.parent != dof.segment || child.dofs.size() != 3) continue;
        HeldChild held{static_cast<int>(c), {}, {}};
        bool ball = true;
        for (int j = 0; j < 3 && ball; ++j) {
          const Dof& angle = model_.dofs[child.dofs[j]];
          Eigen::Index axis = 0;
          const double largest = angle.axis.cwiseAbs().maxCoeff(&axis);
          ball = angle.type == DofType::kRotation && angle.isFree() && largest == 1.0 &&
                 angle.axis.cwiseAbs().sum() == 1.0;
          held.axis[j] = static_cast<int>(axis);
          held.sign[j] = angle.axis[axis];
        }
        ball = ball && held.axis[0] != held.axis[1] && held.axis[1] != held.axis[2] &&
               held.axis[0] != held.axis[2];
        if (ball) refine_held_[i].push_back(held);
      }
    }
  }

  // Sets the held children's angles in `tried` (which differs from `q` in their parent's DOFs)
  // so each child keeps the world orientation it has at q, within its joint limits.
  void holdChildren(const Eigen::VectorXd& q, Eigen::VectorXd& tried,
                    const std::vector<HeldChild>& children) {
    const int s = model_.segments[children[0].segment].parent;
    const Eigen::Matrix3d turn = localTransform(model_, s, tried).linear().transpose() *
                                 localTransform(model_, s, q).linear();
    for (const HeldChild& held : children) {
      const Segment& child = model_.segments[held.segment];
      const Eigen::Matrix3d target = turn * localTransform(model_, held.segment, q).linear();
      // target = R(e_a0, phi0) R(e_a1, phi1) R(e_a2, phi2): two solutions, the one nearer the
      // current angles is taken.
      const Eigen::Vector3d phi = target.eulerAngles(held.axis[0], held.axis[1], held.axis[2]);
      const Eigen::Vector3d other(phi[0] + M_PI, M_PI - phi[1], phi[2] + M_PI);
      double best_distance = INFINITY;
      Eigen::Vector3d best;
      for (const Eigen::Vector3d& solution : {phi, other}) {
        Eigen::Vector3d angles;
        double distance = 0;
        for (int j = 0; j < 3; ++j) {
          const double current = q[child.dofs[j]];
          const double a = held.sign[j] * solution[j];
          angles[j] = a + 2 * M_PI * std::round((current - a) / (2 * M_PI));
          distance += std::abs(angles[j] - current);
        }
        if (distance < best_distance) {
          best_distance = distance;
          best = angles;
        }
      }
      for (int j = 0; j < 3; ++j) {
        const Dof& angle = model_.dofs[child.dofs[j]];
        tried[child.dofs[j]] = std::clamp(best[j], angle.min, angle.max);
      }
    }
  }

  // For FilterOptions::refine_plant and refine_unexplained: each of the model's feet with the free
  // rotations of the two segments above it, facing twists left out (the facing prior governs them,
  // and without them hip and knee have three angles for the foot's three coordinates).
  void findLegs() {
    for (const std::string& name : model_.feet) {
      Leg leg;
      leg.segment = model_.segmentIndex(name);
      for (int s = leg.segment; s >= 0; s = model_.segments[s].parent)
        leg.chain.insert(leg.chain.begin(), s);
      const int knee = model_.segments[leg.segment].parent;
      for (int s : {model_.segments[knee].parent, knee, leg.segment})
        for (int d : model_.segments[s].dofs) {
          const Dof& dof = model_.dofs[d];
          const bool facing = std::find(model_.facing_twists.begin(), model_.facing_twists.end(),
                                        dof.name) != model_.facing_twists.end();
          if (!dof.isFree() || dof.type != DofType::kRotation || facing) continue;
          leg.rotations.push_back(d);
          if (s != leg.segment) leg.dofs.push_back(d);
        }
      if (!leg.dofs.empty()) legs_.push_back(std::move(leg));
    }
  }

  // Re-solves the planted feet's hip and knee angles in `tried` (which differs from `q` in the
  // pelvis) so each foot's joint stays where it is at q.
  void plantFeet(const Eigen::VectorXd& q, Eigen::VectorXd& tried) {
    KinematicsData& kin = plant_kinematics_;
    std::vector<Eigen::Vector3d>& targets = joint_points_;
    targets.clear();
    for (const Leg& leg : legs_) {
      forwardKinematics(model_, kin, q, leg.chain);
      targets.push_back(kin.world[leg.segment].translation());
    }
    for (std::size_t f = 0; f < legs_.size(); ++f)
      moveJointTo(legs_[f], legs_[f].segment, targets[f], tried);
  }

  // Moves the origin of `segment` (the leg's foot or a segment above it on its chain) towards
  // `target` by the leg's hip and knee angles in `tried`: damped Gauss-Newton steps on a numeric
  // Jacobian, clamped to the joint limits.
  void moveJointTo(const Leg& leg, int segment, const Eigen::Vector3d& target,
                   Eigen::VectorXd& tried) {
    constexpr int kIterations = 6;
    constexpr double kTolerance = 1e-4, kProbe = 1e-5, kDamping = 1e-4;  // metres, radians
    KinematicsData& kin = plant_kinematics_;
    Eigen::VectorXd& probe = plant_probe_;
    const int n = static_cast<int>(leg.dofs.size());
    for (int iteration = 0; iteration < kIterations; ++iteration) {
      forwardKinematics(model_, kin, tried, leg.chain);
      const Eigen::Vector3d at = kin.world[segment].translation();
      const Eigen::Vector3d residual = target - at;
      if (residual.norm() < kTolerance) break;
      // On the stack: two joints have at most 12 DOFs, and this runs for every planted trial.
      Eigen::Matrix<double, 3, Eigen::Dynamic, 0, 3, kMaxPlantDofs> jacobian(3, n);
      for (int k = 0; k < n; ++k) {
        probe = tried;
        probe[leg.dofs[k]] += kProbe;
        forwardKinematics(model_, kin, probe, leg.chain);
        jacobian.col(k) = (kin.world[segment].translation() - at) / kProbe;
      }
      using Square =
          Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxPlantDofs, kMaxPlantDofs>;
      const Square normal = jacobian.transpose() * jacobian + kDamping * Square::Identity(n, n);
      const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxPlantDofs, 1> change =
          normal.ldlt().solve(jacobian.transpose() * residual);
      for (int k = 0; k < n; ++k) {
        const Dof& dof = model_.dofs[leg.dofs[k]];
        tried[leg.dofs[k]] = std::clamp(tried[leg.dofs[k]] + change[k], dof.min, dof.max);
      }
    }
  }

  // FilterOptions::refine_restart_share: restarts one limb (the next in turn each frame) from
  // random draws of its root segment's angles, searches around the best draw on all the limb's
  // angles, and keeps the result if it beats the pose; otherwise the evaluator goes back to the
  // pose. Every pose tried counts against `budget`.
  void restartLimb(Eigen::VectorXd& q, double& best, int& budget) {
    if (restart_limbs_.empty()) return;
    const RestartLimb& limb = restart_limbs_[restart_frame_++ % restart_limbs_.size()];
    Eigen::VectorXd& tried = refine_trial_;
    Eigen::VectorXd& local = restart_pose_;
    double local_value = -INFINITY;
    for (int k = 0; k < restart_draws_ && budget > 2; ++k) {
      tried = q;
      for (int d : limb.root_dofs)
        tried[d] =
            std::uniform_real_distribution<double>(model_.dofs[d].min, model_.dofs[d].max)(rng_);
      const double value = trialScore(tried, budget);
      refiner_->reject();
      if (value > local_value) {
        local_value = value;
        local = tried;
      }
    }
    if (local_value == -INFINITY || budget <= 2) return;
    trialScore(local, budget);
    refiner_->accept();
    // Up to 3 poses of search per draw on the limb's angles.
    searchAndKeep(limb.dofs, 3 * restart_draws_, 0, local, local_value, q, best, budget);
  }

  // The second half of a restart and of a swap. `local`, the evaluator's current pose, scoring
  // `local_value`, is searched by coordinate steps on `dofs` as the refinement takes them, for up
  // to `poses` evaluations with one kept back to restore the pose; a sweep that tries nothing
  // (every step too small to move a DOF) ends it. The result replaces q if it beats `best` by
  // `margin` (log-likelihood); otherwise the evaluator goes back to q.
  void searchAndKeep(const std::vector<int>& dofs, int poses, double margin, Eigen::VectorXd& local,
                     double local_value, Eigen::VectorXd& q, double& best, int& budget) {
    std::vector<double>& steps = restart_steps_;
    steps.clear();
    for (int d : dofs) steps.push_back(options_.refine_step * model_.dofs[d].max_speed);
    const int search_start = budget;
    for (int swept_from = -1;
         search_start - budget < poses && budget > 1 && budget != swept_from;) {
      swept_from = budget;
      for (std::size_t j = 0; j < dofs.size() && budget > 1; ++j)
        stepDof(dofs[j], steps[j], nullptr, local, local_value, budget, 1);
    }
    if (local_value > best + margin) {
      best = local_value;
      q = local;
      return;
    }
    trialScore(q, budget);
    refiner_->accept();
  }

  // FilterOptions::refine_swap: each foot's leg (its grandparent, parent and itself), DOF by DOF
  // in model order, paired with the other's: all of them searched, the knees' alone exchanged with
  // refine_swap_knees_only.
  void findSwappedLegs() {
    const auto fail = [](const std::string& why) {
      throw std::invalid_argument("factored filter: refine_swap: " + why);
    };
    if (model_.feet.size() != 2)
      fail("the body model names " + std::to_string(model_.feet.size()) + " feet, not two");
    std::vector<int> legs[2], knees[2];
    for (int f = 0; f < 2; ++f) {
      const int foot = model_.segmentIndex(model_.feet[f]);
      const int knee = model_.segments[foot].parent;
      for (int s : {model_.segments[knee].parent, knee, foot})
        for (int d : model_.segments[s].dofs)
          if (model_.dofs[d].isFree()) {
            legs[f].push_back(d);
            if (s == knee) knees[f].push_back(d);
          }
    }
    if (legs[0].size() != legs[1].size() || knees[0].size() != knees[1].size())
      fail("the legs of '" + model_.feet[0] + "' and '" + model_.feet[1] +
           "' do not have the same free DOFs per segment (" + std::to_string(legs[0].size()) +
           " and " + std::to_string(legs[1].size()) + ")");
    const std::vector<int>* exchanged = options_.refine_swap_knees_only ? knees : legs;
    for (std::size_t k = 0; k < exchanged[0].size(); ++k)
      swap_pairs_.push_back({exchanged[0][k], exchanged[1][k]});
    for (std::size_t k = 0; k < legs[0].size(); ++k) {
      swap_dofs_.push_back(legs[0][k]);
      swap_dofs_.push_back(legs[1][k]);
    }
  }

  // FilterOptions::refine_swap: the pose with the legs' angles exchanged, searched locally on
  // them; kept if it beats the pose by the margin, otherwise the evaluator goes back to the pose.
  void swapLegs(Eigen::VectorXd& q, double& best, int& budget) {
    if (budget <= 2) return;
    Eigen::VectorXd& local = restart_pose_;
    local = q;
    for (const auto& [a, b] : swap_pairs_) {
      local[a] = std::clamp(q[b], model_.dofs[a].min, model_.dofs[a].max);
      local[b] = std::clamp(q[a], model_.dofs[b].min, model_.dofs[b].max);
    }
    const double local_value = trialScore(local, budget);
    refiner_->accept();
    // Up to 2 poses per leg angle.
    searchAndKeep(swap_dofs_, 2 * static_cast<int>(swap_dofs_.size()),
                  options_.likelihood.beta * options_.refine_swap_margin, local, local_value, q,
                  best, budget);
  }

  // FilterOptions::refine_unexplained: in each camera, the largest blob of silhouette that q leaves
  // unexplained gives a ray through its centroid; each leg's knee, then ankle, is moved by its hip
  // and knee angles to the ray's point nearest it if that point is below the hip. The best of
  // those poses is searched locally on its leg's angles and kept if it beats the pose; otherwise
  // the evaluator goes back to q.
  void chaseUnexplained(const std::vector<SilhouetteMask>& masks, Eigen::VectorXd& q, double& best,
                        int& budget) {
    // Fixed before measuring: a 5-pixel opening drops the slivers along the edges; a blob counts
    // from 2 % of the camera's silhouette (a forearm's or a shin's share) and 100 pixels.
    constexpr int kOpening = 5;
    constexpr double kMinShare = 0.02;
    constexpr long kMinPixels = 100;
    if (legs_.empty() || budget <= 2) return;
    KinematicsData& kin = plant_kinematics_;
    forwardKinematics(model_, kin, q);
    std::vector<Eigen::Vector3d>& joints = joint_points_;  // per leg: hip, knee, ankle
    joints.clear();
    for (const Leg& leg : legs_) {
      const int knee = model_.segments[leg.segment].parent;
      for (int s : {model_.segments[knee].parent, knee, leg.segment})
        joints.push_back(kin.world[s].translation());
    }
    // The evaluator stands at q (every search before this one ends back at its pose).
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rays;  // origin, unit direction
    for (std::size_t c = 0; c < rig_.size(); ++c) {
      refiner_->currentFootprints(c, unexplained_footprints_);
      const long min_area =
          std::max(kMinPixels, std::lround(kMinShare * static_cast<double>(masks[c].total())));
      const std::vector<UnexplainedBlob> blobs =
          unexplainedBlobs(masks[c], unexplained_footprints_.data(),
                           static_cast<int>(unexplained_footprints_.size()), min_area, kOpening);
      if (!blobs.empty())
        rays.emplace_back(rig_[c].center(), rig_[c].backProject(blobs.front().centroid));
    }
    Eigen::VectorXd& tried = refine_trial_;
    Eigen::VectorXd& local = restart_pose_;
    double local_value = -INFINITY;
    std::size_t local_leg = 0;
    for (const auto& [origin, direction] : rays) {
      for (std::size_t l = 0; l < legs_.size(); ++l) {
        const int segments[2] = {model_.segments[legs_[l].segment].parent, legs_[l].segment};
        for (int j = 0; j < 2 && budget > 2; ++j) {
          const Eigen::Vector3d& joint = joints[3 * l + 1 + j];
          const Eigen::Vector3d target =
              origin + direction * std::max(0.0, direction.dot(joint - origin));
          // World z is up: a knee or ankle above the hip is a blob of the arms or the trunk.
          if (target.z() >= joints[3 * l].z()) continue;
          tried = q;
          moveJointTo(legs_[l], segments[j], target, tried);
          const double value = trialScore(tried, budget);
          refiner_->reject();
          if (value > local_value) {
            local_value = value;
            local = tried;
            local_leg = l;
          }
        }
      }
    }
    if (local_value == -INFINITY || budget <= 2) return;
    trialScore(local, budget);
    refiner_->accept();
    // Up to 2 poses per leg angle.
    const std::vector<int>& dofs = legs_[local_leg].rotations;
    searchAndKeep(dofs, 2 * static_cast<int>(dofs.size()), 0, local, local_value, q, best, budget);
  }

  struct RestartLimb {
    std::vector<int> root_dofs;  // the limb root's free rotation DOFs
    std::vector<int> dofs;       // every free rotation DOF of the limb
  };
  // Limbs: segments with at least two free rotations whose parent has several children (the legs,
  // the arms, the chest and the head of the human; none in the hand, whose fingers bend one way).
  void findRestartLimbs() {
    std::vector<int> children(model_.segments.size(), 0);
    for (const Segment& seg : model_.segments)
      if (seg.parent >= 0) ++children[seg.parent];
    for (std::size_t s = 0; s < model_.segments.size(); ++s) {
      const Segment& seg = model_.segments[s];
      if (seg.parent < 0 || children[seg.parent] < 2) continue;
      RestartLimb limb;
      const auto rotations = [&](int segment, std::vector<int>& out) {
        for (int d : model_.segments[segment].dofs)
          if (model_.dofs[d].isFree() && model_.dofs[d].type == DofType::kRotation)
            out.push_back(d);
      };
      rotations(static_cast<int>(s), limb.root_dofs);
      if (limb.root_dofs.size() < 2) continue;
      limb.dofs = limb.root_dofs;
      for (int d : descendants_[s]) rotations(d, limb.dofs);
      restart_limbs_.push_back(limb);
    }
  }

  // FilterOptions::refine_facing_prior: the model's facing twists, each signed +1 or -1 as its
  // axis is along or against the first's (mirrored legs twist about opposite axes; the model
  // refuses any other).
  void findFacingTwists() {
    if (model_.facing_twists.empty()) return;
    const Eigen::Vector3d& first = model_.dofs[model_.dofIndex(model_.facing_twists[0])].axis;
    for (const std::string& name : model_.facing_twists) {
      const int d = model_.dofIndex(name);
      facing_twists_.push_back({d, model_.dofs[d].axis.dot(first) > 0 ? 1.0 : -1.0});
    }
  }

  // How far `pose`'s pelvis faces from its legs, as a cost (0 without the prior).
  double facingPrior(const Eigen::VectorXd& pose) const {
    if (facing_twists_.empty()) return 0;
    double sum = 0;
    for (const auto& [d, sign] : facing_twists_) sum += sign * pose[d];
    const double c = sum / static_cast<double>(facing_twists_.size()) /
                     model_.dofs[facing_twists_[0].first].max_speed;
    return options_.refine_facing_prior * c * c;
  }

  void finishFrame(FrameEstimate& estimate) {
    std::vector<const Eigen::VectorXd*> qs;
    std::vector<double> lw;
    for (const Particle& p : particles_) {
      qs.push_back(&p.q);
      lw.push_back(p.log_weight);
    }
    weightedEstimate(qs, lw, estimate);
    // Kept sorted best first; a refined best particle is the estimate.
    if (options_.estimate_best || refiner_) estimate.q = particles_[0].q;
  }

  const BodyModel& model_;
  const Rig& rig_;
  FilterOptions options_;
  WorkerPool& pool_;
  std::mt19937_64 rng_;
  std::function<bool()> yield_;  // see PoseFilter::setYield

  std::vector<Layer> layers_;
  std::vector<int> static_segments_;
  int samples_ = 0;
  int candidates_per_layer_ = 0;
  int max_rows_ = 0;

  std::vector<Particle> particles_, next_particles_;
  std::vector<Candidate> candidates_;
  std::vector<RowSpan> candidate_spans_;
  std::vector<Footprint> candidate_footprints_;
  std::vector<PixelCounts> candidate_counts_;  // per candidate and camera
  std::vector<int> order_;
  std::vector<int> pose_groups_;  // per group of same-pose candidates: its first candidate
  std::vector<int> pose_group_;   // per candidate: its group
  std::vector<int> group_node_;   // per group: the node of its first kept candidate, or -1
  std::vector<Node> nodes_;
  std::vector<Footprint> node_footprints_;
  std::vector<RowSpan> span_arena_;
  std::size_t arena_used_ = 0;
  std::vector<WorkerScratch> scratch_;
  std::vector<std::vector<int>> descendants_;  // per segment
  std::vector<RestOfBody> rest_;               // per kept particle
  // FilterOptions::refine_swap: the DOF pairs exchanged (one leg's, the other's), and the DOFs
  // searched after (both legs').
  std::vector<std::pair<int, int>> swap_pairs_;
  std::vector<int> swap_dofs_;
  int refine_evaluations_ = 0;
  std::unique_ptr<IncrementalBodyEvaluator> refiner_;  // only with a refine share
  std::vector<int> refine_dofs_;                       // the free DOFs, in layer order
  std::vector<double> refine_steps_;                   // per refined DOF
  std::vector<std::vector<HeldChild>> refine_held_;  // per refined DOF (FilterOptions::refine_hold)
  std::vector<double> refine_hold_steps_;            // per refined DOF
  std::vector<Leg> legs_;                    // FilterOptions::refine_plant and refine_unexplained
  KinematicsData plant_kinematics_{model_};  // scratch of moveJointTo() and the callers
  std::vector<Footprint> unexplained_footprints_;  // scratch of chaseUnexplained()
  std::vector<Eigen::Vector3d> joint_points_;  // scratch of plantFeet() and chaseUnexplained()
  Eigen::VectorXd plant_probe_;                // scratch of moveJointTo()
  std::vector<RestartLimb> restart_limbs_;  // FilterOptions::refine_restart_share
  int restart_draws_ = 0;
  long restart_frame_ = 0;
  Eigen::VectorXd restart_pose_;  // scratch of restartLimb()
  std::vector<double> restart_steps_;
  Eigen::VectorXd refine_trial_, refine_sweep_start_;  // scratch of refine()
  // FilterOptions::refine_facing_prior: each facing twist's DOF and sign.
  std::vector<std::pair<int, double>> facing_twists_;
};

}  // namespace

std::unique_ptr<PoseFilter> makeFactoredFilter(const BodyModel& model, const Rig& rig,
                                               const FilterOptions& options, WorkerPool& pool) {
  return std::make_unique<FactoredFilter>(model, rig, options, pool);
}

}  // namespace mocap
