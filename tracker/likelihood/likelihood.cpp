// Pixel counting of the masked chain: per row, the footprint's span minus the union of the
// explained spans in that row, counted on the prefix-summed silhouette.
#include "tracker/likelihood/likelihood.h"

#include <algorithm>

namespace mocap {

namespace {

using Row = SilhouetteMask::Row;

// Rows [y, end) of `spans` (starting at row y) with nothing explained: area and silhouette pixels.
void countRows(const SilhouetteMask& mask, int y, int end, const RowSpan* spans, long& area,
               long& silhouette) {
  for (Row row = mask.row(y); y < end; ++y, ++spans, row.next()) {
    const int a = spans->x0, b = spans->x1;
    if (a >= b) continue;
    area += b - a;
    silhouette += row.count(a, b);
  }
}

// One row's span [a, b) under explained footprints. With kWholeSpan its area and silhouette
// pixels are counted, and prefix counts at its ends are reused (an explained overlap usually
// shares an endpoint with the span); without, only the explained part is counted (a footprint
// whose whole counts are known, see recountFootprint).
template <bool kWholeSpan>
class SpanRow {
 public:
  SpanRow(const Row& row, int a, int b, long& area, long& silhouette) : row_(row), a_(a), b_(b) {
    if constexpr (kWholeSpan) {
      ca_ = row.before(a);
      cb_ = row.before(b);
      area += b - a;
      silhouette += cb_ - ca_;
    }
  }
  int before(int x) const {
    if constexpr (kWholeSpan) {
      if (x == a_) return ca_;
      if (x == b_) return cb_;
    }
    return row_.before(x);
  }

