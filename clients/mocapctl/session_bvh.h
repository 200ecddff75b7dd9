// BVH from a recorded session, without a daemon. A session stores the frames, the bodies and, from
// a source that knows it (the fake scene), the true pose of each set (truth.csv); it does not store
// the poses the daemon tracked. So the session alone gives its truth, on the body the truth is of;
// the tracked poses come from replaying the session through mocapd.
#pragma once

#include <string>
#include <vector>

#include "drivers/record/session_reader.h"
#include "mocap/v1/mocap.pb.h"
#include "tracker/model/body_model.h"

namespace mocapctl {

// A body model as GetSkeleton describes it (body_version 0).
mocap::v1::Skeleton skeletonOf(const mocap::BodyModel& model);

// Poses ready for writeBvh: evenly spaced frames of one skeleton.
struct BvhClip {
  mocap::v1::Skeleton skeleton;
  std::vector<std::vector<double>> frames;
  double frame_time_s = 0;
  // Sets inside the clip without a true pose (the subject out of view): each holds the pose
  // before it, so the clip keeps the recorded pace.
  int held_sets = 0;
};

// The session's true poses from its first set with one to its last, one frame per committed set,
// on truthBodyModel(); the frame time is the sets' mean interval (a single frame: the first
// camera's nominal rate). Throws std::runtime_error naming the session when it stores no truth or
// no body.
BvhClip truthClip(const mocap::SessionReader& session);

}  // namespace mocapctl
