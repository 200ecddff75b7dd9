// Writes poses streamed from mocapd as a standard BVH file: the hierarchy from GetSkeleton, one
// motion line per pose. Every segment becomes a joint with its rest offset; a joint's channels are
// Zrotation Xrotation Yrotation (degrees), plus Xposition Yposition Zposition for the root and for
// any segment with translational DOFs. Lengths stay in metres and the world stays Z-up, as the
// daemon reports them (importers such as Blender's let you pick the up axis and the scale).
#pragma once

#include <ostream>
#include <vector>

#include "mocap/v1/mocap.pb.h"

namespace mocapctl {

// `frames`: one DOF vector per pose, in skeleton.dofs order. Throws std::runtime_error if a frame
// has the wrong number of values.
void writeBvh(std::ostream& out, const mocap::v1::Skeleton& skeleton,
              const std::vector<std::vector<double>>& frames, double frame_time_s);

}  // namespace mocapctl
