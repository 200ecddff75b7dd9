// The factored silhouette likelihood (paper §6.2). A segment's footprint is compared with the
// silhouette minus the pixels already explained by the segments observed before it in the same
// particle, so a pixel is credited once. log P(Y_i | X_i, pre(Y_i)) = beta * (matched - outside):
// matched = newly explained silhouette pixels, outside = footprint pixels off the silhouette. The
// product over segments is the full-body likelihood Condensation uses.
#pragma once

#include <vector>

#include "tracker/likelihood/raster.h"
#include "tracker/likelihood/silhouette_mask.h"

namespace mocap {

// The most cameras one rig may have (fixed-size per-camera scratch on the hot path).
inline constexpr std::size_t kMaxCameras = 16;

struct LikelihoodParams {
  double beta = 0.02;         // log-likelihood per pixel
  int points_per_circle = 8;  // outline tessellation used by the tracker
};

struct PixelCounts {
  long matched = 0;  // silhouette pixels in the footprint not explained before
  long outside = 0;  // footprint pixels off the silhouette
  long area = 0;     // footprint pixels
  PixelCounts& operator+=(const PixelCounts& o) {
    matched += o.matched;
    outside += o.outside;
    area += o.area;
    return *this;
  }
  friend PixelCounts operator+(PixelCounts a, const PixelCounts& b) { return a += b; }
};

// Counts `footprint` against `mask`, skipping silhouette pixels covered by any of `explained`
// (footprints of earlier segments of the same particle, in the same camera). Touches only the
// footprint's rows.
PixelCounts countFootprint(const SilhouetteMask& mask, const Footprint& footprint,
                           const Footprint* explained, int explained_count);

// The counts of a footprint already counted against another chain (`counted`) against this one:
// its area and silhouette pixels are taken from `counted`, so only the rows `explained` covers
// are walked.
PixelCounts recountFootprint(const SilhouetteMask& mask, const Footprint& footprint,
                             const PixelCounts& counted, const Footprint* explained,
                             int explained_count);

inline double logLikelihood(const LikelihoodParams& params, const PixelCounts& counts) {
  return params.beta * (static_cast<double>(counts.matched) - static_cast<double>(counts.outside));
}

}  // namespace mocap

namespace mocap {

// Rasterizes one segment's shape at `pose` into every camera of `rig` (spans into
// span_buffers[c], footprint into footprints[c]) and counts it against masks[c], skipping the
// pixels of explained[c]; each camera's counts also go to camera_counts[c] if given. The one
// observation step shared by every filter.
PixelCounts observeSegment(const Shape& shape, const Eigen::Isometry3d& pose, const Rig& rig,
                           const std::vector<SilhouetteMask>& masks, ShapeRasterizer& rasterizer,
                           RowSpan* const* span_buffers, Footprint* footprints,
                           const std::vector<std::vector<Footprint>>& explained,
                           PixelCounts* camera_counts = nullptr);

}  // namespace mocap
