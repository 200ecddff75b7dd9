// The background manager: capture, judging, persistence and replay of the empty-scene backgrounds,
// and the silhouette source each camera gets from them.
#include "server/background_manager.h"

#include <filesystem>
#include <iomanip>
#include <set>
#include <sstream>
#include <stdexcept>

#include "server/log.h"
#include "server/recording_control.h"
#include "server/stats.h"

namespace mocap {
namespace {

// A background capture gives up when no camera contributed a frame for this long: a stalled camera
// must not hold the RPC forever.
constexpr int64_t kCaptureStallNs = 3'000'000'000;
// A captured background with more of its image unsteady than this is reported (unsteadyShare), and
// likewise with more of it changed from the background it replaces (changedShare).
// Fixed before measuring; then, in the fake scene's two 780x580 views, 25 frames: the empty room
// 0.00 %, the person walking in the lab rig's view 2.2 and 2.4 % unsteady (a person standing still
// is not), and 2.7 and 2.3 % changed from the scene's empty room.
constexpr double kDoubtfulShare = 0.01;

constexpr const char* kBackgroundSuffix = ".background.yml";

// A camera id as a file name: nothing that could leave the directory or hide the file.
std::string fileNamePart(const std::string& text) {
  std::string name;
  for (char ch : text) {
    const bool plain = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') ||
                       (ch >= '0' && ch <= '9') || ch == '.' || ch == '_' || ch == '-';
    name += plain ? ch : '_';
  }
  if (!name.empty() && name.front() == '.') name.front() = '_';
  return name;
}

}  // namespace

BackgroundManager::BackgroundManager(const ServerConfig& config,
                                     const std::vector<OpenedCamera>& cameras,
                                     std::shared_ptr<const SessionReader> replay,
                                     GroundTruthSilhouettes ground_truth,
                                     RecordingControl& recording)
    : config_(config),
      cameras_(cameras),
      replay_(std::move(replay)),
      true_silhouettes_(ground_truth != nullptr),
      recording_(recording) {
  auto truth = true_silhouettes_ ? std::make_shared<SceneTruth>(std::move(ground_truth)) : nullptr;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    if (truth)
      sources_.push_back(std::make_unique<TrueSilhouettes>(truth, c));
    else
      sources_.push_back(withoutBackgroundSource());
  }
  next_replayed_backgrounds_.assign(cameras_.size(), 0);
  source_statuses_.assign(cameras_.size(),
                          true_silhouettes_ ? "ground truth"
                          : replay_ && replay_->backgrounds().empty()
                              ? withoutBackground("the session stores no background")
                              : withoutBackground(""));
}

BackgroundManager::~BackgroundManager() { joinSaver(); }

void BackgroundManager::initialize() {
  if (!config_.background_directory.empty() && !replay_) loadSaved();
  if (replay_ && replay_->backgrounds().empty() && !config_.threshold_before_background) {
    logWarning() << "replay: " << replay_->path().string()
                 << " stores no background (recorded before sessions kept them, or without one): "
                    "nothing is tracked; before_background: threshold tracks its images "
                    "thresholded";
  }
}

std::string BackgroundManager::backgroundFile(std::size_t camera) const {
  if (config_.background_directory.empty() || camera >= cameras_.size()) return "";
  const OpenedCamera& opened = cameras_[camera];
  const std::string id =
      opened.info.id.empty() ? "camera" + std::to_string(camera) : opened.info.id;
  const std::string driver = opened.info.driver.empty() ? opened.config.driver : opened.info.driver;
  return (std::filesystem::path(config_.background_directory) /
          (fileNamePart(driver + "-" + id) + kBackgroundSuffix))
      .string();
}

const char* BackgroundManager::withoutBackgroundIs() const {
  return config_.threshold_before_background ? "thresholded" : "not tracked";
}

std::string BackgroundManager::withoutBackground(const std::string& why) const {
  std::string source = config_.threshold_before_background
                           ? "threshold"
                           : "none: waiting for a background (CaptureBackground, nobody in view)";
  return why.empty() ? source : source + " (" + why + ")";
}

std::unique_ptr<SilhouetteSource> BackgroundManager::withoutBackgroundSource() const {
  if (!config_.threshold_before_background) return nullptr;
  return std::make_unique<ThresholdedSilhouettes>();
}

