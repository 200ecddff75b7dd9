// Assembling and tearing down the daemon.
#include "server/mocap_server.h"

#include <chrono>
#include <fstream>
#include <sstream>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "drivers/camera_driver.h"
#include "drivers/fake/scene_setup.h"
#include "server/log.h"
#include "tracker/model/builtin_models.h"
#include "tracker/search/acquire.h"

namespace mocap {
namespace {

// How long shutdown lets the pose streams deliver their last pose before cancelling them.
constexpr auto kShutdownGrace = std::chrono::seconds(2);

Expected<std::string> readFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Status::Error(path + ": cannot read");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

bool isFakeScene(const CameraConfig& camera) { return camera.driver == "fake"; }

OpenedCamera openedCamera(const CameraConfig& config, std::unique_ptr<Camera> camera) {
  OpenedCamera opened;
  opened.config = config;
  opened.camera = std::move(camera);
  opened.info = opened.camera->info();
  return opened;
}

}  // namespace

Expected<std::unique_ptr<MocapServer>> MocapServer::create(const ServerConfig& config) {
  std::unique_ptr<MocapServer> server(new MocapServer(config));
  PipelineInputs inputs;
  Status step = server->loadBodyAndCalibration();
  if (step.ok()) step = server->loadSceneMotion();
  if (step.ok()) step = config.replay() ? server->openReplay(inputs) : server->openCameras(inputs);
  if (step.ok()) step = server->prepareTracking(inputs);
  if (!step.ok()) return step;
  try {
    server->pipeline_ = std::make_unique<Pipeline>(server->config_, *server->model_, *server->rig_,
                                                   std::move(inputs), server->publisher_);
  } catch (const std::exception& e) {
    return Status::Error(e.what());
  }
  server->service_ = std::make_unique<MocapServiceImpl>(server->config_, *server->model_,
                                                        *server->pipeline_, server->publisher_);
  step = server->listen();
  if (!step.ok()) return step;
  if (server->config_.web.enabled) {
    server->web_ = std::make_unique<WebView>(server->config_, *server->pipeline_, *server->rig_,
                                             server->publisher_);
    server->pipeline_->setMaskObserver(server->web_->maskObserver());
  }
  return server;
}

void MocapServer::trackAtCameraRate(double fps) {
  if (model_) *model_ = atFrameRate(*model_, fps);
}

Status MocapServer::loadBodyAndCalibration() {
  const ServerConfig& config = config_;
  try {
    if (config.body_model == "builtin:hand") {
      model_ = std::make_unique<BodyModel>(builtinHandModel());
    } else if (config.body_model == "builtin:human") {
      model_ = std::make_unique<BodyModel>(builtinHumanModel());
    } else if (config.body_model_file) {
      model_ = std::make_unique<BodyModel>(*config.body_model_file);
    } else if (!config.body_model.empty()) {
      model_ = std::make_unique<BodyModel>(loadBodyModel(config.body_model));
    }
    if (!config.calibration_file.empty())
      rig_ = std::make_unique<Rig>(loadRig(config.calibration_file));
    if (!config.replay() && !config.cameras.empty()) trackAtCameraRate(config.cameras.front().fps);
  } catch (const std::exception& e) {
    return Status::Error(e.what());
  }
  return Status::Ok();
}

Status MocapServer::loadSceneMotion() {
  if (config_.scene_motion.empty()) return Status::Ok();
  // The body fitted to the recorded subject, so the scene shows that person's proportions
  // (docs/human.md); the tracker tracks it too, unless told to track the configured body as it
  // would a real person, whose body nobody fitted beforehand.
  try {
    const double fps = config_.cameras.front().fps;
    if (!model_) model_ = std::make_unique<BodyModel>(atFrameRate(builtinHumanModel(), fps));
    SceneSubject subject =
        loadSceneSubject(config_.scene_motion, *model_, fps, config_.scene_motion_load);
    scene_motion_ = std::move(subject.motion);
    if (config_.track_subject_body)
      model_ = std::make_unique<BodyModel>(*subject.body);
    else
      subject_body_ = std::move(subject.body);
  } catch (const std::exception& e) {
    return Status::Error(config_.source + ": scene_motion: " + e.what());
  }
  return Status::Ok();
}

Status MocapServer::openReplay(PipelineInputs& inputs) {
  const ServerConfig& config = config_;
  Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(config.replay_directory);
  if (!reader.ok()) return Status::Error("replay: " + reader.error());
  std::shared_ptr<const SessionReader> session = std::move(reader.value());
  if (config.recorded_silhouettes && session->manifest().format_version < 2)
    return Status::Error("replay: --recorded-silhouettes: " + config.replay_directory +
                         " stores no silhouettes (a format 1 session, recorded before they were)");
  for (std::size_t c = 0; c < session->cameras().size(); ++c) {
    const SessionCamera& recorded = session->cameras()[c];
    OpenedCamera camera;
    camera.config.index = static_cast<int>(c);
    camera.config.driver = "replay";
    camera.config.device = config.replay_directory;
    camera.config.width = recorded.width;
    camera.config.height = recorded.height;
    camera.config.fps = recorded.fps > 0 ? recorded.fps : 25.0;
    camera.config.pixel_format = recorded.pixel_format;
    camera.info = {"replay",
                   recorded.name,
                   "recorded session camera",
                   {{recorded.width, recorded.height, recorded.fps, recorded.pixel_format}}};
    inputs.cameras.push_back(std::move(camera));
  }
  if (!rig_) {
    if (session->rig().empty())
      return Status::Error(
          "replay: the session has no calibration and the configuration "
          "names no calibration file");
    rig_ = std::make_unique<Rig>(session->rig());
  }
  // The body the session was tracked with, unless the configuration names one; sessions that
  // store none were recorded before bodies were stored, when the daemon tracked the hand.
  if (!model_) {
    if (session->bodyModel()) {
      model_ = std::make_unique<BodyModel>(*session->bodyModel());
    } else {
      logWarning() << "replay: the session stores no body model and the configuration names "
                      "none; tracking the built-in hand";
      model_ = std::make_unique<BodyModel>(builtinHandModel());
    }
  }
  if (!inputs.cameras.empty()) trackAtCameraRate(inputs.cameras.front().config.fps);
  // Tracked as it was live: the session's tracker settings, under the keys the configuration
  // sets itself. Sessions that store none take the configuration's.
  if (!session->trackerSettings().empty()) {
    try {
      config_.tracker = replayTrackerSettings(config, session->trackerSettings(),
                                              (session->path() / kManifestFile).string());
    } catch (const ConfigError& e) {
      return Status::Error(std::string("replay: ") + e.what());
    }
  }
  // The truth's joints on the body it is of (the scene's subject tracked with another body, or
  // the session's when the configuration names another to track).
  const BodyModel* truth_body = session->truthBodyModel();
  if (truth_body && truth_body->dofs.size() == model_->dofs.size())
    inputs.reference_model = std::make_shared<const BodyModel>(*truth_body);
  inputs.replay = std::move(session);
  return Status::Ok();
}

Status MocapServer::openCameras(PipelineInputs& inputs) {
  const ServerConfig& config = config_;
  bool any_fake = false, all_fake = true;
  for (const CameraConfig& camera : config.cameras) {
    any_fake = any_fake || isFakeScene(camera);
    all_fake = all_fake && isFakeScene(camera);
  }
  if (any_fake && !all_fake)
    return Status::Error(config.source +
                         ": cameras: the fake scene cannot be mixed with real cameras");
  if (any_fake) return openFakeScene(inputs);
  if (!model_) return Status::Error(config.source + ": body_model: required with real cameras");
  if (!rig_) return Status::Error(config.source + ": calibration: required with real cameras");
  for (const CameraConfig& camera_config : config.cameras) {
    std::unique_ptr<Driver> driver = DriverRegistry::instance().create(camera_config.driver);
    if (!driver)
      return Status::Error("cameras[" + std::to_string(camera_config.index) + "]: no driver '" +
                           camera_config.driver + "'");
    Expected<std::unique_ptr<Camera>> opened = driver->open(camera_config);
    if (!opened.ok()) {
      return Status::Error("cameras[" + std::to_string(camera_config.index) + "] (" +
                           camera_config.driver + " " + camera_config.device +
                           "): " + opened.error());
    }
    inputs.cameras.push_back(openedCamera(camera_config, std::move(opened.value())));
  }
  return Status::Ok();
}

Status MocapServer::openFakeScene(PipelineInputs& inputs) {
  const ServerConfig& config = config_;
  FakeSceneSetupOptions options;
  options.cameras = config.cameras;
  options.seed = config.tracker.filter.seed;
  options.empty_seconds = config.scene_empty_seconds;
  options.slow_motion = config.scene_slow_motion;
  options.fit_pose_seconds = config.scene_fit_pose_seconds;
  options.subject = subject_body_ ? subject_body_.get() : model_.get();
  options.rig = rig_.get();
  options.motion = scene_motion_;
  options.subject_seed = config.scene_subject_seed;
  Expected<FakeSceneSetup> setup = setUpFakeScene(options);
  if (!setup.ok()) return Status::Error(setup.error());
  std::shared_ptr<FakeScene> scene = setup.value().scene;
  if (!model_) {
    model_ = std::make_unique<BodyModel>(scene->model());
    trackAtCameraRate(config.cameras.front().fps);
  }
  if (!rig_) rig_ = std::make_unique<Rig>(scene->rig());
  // The demo measures tracking: the tracker sees the scene's true silhouettes unless the
  // configuration asks for them to be extracted from the rendered images.
  if (config.true_silhouettes) {
    inputs.ground_truth = [scene](uint64_t sequence) {
      return scene->groundTruth(sequence).silhouettes;
    };
    inputs.scene_backgrounds = setup.value().emptyBackgrounds();
  }
  for (std::size_t c = 0; c < config.cameras.size(); ++c)
    inputs.cameras.push_back(openedCamera(config.cameras[c], std::move(setup.value().cameras[c])));
  inputs.reference_pose = [scene](uint64_t sequence) { return scene->truePose(sequence); };
  // Scored against the joints of whom the cameras see: the scene's body, or its simulated person
  // (carried as the scene's DOFs on a body with that person's bones, so recordings keep it too).
  inputs.reference_model = scene->subject() ? scene->truthBody() : subject_body_;
  // The subject's first pose in view, as a real session would give it by a start-up pose.
  inputs.initial_pose = scene->truePose(scene->options().empty_frames);
  return Status::Ok();
}

Status MocapServer::prepareTracking(PipelineInputs& inputs) {
  const ServerConfig& config = config_;
  // tracker.dofs: gait tracks the body's gait DOFs; the others hold the starting pose (the fake
  // scene's first true pose, or the neutral pose).
  if (config_.tracker.dofs == "gait") {
    BodyModel& model = *model_;
    inputs.fit_model = std::make_shared<const BodyModel>(model);  // FitBody fits every DOF
    if (model.gait_dofs.empty())
      return Status::Error(config.source + ": tracker.dofs: gait, but the body model '" +
                           model.name + "' names no gait_dofs");
    const Eigen::VectorXd hold = inputs.initial_pose.size() == static_cast<long>(model.dofs.size())
                                     ? inputs.initial_pose
                                     : model.neutralPose();
    model = freezeAllBut(model, model.gait_dofs, hold);
  }
  // tracker.start (config.h): the scene's true first pose, the subject found in the silhouettes,
  // or the neutral pose.
  const std::string& start = config_.tracker.start;
  const bool placeable = canAcquire(*model_);
  if (start == "acquire" && !placeable)
    return Status::Error(config.source + ": tracker.start: acquire, but " +
                         whyCannotAcquire(*model_));
  if (start == "neutral") inputs.initial_pose = Eigen::VectorXd();
  inputs.acquire =
      start == "acquire" || (start == "auto" && inputs.initial_pose.size() == 0 && placeable);
  return Status::Ok();
}

Status MocapServer::listen() {
  const ServerConfig& config = config_;
  std::shared_ptr<grpc::ServerCredentials> credentials = grpc::InsecureServerCredentials();
  if (!config.tls_cert_file.empty()) {
    Expected<std::string> cert = readFile(config.tls_cert_file);
    Expected<std::string> key = readFile(config.tls_key_file);
    if (!cert.ok()) return Status::Error(cert.error());
    if (!key.ok()) return Status::Error(key.error());
    grpc::SslServerCredentialsOptions tls;
    tls.pem_key_cert_pairs.push_back({key.value(), cert.value()});
    if (!config.tls_client_ca_file.empty()) {
      Expected<std::string> client_ca = readFile(config.tls_client_ca_file);
      if (!client_ca.ok()) return Status::Error(client_ca.error());
      // A client without a certificate one of these authorities signed is refused in the handshake.
      tls.pem_root_certs = client_ca.value();
      tls.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
    }
    credentials = grpc::SslServerCredentials(tls);
  }
  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  // gRPC binds with SO_REUSEPORT by default: a second daemon on the same port would start without
  // an error and take half the clients' connections.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(config.listen, credentials, &port_);
  builder.RegisterService(service_.get());
  server_ = builder.BuildAndStart();
  if (!server_ || port_ == 0)
    return Status::Error("cannot listen on " + config.listen + " (address in use or invalid)");
  return Status::Ok();
}

MocapServer::~MocapServer() { shutdown(); }

Status MocapServer::start() {
  startVmcSender();  // before the first pose
  const Status started = pipeline_->start();
  if (!started.ok()) return started;
  const std::string host = config_.listen.substr(0, config_.listen.rfind(':'));
  logInfo() << "serving " << model_->name << " tracking (" << config_.tracker.method << ", "
            << config_.tracker.filter.evaluations_per_frame << " evaluations/frame) from "
            << pipeline_->cameras().size() << " camera(s)"
            << (config_.replay() ? " replayed from " + config_.replay_directory : "") << " on "
            << host << ":" << port_
            << (config_.tls_cert_file.empty()        ? ""
                : config_.tls_client_ca_file.empty() ? " with TLS"
                                                     : " with TLS and client certificates")
            << (config_.bearer_token.empty() ? "" : ", bearer token required");
  startWebView();
  return Status::Ok();
}

void MocapServer::startWebView() {
  if (!web_) return;
  const Status listening = web_->start();
  if (!listening.ok()) {
    // Kept, not destroyed: the pipeline's mask observer refers to it.
    logWarning() << listening.message() << "; running without the web view";
    return;
  }
  const std::string& listen = config_.web.listen;
  logInfo() << "web view at http://" << listen.substr(0, listen.rfind(':')) << ":" << web_->port()
            << "/";
}

void MocapServer::startVmcSender() {
  if (config_.vmc.send_to.empty()) return;
  if (makeVmcRig(*model_).empty()) {
    logWarning() << "vmc: the body '" << model_->name
                 << "' has no human segments to drive a humanoid with; nothing is sent";
    return;
  }
  vmc_ = std::make_unique<VmcSender>(
      config_.vmc.send_to, [this] { return pipeline_->trackedBody().model; },
      [](const std::string& message) { logWarning() << message; });
  const Status started = vmc_->start();
  if (!started.ok()) {
    logWarning() << started.message() << "; running without VMC";
    vmc_.reset();
    return;
  }
  publisher_.subscribe(vmc_.get());
  std::string receivers;
  for (const VmcTarget& target : config_.vmc.send_to)
    receivers += (receivers.empty() ? "" : ", ") + target.text();
  logInfo() << "sending the poses over VMC to " << receivers;
}

void MocapServer::shutdown() {
  if (shut_down_) return;
  shut_down_ = true;
  if (server_) server_->GetHealthCheckService()->Shutdown();
  if (pipeline_) pipeline_->stop();
  publisher_.close();
  if (web_) web_->stop();
  if (vmc_) vmc_->stop();
  if (server_) server_->Shutdown(std::chrono::system_clock::now() + kShutdownGrace);
  logInfo() << "stopped";
}

std::string describeAvailableCameras() {
  std::ostringstream out;
  for (const std::string& name : DriverRegistry::instance().names()) {
    std::unique_ptr<Driver> driver = DriverRegistry::instance().create(name);
    const std::vector<CameraInfo> cameras = driver->enumerate();
    if (cameras.empty()) out << name << ": no cameras\n";
    for (const CameraInfo& camera : cameras) {
      out << camera.driver << "  " << camera.id << "  " << camera.model << "\n";
      for (const VideoMode& mode : camera.modes) {
        out << "    " << mode.width << "x" << mode.height << " " << mode.pixel_format;
        if (mode.fps > 0) out << " @ " << mode.fps << " fps";
        out << "\n";
      }
    }
  }
  return out.str();
}

}  // namespace mocap
