// The MocapService RPCs.
#include "server/mocap_service.h"

#include <ctime>

#include "server/log.h"
#include "server/pose_stream.h"
#include "server/proto_conversion.h"
#include "server/stats.h"
#include "tracker/search/acquire.h"

namespace mocap {
namespace {

// Compares without an early exit, so the time taken does not tell how much of a guess matched.
bool sameSecret(const std::string& a, const std::string& b) {
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < a.size(); ++i)
    difference |= static_cast<unsigned char>(a[i] ^ (i < b.size() ? b[i] : 0));
  return difference == 0;
}

std::string sessionNameNow() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char name[32];
  std::strftime(name, sizeof name, "%Y%m%dT%H%M%SZ", &utc);
  return name;
}

grpc::Status recordingStatus(const RecordingResult& result) {
  switch (result.error) {
    case RecordingError::kNone: return grpc::Status::OK;
    case RecordingError::kBadPath:
      return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, result.message);
    case RecordingError::kOutsideRoot:
      return grpc::Status(grpc::StatusCode::PERMISSION_DENIED, result.message);
    case RecordingError::kNotConfigured:
    case RecordingError::kBusy:
    case RecordingError::kNotRecording:
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, result.message);
    case RecordingError::kIo: return grpc::Status(grpc::StatusCode::INTERNAL, result.message);
  }
  return grpc::Status(grpc::StatusCode::UNKNOWN, result.message);
}

// 0 in a request: a second of frames at 25 Hz, enough for a stable mean and deviation.
constexpr int kDefaultBackgroundFrames = 25;
// The learner holds no frames, but the RPC blocks while it learns: a minute at 25 Hz is plenty.
constexpr uint32_t kMaxBackgroundFrames = 1500;

grpc::Status backgroundStatus(const BackgroundResult& result) {
  switch (result.error) {
    case BackgroundError::kNone: return grpc::Status::OK;
    case BackgroundError::kReplay:
    case BackgroundError::kBusy:
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, result.message);
    case BackgroundError::kStalled:
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, result.message);
    case BackgroundError::kStopped:
      return grpc::Status(grpc::StatusCode::UNAVAILABLE, result.message);
    case BackgroundError::kUnusable:
    case BackgroundError::kNotSaved:
      return grpc::Status(grpc::StatusCode::INTERNAL, result.message);
  }
  return grpc::Status(grpc::StatusCode::UNKNOWN, result.message);
}

// 0 in a request: enough for the fit (docs/human.md fits from 5), 2 s of turning and about 2.4 s
// of fitting on one core.
constexpr int kDefaultFitFrameSets = 5;
// Each set adds half a second of collecting, about 0.5 s of fitting and a 120 KB silhouette per
// camera held meanwhile.
constexpr int kMaxFitFrameSets = 250;

grpc::Status bodyFitStatus(const FitBodyResult& result) {
  switch (result.error) {
    case BodyFitError::kNone:
      return grpc::Status::OK;
    case BodyFitError::kCannotFit:
    case BodyFitError::kCannotApply:
    case BodyFitError::kBusy:
    case BodyFitError::kNoSubject:
      return grpc::Status(grpc::StatusCode::FAILED_PRECONDITION, result.message);
    case BodyFitError::kStalled:
      return grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, result.message);
    case BodyFitError::kStopped:
      return grpc::Status(grpc::StatusCode::UNAVAILABLE, result.message);
    case BodyFitError::kFailed:
      return grpc::Status(grpc::StatusCode::INTERNAL, result.message);
  }
  return grpc::Status(grpc::StatusCode::UNKNOWN, result.message);
}

}  // namespace

MocapServiceImpl::MocapServiceImpl(const ServerConfig& config, const BodyModel& model,
                                   Pipeline& pipeline, PosePublisher& publisher)
    : config_(config),
      model_(model),
      pipeline_(pipeline),
      publisher_(publisher),
      started_ns_(monotonicNowNs()) {}

grpc::Status MocapServiceImpl::authorize(const grpc::CallbackServerContext* context) const {
  if (config_.bearer_token.empty()) return grpc::Status::OK;
  const auto& metadata = context->client_metadata();
  const auto found = metadata.find("authorization");
  if (found != metadata.end()) {
    const std::string value(found->second.data(), found->second.size());
    const std::string prefix = "Bearer ";
    if (value.rfind(prefix, 0) == 0 && sameSecret(value.substr(prefix.size()), config_.bearer_token))
      return grpc::Status::OK;
  }
  return grpc::Status(grpc::StatusCode::UNAUTHENTICATED,
                      "this daemon needs 'authorization: Bearer <token>' metadata");
}

