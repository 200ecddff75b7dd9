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
// candidates by a look-ahead over more of the body (FilterOptions::Lookahead, in
// factored_lookahead.cpp) while each particle's weight keeps only the paper's factor, and a
// full-body refinement (refine/refinement.h) corrects the best particle after the layers.
#include "tracker/filters/factored_filter.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <stdexcept>

#include "tracker/model/kinematics.h"

namespace mocap {

FactoredFilter::FactoredFilter(const BodyModel& model, const Rig& rig, const FilterOptions& options,
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

void FactoredFilter::reset(const Eigen::VectorXd& q0) {
  if (q0.size() != static_cast<long>(model_.dofs.size()))
    throw std::invalid_argument("factored filter: initial pose has the wrong number of DOFs");
  // One particle: the first layer spreads the whole budget over it.
  particles_.assign(1, FactoredParticle{q0, 0.0, std::vector<int>(model_.segments.size(), -1)});
  clampToLimits(model_, particles_[0].q);
}

FrameEstimate FactoredFilter::step(const std::vector<SilhouetteMask>& masks) {
  if (masks.size() != rig_.size())
    throw std::invalid_argument("factored filter: expected one mask per camera");
  if (particles_.empty()) reset(model_.neutralPose());
  FrameEstimate estimate;
  startFrame(estimate);
  double injection_debt = 0;
  for (const FactoredLayer& layer : plan_.layers) {
    const int count = generateCandidates(layer, injection_debt);
    if (layer.lookahead) {
      // One task per parent and camera: 5 parents alone would leave a thread idle.
      const int cameras = static_cast<int>(rig_.size());
      pool_.parallelFor(static_cast<int>(particles_.size()) * cameras, [&](int i, int worker) {
        placeRest(layer, i / cameras, static_cast<std::size_t>(i % cameras), masks, worker);
      });
      for (std::size_t p = 0; p < particles_.size(); ++p)
        estimate.segment_renders += rest_[p].renders;
    }
    groupSamePoses(layer, count);
    pool_.parallelFor(static_cast<int>(pose_groups_.size()),
                      [&](int g, int worker) { evaluateGroup(layer, g, count, masks, worker); });
    estimate.evaluations += count;
    estimate.segment_renders +=
        static_cast<long>(pose_groups_.size()) +
        static_cast<long>(count) * (layer.lookahead ? plan_.descendants[layer.segment].size() : 0);
    keepBest(layer, count);
  }
  if (refinement_) refinement_->run(masks, yield_, rng_, particles_[0].q, estimate);
  finishFrame(estimate);
  return estimate;
}

void FactoredFilter::startFrame(FrameEstimate& estimate) {
  nodes_.clear();
  node_footprints_.clear();
  arena_used_ = 0;
  double max_lw = -INFINITY;
  for (const FactoredParticle& p : particles_) max_lw = std::max(max_lw, p.log_weight);
  double sum = 0;
  for (const FactoredParticle& p : particles_) sum += std::exp(p.log_weight - max_lw);
  const double log_norm = max_lw + std::log(sum);
  for (FactoredParticle& p : particles_) {
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
    for (FactoredParticle& p : particles_) p.node[s] = node;
  }
}

int FactoredFilter::addNode(const Eigen::Isometry3d& pose) {
  nodes_.push_back({pose, static_cast<int>(node_footprints_.size())});
  node_footprints_.resize(node_footprints_.size() + rig_.size());
  return static_cast<int>(nodes_.size()) - 1;
}

int FactoredFilter::generateCandidates(const FactoredLayer& layer, double& injection_debt) {
  const int parents = static_cast<int>(particles_.size());
  int count = 0;
  if (layer.dof < 0) {
    for (int p = 0; p < parents; ++p) {
      FactoredCandidate& c = candidates_[count++];
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
      FactoredCandidate& c = candidates_[count++];
      c.q = particles_[p].q;
      c.q[layer.dof] = share == 1 ? 0.5 * (lo + hi) : lo + (hi - lo) * j / (share - 1);
      c.parent = p;
      c.log_weight = particles_[p].log_weight;
    }
  }
  // Positions have no bounded static distribution (a root uniform over a 20 m room lands off
  // every camera, where an empty footprint outscores a misplaced body): inject joint angles only,
  // carrying the share over to the next rotation layer.
  injection_debt += options_.injection.share * count;
  if (dof.type == DofType::kTranslation) return count;
  const int injected = std::min(count, static_cast<int>(injection_debt));
  injection_debt -= injected;
  const bool whole_segment =
      options_.injection.redraw == InjectionOptions::Redraw::kSegment && layer.first_dof;
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

void FactoredFilter::groupSamePoses(const FactoredLayer& layer, int count) {
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

void FactoredFilter::evaluateGroup(const FactoredLayer& layer, int g, int count,
                                   const std::vector<SilhouetteMask>& masks, int worker) {
  const int first = pose_groups_[g];
  evaluate(layer, first, -1, masks, worker);
  for (int i = first + 1; i < count; ++i)
    if (pose_group_[i] == g) evaluate(layer, i, first, masks, worker);
}

void FactoredFilter::evaluate(const FactoredLayer& layer, int i, int same_pose,
                              const std::vector<SilhouetteMask>& masks, int worker) {
  FactoredCandidate& cand = candidates_[i];
  const FactoredParticle& parent = particles_[cand.parent];
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
    for (std::size_t k = 0; k < placed.size(); ++k) explained[k] = node_footprints_[placed[k] + c];
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
  if (layer.lookahead) rankByLookahead(layer, i, masks, scratch);
}

void FactoredFilter::keepBest(const FactoredLayer& layer, int count) {
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
    const FactoredCandidate& cand = candidates_[order_[k]];
    FactoredParticle& out = next_particles_[k];
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

void FactoredFilter::finishFrame(FrameEstimate& estimate) {
  std::vector<const Eigen::VectorXd*> qs;
  std::vector<double> lw;
  for (const FactoredParticle& p : particles_) {
    qs.push_back(&p.q);
    lw.push_back(p.log_weight);
  }
  weightedEstimate(qs, lw, estimate);
  // Kept sorted best first; a refined best particle is the estimate.
  if (refinement_) estimate.q = particles_[0].q;
}

std::unique_ptr<PoseFilter> makeFactoredFilter(const BodyModel& model, const Rig& rig,
                                               const FilterOptions& options, WorkerPool& pool) {
  validateFilterOptions(options);
  return std::make_unique<FactoredFilter>(model, rig, options, pool);
}

}  // namespace mocap
