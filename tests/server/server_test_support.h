// Shared by the server tests: a daemon configuration on the fake scene, a loopback client, a
// background capture request, a body fit request, and a pose reader that counts what it receives.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include <grpcpp/grpcpp.h>

#include "mocap/v1/mocap.grpc.pb.h"
#include "server/config.h"

namespace mocap::test {

// The embedded default (fake scene, 2 cameras, 780x580, 25 Hz) on a port the OS picks.
inline ServerConfig sceneConfig() {
  ServerConfig config = parseConfig(kDefaultConfigYaml, "<embedded default>", ".");
  config.listen = "127.0.0.1:0";
  config.log_level = LogLevel::kWarning;
  return config;
}

inline std::unique_ptr<v1::MocapService::Stub> connect(int port) {
  return v1::MocapService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port),
                                                       grpc::InsecureChannelCredentials()));
}

// Asks the daemon to learn the background from `frames` frames, waiting at most `deadline`.
inline grpc::Status captureBackground(v1::MocapService::Stub& stub, uint32_t frames,
                                      v1::CaptureBackgroundResponse& response,
                                      std::chrono::seconds deadline = std::chrono::seconds(30)) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + deadline);
  v1::CaptureBackgroundRequest request;
  request.set_frames(frames);
  return stub.CaptureBackground(&context, request, &response);
}

// Asks the daemon to fit the body from `frame_sets` frame sets (and to track with it, with
// `apply`), waiting at most `deadline`.
inline grpc::Status fitBody(v1::MocapService::Stub& stub, int frame_sets,
                            v1::FitBodyResponse& response, bool apply = false,
                            std::chrono::seconds deadline = std::chrono::seconds(60)) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + deadline);
  v1::FitBodyRequest request;
  request.set_frame_sets(frame_sets);
  request.set_apply(apply);
  return stub.FitBody(&context, request, &response);
}

// Reads a pose stream on its own thread, counting poses and the frame-set sequences they span.
class PoseCounter {
 public:
  PoseCounter(v1::MocapService::Stub& stub, const std::string& token = "") {
    if (!token.empty()) context_.AddMetadata("authorization", "Bearer " + token);
    reader_ = stub.StreamPoses(&context_, v1::StreamPosesRequest());
    thread_ = std::thread([this] {
      v1::Pose pose;
      while (reader_->Read(&pose)) {
        if (counting_) {
          if (received_ == 0) first_ = pose.frame_sequence();
          last_ = pose.frame_sequence();
          ++received_;
        }
      }
      status_ = reader_->Finish();
    });
  }
  ~PoseCounter() {
    context_.TryCancel();
    thread_.join();
  }
  void startCounting() { counting_ = true; }
  void stopCounting() { counting_ = false; }
  uint64_t received() const { return received_; }
  // Frame sets from the first to the last counted pose: what a perfect subscriber would get.
  uint64_t spanned() const { return received_ == 0 ? 0 : last_ - first_ + 1; }
  // Waits for the stream to end (daemon shutdown) and returns its status.
  grpc::Status finish() {
    thread_.join();
    thread_ = std::thread([] {});
    return status_;
  }

 private:
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReader<v1::Pose>> reader_;
  std::thread thread_;
  std::atomic<bool> counting_{false};
  std::atomic<uint64_t> received_{0};
  std::atomic<uint64_t> first_{0};
  std::atomic<uint64_t> last_{0};
  grpc::Status status_;
};

}  // namespace mocap::test
