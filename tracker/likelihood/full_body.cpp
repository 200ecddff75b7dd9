// Full-body likelihood evaluation for the baseline filters.
#include "tracker/likelihood/full_body.h"

#include <algorithm>

namespace mocap {

FullBodyEvaluator::Scratch::Scratch(const BodyModel& model, const Rig& rig, int points_per_circle,
                                    int max_rows)
    : kinematics(model),
      rasterizer(points_per_circle),
      spans(model.segments.size() * rig.size() * max_rows),
      footprints(rig.size()),
      explained(rig.size()) {}

FullBodyEvaluator::FullBodyEvaluator(const BodyModel& model, const Rig& rig, int points_per_circle,
                                     int workers)
    : model_(model), rig_(rig) {
  for (const CameraModel& c : rig) max_rows_ = std::max(max_rows_, c.height);
  for (std::size_t s = 0; s < model.segments.size(); ++s)
    if (model.segments[s].shape.type != ShapeType::kNone) drawn_.push_back(static_cast<int>(s));
  for (int w = 0; w < workers; ++w) scratch_.emplace_back(model, rig, points_per_circle, max_rows_);
}

PixelCounts FullBodyEvaluator::evaluate(const Eigen::VectorXd& q,
                                        const std::vector<SilhouetteMask>& masks, int worker) {
  Scratch& scratch = scratch_[worker];
  forwardKinematics(model_, scratch.kinematics, q);
  for (auto& e : scratch.explained) e.clear();
  PixelCounts total;
  RowSpan* spans[kMaxCameras];
  for (std::size_t k = 0; k < drawn_.size(); ++k) {
    const int s = drawn_[k];
    for (std::size_t c = 0; c < rig_.size(); ++c)
      spans[c] = &scratch.spans[(k * rig_.size() + c) * max_rows_];
    total +=
        observeSegment(model_.segments[s].shape, scratch.kinematics.world[s], rig_, masks,
                       scratch.rasterizer, spans, scratch.footprints.data(), scratch.explained);
    for (std::size_t c = 0; c < rig_.size(); ++c)
      scratch.explained[c].push_back(scratch.footprints[c]);
  }
  return total;
}

}  // namespace mocap