grpc::ServerUnaryReactor* MocapServiceImpl::finish(grpc::CallbackServerContext* context,
                                                   const grpc::Status& status) {
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  reactor->Finish(status);
  return reactor;
}

grpc::ServerWriteReactor<v1::Pose>* MocapServiceImpl::StreamPoses(
    grpc::CallbackServerContext* context, const v1::StreamPosesRequest* request) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return refusedPoseStream(allowed);
  std::vector<int> joints;
  for (const std::string& name : request->joints()) {
    const int index = model_.pointIndex(name);
    if (index < 0) {
      return refusedPoseStream(grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                            "unknown joint '" + name + "' (see GetSkeleton)"));
    }
    joints.push_back(index);
  }
  logInfo() << "pose subscriber " << context->peer() << " joined";
  return startPoseStream(publisher_, model_, std::move(joints));
}

grpc::ServerUnaryReactor* MocapServiceImpl::GetSkeleton(grpc::CallbackServerContext* context,
                                                        const v1::GetSkeletonRequest*,
                                                        v1::Skeleton* response) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return finish(context, allowed);
  const TrackedBody body = pipeline_.trackedBody();
  skeletonToProto(*body.model, body.version, *response);
  return finish(context, grpc::Status::OK);
}

grpc::ServerUnaryReactor* MocapServiceImpl::GetStatus(grpc::CallbackServerContext* context,
                                                      const v1::GetStatusRequest*,
                                                      v1::Status* response) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return finish(context, allowed);
  const PipelineStatus status = pipeline_.status();
  response->set_version(MOCAP_VERSION);
  response->set_mode(config_.replay() ? "replay" : "live");
  response->set_uptime_ns(monotonicNowNs() - started_ns_);
  const std::vector<OpenedCamera>& cameras = pipeline_.cameras();
  for (std::size_t c = 0; c < cameras.size() && c < status.cameras.size(); ++c)
    cameraStatusToProto(cameras[c], status.cameras[c], status.running, *response->add_cameras());
  response->set_tracker_fps(status.tracker_fps);
  response->set_poses_published(status.poses_published);
  response->set_frame_sets_skipped(status.frame_sets_skipped);
  latencyToProto(status.latency, *response->mutable_latency());
  for (const auto& [stage, latency] : status.stage_latency) {
    v1::StageLatency& out = *response->add_stage_latency();
    out.set_stage(stage);
    latencyToProto(latency, *out.mutable_latency());
  }
  response->set_subscribers(static_cast<uint32_t>(publisher_.subscriberCount()));
  recordingToProto(status.recording, *response->mutable_recording());
  response->set_tracker_method(config_.tracker.method);
  response->set_evaluations_per_frame(status.evaluations_per_frame);
  response->set_refinements_cut(status.refinements_cut);
  response->set_tracking(status.tracking);
  response->set_search_failure(status.search_failure);
  response->set_acquisitions(status.acquisitions);
  response->set_losses(status.losses);
  auto& settings = *response->mutable_tracker_settings();
  for (const auto& [key, value] : config_.tracker.keyValues()) settings[key] = value;
  settings["threads"] = std::to_string(config_.tracker.threads);
  for (const std::string& warning : status.background_warnings)
    response->add_background_warnings(warning);
  return finish(context, grpc::Status::OK);
}

grpc::ServerUnaryReactor* MocapServiceImpl::ListCameras(grpc::CallbackServerContext* context,
                                                        const v1::ListCamerasRequest*,
                                                        v1::ListCamerasResponse* response) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return finish(context, allowed);
  for (const OpenedCamera& camera : pipeline_.cameras())
    cameraInfoToProto(camera, *response->add_cameras());
  return finish(context, grpc::Status::OK);
}

