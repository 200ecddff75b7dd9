// Incremental full-body evaluation: subtree kinematics, re-rasterization of the moved segments,
// and per-row differences of their footprints applied to the coverage counts.
#include "tracker/incremental_body.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace mocap {

namespace {

using Row = SilhouetteMask::Row;

// Adds kDelta (+1 or -1) covers to columns [a, b) of `row`. With `sil`, returns the silhouette
// pixels whose cover changes between none and some: gained by an add, lost by a removal. Those
// pixels are usually all or none of the interval; otherwise they come in runs, one lookup each.
template <int kDelta>
long adjust(uint8_t* row, const Row* sil, int a, int b) {
  if (a >= b) return 0;
  long changed = 0;
  if (sil) {
    constexpr uint8_t kEdge = kDelta > 0 ? 0 : 1;  // the cover that changes the union
    int edge = 0;
    for (int x = a; x < b; ++x) edge += row[x] == kEdge;
    if (edge == b - a) {
      changed = sil->count(a, b);
    } else if (edge > 0) {
      int run = -1;
      for (int x = a; x < b; ++x) {
        if (row[x] == kEdge) {
          if (run < 0) run = x;
        } else if (run >= 0) {
          changed += sil->count(run, x);
          run = -1;
        }
      }
      if (run >= 0) changed += sil->count(run, b);
    }
  }
  for (int x = a; x < b; ++x) row[x] = static_cast<uint8_t>(row[x] + kDelta);
  return changed;
}

// Row y of `f` as [a, b); an empty row as [0, 0), so the interval arithmetic below holds.
void spanAt(const Footprint& f, int y, int& a, int& b) {
  a = b = 0;
  if (y < f.y0 || y >= f.y1) return;
  const RowSpan s = f.spans[y - f.y0];
  if (s.x0 < s.x1) {
    a = s.x0;
    b = s.x1;
  }
}

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
      explained_(rig.size()),
      moved_flag_(model.segments.size(), 0) {
  for (const CameraModel& c : rig) max_rows_ = std::max(max_rows_, c.height);
  for (std::size_t s = 0; s < model.segments.size(); ++s) {
    if (model.segments[s].shape.type == ShapeType::kNone) continue;
    drawn_index_[s] = static_cast<int>(drawn_.size());
    drawn_.push_back(static_cast<int>(s));
  }
  if (drawn_.size() > std::numeric_limits<uint8_t>::max())
    throw std::invalid_argument("incremental body evaluator: too many drawn segments");
  spans_.resize(drawn_.size() * 2 * cameras_ * max_rows_);
  footprints_.resize(drawn_.size() * 2 * cameras_);
  slot_.assign(drawn_.size(), 0);
  segment_counts_.resize(drawn_.size());
  trial_counts_.resize(drawn_.size());
  for (const CameraModel& c : rig)
    coverage_.emplace_back(static_cast<std::size_t>(c.width) * c.height, 0);
}

PixelCounts IncrementalBodyEvaluator::reset(const Eigen::VectorXd& q,
                                            const std::vector<SilhouetteMask>& masks) {
  if (masks.size() != cameras_)
    throw std::invalid_argument("incremental body evaluator: expected one mask per camera");
  for (std::size_t c = 0; c < cameras_; ++c)
    if (masks[c].width() != rig_[c].width || masks[c].height() != rig_[c].height)
      throw std::invalid_argument("incremental body evaluator: mask size differs from the camera's");
  if (pending_) reject();
  // The previous pose's covers are taken off again, which leaves the coverage all zero.
  for (std::size_t k = 0; k < drawn_.size(); ++k)
    for (std::size_t c = 0; c < cameras_; ++c) {
      Footprint& f = footprint(static_cast<int>(k), c, slot_[k]);
      moveFootprint(c, f, Footprint(), false);
      f = Footprint();
    }
  masks_ = &masks;
  q_ = q;
  forwardKinematics(model_, kinematics_, q);
  sums_ = SegmentCounts();
  matched_ = 0;
  for (std::size_t k = 0; k < drawn_.size(); ++k) {
    const int ki = static_cast<int>(k);
    segment_counts_[k] = draw(ki, slot_[k]);
    sums_.area += segment_counts_[k].area;
    sums_.silhouette += segment_counts_[k].silhouette;
    for (std::size_t c = 0; c < cameras_; ++c)
      matched_ += moveFootprint(c, Footprint(), footprint(ki, c, slot_[k]), true);
  }
  renders_ += static_cast<long>(drawn_.size());
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
  for (std::size_t s = 0; s < model_.segments.size(); ++s) {
    const Segment& seg = model_.segments[s];
    bool moved = seg.parent >= 0 && moved_flag_[seg.parent];
    for (int d : seg.dofs) moved = moved || !sameBits(q[d], q_[d]);
    moved_flag_[s] = moved;
    if (moved) moved_.push_back(static_cast<int>(s));
  }
  saved_world_.resize(moved_.size());
  for (std::size_t i = 0; i < moved_.size(); ++i) saved_world_[i] = kinematics_.world[moved_[i]];
  forwardKinematics(model_, kinematics_, q, moved_);
  trial_sums_ = sums_;
  trial_matched_ = matched_;
  int moved_drawn = 0;
  for (int s : moved_) moved_drawn += drawn_index_[s] >= 0;
  // When most of the body moves (the root, the trunk, a pattern move), moving its footprints in
  // the coverage and back again costs more than counting the whole body through the masked chain
  // as FullBodyEvaluator does; the coverage then follows only if the trial is accepted.
  applied_ = 2 * moved_drawn <= static_cast<int>(drawn_.size());
  for (int s : moved_) {
    const int k = drawn_index_[s];
    if (k < 0) continue;
    const SegmentCounts& before = segment_counts_[k];
    const SegmentCounts& after = trial_counts_[k] = draw(k, 1 - slot_[k]);
    trial_sums_.area += after.area - before.area;
    trial_sums_.silhouette += after.silhouette - before.silhouette;
    if (applied_)
      for (std::size_t c = 0; c < cameras_; ++c)
        trial_matched_ +=
            moveFootprint(c, footprint(k, c, slot_[k]), footprint(k, c, 1 - slot_[k]), true);
    ++renders_;
  }
  if (!applied_) {
    trial_matched_ = 0;
    for (auto& e : explained_) e.clear();
    for (std::size_t k = 0; k < drawn_.size(); ++k) {
      const int ki = static_cast<int>(k);
      const int slot = moved_flag_[drawn_[k]] ? 1 - slot_[k] : slot_[k];
      for (std::size_t c = 0; c < cameras_; ++c) {
        const Footprint& f = footprint(ki, c, slot);
        trial_matched_ += countFootprint((*masks_)[c], f, explained_[c].data(),
                                         static_cast<int>(explained_[c].size()))
                              .matched;
        explained_[c].push_back(f);
      }
    }
  }
  pending_ = true;
  return total(trial_sums_, trial_matched_);
}

void IncrementalBodyEvaluator::accept() {
  if (!pending_) return;
  for (int s : moved_) {
    const int k = drawn_index_[s];
    if (k < 0) continue;
    if (!applied_)
      for (std::size_t c = 0; c < cameras_; ++c)
        moveFootprint(c, footprint(k, c, slot_[k]), footprint(k, c, 1 - slot_[k]), false);
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
  for (std::size_t i = 0; i < moved_.size(); ++i) {
    const int s = moved_[i];
    kinematics_.world[s] = saved_world_[i];
    const int k = drawn_index_[s];
    if (k < 0 || !applied_) continue;
    for (std::size_t c = 0; c < cameras_; ++c)
      moveFootprint(c, footprint(k, c, 1 - slot_[k]), footprint(k, c, slot_[k]), false);
  }
  pending_ = false;
}

IncrementalBodyEvaluator::SegmentCounts IncrementalBodyEvaluator::draw(int k, int slot) {
  const int s = drawn_[k];
  SegmentCounts counts;
  for (std::size_t c = 0; c < cameras_; ++c) {
    RowSpan* buffer = &spans_[((static_cast<std::size_t>(k) * 2 + slot) * cameras_ + c) * max_rows_];
    Footprint& f = footprint(k, c, slot);
    f = rasterizer_.rasterize(model_.segments[s].shape, kinematics_.world[s], rig_[c], buffer);
    // Alone, nothing explained: matched is every silhouette pixel of the footprint.
    const PixelCounts alone = countFootprint((*masks_)[c], f, nullptr, 0);
    counts.area += alone.area;
    counts.silhouette += alone.matched;
  }
  return counts;
}

long IncrementalBodyEvaluator::moveFootprint(std::size_t c, const Footprint& from,
                                             const Footprint& to, bool count) {
  if (from.empty() && to.empty()) return 0;
  const int y0 = from.empty() ? to.y0 : to.empty() ? from.y0 : std::min(from.y0, to.y0);
  const int y1 = from.empty() ? to.y1 : to.empty() ? from.y1 : std::max(from.y1, to.y1);
  const int width = rig_[c].width;
  uint8_t* const coverage = coverage_[c].data();
  const SilhouetteMask& mask = (*masks_)[c];
  long delta = 0;
  for (int y = y0; y < y1; ++y) {
    int a0, b0, a1, b1;
    spanAt(from, y, a0, b0);
    spanAt(to, y, a1, b1);
    if (a0 == a1 && b0 == b1) continue;  // the usual row of a small move: nothing changes
    uint8_t* row = coverage + static_cast<std::size_t>(y) * width;
    const Row sil_row = mask.row(y);
    const Row* sil = count ? &sil_row : nullptr;
    // Covers come off what `from` has and `to` lacks (at most two intervals), and the reverse
    // gains them. Taking off first keeps every count within the footprints that hold it.
    delta -= adjust<-1>(row, sil, a0, std::min(b0, a1));
    delta -= adjust<-1>(row, sil, std::max(a0, b1), b0);
    delta += adjust<+1>(row, sil, a1, std::min(b1, a0));
    delta += adjust<+1>(row, sil, std::max(a1, b0), b1);
  }
  return delta;
}

PixelCounts IncrementalBodyEvaluator::total(const SegmentCounts& sums, long matched) const {
  PixelCounts counts;
  counts.matched = matched;
  counts.outside = sums.area - sums.silhouette;
  counts.area = sums.area;
  return counts;
}

}  // namespace mocap
