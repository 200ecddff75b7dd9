// The look-ahead a layer of the factored filter may rank its candidates by
// (FilterOptions::Lookahead::kBody), an addition to the paper: the candidate's segment counted with
// the whole body, the segments not placed yet at their previous relative pose, while each
// particle's weight keeps only the paper's factor.
#include <algorithm>

#include "tracker/filters/factored_filter.h"
#include "tracker/model/kinematics.h"

namespace mocap {

void FactoredFilter::rankByLookahead(const FactoredLayer& layer, int i,
                                     const std::vector<SilhouetteMask>& masks,
                                     WorkerScratch& scratch) {
  FactoredCandidate& cand = candidates_[i];
  const FactoredParticle& parent = particles_[cand.parent];
  const int s = layer.segment;
  // The whole body: the parent's placed segments and the rest at their previous pose (counted
  // once per parent), then this candidate's segment and subtree over what those explain.
  const RestOfBody& rest = rest_[cand.parent];
  PixelCounts total;
  for (std::size_t c = 0; c < rig_.size(); ++c) {
    scratch.explained[c] = rest.explained[c];
    total += rest.camera_counts[c];
    total += countFootprint(masks[c], candidateFootprints(i)[c], scratch.explained[c].data(),
                            static_cast<int>(scratch.explained[c].size()));
  }
  cand.selection = parent.log_weight + logLikelihood(options_.likelihood,
                                                     total + lookAhead(s, cand, i, masks, scratch));
}

void FactoredFilter::placeRest(const FactoredLayer& layer, int p, std::size_t c,
                               const std::vector<SilhouetteMask>& masks, int worker) {
  const FactoredParticle& parent = particles_[p];
  RestOfBody& rest = rest_[p];
  WorkerScratch& scratch = scratch_[worker];
  forwardKinematics(model_, scratch.kinematics, parent.q);
  std::vector<Footprint>& explained = rest.explained[c];
  explained.clear();
  for (std::size_t j = 0; j < parent.node.size(); ++j) {
    if (static_cast<int>(j) == layer.segment || parent.node[j] < 0) continue;
    explained.push_back(node_footprints_[nodes_[parent.node[j]].first_footprint + c]);
  }
  const std::vector<int>& below = plan_.descendants[layer.segment];
  PixelCounts& counts = rest.camera_counts[c] = PixelCounts();
  int k = 0;
  for (std::size_t j = 0; j < model_.segments.size(); ++j) {
    const int o = static_cast<int>(j);
    if (o == layer.segment || parent.node[o] >= 0 ||
        model_.segments[o].shape.type == ShapeType::kNone ||
        std::find(below.begin(), below.end(), o) != below.end())
      continue;
    const Footprint f =
        scratch.rasterizer.rasterize(model_.segments[o].shape, scratch.kinematics.world[o],
                                     rig_[c], &rest.spans[(k * rig_.size() + c) * max_rows_]);
    counts += countFootprint(masks[c], f, explained.data(), static_cast<int>(explained.size()));
    explained.push_back(f);
    ++k;
  }
  if (c == 0) rest.renders = k;
}

PixelCounts FactoredFilter::lookAhead(int s, const FactoredCandidate& cand, int i,
                                      const std::vector<SilhouetteMask>& masks,
                                      WorkerScratch& scratch) {
  for (std::size_t c = 0; c < rig_.size(); ++c)
    scratch.explained[c].push_back(candidateFootprints(i)[c]);
  scratch.poses[s] = cand.pose;
  PixelCounts total;
  RowSpan* spans[kMaxCameras];
  const std::vector<int>& below = plan_.descendants[s];
  for (std::size_t k = 0; k < below.size(); ++k) {
    const int d = below[k];
    scratch.poses[d] = scratch.poses[model_.segments[d].parent] * localTransform(model_, d, cand.q);
    for (std::size_t c = 0; c < rig_.size(); ++c)
      spans[c] = &scratch.lookahead_spans[(k * rig_.size() + c) * max_rows_];
    total +=
        observeSegment(model_.segments[d].shape, scratch.poses[d], rig_, masks, scratch.rasterizer,
                       spans, scratch.footprints.data(), scratch.explained);
    for (std::size_t c = 0; c < rig_.size(); ++c)
      scratch.explained[c].push_back(scratch.footprints[c]);
  }
  return total;
}

}  // namespace mocap
