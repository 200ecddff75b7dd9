// The gRPC MocapService on the callback API. StreamPoses gets one ServerWriteReactor per
// subscriber (see pose_stream.cpp); CaptureBackground answers when the mask thread is done,
// FitBody when the pipeline's fit thread is; every other call answers at once from the pipeline's
// state.
#pragma once

#include <string>

#include <grpcpp/grpcpp.h>

#include "mocap/v1/mocap.grpc.pb.h"
#include "server/pipeline.h"
#include "server/pose_publisher.h"
#include "tracker/model/body_model.h"

namespace mocap {

class MocapServiceImpl final : public v1::MocapService::CallbackService {
 public:
  // Everything is borrowed and must outlive the service. `mode` is "live" or "replay".
  MocapServiceImpl(const ServerConfig& config, const BodyModel& model, Pipeline& pipeline,
                   PosePublisher& publisher);

  grpc::ServerWriteReactor<v1::Pose>* StreamPoses(grpc::CallbackServerContext* context,
                                                  const v1::StreamPosesRequest* request) override;
  grpc::ServerUnaryReactor* GetSkeleton(grpc::CallbackServerContext* context,
                                        const v1::GetSkeletonRequest* request,
                                        v1::Skeleton* response) override;
  grpc::ServerUnaryReactor* GetStatus(grpc::CallbackServerContext* context,
                                      const v1::GetStatusRequest* request,
                                      v1::Status* response) override;
  grpc::ServerUnaryReactor* ListCameras(grpc::CallbackServerContext* context,
                                        const v1::ListCamerasRequest* request,
                                        v1::ListCamerasResponse* response) override;
  grpc::ServerUnaryReactor* StartRecording(grpc::CallbackServerContext* context,
                                           const v1::StartRecordingRequest* request,
                                           v1::RecordingState* response) override;
  grpc::ServerUnaryReactor* StopRecording(grpc::CallbackServerContext* context,
                                          const v1::StopRecordingRequest* request,
                                          v1::RecordingState* response) override;
  grpc::ServerUnaryReactor* CaptureBackground(grpc::CallbackServerContext* context,
                                              const v1::CaptureBackgroundRequest* request,
                                              v1::CaptureBackgroundResponse* response) override;
  grpc::ServerUnaryReactor* Reacquire(grpc::CallbackServerContext* context,
                                      const v1::ReacquireRequest* request,
                                      v1::ReacquireResponse* response) override;
  grpc::ServerUnaryReactor* FitBody(grpc::CallbackServerContext* context,
                                    const v1::FitBodyRequest* request,
                                    v1::FitBodyResponse* response) override;

 private:
  // OK if no token is configured or the call carries "authorization: Bearer <token>".
  grpc::Status authorize(const grpc::CallbackServerContext* context) const;
  static grpc::ServerUnaryReactor* finish(grpc::CallbackServerContext* context,
                                          const grpc::Status& status);

  const ServerConfig& config_;
  const BodyModel& model_;  // as configured (a fitted body applied since has its joint names)
  Pipeline& pipeline_;
  PosePublisher& publisher_;
  const int64_t started_ns_;
};

}  // namespace mocap
