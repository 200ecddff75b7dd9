// Every conversion from the daemon's types to the wire messages, in one place.
#pragma once

#include <vector>

#include "mocap/v1/mocap.pb.h"
#include "server/pipeline.h"
#include "server/pose.h"
#include "tracker/model/body_model.h"

namespace mocap {

// `joints`: indices into model.points to include, in that order; empty means all.
void poseToProto(const Pose& pose, const BodyModel& model, const std::vector<int>& joints,
                 uint64_t missed_before, v1::Pose& out);
void skeletonToProto(const BodyModel& model, uint32_t body_version, v1::Skeleton& out);
void cameraInfoToProto(const OpenedCamera& camera, v1::CameraInfo& out);
void recordingToProto(const RecordingStatus& recording, v1::RecordingState& out);
void latencyToProto(const LatencySummary& latency, v1::LatencyPercentiles& out);
void cameraStatusToProto(const OpenedCamera& camera, const CameraRuntimeStatus& status,
                         bool pipeline_running, v1::CameraStatus& out);
// A successful fit: the fitted body as a body model file, its proportions and figures.
void bodyFitToProto(const FitBodyResult& result, v1::FitBodyResponse& out);

}  // namespace mocap
