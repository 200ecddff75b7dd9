// Assembling and tearing down the daemon.
#include "server/mocap_server.h"

#include <chrono>
#include <fstream>
#include <sstream>

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include "drivers/fake/fake_driver.h"
#include "server/log.h"
#include "tracker/search/acquire.h"
#include "tracker/model/builtin_models.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/retarget.h"

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

// The fake driver as the daemon configures it: the scene built from the camera list, and the
// configured model and calibration if any (the scene's defaults otherwise).
FakeDriverOptions fakeDriverOptions(const ServerConfig& config, const BodyModel* model,
                                    const Rig* rig, std::shared_ptr<const Motion> motion) {
  FakeDriverOptions options;
  const CameraConfig& first = config.cameras.front();
  options.scene.cameras = static_cast<int>(config.cameras.size());
  options.scene.width = first.width;
  options.scene.height = first.height;
  options.scene.fps = first.fps;
  options.scene.gray = first.pixel_format == "GREY";
  options.scene.seed = config.tracker.seed;
  if (model) options.scene.model = std::make_shared<const BodyModel>(*model);
  if (rig) options.scene.rig = *rig;
  options.scene.motion = std::move(motion);
  options.scene.empty_frames =
      static_cast<uint64_t>(std::llround(config.scene_empty_seconds * first.fps));
  options.scene.fit_pose_frames =
      static_cast<uint64_t>(std::llround(config.scene_fit_pose_seconds * first.fps));
  return options;
}

}  // namespace