void BackgroundManager::setSourceStatus(std::size_t camera, std::string status) {
  if (true_silhouettes_) return;  // the scene's true silhouettes are used whatever the background
  std::lock_guard lock(status_mutex_);
  source_statuses_[camera] = std::move(status);
}

void BackgroundManager::warn(const std::string& warning) {
  logWarning() << warning;
  std::lock_guard lock(status_mutex_);
  warnings_.push_back(warning);
}

std::vector<std::string> BackgroundManager::sources() const {
  std::lock_guard lock(status_mutex_);
  return source_statuses_;
}

std::vector<std::string> BackgroundManager::warnings() const {
  std::lock_guard lock(status_mutex_);
  return warnings_;
}

void BackgroundManager::loadSaved() {
  std::set<std::string> expected;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const std::string path = backgroundFile(c);
    if (!expected.insert(std::filesystem::path(path).filename().string()).second)
      throw std::invalid_argument("cameras[" + std::to_string(c) + "] (" + cameras_[c].info.id +
                                  ") would share its background file " + path +
                                  " with another camera");
  }
  for (std::size_t c = 0; c < cameras_.size(); ++c) loadSaved(c, backgroundFile(c));
  // A file no camera claims is most likely a camera since removed or renamed: said, not deleted.
  std::string known;
  for (const std::string& file : expected) known += (known.empty() ? "" : ", ") + file;
  std::error_code error;
  for (const auto& entry :
       std::filesystem::directory_iterator(config_.background_directory, error)) {
    const std::string name = entry.path().filename().string();
    if (name.front() == '.' || !name.ends_with(kBackgroundSuffix) || expected.count(name)) continue;
    warn("background file ignored: " + entry.path().string() +
         ": no configured camera saves to it (the cameras' files are " + known + ")");
  }
}

void BackgroundManager::loadSaved(std::size_t c, const std::string& path) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) return;
  const std::string fallback = "; cameras[" + std::to_string(c) + "] is " + withoutBackgroundIs() +
                               " until the next CaptureBackground";
  BackgroundModel model;
  try {
    model = loadBackground(path);
  } catch (const std::exception& e) {
    warn("background file unusable: " + std::string(e.what()) + fallback);
    setSourceStatus(c, withoutBackground(path + " unusable"));
    return;
  }
  const CameraConfig& camera = cameras_[c].config;
  const int channels = camera.pixel_format == "GREY" ? 1 : model.channels();
  if (model.size() != cv::Size(camera.width, camera.height) || model.channels() != channels) {
    warn("background file unusable: " + path + ": it is " + std::to_string(model.size().width) +
         "x" + std::to_string(model.size().height) + " with " + std::to_string(model.channels()) +
         " channel(s) but cameras[" + std::to_string(c) + "] is " + std::to_string(camera.width) +
         "x" + std::to_string(camera.height) + (camera.pixel_format == "GREY" ? " gray" : "") +
         fallback);
    setSourceStatus(c, withoutBackground(path + " does not fit this camera"));
    return;
  }
  useBackground(c, std::make_shared<const BackgroundModel>(std::move(model)));
  logInfo() << "cameras[" << c << "]: background loaded from " << path;
  setSourceStatus(c, "background loaded from " + path);
}

void BackgroundManager::capture(int frames, std::function<void(const BackgroundResult&)> done) {
  if (replay_) {
    // Replay must give the same poses every run, from the recorded frames alone.
    done({BackgroundError::kReplay, "background capture needs live cameras, not a replay", 0, {}});
    return;
  }
  auto capture = std::make_unique<Capture>();
  capture->frames = frames;
  capture->done = std::move(done);
  capture->learners.resize(cameras_.size());
  capture->last_progress_ns = monotonicNowNs();
  std::unique_lock lock(mutex_);
  if (!accepting_) {
    lock.unlock();
    capture->done({BackgroundError::kStopped, "the pipeline is not running", 0, {}});
    return;
  }
  if (busy_) {
    lock.unlock();
    capture->done({BackgroundError::kBusy, "a background capture is already under way", 0, {}});
    return;
  }
  busy_ = true;
  request_ = std::move(capture);
}

void BackgroundManager::open() {
  std::lock_guard lock(mutex_);
  accepting_ = true;
}

void BackgroundManager::poll() {
  if (!capturing_) {
    std::lock_guard lock(mutex_);
    capturing_ = std::move(request_);
  }
  // Also checked without frames, so a capture on stalled cameras ends.
  if (capturing_ && finish(*capturing_)) capturing_.reset();
}

