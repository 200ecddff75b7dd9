// Writes poses as a standard BVH file: the hierarchy from a Skeleton (GetSkeleton's, or one made
// from a body model), one motion line per pose. Every segment becomes a joint with its rest offset;
// a joint's channels are Zrotation Xrotation Yrotation (degrees), plus Xposition Yposition
// Zposition for the root and for any segment with translational DOFs.
//
// By default the file is as animation tools import BVH: Y up, metres. The daemon's world is
// right-handed Z up, so a world point (x, y, z) is written as (x, z, -y): a rotation, not a mirror,
// and the one Blender's importer undoes with its default axes (forward -Z, up Y), so the body comes
// back exactly where the daemon saw it. The root's OFFSET is zero and its position channels are
// its world position, which BVH readers that add the channels to the OFFSET and those that
// replace it (Blender's) read alike: the body travels as the poses do, its feet at y = 0 when
// they are on the daemon's floor.
#pragma once

#include <ostream>
#include <vector>

#include "mocap/v1/mocap.pb.h"

namespace mocapctl {

struct BvhExportOptions {
  bool y_up = true;            // false: the daemon's Z-up world as it is
  double units_per_metre = 1;  // 100: centimetres
};

// `frames`: one DOF vector per pose, in skeleton.dofs order. Throws std::runtime_error if a frame
// has the wrong number of values or the skeleton has no segment.
void writeBvh(std::ostream& out, const mocap::v1::Skeleton& skeleton,
              const std::vector<std::vector<double>>& frames, double frame_time_s,
              const BvhExportOptions& options = {});

}  // namespace mocapctl