 private:
  const Row& row_;
  int a_, b_, ca_ = 0, cb_ = 0;
};

// The same with one explained footprint `e` active over all the rows (the common case: the
// parent segment or the palm). `explained` gathers the silhouette pixels of the overlap.
template <bool kWholeSpan>
void countRowsMinusOne(const SilhouetteMask& mask, int y, int end, const RowSpan* spans,
                       const Footprint& e, long& area, long& silhouette, long& explained) {
  const RowSpan* es = e.spans + (y - e.y0);
  for (Row row = mask.row(y); y < end; ++y, ++spans, ++es, row.next()) {
    const int a = spans->x0, b = spans->x1;
    if (a >= b) continue;
    const SpanRow<kWholeSpan> span(row, a, b, area, silhouette);
    const int lo = std::max(a, static_cast<int>(es->x0));
    const int hi = std::min(b, static_cast<int>(es->x1));
    if (lo >= hi) continue;
    explained += span.before(hi) - span.before(lo);
  }
}

// Two explained footprints (the next most common case), kept in registers.
template <bool kWholeSpan>
void countRowsMinusTwo(const SilhouetteMask& mask, int y, int end, const RowSpan* spans,
                       const Footprint& e, const Footprint& g, long& area, long& silhouette,
                       long& explained) {
  const RowSpan* es = e.spans + (y - e.y0);
  const RowSpan* gs = g.spans + (y - g.y0);
  for (Row row = mask.row(y); y < end; ++y, ++spans, ++es, ++gs, row.next()) {
    const int a = spans->x0, b = spans->x1;
    if (a >= b) continue;
    const SpanRow<kWholeSpan> span(row, a, b, area, silhouette);
    int lo0 = std::max(a, static_cast<int>(es->x0)), hi0 = std::min(b, static_cast<int>(es->x1));
    int lo1 = std::max(a, static_cast<int>(gs->x0)), hi1 = std::min(b, static_cast<int>(gs->x1));
    if (lo0 >= hi0) {  // only the second, if any
      lo0 = lo1;
      hi0 = hi1;
    } else if (lo1 < hi1) {
      if (lo1 < lo0) {
        std::swap(lo0, lo1);
        std::swap(hi0, hi1);
      }
      if (lo1 > hi0) {  // disjoint: count the first now, the second below
        explained += span.before(hi0) - span.before(lo0);
        lo0 = lo1;
      }
      hi0 = std::max(hi0, hi1);
    }
    if (lo0 >= hi0) continue;
    explained += span.before(hi0) - span.before(lo0);
  }
}

// Three or more explained footprints active over all the rows: per row, the parts of the span
// they cover, whose union is counted once. They mostly overlap, so they are merged into one
// interval as they come; only rows where some stay apart take the sort.
template <bool kWholeSpan>
void countRowsMinusMany(const SilhouetteMask& mask, int y, int end, const RowSpan* spans,
                        const Footprint* const* active, int n_active, long& area, long& silhouette,
                        long& explained) {
  constexpr int kMax = 64;
  const RowSpan* es[kMax];
  for (int i = 0; i < n_active; ++i) es[i] = active[i]->spans + (y - active[i]->y0);
  RowSpan cut[kMax + 1];
  Row row = mask.row(y);
  for (int r = 0; y < end; ++y, ++r, row.next()) {
    const int a = spans[r].x0, b = spans[r].x1;
    if (a >= b) continue;
    int u_lo = b, u_hi = b;  // the merged interval; empty while u_lo == b
    int n_apart = 0;
    for (int i = 0; i < n_active; ++i) {
      const RowSpan e = es[i][r];
      const int lo = std::max(a, static_cast<int>(e.x0));
      const int hi = std::min(b, static_cast<int>(e.x1));
      if (lo >= hi) continue;
      if (u_lo == b) {
        u_lo = lo;
        u_hi = hi;
      } else if (lo <= u_hi && hi >= u_lo) {  // overlapping or touching
        u_lo = std::min(u_lo, lo);
        u_hi = std::max(u_hi, hi);
      } else {
        cut[n_apart++] = {static_cast<int16_t>(lo), static_cast<int16_t>(hi)};
      }
    }
    const SpanRow<kWholeSpan> span(row, a, b, area, silhouette);
    if (u_lo == b) continue;
    if (n_apart == 0) {
      explained += span.before(u_hi) - span.before(u_lo);
      continue;
    }
    // Sorted by start, then the union walked once.
    cut[n_apart++] = {static_cast<int16_t>(u_lo), static_cast<int16_t>(u_hi)};
    for (int i = 1; i < n_apart; ++i) {
      const RowSpan c = cut[i];
      int j = i;
      for (; j > 0 && cut[j - 1].x0 > c.x0; --j) cut[j] = cut[j - 1];
      cut[j] = c;
    }
    int covered_to = a;
    for (int i = 0; i < n_apart; ++i) {
      const int lo = std::max(covered_to, static_cast<int>(cut[i].x0));
      const int hi = cut[i].x1;
      if (hi > lo) {
        explained += span.before(hi) - span.before(lo);
        covered_to = hi;
      }
    }
  }
}

// Walks the footprint's rows in bands over which the set of explained footprints covering them
// does not change (see countFootprint; without kWholeSpan, see recountFootprint).
template <bool kWholeSpan>
void countBands(const SilhouetteMask& mask, const Footprint& footprint, const Footprint* explained,
                int explained_count, long& area, long& silhouette, long& already) {
  // Only explained footprints whose boxes touch this one matter (usually the parent and a
  // neighbour). The rows are walked in bands over which the set of explained footprints covering
  // them does not change, so each band runs a loop specialised to that set's size (mostly 0 or 1).
  constexpr int kMaxOverlapping = 64;
  const Footprint* pending[kMaxOverlapping];
  int n_pending = 0;
  for (int k = 0; k < explained_count && n_pending < kMaxOverlapping; ++k) {
    const Footprint& e = explained[k];
    if (e.empty() || !footprint.overlapsBox(e)) continue;
    int j = n_pending++;
    for (; j > 0 && pending[j - 1]->y0 > e.y0; --j) pending[j] = pending[j - 1];
    pending[j] = &e;
  }
  if (!kWholeSpan && n_pending == 0) return;
  const Footprint* active[kMaxOverlapping];
  int n_active = 0, next_pending = 0;
  for (int y = footprint.y0; y < footprint.y1;) {
    while (next_pending < n_pending && pending[next_pending]->y0 <= y)
      active[n_active++] = pending[next_pending++];
    int end = footprint.y1;
    if (next_pending < n_pending) end = std::min(end, pending[next_pending]->y0);
    for (int i = 0; i < n_active;) {
      if (active[i]->y1 <= y) {  // finished: drop it
        active[i] = active[--n_active];
        continue;
      }
      end = std::min(end, active[i]->y1);
      ++i;
    }
    const RowSpan* spans = footprint.spans + (y - footprint.y0);
    if (n_active == 0) {
      if constexpr (kWholeSpan) countRows(mask, y, end, spans, area, silhouette);
    } else if (n_active == 1) {
      countRowsMinusOne<kWholeSpan>(mask, y, end, spans, *active[0], area, silhouette, already);
    } else if (n_active == 2) {
      countRowsMinusTwo<kWholeSpan>(mask, y, end, spans, *active[0], *active[1], area, silhouette,
                                    already);
    } else {
      countRowsMinusMany<kWholeSpan>(mask, y, end, spans, active, n_active, area, silhouette,
                                     already);
    }
    y = end;
  }
}

}  // namespace

PixelCounts countFootprint(const SilhouetteMask& mask, const Footprint& footprint,
                           const Footprint* explained, int explained_count) {
  PixelCounts counts;
  if (footprint.empty()) return counts;
  long area = 0, silhouette = 0, already = 0;
  countBands<true>(mask, footprint, explained, explained_count, area, silhouette, already);
  counts.area = area;
  counts.outside = area - silhouette;
  counts.matched = silhouette - already;
  return counts;
}

PixelCounts recountFootprint(const SilhouetteMask& mask, const Footprint& footprint,
                             const PixelCounts& counted, const Footprint* explained,
                             int explained_count) {
  PixelCounts counts = counted;
  if (footprint.empty()) return counts;
  long area = 0, silhouette = 0, already = 0;
  countBands<false>(mask, footprint, explained, explained_count, area, silhouette, already);
  counts.matched = counted.area - counted.outside - already;
  return counts;
}

}  // namespace mocap

namespace mocap {

PixelCounts observeSegment(const Shape& shape, const Eigen::Isometry3d& pose, const Rig& rig,
                           const std::vector<SilhouetteMask>& masks, ShapeRasterizer& rasterizer,
                           RowSpan* const* span_buffers, Footprint* footprints,
                           const std::vector<std::vector<Footprint>>& explained,
                           PixelCounts* camera_counts) {
  PixelCounts counts;
  for (std::size_t c = 0; c < rig.size(); ++c) {
    footprints[c] = rasterizer.rasterize(shape, pose, rig[c], span_buffers[c]);
    const PixelCounts camera = countFootprint(masks[c], footprints[c], explained[c].data(),
                                              static_cast<int>(explained[c].size()));
    if (camera_counts) camera_counts[c] = camera;
    counts += camera;
  }
  return counts;
}

}  // namespace mocap
