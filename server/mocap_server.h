// The daemon as an object: opens the cameras, builds the pipeline and the gRPC server (with
// health checking and reflection), and shuts it all down in order. mocapd's main and the
// end-to-end tests both use it.
#pragma once

#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>

#include "drivers/status.h"
#include "server/config.h"
#include "server/mocap_service.h"
#include "server/pipeline.h"
#include "server/pose_publisher.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"

namespace mocap {

class MocapServer {
 public:
  // Loads the model and calibration, opens the cameras and binds the listening address; nothing
  // runs yet. The error names the file, camera or address at fault.
  static Expected<std::unique_ptr<MocapServer>> create(const ServerConfig& config);
  ~MocapServer();
  MocapServer(const MocapServer&) = delete;
  MocapServer& operator=(const MocapServer&) = delete;

  // Starts the cameras and the pipeline.
  Status start();
  // Marks the service NOT_SERVING, stops the cameras and the pipeline, closes the recording,
  // ends every pose stream with OK and stops the gRPC server. Idempotent.
  void shutdown();

  int port() const { return port_; }  // the bound port (useful with "host:0")
  const BodyModel& model() const { return *model_; }
  Pipeline& pipeline() { return *pipeline_; }

 private:
  explicit MocapServer(const ServerConfig& config) : config_(config) {}

  ServerConfig config_;  // as given, but a replay's tracker settings come from the session
  std::unique_ptr<BodyModel> model_;
  std::unique_ptr<Rig> rig_;
  PosePublisher publisher_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<MocapServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_ = 0;
  bool shut_down_ = false;
};

// Every camera every compiled-in driver sees, one line each, for `mocapd --list-cameras`.
std::string describeAvailableCameras();

}  // namespace mocap
