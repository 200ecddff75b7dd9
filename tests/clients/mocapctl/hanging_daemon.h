// A gRPC server on loopback that takes every mocapd request and answers none until the client has
// given up, as a daemon whose pipeline hangs would: what mocapctl's deadlines are tested against.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include <grpcpp/grpcpp.h>

#include "mocap/v1/mocap.grpc.pb.h"

namespace mocapctl::test {

class HangingDaemon final : public mocap::v1::MocapService::Service {
 public:
  // Listens on 127.0.0.1, on a port of the system's choosing.
  HangingDaemon() {
    grpc::ServerBuilder builder;
    builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port_);
    builder.RegisterService(this);
    server_ = builder.BuildAndStart();
  }
  ~HangingDaemon() override {
    // Cancels what still waits, so each handler returns.
    server_->Shutdown(std::chrono::system_clock::now());
  }

  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }

  // Each unary request of the service: answered only once the client has gone.
  grpc::Status GetStatus(grpc::ServerContext* context, const mocap::v1::GetStatusRequest*,
                         mocap::v1::Status*) override {
    return hang(context);
  }
  grpc::Status GetSkeleton(grpc::ServerContext* context, const mocap::v1::GetSkeletonRequest*,
                           mocap::v1::Skeleton*) override {
    return hang(context);
  }
  grpc::Status ListCameras(grpc::ServerContext* context, const mocap::v1::ListCamerasRequest*,
                           mocap::v1::ListCamerasResponse*) override {
    return hang(context);
  }
  grpc::Status StartRecording(grpc::ServerContext* context, const mocap::v1::StartRecordingRequest*,
                              mocap::v1::RecordingState*) override {
    return hang(context);
  }
  grpc::Status StopRecording(grpc::ServerContext* context, const mocap::v1::StopRecordingRequest*,
                             mocap::v1::RecordingState*) override {
    return hang(context);
  }
  grpc::Status CaptureBackground(grpc::ServerContext* context,
                                 const mocap::v1::CaptureBackgroundRequest*,
                                 mocap::v1::CaptureBackgroundResponse*) override {
    return hang(context);
  }
  grpc::Status Reacquire(grpc::ServerContext* context, const mocap::v1::ReacquireRequest*,
                         mocap::v1::ReacquireResponse*) override {
    return hang(context);
  }
  grpc::Status FitBody(grpc::ServerContext* context, const mocap::v1::FitBodyRequest*,
                       mocap::v1::FitBodyResponse*) override {
    return hang(context);
  }

 private:
  // The synchronous API tells a handler of the client's cancel only when asked.
  static grpc::Status hang(grpc::ServerContext* context) {
    while (!context->IsCancelled()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return grpc::Status::OK;  // too late: nobody is waiting for it
  }

  int port_ = 0;
  std::unique_ptr<grpc::Server> server_;
};

}  // namespace mocapctl::test
