// Incremental full-body evaluation: subtree kinematics, re-rasterization of the moved segments, and
// their masked chain over the footprints of the segments that stand still.
#include "tracker/incremental_body.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace mocap {

namespace {

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

IncrementalBodyEvaluator::IncrementalBodyEvaluator(const BodyModel& model, const Rig& rig,
                                                   int points_per_circle)
    : model_(model),
      rig_(rig),
      cameras_(rig.size()),
      rasterizer_(points_per_circle),
      drawn_index_(model.segments.size(), -1),
      kinematics_(model),
      moved_flag_(model.segments.size(), 0),
      rest_explained_(rig.size()) {
  for (const CameraModel& c : rig) max_rows_ = std::max(max_rows_, c.height);
  for (std::size_t s = 0; s < model.segments.size(); ++s) {
    if (model.segments[s].shape.type == ShapeType::kNone) continue;
    drawn_index_[s] = static_cast<int>(drawn_.size());
    drawn_.push_back(static_cast<int>(s));
  }
  spans_.resize(drawn_.size() * 2 * cameras_ * max_rows_);
  footprints_.resize(drawn_.size() * 2 * cameras_);
  slot_.assign(drawn_.size(), 0);
  segment_counts_.resize(drawn_.size());
  trial_counts_.resize(drawn_.size());
  for (auto& e : rest_explained_) e.reserve(drawn_.size());
}

PixelCounts IncrementalBodyEvaluator::reset(const Eigen::VectorXd& q,
                                            const std::vector<SilhouetteMask>& masks) {
  if (masks.size() != cameras_)
    throw std::invalid_argument("incremental body evaluator: expected one mask per camera");
  for (std::size_t c = 0; c < cameras_; ++c)
    if (masks[c].width() != rig_[c].width || masks[c].height() != rig_[c].height)
      throw std::invalid_argument("incremental body evaluator: mask size differs from the camera's");
  pending_ = false;
  rest_valid_ = false;
  masks_ = &masks;
  q_ = q;
  forwardKinematics(model_, kinematics_, q);
  // The whole body is the moved set over an empty rest.
  moved_drawn_.resize(drawn_.size());
  for (std::size_t k = 0; k < drawn_.size(); ++k) {
    moved_drawn_[k] = static_cast<int>(k);
    draw(static_cast<int>(k), slot_[k]);
  }
  renders_ += static_cast<long>(drawn_.size());
  for (auto& e : rest_explained_) e.clear();
  matched_ = movedOverRest(false);
  sums_ = SegmentCounts();
  for (std::size_t k = 0; k < drawn_.size(); ++k) {
    segment_counts_[k] = trial_counts_[k];
    sums_.area += segment_counts_[k].area;
    sums_.silhouette += segment_counts_[k].silhouette;
  }
  counts_ = total(sums_, matched_);
  return counts_;
}

PixelCounts IncrementalBodyEvaluator::trial(const Eigen::VectorXd& q) {
  if (!masks_) throw std::logic_error("incremental body evaluator: trial before reset");
  if (pending_) throw std::logic_error("incremental body evaluator: trial still pending");
  if (q.size() != q_.size())
    throw std::invalid_argument("incremental body evaluator: pose has the wrong number of DOFs");
  trial_q_ = q;
  // A segment moves if one of its DOFs changed (to the bit: the full evaluation would see any
  // difference) or its parent moved.
  moved_.clear();
  moved_drawn_.clear();
  for (std::size_t s = 0; s < model_.segments.size(); ++s) {
    const Segment& seg = model_.segments[s];
    bool moved = seg.parent >= 0 && moved_flag_[seg.parent];
    for (int d : seg.dofs) moved = moved || !sameBits(q[d], q_[d]);
    moved_flag_[s] = moved;
    if (!moved) continue;
    moved_.push_back(static_cast<int>(s));
    if (drawn_index_[s] >= 0) moved_drawn_.push_back(drawn_index_[s]);
  }
  saved_world_.resize(moved_.size());
  for (std::size_t i = 0; i < moved_.size(); ++i) saved_world_[i] = kinematics_.world[moved_[i]];
  if (!rest_valid_ || rest_of_ != moved_drawn_) restFor();
  forwardKinematics(model_, kinematics_, q, moved_);
  for (int k : moved_drawn_) draw(k, 1 - slot_[k]);
  renders_ += static_cast<long>(moved_drawn_.size());
  trial_matched_ = rest_matched_ + movedOverRest(true);
  trial_sums_ = sums_;
  for (int k : moved_drawn_) {
    trial_sums_.area += trial_counts_[k].area - segment_counts_[k].area;
    trial_sums_.silhouette += trial_counts_[k].silhouette - segment_counts_[k].silhouette;
  }
  pending_ = true;
  return total(trial_sums_, trial_matched_);
}

void IncrementalBodyEvaluator::accept() {
  if (!pending_) return;
  // The rest stands where it stood, so its footprints and matched(R) stay valid.
  for (int k : moved_drawn_) {
    slot_[k] ^= 1;
    segment_counts_[k] = trial_counts_[k];
  }
  std::swap(q_, trial_q_);
  sums_ = trial_sums_;
  matched_ = trial_matched_;
  counts_ = total(sums_, matched_);
  pending_ = false;
}

void IncrementalBodyEvaluator::reject() {
  if (!pending_) return;
  for (std::size_t i = 0; i < moved_.size(); ++i) kinematics_.world[moved_[i]] = saved_world_[i];
  pending_ = false;
}

void IncrementalBodyEvaluator::restFor() {
  for (auto& e : rest_explained_) e.clear();
  std::size_t next_moved = 0;
  for (std::size_t k = 0; k < drawn_.size(); ++k) {
    if (next_moved < moved_drawn_.size() && moved_drawn_[next_moved] == static_cast<int>(k)) {
      ++next_moved;
      continue;
    }
    for (std::size_t c = 0; c < cameras_; ++c)
      rest_explained_[c].push_back(footprint(static_cast<int>(k), c, slot_[k]));
  }
  // matched(R) directly when R is the smaller part (the root or a pattern move moves nearly all).
  if (2 * moved_drawn_.size() > drawn_.size()) {
    rest_matched_ = 0;
    for (std::size_t c = 0; c < cameras_; ++c) {
      const std::vector<Footprint>& rest = rest_explained_[c];
      for (std::size_t i = 0; i < rest.size(); ++i)
        rest_matched_ +=
            countFootprint((*masks_)[c], rest[i], rest.data(), static_cast<int>(i)).matched;
    }
  } else {
    rest_matched_ = matched_ - movedOverRest(false);
  }
  rest_of_ = moved_drawn_;
  rest_valid_ = true;
}

long IncrementalBodyEvaluator::movedOverRest(bool trial) {
  long matched = 0;
  for (int k : moved_drawn_) trial_counts_[k] = SegmentCounts();
  for (std::size_t c = 0; c < cameras_; ++c) {
    std::vector<Footprint>& explained = rest_explained_[c];
    const std::size_t rest = explained.size();
    for (int k : moved_drawn_) {
      const Footprint& f = footprint(k, c, trial ? 1 - slot_[k] : slot_[k]);
      const PixelCounts counts = countFootprint((*masks_)[c], f, explained.data(),
                                                static_cast<int>(explained.size()));
      matched += counts.matched;
      trial_counts_[k].area += counts.area;
      trial_counts_[k].silhouette += counts.area - counts.outside;
      explained.push_back(f);
    }
    explained.resize(rest);
  }
  return matched;
}

void IncrementalBodyEvaluator::draw(int k, int slot) {
  const int s = drawn_[k];
  for (std::size_t c = 0; c < cameras_; ++c) {
    RowSpan* buffer = &spans_[((static_cast<std::size_t>(k) * 2 + slot) * cameras_ + c) * max_rows_];
    footprint(k, c, slot) =
        rasterizer_.rasterize(model_.segments[s].shape, kinematics_.world[s], rig_[c], buffer);
  }
}

PixelCounts IncrementalBodyEvaluator::total(const SegmentCounts& sums, long matched) const {
  PixelCounts counts;
  counts.matched = matched;
  counts.outside = sums.area - sums.silhouette;
  counts.area = sums.area;
  return counts;
}

}  // namespace mocap