bool BackgroundManager::silhouette(std::size_t camera, const cv::Mat& image,
                                   uint64_t frame_sequence, SilhouetteMask& silhouette) {
  if (capturing_) learn(*capturing_, camera, image);
  if (true_silhouettes_) return sources_[camera]->update(image, frame_sequence, silhouette);
  if (replay_) replayBackgrounds(camera, frame_sequence);
  if (SilhouetteSource* source = sources_[camera].get()) {
    if (source->update(image, frame_sequence, silhouette)) return true;
    // A background of another format (the camera's pixel format changed since it was saved): no
    // silhouettes, or thresholded ones, beat silhouettes frozen at the last good frame.
    const std::string error = source->lastError();
    logWarning() << "camera " << camera << ": silhouette extraction failed: " << error << "; "
                 << withoutBackgroundIs() << " until the next capture";
    setSourceStatus(camera, withoutBackground("background unusable: " + error));
    useBackground(camera, nullptr);
  }
  SilhouetteSource* fallback = sources_[camera].get();
  return fallback && fallback->update(image, frame_sequence, silhouette);
}

void BackgroundManager::close() {
  std::unique_ptr<Capture> pending;
  {
    std::lock_guard lock(mutex_);
    accepting_ = false;
    pending = std::move(request_);
  }
  if (!capturing_) capturing_ = std::move(pending);
  if (capturing_)
    endCapture(capturing_->done, {BackgroundError::kStopped, "the pipeline stopped", 0, {}});
  capturing_.reset();
}

void BackgroundManager::joinSaver() {
  if (save_thread_.joinable()) save_thread_.join();
}

void BackgroundManager::learn(Capture& capture, std::size_t camera, const cv::Mat& image) {
  BackgroundLearner& learner = capture.learners[camera];
  if (learner.frames() >= capture.frames) return;
  if (learner.add(image)) capture.last_progress_ns = monotonicNowNs();
}

void BackgroundManager::endCapture(const std::function<void(const BackgroundResult&)>& done,
                                   const BackgroundResult& result) {
  {
    std::lock_guard lock(mutex_);
    busy_ = false;
  }
  done(result);
}

bool BackgroundManager::finish(Capture& capture) {
  bool complete = true;
  for (const BackgroundLearner& learner : capture.learners)
    complete = complete && learner.frames() >= capture.frames;
  if (!complete) {
    if (monotonicNowNs() - capture.last_progress_ns < kCaptureStallNs) return false;
    std::string counts;
    for (std::size_t c = 0; c < capture.learners.size(); ++c) {
      counts += (c ? ", " : "") + std::string("camera ") + std::to_string(c) + ": " +
                std::to_string(capture.learners[c].frames());
    }
    endCapture(capture.done,
               {BackgroundError::kStalled,
                "no usable frame for " + std::to_string(kCaptureStallNs / 1'000'000'000) +
                    " s; frames learned of " + std::to_string(capture.frames) + " (" + counts + ")",
                0,
                {}});
    return true;
  }
  // The extractors adapt their copies; the models stay as learnt, for the files and recordings.
  std::vector<std::shared_ptr<const BackgroundModel>> models;
  std::vector<std::unique_ptr<SilhouetteSource>> extracted;
  try {
    for (const BackgroundLearner& learner : capture.learners) {
      models.push_back(std::make_shared<const BackgroundModel>(learner.model()));
      extracted.push_back(std::make_unique<ExtractedSilhouettes>(*models.back()));
    }
  } catch (const std::exception& error) {
    endCapture(capture.done, {BackgroundError::kUnusable, error.what(), 0, {}});
    return true;
  }
  const std::vector<std::shared_ptr<const BackgroundModel>> replaced =
      recording_.backgroundsInUse();
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    useBackground(c, models[c], std::move(extracted[c]));
    setSourceStatus(c, "background captured");
  }
  // Installed anyway: the operator, told, decides whether to capture again.
  BackgroundResult learned{BackgroundError::kNone, "", capture.frames, {}};
  judge(models, replaced, learned);
  if (config_.background_directory.empty()) {
    endCapture(capture.done, learned);
    return true;
  }
  // The previous saver ended its capture before this one could start: it is finishing or done.
  joinSaver();
  save_thread_ = std::thread([this, models = std::move(models), learned = std::move(learned),
                              done = std::move(capture.done)]() mutable {
    save(std::move(models), std::move(learned), std::move(done));
  });
  return true;
}

