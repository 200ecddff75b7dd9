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

#include "tracker/filters/factored_plan.h"
#include "tracker/filters/filter.h"
#include "tracker/filters/incremental_body.h"
#include "tracker/filters/refine/refinement.h"
#include "tracker/model/kinematics.h"

namespace mocap {
namespace {

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
      : model_(model),
        rig_(rig),
        options_(options),
        pool_(pool),
        rng_(options.seed),
        plan_(makeFactoredPlan(model, rig, options)),
        max_rows_(plan_.max_rows) {
    if (plan_.refinement.evaluations > 0)
      refinement_ = std::make_unique<Refinement>(model, rig, options_, plan_.refinement, pool);
    candidates_.resize(plan_.candidates_per_layer);
    candidate_spans_.resize(static_cast<std::size_t>(plan_.candidates_per_layer) * rig.size() *
                            max_rows_);
    candidate_footprints_.resize(static_cast<std::size_t>(plan_.candidates_per_layer) * rig.size());
    candidate_counts_.resize(candidate_footprints_.size());
    const std::size_t max_nodes = model.segments.size() + plan_.layers.size() * options.keep;
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
    for (const FactoredLayer& layer : plan_.layers) {
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
          static_cast<long>(count) *
              (layer.lookahead ? plan_.descendants[layer.segment].size() : 0);
      keepBest(layer, count);
    }
    if (refinement_) refinement_->run(masks, yield_, rng_, particles_[0].q, estimate);
    finishFrame(estimate);
    return estimate;
  }

 private:
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
    if (plan_.static_segments.empty()) return;
    KinematicsData& kin = scratch_[0].kinematics;  // workers are idle between layers
    forwardKinematics(model_, kin, particles_[0].q);
    ShapeRasterizer& rasterizer = scratch_[0].rasterizer;
    for (int s : plan_.static_segments) {
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
  int generateCandidates(const FactoredLayer& layer, double& injection_debt) {
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
      const int share =
          plan_.candidates_per_layer / parents + (p < plan_.candidates_per_layer % parents);
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
  void groupSamePoses(const FactoredLayer& layer, int count) {
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

  void evaluateGroup(const FactoredLayer& layer, int g, int count,
                     const std::vector<SilhouetteMask>& masks, int worker) {
    const int first = pose_groups_[g];
    evaluate(layer, first, -1, masks, worker);
    for (int i = first + 1; i < count; ++i)
      if (pose_group_[i] == g) evaluate(layer, i, first, masks, worker);
  }

  // Scores candidate i; `same_pose` is an already placed candidate whose segment pose (and so
  // footprints) it shares, or -1.
  void evaluate(const FactoredLayer& layer, int i, int same_pose,
                const std::vector<SilhouetteMask>& masks, int worker) {
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
  void placeRest(const FactoredLayer& layer, int p, const std::vector<SilhouetteMask>& masks,
                 int worker) {
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
    const std::vector<int>& below = plan_.descendants[layer.segment];
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
    const std::vector<int>& below = plan_.descendants[s];
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
  void keepBest(const FactoredLayer& layer, int count) {
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

  void finishFrame(FrameEstimate& estimate) {
    std::vector<const Eigen::VectorXd*> qs;
    std::vector<double> lw;
    for (const Particle& p : particles_) {
      qs.push_back(&p.q);
      lw.push_back(p.log_weight);
    }
    weightedEstimate(qs, lw, estimate);
    // Kept sorted best first; a refined best particle is the estimate.
    if (options_.estimate_best || refinement_) estimate.q = particles_[0].q;
  }

  const BodyModel& model_;
  const Rig& rig_;
  FilterOptions options_;
  WorkerPool& pool_;
  std::mt19937_64 rng_;
  std::function<bool()> yield_;  // see PoseFilter::setYield

  const FactoredPlan plan_;
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
  std::vector<RestOfBody> rest_;            // per kept particle
  std::unique_ptr<Refinement> refinement_;  // only with a refine share
};

}  // namespace

std::unique_ptr<PoseFilter> makeFactoredFilter(const BodyModel& model, const Rig& rig,
                                               const FilterOptions& options, WorkerPool& pool) {
  return std::make_unique<FactoredFilter>(model, rig, options, pool);
}

}  // namespace mocap