grpc::ServerUnaryReactor* MocapServiceImpl::StartRecording(
    grpc::CallbackServerContext* context, const v1::StartRecordingRequest* request,
    v1::RecordingState* response) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return finish(context, allowed);
  const std::string path = request->path().empty() ? sessionNameNow() : request->path();
  const RecordingResult result = pipeline_.startRecording(path);
  if (result.error != RecordingError::kNone) {
    logWarning() << "recording request '" << path << "' from " << context->peer()
                 << " refused: " << result.message;
    return finish(context, recordingStatus(result));
  }
  recordingToProto(result.status, *response);
  return finish(context, grpc::Status::OK);
}

grpc::ServerUnaryReactor* MocapServiceImpl::StopRecording(grpc::CallbackServerContext* context,
                                                          const v1::StopRecordingRequest*,
                                                          v1::RecordingState* response) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return finish(context, allowed);
  const RecordingResult result = pipeline_.stopRecording();
  if (result.error != RecordingError::kNone) return finish(context, recordingStatus(result));
  recordingToProto(result.status, *response);
  return finish(context, grpc::Status::OK);
}

grpc::ServerUnaryReactor* MocapServiceImpl::CaptureBackground(
    grpc::CallbackServerContext* context, const v1::CaptureBackgroundRequest* request,
    v1::CaptureBackgroundResponse* response) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return finish(context, allowed);
  if (request->frames() > kMaxBackgroundFrames) {
    return finish(context, grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                        "frames: at most " + std::to_string(kMaxBackgroundFrames) +
                                            " per camera (got " +
                                            std::to_string(request->frames()) + ")"));
  }
  const int frames = request->frames() == 0 ? kDefaultBackgroundFrames
                                            : static_cast<int>(request->frames());
  logInfo() << "background capture of " << frames << " frames requested by " << context->peer();
  // Finished from the mask thread: the capture takes a second or more, which must not hold a
  // gRPC callback thread.
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  pipeline_.captureBackground(frames, [reactor, response](const BackgroundResult& result) {
    if (result.error != BackgroundError::kNone)
      logWarning() << "background capture failed: " << result.message;
    response->set_frames_used(static_cast<uint32_t>(result.frames_used));
    for (const std::string& warning : result.warnings) response->add_warnings(warning);
    reactor->Finish(backgroundStatus(result));
  });
  return reactor;
}

grpc::ServerUnaryReactor* MocapServiceImpl::Reacquire(grpc::CallbackServerContext* context,
                                                      const v1::ReacquireRequest*,
                                                      v1::ReacquireResponse*) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return finish(context, allowed);
  switch (pipeline_.reacquire()) {
    case Pipeline::ReacquireError::kReplay:
      return finish(context, grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                                          "replay: the poses depend on the recording alone"));
    case Pipeline::ReacquireError::kCannotPlace:
      return finish(context, grpc::Status(grpc::StatusCode::FAILED_PRECONDITION,
                                          whyCannotAcquire(model_)));
    case Pipeline::ReacquireError::kNone:
      break;
  }
  logInfo() << "reacquisition requested by " << context->peer();
  return finish(context, grpc::Status::OK);
}

grpc::ServerUnaryReactor* MocapServiceImpl::FitBody(grpc::CallbackServerContext* context,
                                                    const v1::FitBodyRequest* request,
                                                    v1::FitBodyResponse* response) {
  if (grpc::Status allowed = authorize(context); !allowed.ok()) return finish(context, allowed);
  if (request->frame_sets() < 0 || request->frame_sets() > kMaxFitFrameSets) {
    return finish(
        context,
        grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                     "frame_sets: from 1 to " + std::to_string(kMaxFitFrameSets) +
                         ", or 0 for the default (" + std::to_string(kDefaultFitFrameSets) +
                         "); got " + std::to_string(request->frame_sets())));
  }
  const int frame_sets = request->frame_sets() == 0 ? kDefaultFitFrameSets : request->frame_sets();
  logInfo() << "body fit from " << frame_sets << " frame sets"
            << (request->apply() ? ", applied," : "") << " requested by " << context->peer();
  // Finished from the pipeline's threads: the fit takes seconds, which must not hold a gRPC
  // callback thread.
  grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
  pipeline_.fitBody(frame_sets, request->apply(), [reactor, response](const FitBodyResult& result) {
    if (result.error == BodyFitError::kNone)
      bodyFitToProto(result, *response);
    else
      logWarning() << "body fit failed: " << result.message;
    reactor->Finish(bodyFitStatus(result));
  });
  return reactor;
}

}  // namespace mocap
