// Recording control: the session the mask thread records into, and its refusals around body fits.
#include "server/recording_control.h"

#include <filesystem>

#include <opencv2/core.hpp>

#include "server/log.h"
#include "server/stats.h"

namespace mocap {
namespace {

// Why `relative_path` cannot name a new session under `root` (error kNone: it can).
RecordingResult checkSessionPath(const std::string& root, const std::string& relative_path) {
  if (root.empty()) {
    return {RecordingError::kNotConfigured,
            "recording is off: the configuration has no recording_directory",
            {}};
  }
  const std::filesystem::path requested(relative_path);
  for (const std::filesystem::path& part : requested) {
    if (part == "..")
      return {RecordingError::kBadPath, "the session path must not contain '..'", {}};
  }
  if (requested.is_absolute())
    return {RecordingError::kBadPath,
            "the session path must be relative to the recording directory",
            {}};
  const Expected<std::filesystem::path> inside = resolveInsideRoot(root, requested);
  if (!inside.ok()) return {RecordingError::kOutsideRoot, inside.error(), {}};
  if (std::filesystem::exists(inside.value()))
    return {RecordingError::kBusy, "session " + relative_path + " already exists", {}};
  return {};
}

}  // namespace

RecordingControl::RecordingControl(
    const ServerConfig& config, const Rig& rig, const std::vector<OpenedCamera>& cameras,
    RecordedTracking tracking,
    std::vector<std::shared_ptr<const BackgroundModel>> scene_backgrounds)
    : config_(config),
      rig_(rig),
      cameras_(cameras),
      tracking_(std::move(tracking)),
      backgrounds_in_use_(std::move(scene_backgrounds)),
      published_(std::make_shared<const RecordingStatus>()) {
  camera_cv_types_.assign(cameras_.size(), -1);
  backgrounds_in_use_.resize(cameras_.size());
  next_frame_sequences_.assign(cameras_.size(), 0);
}

RecordingStatus RecordingControl::statusLocked() const {
  if (!recorder_) return last_;
  const RecorderStats stats = recorder_->stats();
  RecordingStatus status;
  status.active = stats.stopped.empty();  // stopped on its own: closed at the next frame set
  status.path = path_;
  status.frame_sets = stats.sets_written;
  status.started_wall_ns = started_wall_ns_;
  status.stopped = stats.stopped;
  return status;
}

RecorderOptions RecordingControl::recorderOptions() const {
  RecorderOptions options;
  options.images = config_.recording.images;
  options.jpeg_quality = config_.recording.jpeg_quality;
  options.min_free_bytes = static_cast<uint64_t>(config_.recording.min_free_mb) * 1'000'000;
  options.threshold_without_background = config_.threshold_before_background;
  return options;
}

void RecordingControl::publishLocked(RecordingStatus status) {
  sets_written_.store(status.frame_sets);
  published_.store(std::make_shared<const RecordingStatus>(std::move(status)));
}

RecordingStatus RecordingControl::status() const {
  RecordingStatus status = *published_.load();
  if (status.active) status.frame_sets = sets_written_.load();
  return status;
}

RecordingResult RecordingControl::describeCamerasLocked(std::vector<SessionCamera>& cameras) const {
  if (recorder_) return {RecordingError::kBusy, "already recording to " + path_, {}};
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    if (camera_cv_types_[c] < 0)
      return {RecordingError::kBusy, "camera " + std::to_string(c) + " has sent no frame yet", {}};
    SessionCamera camera;
    camera.name = cameras_[c].info.id;
    camera.width = cameras_[c].config.width;
    camera.height = cameras_[c].config.height;
    camera.pixel_format = camera_cv_types_[c] == CV_8UC1 ? kPixelGray : kPixelBgr;
    camera.fps = cameras_[c].config.fps;
    cameras.push_back(camera);
  }
  return {};
}

RecordingResult RecordingControl::start(const std::string& relative_path) {
  if (config_.recorded_silhouettes)
    return {RecordingError::kNotConfigured,
            "this replay hands the tracker the session's silhouettes, not its images: there are "
            "no frames to record (replay without --recorded-silhouettes to record)",
            {}};
  RecordingResult result = checkSessionPath(config_.recording_directory, relative_path);
  if (result.error != RecordingError::kNone) return result;
  std::lock_guard session(session_mutex_);
  if (body_change_reserved_) {
    return {RecordingError::kBusy,
            "a body fit that will change the tracked body is under way (FitBody with apply); "
            "record once it has answered",
            {}};
  }
  std::vector<SessionCamera> cameras;
  {
    std::lock_guard lock(mutex_);
    result = describeCamerasLocked(cameras);
    if (result.error != RecordingError::kNone) return result;
  }
  // Opening writes files: done outside the lock so the mask thread never waits on the disk.
  auto recorder = std::make_unique<Recorder>(config_.recording_directory, recorderOptions());
  if (Status room = recorder->checkFreeSpace(); !room.ok())
    return {RecordingError::kBusy, room.message(), {}};
  SessionTracking tracking;
  const TrackedBody body = tracking_.tracked_body();
  tracking.body = body.model.get();
  tracking.tracker_settings = config_.tracker.keyValues();
  if (tracking_.truth) {
    for (const Dof& dof : tracking_.configured_body->dofs) tracking.truth_dofs.push_back(dof.name);
    // The truth is of the subject's own body when it has one, else of the configured body, which
    // a fitted body applied since is not.
    if (tracking_.reference_model)
      tracking.truth_body = tracking_.reference_model.get();
    else if (body.version > 0)
      tracking.truth_body = tracking_.configured_body;
  }
  const Status opened =
      recorder->open(std::filesystem::path(relative_path), rig_, cameras, tracking);
  if (!opened.ok()) return {RecordingError::kIo, opened.message(), {}};
  std::lock_guard lock(mutex_);
  if (recorder_) return {RecordingError::kBusy, "already recording to " + path_, {}};
  recorder_ = std::move(recorder);
  // The backgrounds in use now apply from each camera's first recorded frame (later ones, from
  // noteBackground, from a later frame).
  for (std::size_t c = 0; c < cameras_.size(); ++c)
    if (backgrounds_in_use_[c])
      recorder_->writeBackground(static_cast<int>(c), 0, backgrounds_in_use_[c]);
  path_ = relative_path;
  started_wall_ns_ = wallNowNs();
  logInfo() << "recording to " << recorder_->sessionPath().string();
  result.status = statusLocked();
  publishLocked(result.status);
  return result;
}