void BackgroundManager::judge(const std::vector<std::shared_ptr<const BackgroundModel>>& models,
                              const std::vector<std::shared_ptr<const BackgroundModel>>& replaced,
                              BackgroundResult& learned) const {
  // Notes camera c's share in `shares` (after `label`) and warns, naming the camera, if it is over
  // the limit.
  const auto judgeShare = [&](std::size_t c, double share, std::ostringstream& shares,
                              const std::string& label, const char* what) {
    shares << (shares.tellp() > 0 ? ", " : "") << label << std::fixed << std::setprecision(2)
           << 100 * share << " %";
    if (share <= kDoubtfulShare) return;
    std::ostringstream warning;
    warning << "camera " << c << " (" << cameras_[c].info.id << "): " << std::fixed
            << std::setprecision(1) << 100 * share << " % of the image " << what;
    logWarning() << warning.str();
    learned.warnings.push_back(warning.str());
  };
  std::ostringstream shares;
  for (std::size_t c = 0; c < models.size(); ++c)
    judgeShare(c, unsteadyShare(*models[c]), shares, "",
               "changed during the capture (someone moving in view?): its background holds them; "
               "capture again with the room empty");
  // Someone standing still through the capture is steady in it; the background it replaces (if
  // any, of the same image format) still shows the room without them.
  // Judged by the test the extractors apply (their default options, as useBackground makes them).
  const SilhouetteOptions extraction;
  std::ostringstream changed_shares;
  for (std::size_t c = 0; c < models.size(); ++c) {
    const BackgroundModel* before = replaced[c].get();
    if (!before || before->size() != models[c]->size() ||
        before->channels() != models[c]->channels())
      continue;
    judgeShare(
        c,
        changedShare(*before, *models[c], extraction.threshold_sigmas, extraction.min_difference),
        changed_shares, "camera " + std::to_string(c) + " ",
        "differs from the background it replaces (someone in view, or the room or its lighting "
        "changed?): if someone stood in view, capture again with the room empty");
  }
  logInfo() << "background learned from " << learned.frames_used
            << " frames per camera; changed during the capture: " << shares.str()
            << (changed_shares.tellp() > 0 ? "; from the background replaced: " : "")
            << changed_shares.str();
}

void BackgroundManager::useBackground(std::size_t camera,
                                      std::shared_ptr<const BackgroundModel> background,
                                      std::unique_ptr<SilhouetteSource> extracted) {
  if (background && !extracted) extracted = std::make_unique<ExtractedSilhouettes>(*background);
  if (!true_silhouettes_)
    sources_[camera] = background ? std::move(extracted) : withoutBackgroundSource();
  recording_.noteBackground(camera, std::move(background));
}

void BackgroundManager::replayBackgrounds(std::size_t camera, uint64_t frame_sequence) {
  const std::vector<SessionBackground>& recorded = replay_->backgrounds();
  // Each camera's lines are in order of from_sequence and its frames come in order of sequence.
  std::size_t& next = next_replayed_backgrounds_[camera];
  for (; next < recorded.size(); ++next) {
    const SessionBackground& line = recorded[next];
    if (static_cast<std::size_t>(line.camera) != camera) continue;
    if (line.from_sequence > frame_sequence) break;
    useBackground(camera, line.model);  // a recording of the replay keeps it too
    setSourceStatus(camera, line.model ? "background recorded in the session (" + line.file + ")"
                                       : withoutBackground("the session recorded none from here"));
  }
}

void BackgroundManager::save(std::vector<std::shared_ptr<const BackgroundModel>> models,
                             BackgroundResult learned,
                             std::function<void(const BackgroundResult&)> done) {
  std::string failures;
  for (std::size_t c = 0; c < models.size(); ++c) {
    try {
      saveBackground(backgroundFile(c), *models[c]);
    } catch (const std::exception& e) {
      failures += (failures.empty() ? "" : "; ") + std::string(e.what());
    }
  }
  if (!failures.empty()) {
    learned.error = BackgroundError::kNotSaved;
    learned.message =
        "the background is learned and in use but a restart will not have it: " + failures;
  } else {
    logInfo() << "backgrounds saved in " << config_.background_directory;
  }
  endCapture(done, learned);
}

}  // namespace mocap
