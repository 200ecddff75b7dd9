// Pixel counting of the masked chain: per row, the footprint's span minus the union of the
// explained spans in that row, counted on the prefix-summed silhouette.
#include "tracker/likelihood.h"

#include <algorithm>

namespace mocap {

PixelCounts countFootprint(const SilhouetteMask& mask, const Footprint& footprint,
                           const Footprint* explained, int explained_count) {
  PixelCounts counts;
  if (footprint.empty()) return counts;
  // Only explained footprints whose boxes touch this one matter (usually the parent and a
  // neighbour). A sweep over the rows keeps the ones covering the current row active, so a row
  // looks at two or three of them, not all.
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
  const Footprint* active[kMaxOverlapping];
  int n_active = 0, next_pending = 0;
  RowSpan cut[kMaxOverlapping];
  for (int y = footprint.y0; y < footprint.y1; ++y) {
    while (next_pending < n_pending && pending[next_pending]->y0 <= y)
      active[n_active++] = pending[next_pending++];
    const RowSpan span = footprint.spans[y - footprint.y0];
    const int a = span.x0, b = span.x1;
    if (a >= b) continue;
    const int in_silhouette = mask.count(y, a, b);
    counts.area += b - a;
    counts.outside += (b - a) - in_silhouette;
    if (n_active == 0) {  // most rows: nothing explained here yet
      counts.matched += in_silhouette;
      continue;
    }
    // The explained parts of [a, b) in this row, sorted by start, then their union counted once.
    int n_cut = 0;
    for (int i = 0; i < n_active;) {
      const Footprint& e = *active[i];
      if (y >= e.y1) {  // finished: drop it
        active[i] = active[--n_active];
        continue;
      }
      ++i;
      const RowSpan es = e.spans[y - e.y0];
      const int lo = std::max(a, static_cast<int>(es.x0));
      const int hi = std::min(b, static_cast<int>(es.x1));
      if (lo >= hi) continue;
      int j = n_cut++;
      for (; j > 0 && cut[j - 1].x0 > lo; --j) cut[j] = cut[j - 1];
      cut[j] = {static_cast<int16_t>(lo), static_cast<int16_t>(hi)};
    }
    int already = 0;
    int covered_to = a;
    for (int i = 0; i < n_cut; ++i) {
      const int lo = std::max(covered_to, static_cast<int>(cut[i].x0));
      const int hi = cut[i].x1;
      if (hi > lo) {
        already += mask.count(y, lo, hi);
        covered_to = hi;
      }
    }
    counts.matched += in_silhouette - already;
  }
  return counts;
}

}  // namespace mocap

namespace mocap {

PixelCounts observeSegment(const Shape& shape, const Eigen::Isometry3d& pose, const Rig& rig,
                           const std::vector<SilhouetteMask>& masks, ShapeRasterizer& rasterizer,
                           RowSpan* const* span_buffers, Footprint* footprints,
                           const std::vector<std::vector<Footprint>>& explained) {
  PixelCounts counts;
  for (std::size_t c = 0; c < rig.size(); ++c) {
    footprints[c] = rasterizer.rasterize(shape, pose, rig[c], span_buffers[c]);
    counts += countFootprint(masks[c], footprints[c], explained[c].data(),
                             static_cast<int>(explained[c].size()));
  }
  return counts;
}

}  // namespace mocap