RecordingResult RecordingControl::stop() {
  std::unique_ptr<Recorder> recorder;
  RecordingStatus final_status;
  {
    std::lock_guard lock(mutex_);
    if (recorder_) final_status = statusLocked();
    recorder = std::move(recorder_);
  }
  if (recorder) {
    // Flushing the queue to disk happens outside the lock, while the mask thread goes on.
    RecordingResult result = finish(std::move(recorder), final_status);
    if (result.status.stopped.empty()) return result;
  }
  // A recording that stopped on its own was not running when asked: say why it stopped.
  std::lock_guard lock(mutex_);
  const std::string why =
      last_.stopped.empty() ? "" : ": " + last_.path + " stopped on its own: " + last_.stopped;
  return {RecordingError::kNotRecording, "no recording is running" + why, last_};
}

RecordingResult RecordingControl::finish(std::unique_ptr<Recorder> recorder,
                                         RecordingStatus status) {
  const Status closed = recorder->close();
  const RecorderStats stats = recorder->stats();
  status.active = false;
  status.frame_sets = stats.sets_written;
  status.stopped = stats.stopped;
  {
    std::lock_guard lock(mutex_);
    last_ = status;
    // A recording started since stop() took this one out is the one to show.
    if (!recorder_) publishLocked(status);
  }
  const std::string session = recorder->sessionPath().string();
  if (!stats.stopped.empty()) {
    logError() << "recording " << session << " stopped: " << stats.stopped << "; "
               << stats.sets_written << " frame sets kept, " << stats.sets_discarded
               << " queued ones discarded";
    return {RecordingError::kNone, "", status};  // the session is whole: the status says why
  }
  logInfo() << "recording " << session << " closed: " << stats.sets_written
            << " frame sets written, " << stats.sets_dropped << " dropped (disk too slow)";
  if (!closed.ok()) return {RecordingError::kIo, closed.message(), status};
  return {RecordingError::kNone, "", status};
}

void RecordingControl::tap(const FrameSet& set, uint64_t frame_sequence) {
  std::unique_ptr<Recorder> stopped;
  RecordingStatus stopped_status;
  {
    std::lock_guard lock(mutex_);
    for (std::size_t c = 0; c < set.frames.size() && c < cameras_.size(); ++c) {
      if (!set.frames[c]) continue;
      camera_cv_types_[c] = set.frames[c]->image.type();
      next_frame_sequences_[c] = set.frames[c]->sequence + 1;
    }
    if (recorder_ && recorder_->stopped()) {
      stopped_status = statusLocked();
      last_ = stopped_status;  // until finish() has the final count
      publishLocked(stopped_status);
      stopped = std::move(recorder_);
    } else if (recorder_) {
      SetTruth truth{frame_sequence, {}};
      if (tracking_.truth) truth.dofs = tracking_.truth(frame_sequence);
      recorder_->write(set, std::move(truth));
      sets_written_.store(recorder_->stats().sets_written);
    }
  }
  // Its writer has already stopped, so closing joins it at once and syncs the index files: the
  // mask thread waits this once, outside the lock.
  if (stopped) finish(std::move(stopped), stopped_status);
}

void RecordingControl::noteBackground(std::size_t camera,
                                      std::shared_ptr<const BackgroundModel> background) {
  std::lock_guard lock(mutex_);
  if (recorder_)
    recorder_->writeBackground(static_cast<int>(camera), next_frame_sequences_[camera], background);
  backgrounds_in_use_[camera] = std::move(background);
}

std::vector<std::shared_ptr<const BackgroundModel>> RecordingControl::backgroundsInUse() const {
  std::lock_guard lock(mutex_);
  return backgrounds_in_use_;
}

bool RecordingControl::reserveBodyChange() {
  std::lock_guard session(session_mutex_);
  {
    std::lock_guard lock(mutex_);
    if (recorder_) return false;
  }
  body_change_reserved_ = true;
  return true;
}

void RecordingControl::releaseBodyChange() {
  std::lock_guard session(session_mutex_);
  body_change_reserved_ = false;
}

}  // namespace mocap
