// Incremental full-body evaluation: subtree kinematics, re-rasterization of the moved segments, and
// their masked chain over the footprints of the segments that stand still.
#include "tracker/filters/incremental_body.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace mocap {

namespace {

bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

}  // namespace

IncrementalBodyEvaluator::IncrementalBodyEvaluator(const BodyModel& model, const Rig& rig,
                                                   int points_per_circle, WorkerPool* pool)
    : model_(model),
      rig_(rig),
      cameras_(rig.size()),
      pool_(pool),
      rasterizers_(pool ? pool->size() : 1, ShapeRasterizer(points_per_circle)),
      camera_matched_(rig.size()),
      camera_rest_(rig.size()),
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
  footprint_counts_.resize(footprints_.size());
  slot_.assign(drawn_.size(), 0);
  for (auto& e : rest_explained_) e.reserve(drawn_.size());
}

PixelCounts IncrementalBodyEvaluator::reset(const Eigen::VectorXd& q,
                                            const std::vector<SilhouetteMask>& masks) {
  if (masks.size() != cameras_)
    throw std::invalid_argument("incremental body evaluator: expected one mask per camera");
  for (std::size_t c = 0; c < cameras_; ++c)
    if (masks[c].width() != rig_[c].width || masks[c].height() != rig_[c].height)
      throw std::invalid_argument(
          "incremental body evaluator: mask size differs from the camera's");
  pending_ = false;
  rest_valid_ = false;
  masks_ = &masks;
  q_ = q;
  forwardKinematics(model_, kinematics_, q);
  // The whole body is the moved set over an empty rest.
  moved_drawn_.resize(drawn_.size());
  for (std::size_t k = 0; k < drawn_.size(); ++k) moved_drawn_[k] = static_cast<int>(k);
  forEachCamera([&](std::size_t c, ShapeRasterizer& rasterizer) {
    rest_explained_[c].clear();
    for (int k : moved_drawn_) draw(k, c, slot_[k], rasterizer);
    camera_matched_[c] = movedOverRest(c, Moved::kDrawn);
  });
  renders_ += static_cast<long>(drawn_.size());
  counts_ = PixelCounts();
  for (long m : camera_matched_) counts_.matched += m;
  for (int k : moved_drawn_) addOwnCounts(k, slot_[k], 1, counts_);
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
  const bool new_rest = !rest_valid_ || rest_of_ != moved_drawn_;
  // matched(R) directly when R is the smaller part (the root or a pattern move moves nearly all).
  if (new_rest) rest_direct_ = 2 * moved_drawn_.size() > drawn_.size();
  forwardKinematics(model_, kinematics_, q, moved_);
  forEachCamera([&](std::size_t c, ShapeRasterizer& rasterizer) {
    if (new_rest) camera_rest_[c] = restFor(c);
    for (int k : moved_drawn_) draw(k, c, slotOf(k, Moved::kTrial), rasterizer);
    camera_matched_[c] = movedOverRest(c, Moved::kTrial);
  });
  if (new_rest) {
    rest_matched_ = rest_direct_ ? 0 : counts_.matched;
    for (long m : camera_rest_) rest_matched_ += rest_direct_ ? m : -m;
    rest_of_ = moved_drawn_;
    rest_valid_ = true;
  }
  renders_ += static_cast<long>(moved_drawn_.size());
  trial_counts_ = counts_;
  trial_counts_.matched = rest_matched_;
  for (long m : camera_matched_) trial_counts_.matched += m;
  for (int k : moved_drawn_) {
    addOwnCounts(k, slotOf(k, Moved::kTrial), 1, trial_counts_);
    addOwnCounts(k, slot_[k], -1, trial_counts_);
  }
  pending_ = true;
  return trial_counts_;
}

void IncrementalBodyEvaluator::currentFootprints(std::size_t c, std::vector<Footprint>& out) const {
  out.clear();
  for (std::size_t k = 0; k < drawn_.size(); ++k)
    out.push_back(footprints_[slotIndex(static_cast<int>(k), c, slot_[k])]);
}

void IncrementalBodyEvaluator::accept() {
  if (!pending_) return;
  // The rest stands where it stood, so its footprints and matched(R) stay valid.
  for (int k : moved_drawn_) slot_[k] ^= 1;
  std::swap(q_, trial_q_);
  counts_ = trial_counts_;
  pending_ = false;
}

void IncrementalBodyEvaluator::reject() {
  if (!pending_) return;
  for (std::size_t i = 0; i < moved_.size(); ++i) kinematics_.world[moved_[i]] = saved_world_[i];
  pending_ = false;
}

long IncrementalBodyEvaluator::restFor(std::size_t c) {
  std::vector<Footprint>& rest = rest_explained_[c];
  rest.clear();
  std::size_t next_moved = 0;
  for (std::size_t k = 0; k < drawn_.size(); ++k) {
    if (next_moved < moved_drawn_.size() && moved_drawn_[next_moved] == static_cast<int>(k)) {
      ++next_moved;
      continue;
    }
    rest.push_back(footprint(static_cast<int>(k), c, slot_[k]));
  }
  if (!rest_direct_) return movedOverRest(c, Moved::kCurrent);
  long matched = 0;
  for (std::size_t i = 0; i < rest.size(); ++i)
    matched += countFootprint((*masks_)[c], rest[i], rest.data(), static_cast<int>(i)).matched;
  return matched;
}

long IncrementalBodyEvaluator::movedOverRest(std::size_t c, Moved which) {
  long matched = 0;
  std::vector<Footprint>& explained = rest_explained_[c];
  const std::size_t rest = explained.size();
  for (int k : moved_drawn_) {
    const std::size_t at = slotIndex(k, c, slotOf(k, which));
    const Footprint& f = footprints_[at];
    const int n = static_cast<int>(explained.size());
    PixelCounts counts;
    if (which == Moved::kCurrent) {
      counts = recountFootprint((*masks_)[c], f, footprint_counts_[at], explained.data(), n);
    } else {
      counts = countFootprint((*masks_)[c], f, explained.data(), n);
      footprint_counts_[at] = counts;  // its area and outside pixels hold for any chain
    }
    matched += counts.matched;
    explained.push_back(f);
  }
  explained.resize(rest);
  return matched;
}

void IncrementalBodyEvaluator::addOwnCounts(int k, int slot, long sign, PixelCounts& to) const {
  for (std::size_t c = 0; c < cameras_; ++c) {
    const PixelCounts& own = footprint_counts_[slotIndex(k, c, slot)];
    to.area += sign * own.area;
    to.outside += sign * own.outside;
  }
}

void IncrementalBodyEvaluator::draw(int k, std::size_t c, int slot, ShapeRasterizer& rasterizer) {
  const int s = drawn_[k];
  RowSpan* buffer = &spans_[slotIndex(k, c, slot) * max_rows_];
  footprint(k, c, slot) =
      rasterizer.rasterize(model_.segments[s].shape, kinematics_.world[s], rig_[c], buffer);
}

}  // namespace mocap
