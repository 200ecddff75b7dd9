// Where a pose leaves the silhouette unexplained: the silhouette pixels no segment's footprint
// covers, opened so the slivers a slightly-off outline leaves along every edge drop out, as
// connected blobs. A limb the tracker has lost inside the trunk leaves such a blob where it really
// is; the factored filter's refinement aims limb proposals at it
// (FilterOptions::refine_unexplained).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "tracker/likelihood/raster.h"
#include "tracker/likelihood/silhouette_mask.h"

namespace mocap {

struct UnexplainedBlob {
  Eigen::Vector2d centroid;  // pixels
  long area = 0;             // pixels, after the opening
};

// The blobs of at least `min_area` pixels left of `mask` once `footprints` are taken out and the
// rest opened with a square of `opening` pixels (odd; 1: no opening), largest first. Only the
// footprints' box grown by a quarter of its size on each side is looked at: a limb is not farther
// from the body than that.
std::vector<UnexplainedBlob> unexplainedBlobs(const SilhouetteMask& mask,
                                              const Footprint* footprints, int count, long min_area,
                                              int opening);

}  // namespace mocap
