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
#include "server/vmc_sender.h"
#include "server/web_view.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/motion/motion.h"

namespace mocap {

class MocapServer {
 public:
  // Loads the model and calibration, opens the cameras and binds the listening address; nothing
  // runs yet. The error names the file, camera or address at fault.
  static Expected<std::unique_ptr<MocapServer>> create(const ServerConfig& config);
  ~MocapServer();
  MocapServer(const MocapServer&) = delete;
  MocapServer& operator=(const MocapServer&) = delete;

  // Starts the cameras, the pipeline and the web view (a web view that cannot listen is a
  // warning: the capture goes on without it).
  Status start();
  // Marks the service NOT_SERVING, stops the cameras and the pipeline, closes the recording,
  // ends every pose stream with OK and stops the gRPC server. Idempotent.
  void shutdown();

  int port() const { return port_; }  // the bound port (useful with "host:0")
  // The web view's bound port; 0 when it is off or could not listen.
  int webPort() const { return web_ ? web_->port() : 0; }
  // The web view; null when it is off. For tests.
  WebView* webView() { return web_.get(); }
  const BodyModel& model() const { return *model_; }
  Pipeline& pipeline() { return *pipeline_; }

 private:
  explicit MocapServer(const ServerConfig& config) : config_(config) {}

  // The steps of create(), in order; each error names the file, camera or address at fault.
  // The configured body and calibration, either of which may stay unset until the source gives it.
  Status loadBodyAndCalibration();
  // scene_motion: the subject moving as the recorded person did; sets subject_body_ when the
  // tracker tracks another body.
  Status loadSceneMotion();
  Status openReplay(PipelineInputs& inputs);
  Status openFakeScene(PipelineInputs& inputs);
  Status openCameras(PipelineInputs& inputs);
  // tracker.dofs and tracker.start.
  Status prepareTracking(PipelineInputs& inputs);
  Status listen();
  // Serves the web view, if configured; a failure to listen is logged, not fatal.
  void startWebView();
  // Sends the poses over VMC, if configured; a failure is logged, not fatal.
  void startVmcSender();
  // A model's speed limits are per frame at its frame_rate; the tracker's frames come at the
  // cameras' rate (the recorded rate in a replay), so the body is tracked rescaled to it.
  void trackAtCameraRate(double fps);

  ServerConfig config_;  // as given, but a replay's tracker settings come from the session
  std::unique_ptr<BodyModel> model_;
  std::unique_ptr<Rig> rig_;
  // The fake scene's motion (scene_motion), and its subject's body when not the tracked one.
  std::shared_ptr<const Motion> scene_motion_;
  std::shared_ptr<const BodyModel> subject_body_;
  PosePublisher publisher_;
  std::unique_ptr<Pipeline> pipeline_;
  std::unique_ptr<MocapServiceImpl> service_;
  std::unique_ptr<grpc::Server> server_;
  std::unique_ptr<WebView> web_;    // null when web.enabled is false
  std::unique_ptr<VmcSender> vmc_;  // null without vmc.send_to
  int port_ = 0;
  bool shut_down_ = false;
};

// Every camera every compiled-in driver sees, one line each, for `mocapd --list-cameras`.
std::string describeAvailableCameras();

}  // namespace mocap
