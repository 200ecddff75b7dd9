// One StreamPoses subscriber: a ServerWriteReactor with one write in flight and a small
// drop-oldest queue, fed by the PosePublisher.
#pragma once

#include <grpcpp/grpcpp.h>

#include "mocap/v1/mocap.pb.h"
#include "server/pose_publisher.h"
#include "tracker/model/body_model.h"

namespace mocap {

// Poses a subscriber may have waiting behind its write in flight; older ones are dropped and
// counted in the next pose's missed_before.
inline constexpr std::size_t kSubscriberQueuePoses = 2;

// Creates and registers the reactor; it deletes itself when the call is done. `joints` are point
// indices of the model (empty: all).
grpc::ServerWriteReactor<v1::Pose>* startPoseStream(PosePublisher& publisher,
                                                    const BodyModel& model,
                                                    std::vector<int> joints);

// A stream that ends at once with `status` (refused calls).
grpc::ServerWriteReactor<v1::Pose>* refusedPoseStream(const grpc::Status& status);

}  // namespace mocap