Expected<std::unique_ptr<MocapServer>> MocapServer::create(const ServerConfig& config) {
  std::unique_ptr<MocapServer> server(new MocapServer(config));
  PipelineInputs inputs;
  // A model's speed limits are per frame at its frame_rate; the tracker's frames come at the
  // cameras' rate (the recorded rate in a replay), so the body is tracked rescaled to it.
  const auto atCameraRate = [&server](double fps) {
    if (server->model_) *server->model_ = atFrameRate(*server->model_, fps);
  };
  try {
    if (config.body_model == "builtin:hand") {
      server->model_ = std::make_unique<BodyModel>(builtinHandModel());
    } else if (config.body_model == "builtin:human") {
      server->model_ = std::make_unique<BodyModel>(builtinHumanModel());
    } else if (config.body_model_file) {
      server->model_ = std::make_unique<BodyModel>(*config.body_model_file);
    } else if (!config.body_model.empty()) {
      server->model_ = std::make_unique<BodyModel>(loadBodyModel(config.body_model));
    }
    if (!config.calibration_file.empty())
      server->rig_ = std::make_unique<Rig>(loadRig(config.calibration_file));
    if (!config.replay() && !config.cameras.empty()) atCameraRate(config.cameras.front().fps);
  } catch (const std::exception& e) {
    return Status::Error(e.what());
  }
  std::shared_ptr<const Motion> scene_motion;
  // The scene's subject, when the tracker tracks another body (track_subject_body: false).
  std::shared_ptr<const BodyModel> subject_body;
  if (!config.scene_motion.empty()) {
    // The body fitted to the recorded subject, so the scene shows that person's proportions
    // (docs/human.md); the tracker tracks it too, unless told to track the configured body as it
    // would a real person, whose body nobody fitted beforehand.
    try {
      const Bvh bvh = loadBvh(config.scene_motion);
      const double fps = config.cameras.front().fps;
      if (!server->model_)
        server->model_ = std::make_unique<BodyModel>(atFrameRate(builtinHumanModel(), fps));
      auto fitted = std::make_unique<BodyModel>(fitModelToBvh(*server->model_, bvh.skeleton));
      scene_motion = std::make_shared<const Motion>(
          retargetBvh(*fitted, bvh.skeleton, bvh.motion, fps).motion);
      if (config.track_subject_body)
        server->model_ = std::move(fitted);
      else
        subject_body = std::move(fitted);
    } catch (const std::exception& e) {
      return Status::Error(config.source + ": scene_motion: " + e.what());
    }
  }

  if (config.replay()) {
    Expected<std::unique_ptr<SessionReader>> reader = SessionReader::open(config.replay_directory);
    if (!reader.ok()) return Status::Error("replay: " + reader.error());
    std::shared_ptr<const SessionReader> session = std::move(reader.value());
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
    if (!server->rig_) {
      if (session->rig().empty())
        return Status::Error(
            "replay: the session has no calibration and the configuration "
            "names no calibration file");
      server->rig_ = std::make_unique<Rig>(session->rig());
    }
    // The body the session was tracked with, unless the configuration names one; sessions that
    // store none were recorded before bodies were stored, when the daemon tracked the hand.
    if (!server->model_) {
      if (session->bodyModel()) {
        server->model_ = std::make_unique<BodyModel>(*session->bodyModel());
      } else {
        logWarning() << "replay: the session stores no body model and the configuration names "
                        "none; tracking the built-in hand";
        server->model_ = std::make_unique<BodyModel>(builtinHandModel());
      }
    }
    if (!inputs.cameras.empty()) atCameraRate(inputs.cameras.front().config.fps);
    // Tracked as it was live: the session's tracker settings, under the keys the configuration
    // sets itself. Sessions that store none take the configuration's.
    if (!session->trackerSettings().empty()) {
      try {
        server->config_.tracker = replayTrackerSettings(config, session->trackerSettings(),
                                                        (session->path() / kManifestFile).string());
      } catch (const ConfigError& e) {
        return Status::Error(std::string("replay: ") + e.what());
      }
    }
    // The truth's joints on the body it is of (the scene's subject tracked with another body, or
    // the session's when the configuration names another to track).
    const BodyModel* truth_body = session->truthBodyModel();
    if (truth_body && truth_body->dofs.size() == server->model_->dofs.size())
      inputs.reference_model = std::make_shared<const BodyModel>(*truth_body);
    inputs.replay = std::move(session);
  } else {
    bool any_fake = false, all_fake = true;
    for (const CameraConfig& camera : config.cameras) {
      any_fake = any_fake || isFakeScene(camera);
      all_fake = all_fake && isFakeScene(camera);
    }
    if (any_fake && !all_fake)
      return Status::Error(config.source +
                           ": cameras: the fake scene cannot be mixed with real cameras");
    if (any_fake) {
      FakeDriver driver(fakeDriverOptions(config,
                                          subject_body ? subject_body.get() : server->model_.get(),
                                          server->rig_.get(), scene_motion));
      Expected<std::shared_ptr<FakeScene>> scene = driver.scene();
      if (!scene.ok()) return Status::Error("fake scene: " + scene.error());
      std::shared_ptr<FakeScene> shared = scene.value();
      if (!server->model_) {
        server->model_ = std::make_unique<BodyModel>(shared->model());
        atCameraRate(config.cameras.front().fps);
      }
      if (!server->rig_) server->rig_ = std::make_unique<Rig>(shared->rig());
      for (const CameraConfig& camera_config : config.cameras) {
        Expected<std::unique_ptr<Camera>> opened = driver.open(camera_config);
        if (!opened.ok()) {
          return Status::Error("cameras[" + std::to_string(camera_config.index) + "] (fake " +
                               camera_config.device + "): " + opened.error());
        }
        OpenedCamera camera;
        camera.config = camera_config;
        camera.camera = std::move(opened.value());
        camera.info = camera.camera->info();
        inputs.cameras.push_back(std::move(camera));
      }
      // The demo measures tracking: the tracker sees the scene's true silhouettes unless the
      // configuration asks for them to be extracted from the rendered images.
      if (config.true_silhouettes) {
        inputs.ground_truth = [shared](uint64_t sequence) {
          return shared->groundTruth(sequence).silhouettes;
        };
        for (std::size_t c = 0; c < inputs.cameras.size(); ++c) {
          auto empty = std::make_shared<BackgroundModel>();
          shared->background(static_cast<int>(c)).convertTo(empty->mean, CV_32F);
          empty->stddev = cv::Mat(empty->mean.size(), empty->mean.type(),
                                  cv::Scalar::all(shared->options().noise_sigma));
          inputs.scene_backgrounds.push_back(std::move(empty));
        }
      }
      inputs.reference_pose = [shared](uint64_t sequence) { return shared->truePose(sequence); };
      inputs.reference_model = subject_body;
      // The subject's first pose in view, as a real session would give it by a start-up pose.
      inputs.initial_pose = shared->truePose(shared->options().empty_frames);
    } else {
      if (!server->model_)
        return Status::Error(config.source + ": body_model: required with real cameras");
      if (!server->rig_)
        return Status::Error(config.source + ": calibration: required with real cameras");
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
        OpenedCamera camera;
        camera.config = camera_config;
        camera.camera = std::move(opened.value());
        camera.info = camera.camera->info();
        inputs.cameras.push_back(std::move(camera));
      }
    }
  }

  // tracker.dofs: gait tracks the body's gait DOFs; the others hold the starting pose (the fake
  // scene's first true pose, or the neutral pose).
  if (server->config_.tracker.dofs == "gait") {
    BodyModel& model = *server->model_;
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
  const std::string& start = server->config_.tracker.start;
  const bool placeable = canAcquire(*server->model_);
  if (start == "acquire" && !placeable)
    return Status::Error(config.source + ": tracker.start: acquire, but " +
                         whyCannotAcquire(*server->model_));
  if (start == "neutral") inputs.initial_pose = Eigen::VectorXd();
  inputs.acquire =
      start == "acquire" || (start == "auto" && inputs.initial_pose.size() == 0 && placeable);

  try {
    server->pipeline_ = std::make_unique<Pipeline>(server->config_, *server->model_, *server->rig_,
                                                   std::move(inputs), server->publisher_);
  } catch (const std::exception& e) {
    return Status::Error(e.what());
  }
  server->service_ = std::make_unique<MocapServiceImpl>(server->config_, *server->model_,
                                                        *server->pipeline_, server->publisher_);

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
  builder.AddListeningPort(config.listen, credentials, &server->port_);
  builder.RegisterService(server->service_.get());
  server->server_ = builder.BuildAndStart();
  if (!server->server_ || server->port_ == 0)
    return Status::Error("cannot listen on " + config.listen + " (address in use or invalid)");
  return server;
}

MocapServer::~MocapServer() { shutdown(); }

Status MocapServer::start() {
  const Status started = pipeline_->start();
  if (!started.ok()) return started;
  const std::string host = config_.listen.substr(0, config_.listen.rfind(':'));
  logInfo() << "serving " << model_->name << " tracking (" << config_.tracker.method << ", "
            << config_.tracker.evaluations << " evaluations/frame) from "
            << pipeline_->cameras().size() << " camera(s)"
            << (config_.replay() ? " replayed from " + config_.replay_directory : "") << " on "
            << host << ":" << port_
            << (config_.tls_cert_file.empty()        ? ""
                : config_.tls_client_ca_file.empty() ? " with TLS"
                                                     : " with TLS and client certificates")
            << (config_.bearer_token.empty() ? "" : ", bearer token required");
  return Status::Ok();
}

void MocapServer::shutdown() {
  if (shut_down_) return;
  shut_down_ = true;
  if (server_) server_->GetHealthCheckService()->Shutdown();
  if (pipeline_) pipeline_->stop();
  publisher_.close();
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
