// The capture-to-pose pipeline: stage threads, hand-offs, the recorder tap and the meters.
#include "server/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <set>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "drivers/fake/replay_pump.h"
#include "server/log.h"

namespace mocap {
namespace {

// How often a stage waiting for input rechecks whether the pipeline is stopping.
constexpr auto kPollInterval = std::chrono::milliseconds(100);
// A background capture gives up when no camera contributed a frame for this long: a stalled camera
// must not hold the RPC forever.
constexpr int64_t kCaptureStallNs = 3'000'000'000;
// A body fit gives up the same way when no frame set with every camera's silhouettes comes.
constexpr int64_t kFitStallNs = kCaptureStallNs;
// A body fit takes a frame set this often: 5 sets span 2 s, in which a subject asked to turn in
// the fit pose turns by some tens of degrees.
constexpr double kFitSetIntervalSeconds = 0.5;
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

FitBodyResult fitFailure(BodyFitError error, std::string message) {
  FitBodyResult result;
  result.error = error;
  result.message = std::move(message);
  return result;
}

}  // namespace

Pipeline::Pipeline(const ServerConfig& config, const BodyModel& model, const Rig& rig,
                   PipelineInputs inputs, PosePublisher& publisher)
    : config_(config),
      model_(model),
      rig_(rig),
      cameras_(std::move(inputs.cameras)),
      replay_(std::move(inputs.replay)),
      ground_truth_(std::move(inputs.ground_truth)),
      reference_pose_(std::move(inputs.reference_pose)),
      reference_model_(std::move(inputs.reference_model)),
      fit_model_(std::move(inputs.fit_model)),
      publisher_(publisher),
      masks_(config.replay() ? Handoff<MaskSet>::Mode::kLossless
                             : Handoff<MaskSet>::Mode::kLatestWins),
      poses_(config.replay() ? Handoff<std::shared_ptr<Pose>>::Mode::kLossless
                             : Handoff<std::shared_ptr<Pose>>::Mode::kLatestWins),
      can_acquire_(canAcquire(model)),
      kinematics_(model),
      reference_kinematics_(reference_model_ ? *reference_model_ : model) {
  if (cameras_.empty()) throw std::invalid_argument("no cameras");
  if (reference_model_ && reference_model_->dofs.size() != model_.dofs.size())
    throw std::invalid_argument("the reference body has " +
                                std::to_string(reference_model_->dofs.size()) +
                                " DOFs, the tracked one " + std::to_string(model_.dofs.size()));
  if (rig_.size() != cameras_.size()) {
    throw std::invalid_argument("the calibration has " + std::to_string(rig_.size()) +
                                " cameras but " + std::to_string(cameras_.size()) +
                                " are configured");
  }
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const CameraConfig& camera = cameras_[c].config;
    if (camera.width != rig_[c].width || camera.height != rig_[c].height) {
      throw std::invalid_argument(
          "cameras[" + std::to_string(c) + "] is " + std::to_string(camera.width) + "x" +
          std::to_string(camera.height) + " but its calibration is " +
          std::to_string(rig_[c].width) + "x" + std::to_string(rig_[c].height));
    }
    camera_rates_.push_back(std::make_unique<RateMeter>());
  }
  camera_cv_types_.assign(cameras_.size(), -1);
  extractors_.resize(cameras_.size());
  backgrounds_in_use_ = std::move(inputs.scene_backgrounds);
  backgrounds_in_use_.resize(cameras_.size());
  next_replayed_backgrounds_.assign(cameras_.size(), 0);
  next_frame_sequences_.assign(cameras_.size(), 0);
  silhouette_sources_.assign(cameras_.size(),
                             ground_truth_ ? "ground truth"
                             : replay_ && replay_->backgrounds().empty()
                                 ? withoutBackground("the session stores no background")
                                 : withoutBackground(""));
  if (!config_.background_directory.empty() && !replay_) loadBackgrounds();
  if (replay_ && replay_->backgrounds().empty() && !config_.threshold_before_background) {
    logWarning() << "replay: " << replay_->path().string()
                 << " stores no background (recorded before sessions kept them, or without one): "
                    "nothing is tracked; before_background: threshold tracks its images "
                    "thresholded";
  }
  if (replay_ && replay_->hasTruth() && !reference_pose_) {
    reference_pose_ = [session = replay_](uint64_t frame_sequence) {
      const Eigen::VectorXd* truth = session->truth(frame_sequence);
      return truth ? *truth : Eigen::VectorXd();
    };
  }

  SyncConfig sync;
  sync.camera_count = static_cast<int>(cameras_.size());
  sync.frame_period =
      std::chrono::nanoseconds(static_cast<int64_t>(1e9 / cameras_.front().config.fps));
  if (config.sync.tolerance_ms)
    sync.tolerance =
        std::chrono::nanoseconds(static_cast<int64_t>(*config.sync.tolerance_ms * 1e6));
  if (config.sync.deadline_ms)
    sync.deadline = std::chrono::nanoseconds(static_cast<int64_t>(*config.sync.deadline_ms * 1e6));
  sync.mode = replay_ ? SyncMode::kReplay : SyncMode::kLive;
  Expected<std::unique_ptr<FrameSynchronizer>> created = FrameSynchronizer::create(sync);
  if (!created.ok()) throw std::invalid_argument("synchronizer: " + created.error());
  synchronizer_ = std::move(created.value());

  pool_ = std::make_unique<WorkerPool>(config.tracker.threads);
  body_ = {std::make_shared<const BodyModel>(model), 0};
  applied_body_ = body_;
  makeTrackerFilter(false);
  if (inputs.acquire) {
    if (!acquiring_) throw std::invalid_argument("tracker.start: the body's root cannot be placed");
    tracking_ = false;
  } else {
    filter_->reset(inputs.initial_pose.size() == static_cast<long>(model_.dofs.size())
                       ? inputs.initial_pose
                       : model_.neutralPose());
  }
}

void Pipeline::makeTrackerFilter(bool in_fit_pose) {
  const FilterOptions options = config_.tracker.filterOptions();
  auto make = [this, options, body = body_.model] {
    return makeFilter(config_.tracker.method, *body, rig_, options, *pool_);
  };
  // A body that can be placed is tracked through an acquiring filter, so it can be found again
  // on request or once lost, and each pose carries its silhouette fit; from a known pose that
  // filter tracks as the plain one.
  acquiring_ = nullptr;
  if (can_acquire_) {
    AcquiringOptions acquiring_options;
    acquiring_options.lost_below = config_.tracker.lost_below;
    acquiring_options.lost_after = config_.tracker.lost_after;
    const BodyModel& body = *body_.model;
    std::vector<Eigen::VectorXd> stances = acquisitionStances(body);
    if (in_fit_pose && body.fit_pose) stances.push_back(body.stancePose(*body.fit_pose));
    auto acquiring = std::make_unique<AcquiringFilter>(body, rig_, std::move(stances),
                                                       options.likelihood, make, acquiring_options);
    acquiring_ = acquiring.get();
    filter_ = std::move(acquiring);
  } else {
    filter_ = make();
  }
  // Live, a step's refinement gives way to a newer frame set rather than have it wait or be
  // dropped. Replay queues every set, so it never yields and stays repeatable.
  if (!config_.replay()) filter_->setYield([this] { return masks_.waiting(); });
}

void Pipeline::switchToAppliedBody() {
  TrackedBody applied;
  {
    std::lock_guard lock(body_mutex_);
    applied = applied_body_;
  }
  if (applied.version == body_.version) return;
  if (acquiring_) {
    earlier_acquisitions_ += acquiring_->acquisitions();
    earlier_losses_ += acquiring_->losses();
  }
  filter_.reset();  // before the body it borrows
  body_ = std::move(applied);
  // The tracker finds the subject anew, as a daemon started with the fitted body would, the fit
  // pose among its stances: the subject stands in it until the fit answers. The pose tracked with
  // the old body is no start: it fits the new body badly, and its heading was 60-110 degrees off
  // on the fake scene's subject (see docs/service.md).
  makeTrackerFilter(true);  // acquiring: fitBody fits only bodies that can be placed
  logInfo() << "tracking with the fitted body (body version " << body_.version << ")";
}

TrackedBody Pipeline::trackedBody() const {
  std::lock_guard lock(body_mutex_);
  return applied_body_;
}

Pipeline::ReacquireError Pipeline::reacquire() {
  if (config_.replay()) return ReacquireError::kReplay;
  if (!can_acquire_) return ReacquireError::kCannotPlace;
  reacquire_requested_ = true;
  return ReacquireError::kNone;
}

Pipeline::~Pipeline() {
  stop();
  // stop() returns early if never started
  if (save_thread_.joinable()) save_thread_.join();
  if (fit_thread_.joinable()) fit_thread_.join();
}

void Pipeline::setPoseObserver(std::function<void(const Pose&)> observer) {
  observer_ = std::move(observer);
}

void Pipeline::setMaskObserver(MaskObserver observer) { mask_observer_ = std::move(observer); }

std::string Pipeline::backgroundFile(std::size_t camera) const {
  if (config_.background_directory.empty() || camera >= cameras_.size()) return "";
  const OpenedCamera& opened = cameras_[camera];
  const std::string id =
      opened.info.id.empty() ? "camera" + std::to_string(camera) : opened.info.id;
  const std::string driver = opened.info.driver.empty() ? opened.config.driver : opened.info.driver;
  return (std::filesystem::path(config_.background_directory) /
          (fileNamePart(driver + "-" + id) + kBackgroundSuffix))
      .string();
}

const char* Pipeline::withoutBackgroundIs() const {
  return config_.threshold_before_background ? "thresholded" : "not tracked";
}

std::string Pipeline::withoutBackground(const std::string& why) const {
  std::string source = config_.threshold_before_background
                           ? "threshold"
                           : "none: waiting for a background (CaptureBackground, nobody in view)";
  return why.empty() ? source : source + " (" + why + ")";
}

void Pipeline::setSilhouetteSource(std::size_t camera, std::string source) {
  if (ground_truth_) return;  // the scene's true silhouettes are used whatever the background
  std::lock_guard lock(silhouette_mutex_);
  silhouette_sources_[camera] = std::move(source);
}

void Pipeline::warnBackground(const std::string& warning) {
  logWarning() << warning;
  std::lock_guard lock(silhouette_mutex_);
  background_warnings_.push_back(warning);
}

void Pipeline::loadBackgrounds() {
  std::set<std::string> expected;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const std::string path = backgroundFile(c);
    if (!expected.insert(std::filesystem::path(path).filename().string()).second)
      throw std::invalid_argument("cameras[" + std::to_string(c) + "] (" + cameras_[c].info.id +
                                  ") would share its background file " + path +
                                  " with another camera");
  }
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    const std::string path = backgroundFile(c);
    std::error_code error;
    if (!std::filesystem::exists(path, error)) continue;
    const std::string fallback = "; cameras[" + std::to_string(c) + "] is " +
                                 withoutBackgroundIs() + " until the next CaptureBackground";
    BackgroundModel model;
    try {
      model = loadBackground(path);
    } catch (const std::exception& e) {
      warnBackground("background file unusable: " + std::string(e.what()) + fallback);
      setSilhouetteSource(c, withoutBackground(path + " unusable"));
      continue;
    }
    const CameraConfig& camera = cameras_[c].config;
    const int channels = camera.pixel_format == "GREY" ? 1 : model.channels();
    if (model.size() != cv::Size(camera.width, camera.height) || model.channels() != channels) {
      warnBackground(
          "background file unusable: " + path + ": it is " + std::to_string(model.size().width) +
          "x" + std::to_string(model.size().height) + " with " + std::to_string(model.channels()) +
          " channel(s) but cameras[" + std::to_string(c) + "] is " + std::to_string(camera.width) +
          "x" + std::to_string(camera.height) + (camera.pixel_format == "GREY" ? " gray" : "") +
          fallback);
      setSilhouetteSource(c, withoutBackground(path + " does not fit this camera"));
      continue;
    }
    useBackground(c, std::make_shared<const BackgroundModel>(std::move(model)));
    logInfo() << "cameras[" << c << "]: background loaded from " << path;
    setSilhouetteSource(c, "background loaded from " + path);
  }
  // A file no camera claims is most likely a camera since removed or renamed: said, not deleted.
  std::string known;
  for (const std::string& file : expected) known += (known.empty() ? "" : ", ") + file;
  std::error_code error;
  for (const auto& entry :
       std::filesystem::directory_iterator(config_.background_directory, error)) {
    const std::string name = entry.path().filename().string();
    if (name.front() == '.' || !name.ends_with(kBackgroundSuffix) || expected.count(name)) continue;
    warnBackground("background file ignored: " + entry.path().string() +
                   ": no configured camera saves to it (the cameras' files are " + known + ")");
  }
}

Status Pipeline::start() {
  if (running_.exchange(true)) return Status::Error("the pipeline is already running");
  {
    std::lock_guard lock(capture_mutex_);
    accepting_captures_ = true;
  }
  mask_thread_ = std::thread([this] { maskLoop(); });
  tracker_thread_ = std::thread([this] { trackerLoop(); });
  publisher_thread_ = std::thread([this] { publisherLoop(); });
  if (replay_) {
    replay_thread_ = std::thread([this] { replayLoop(); });
    return Status::Ok();
  }
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    RateMeter* rate = camera_rates_[c].get();
    FrameSynchronizer* synchronizer = synchronizer_.get();
    const Status started = cameras_[c].camera->start(
        [rate, synchronizer](Frame&& frame) {
          rate->tick(monotonicNowNs());
          synchronizer->push(std::move(frame));
        },
        [](int camera, const std::string& message) {
          logWarning() << "camera " << camera << ": " << message;
        });
    if (!started.ok()) {
      const std::string message = "cameras[" + std::to_string(c) + "] (" +
                                  cameras_[c].config.driver + " " + cameras_[c].config.device +
                                  "): " + started.message();
      stop();
      return Status::Error(message);
    }
    started_cameras_.push_back(static_cast<int>(c));
  }
  return Status::Ok();
}

void Pipeline::stop() {
  if (!running_.exchange(false)) return;
  for (int c : started_cameras_) cameras_[c].camera->stop();
  started_cameras_.clear();
  stop_replay_ = true;
  synchronizer_->close();
  if (replay_thread_.joinable()) replay_thread_.join();
  input_closed_ = true;
  // Each stage closes its output when its input is closed and drained.
  if (mask_thread_.joinable()) mask_thread_.join();
  if (tracker_thread_.joinable()) tracker_thread_.join();
  if (publisher_thread_.joinable()) publisher_thread_.join();
  if (save_thread_.joinable()) save_thread_.join();
  stopRecording();
  // The mask thread, which starts fits, has ended: a fit under way is the last; it stops at its
  // next frame set's search (well under a second).
  stop_fit_ = true;
  if (fit_thread_.joinable()) fit_thread_.join();
}

void Pipeline::replayLoop() {
  ReplayPumpOptions options;
  options.real_time = !config_.as_fast_as_possible;
  options.stop = &stop_replay_;
  const Status pumped = pumpSession(*replay_, *synchronizer_, options);
  if (!pumped.ok()) logError() << "replay: " << pumped.message();
  input_closed_ = true;
}

void Pipeline::waitForReplayEnd() {
  std::unique_lock lock(drained_mutex_);
  drained_signal_.wait(lock, [&] { return drained_; });
}

SilhouetteMask Pipeline::thresholdMask(const cv::Mat& image) {
  cv::Mat gray = image;
  if (image.channels() == 3) cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  cv::Mat binary;
  cv::threshold(gray, binary, 127, 255, cv::THRESH_BINARY);
  return SilhouetteMask(binary);
}

void Pipeline::captureBackground(int frames, std::function<void(const BackgroundResult&)> done) {
  if (replay_) {
    // Replay must give the same poses every run, from the recorded frames alone.
    done({BackgroundError::kReplay, "background capture needs live cameras, not a replay", 0, {}});
    return;
  }
  auto capture = std::make_unique<BackgroundCapture>();
  capture->frames = frames;
  capture->done = std::move(done);
  capture->learners.resize(cameras_.size());
  capture->last_progress_ns = monotonicNowNs();
  std::unique_lock lock(capture_mutex_);
  if (!accepting_captures_) {
    lock.unlock();
    capture->done({BackgroundError::kStopped, "the pipeline is not running", 0, {}});
    return;
  }
  if (capture_busy_) {
    lock.unlock();
    capture->done({BackgroundError::kBusy, "a background capture is already under way", 0, {}});
    return;
  }
  capture_busy_ = true;
  capture_request_ = std::move(capture);
}

void Pipeline::fitBody(int frame_sets, bool apply, std::function<void(const FitBodyResult&)> done) {
  const BodyModel& model = fitModel();
  if (!model.fit_pose) {
    done(fitFailure(BodyFitError::kCannotFit,
                    "the body model '" + model.name +
                        "' has no fit_pose (the pose a subject stands in while the body is "
                        "fitted)"));
    return;
  }
  if (!canAcquire(model)) {
    done(fitFailure(BodyFitError::kCannotFit, whyCannotAcquire(model)));
    return;
  }
  if (apply && config_.replay()) {
    done(fitFailure(BodyFitError::kCannotApply,
                    "apply: a replay tracks the session's body (its poses depend on the recording "
                    "alone); fit without apply"));
    return;
  }
  auto collection = std::make_unique<BodyFitCollection>();
  collection->frame_sets = std::max(frame_sets, 1);
  collection->apply = apply;
  collection->every = std::max(
      1, static_cast<int>(std::lround(kFitSetIntervalSeconds * cameras_.front().config.fps)));
  collection->done = std::move(done);
  collection->last_progress_ns = monotonicNowNs();
  FitBodyResult refusal;
  {
    std::lock_guard session(session_body_mutex_);
    bool recording = false;
    if (apply) {
      std::lock_guard lock(recording_mutex_);
      recording = recorder_ != nullptr;
    }
    std::lock_guard lock(capture_mutex_);
    if (!accepting_captures_) {
      refusal = fitFailure(BodyFitError::kStopped, "the pipeline is not running");
    } else if (fit_busy_) {
      refusal =
          fitFailure(BodyFitError::kBusy, "a body fit is already under way; wait for its answer");
    } else if (recording) {
      refusal = fitFailure(BodyFitError::kCannotApply,
                           "apply: a recording is open, and a session stores one body; stop it "
                           "first, or fit without apply");
    } else {
      fit_busy_ = true;
      fit_applies_ = apply;
      fit_request_ = std::move(collection);
      return;
    }
  }
  collection->done(refusal);
}

bool Pipeline::collectForFit(BodyFitCollection& collection,
                             const std::vector<SilhouetteMask>* masks) {
  const int64_t now = monotonicNowNs();
  if (masks) {
    // Sets spaced out, so a subject turning in the fit pose is seen from several sides.
    if (collection.seen++ % collection.every == 0) collection.frames.push_back(*masks);
    collection.last_progress_ns = now;
  }
  if (static_cast<int>(collection.frames.size()) >= collection.frame_sets) {
    // The fit before this one ended its request before this could be made: it is finishing.
    if (fit_thread_.joinable()) fit_thread_.join();
    fit_thread_ = std::thread(
        [this, collected = std::move(collection)]() mutable { runBodyFit(std::move(collected)); });
    return true;
  }
  if (now - collection.last_progress_ns < kFitStallNs) return false;
  endBodyFit(collection.done,
             fitFailure(BodyFitError::kStalled,
                        "no frame set with every camera's silhouettes for " +
                            std::to_string(kFitStallNs / 1'000'000'000) +
                            " s (a stalled camera, or one still waiting for a background); " +
                            "frame sets collected: " + std::to_string(collection.frames.size()) +
                            " of " + std::to_string(collection.frame_sets)));
  return true;
}

void Pipeline::runBodyFit(BodyFitCollection collection) {
  FitBodyResult result;
  result.frame_sets_used = static_cast<int>(collection.frames.size());
  const int64_t start = monotonicNowNs();
  try {
    const BodyModel& model = fitModel();
    std::string why_not;
    BodyFitOptions options;
    options.should_stop = [this] { return stop_fit_.load(); };
    const std::optional<BodyFit> fit =
        fitBodyInPose(model, rig_, collection.frames, config_.tracker.filterOptions().likelihood,
                      options, &why_not);
    if (fit) {
      // The sets the subject was found in (fitBodyInPose leaves the others out).
      result.frame_sets_used = static_cast<int>(fit->poses.size());
      result.fit = *fit;
      result.body = proportionedBodyModel(model, fit->proportions);
      if (collection.apply) {
        // On the tracked body as configured (gait's frozen DOFs stay frozen), so fits do not
        // compound.
        auto applied =
            std::make_shared<const BodyModel>(proportionedBodyModel(model_, fit->proportions));
        std::lock_guard lock(body_mutex_);
        applied_body_ = {std::move(applied), applied_body_.version + 1};
        result.body_version = applied_body_.version;
        body_switch_pending_ = true;
      }
    } else {
      result.error = BodyFitError::kNoSubject;
      result.message = "no subject found standing in the fit pose: " + why_not;
    }
  } catch (const BodyFitStopped&) {
    result.error = BodyFitError::kStopped;
    result.message = "the pipeline stopped during the body fit";
  } catch (const std::exception& error) {
    result.error = BodyFitError::kFailed;
    result.message = std::string("the body fit failed: ") + error.what();
  }
  result.fit_seconds = static_cast<double>(monotonicNowNs() - start) / 1e9;
  if (result.error == BodyFitError::kNone) {
    std::ostringstream proportions;
    for (int k = 0; k < BodyProportions::kCount; ++k)
      proportions << (k ? ", " : "") << BodyProportions::name(k) << " " << std::fixed
                  << std::setprecision(3) << result.fit.proportions[k];
    logInfo() << "body fitted from " << result.frame_sets_used << " frame sets in " << std::fixed
              << std::setprecision(1) << result.fit_seconds << " s: " << proportions.str();
  }
  endBodyFit(collection.done, result);
}

void Pipeline::endBodyFit(const std::function<void(const FitBodyResult&)>& done,
                          const FitBodyResult& result) {
  {
    std::lock_guard lock(capture_mutex_);
    fit_busy_ = false;
    fit_applies_ = false;
  }
  done(result);
}

void Pipeline::learnBackground(BackgroundCapture& capture, std::size_t camera,
                               const cv::Mat& image) {
  BackgroundLearner& learner = capture.learners[camera];
  if (learner.frames() >= capture.frames) return;
  if (learner.add(image)) capture.last_progress_ns = monotonicNowNs();
}

void Pipeline::endCapture(const std::function<void(const BackgroundResult&)>& done,
                          const BackgroundResult& result) {
  {
    std::lock_guard lock(capture_mutex_);
    capture_busy_ = false;
  }
  done(result);
}

bool Pipeline::finishBackground(BackgroundCapture& capture) {
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
  std::vector<std::unique_ptr<SilhouetteExtractor>> extractors;
  try {
    for (const BackgroundLearner& learner : capture.learners) {
      models.push_back(std::make_shared<const BackgroundModel>(learner.model()));
      extractors.push_back(std::make_unique<SilhouetteExtractor>(*models.back()));
    }
  } catch (const std::exception& error) {
    endCapture(capture.done, {BackgroundError::kUnusable, error.what(), 0, {}});
    return true;
  }
  const std::vector<std::shared_ptr<const BackgroundModel>> replaced = backgrounds_in_use_;
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    useBackground(c, models[c], std::move(extractors[c]));
    setSilhouetteSource(c, "background captured");
  }
  // Installed anyway: the operator, told, decides whether to capture again.
  BackgroundResult learned{BackgroundError::kNone, "", capture.frames, {}};
  // Notes camera c's share in `shares` (after `label`) and warns, naming the camera, if it is over
  // the limit.
  const auto judge = [&](std::size_t c, double share, std::ostringstream& shares,
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
    judge(c, unsteadyShare(*models[c]), shares, "",
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
    judge(c,
          changedShare(*before, *models[c], extraction.threshold_sigmas, extraction.min_difference),
          changed_shares, "camera " + std::to_string(c) + " ",
          "differs from the background it replaces (someone in view, or the room or its lighting "
          "changed?): if someone stood in view, capture again with the room empty");
  }
  logInfo() << "background learned from " << capture.frames
            << " frames per camera; changed during the capture: " << shares.str()
            << (changed_shares.tellp() > 0 ? "; from the background replaced: " : "")
            << changed_shares.str();
  if (config_.background_directory.empty()) {
    endCapture(capture.done, learned);
    return true;
  }
  // The previous saver ended its capture before this one could start: it is finishing or done.
  if (save_thread_.joinable()) save_thread_.join();
  save_thread_ = std::thread([this, models = std::move(models), learned = std::move(learned),
                              done = std::move(capture.done)]() mutable {
    saveBackgrounds(std::move(models), std::move(learned), std::move(done));
  });
  return true;
}

void Pipeline::useBackground(std::size_t camera, std::shared_ptr<const BackgroundModel> background,
                             std::unique_ptr<SilhouetteExtractor> extractor) {
  if (background && !extractor) extractor = std::make_unique<SilhouetteExtractor>(*background);
  extractors_[camera] = std::move(extractor);
  std::lock_guard lock(recording_mutex_);
  if (recorder_)
    recorder_->writeBackground(static_cast<int>(camera), next_frame_sequences_[camera], background);
  backgrounds_in_use_[camera] = std::move(background);
}

void Pipeline::replayBackgrounds(std::size_t camera, uint64_t frame_sequence) {
  const std::vector<SessionBackground>& recorded = replay_->backgrounds();
  // Each camera's lines are in order of from_sequence and its frames come in order of sequence.
  std::size_t& next = next_replayed_backgrounds_[camera];
  for (; next < recorded.size(); ++next) {
    const SessionBackground& line = recorded[next];
    if (static_cast<std::size_t>(line.camera) != camera) continue;
    if (line.from_sequence > frame_sequence) break;
    useBackground(camera, line.model);  // a recording of the replay keeps it too
    setSilhouetteSource(camera, line.model
                                    ? "background recorded in the session (" + line.file + ")"
                                    : withoutBackground("the session recorded none from here"));
  }
}

void Pipeline::saveBackgrounds(std::vector<std::shared_ptr<const BackgroundModel>> models,
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

void Pipeline::maskLoop() {
  // A camera missing from a set keeps its previous silhouette: the tracker degrades gracefully
  // instead of seeing an empty view.
  std::vector<SilhouetteMask> latest(cameras_.size());
  for (std::size_t c = 0; c < cameras_.size(); ++c)
    latest[c] = SilhouetteMask(cv::Mat::zeros(rig_[c].height, rig_[c].width, CV_8UC1));
  std::vector<bool> size_warned(cameras_.size(), false);
  // Per camera: whether `latest` holds silhouettes (the truth, extracted or thresholded ones).
  std::vector<bool> has_silhouettes(cameras_.size(), ground_truth_ != nullptr);
  std::unique_ptr<BackgroundCapture> capture;
  std::unique_ptr<BodyFitCollection> fit;
  while (true) {
    {
      std::lock_guard lock(capture_mutex_);
      if (!capture) capture = std::move(capture_request_);
      if (!fit) fit = std::move(fit_request_);
    }
    // Also checked without frames, so a capture or a fit on stalled cameras ends.
    if (capture && finishBackground(*capture)) capture.reset();
    if (fit && collectForFit(*fit, nullptr)) fit.reset();
    std::optional<FrameSet> set = synchronizer_->pop(kPollInterval);
    if (!set) {
      if (!input_closed_) continue;
      // The input closed before it set the flag: whatever is left comes without waiting.
      set = synchronizer_->pop(std::chrono::nanoseconds(0));
      if (!set) break;
    }
    MaskSet masks{set->sequence, 0, set->timestamp_ns, {}};
    for (const std::optional<Frame>& frame : set->frames) {
      if (!frame) continue;
      masks.frame_sequence = frame->sequence;
      break;
    }
    {
      std::lock_guard lock(recording_mutex_);
      for (std::size_t c = 0; c < set->frames.size() && c < cameras_.size(); ++c) {
        if (!set->frames[c]) continue;
        camera_cv_types_[c] = set->frames[c]->image.type();
        next_frame_sequences_[c] = set->frames[c]->sequence + 1;
      }
      if (recorder_) {
        SetTruth truth{masks.frame_sequence, {}};
        if (reference_pose_) truth.dofs = reference_pose_(masks.frame_sequence);
        recorder_->write(*set, std::move(truth));
      }
    }
    std::optional<uint64_t> truth_sequence;
    std::vector<cv::Mat> truth;
    for (std::size_t c = 0; c < cameras_.size(); ++c) {
      if (c >= set->frames.size() || !set->frames[c]) continue;
      const cv::Mat& image = set->frames[c]->image;
      if (image.cols != rig_[c].width || image.rows != rig_[c].height || image.depth() != CV_8U) {
        if (!size_warned[c]) {
          logWarning() << "camera " << c << " delivers " << image.cols << "x" << image.rows
                       << " images but is calibrated for " << rig_[c].width << "x" << rig_[c].height
                       << "; its frames are ignored";
          size_warned[c] = true;
        }
        continue;
      }
      if (capture) learnBackground(*capture, c, image);
      if (ground_truth_) {
        // The frames of one set normally share the scene's frame number: rendered once.
        if (truth_sequence != set->frames[c]->sequence) {
          truth_sequence = set->frames[c]->sequence;
          truth = ground_truth_(*truth_sequence);
        }
        if (c < truth.size()) latest[c] = SilhouetteMask(truth[c]);
        continue;
      }
      if (replay_) replayBackgrounds(c, set->frames[c]->sequence);
      if (extractors_[c] && !extractors_[c]->extract(image)) {
        // A background of another format (the camera's pixel format changed since it was saved):
        // no silhouettes, or thresholded ones, beat silhouettes frozen at the last good frame.
        logWarning() << "camera " << c
                     << ": silhouette extraction failed: " << extractors_[c]->lastError() << "; "
                     << withoutBackgroundIs() << " until the next capture";
        setSilhouetteSource(
            c, withoutBackground("background unusable: " + extractors_[c]->lastError()));
        useBackground(c, nullptr);
      }
      if (extractors_[c] || config_.threshold_before_background) {
        latest[c] = extractors_[c] ? extractors_[c]->silhouette() : thresholdMask(image);
        has_silhouettes[c] = true;
      } else {
        has_silhouettes[c] = false;
      }
    }
    if (std::find(has_silhouettes.begin(), has_silhouettes.end(), false) != has_silhouettes.end()) {
      tracking_ = false;  // nothing to track until every camera has a background
      continue;
    }
    if (mask_observer_) mask_observer_(*set, latest);
    if (fit && collectForFit(*fit, &latest)) fit.reset();
    masks.masks = latest;
    masks_.push(std::move(masks));
  }
  std::unique_ptr<BackgroundCapture> pending;
  std::unique_ptr<BodyFitCollection> pending_fit;
  {
    std::lock_guard lock(capture_mutex_);
    accepting_captures_ = false;
    pending = std::move(capture_request_);
    pending_fit = std::move(fit_request_);
  }
  if (!capture) capture = std::move(pending);
  if (capture)
    endCapture(capture->done, {BackgroundError::kStopped, "the pipeline stopped", 0, {}});
  if (!fit) fit = std::move(pending_fit);
  if (fit) {
    endBodyFit(fit->done,
               fitFailure(BodyFitError::kStopped,
                          "the pipeline stopped after " + std::to_string(fit->frames.size()) +
                              " of " + std::to_string(fit->frame_sets) + " frame sets"));
  }
  masks_.close();
}

void Pipeline::trackerLoop() {
  while (true) {
    std::optional<MaskSet> masks = masks_.pop(kPollInterval);
    if (!masks) {
      if (masks_.closed()) break;
      continue;
    }
    if (body_switch_pending_.exchange(false)) switchToAppliedBody();
    if (reacquire_requested_.exchange(false)) acquiring_->reacquire();
    const FrameEstimate estimate = filter_->step(masks->masks);
    if (acquiring_) {
      acquisitions_ = static_cast<uint64_t>(earlier_acquisitions_ + acquiring_->acquisitions());
      losses_ = static_cast<uint64_t>(earlier_losses_ + acquiring_->losses());
      std::lock_guard lock(search_mutex_);
      search_failure_ = acquiring_->lastFailure();
    }
    tracking_ = estimate.found;
    if (!estimate.found) continue;  // no subject in view: nothing to publish
    const BodyModel& body = *body_.model;
    forwardKinematics(body, kinematics_, estimate.q);
    auto pose = std::make_shared<Pose>();
    pose->frame_sequence = masks->sequence;
    pose->capture_monotonic_ns = masks->timestamp_ns;
    pose->body_version = body_.version;
    pose->points = pointPositions(body, kinematics_);
    pose->orientations.reserve(body.segments.size());
    for (const Eigen::Isometry3d& world : kinematics_.world)
      pose->orientations.emplace_back(world.rotation());
    pose->dofs = estimate.q;
    pose->score = estimate.best_log_weight;
    pose->spread = estimate.spread;
    if (!std::isnan(estimate.silhouette_fit)) pose->silhouette_fit = estimate.silhouette_fit;
    if (const Eigen::VectorXd reference =
            reference_pose_ ? reference_pose_(masks->frame_sequence) : Eigen::VectorXd();
        reference.size() == static_cast<long>(model_.dofs.size())) {
      const BodyModel& subject = reference_model_ ? *reference_model_ : model_;
      forwardKinematics(subject, reference_kinematics_, reference);
      const std::vector<Eigen::Vector3d> truth = pointPositions(subject, reference_kinematics_);
      double sum = 0;
      for (std::size_t p = 0; p < truth.size(); ++p) sum += (truth[p] - pose->points[p]).norm();
      pose->reference_error_mm = truth.empty() ? 0.0 : 1000 * sum / truth.size();
    }
    evaluations_per_frame_ = static_cast<double>(estimate.evaluations);
    if (estimate.cut_short) ++refinements_cut_;
    tracker_rate_.tick(monotonicNowNs());
    poses_.push(std::move(pose));
  }
  poses_.close();
}

void Pipeline::publisherLoop() {
  while (true) {
    std::optional<std::shared_ptr<Pose>> pose = poses_.pop(kPollInterval);
    if (!pose) {
      if (poses_.closed()) break;
      continue;
    }
    Pose& p = **pose;
    const int64_t now = monotonicNowNs();
    p.publish_monotonic_ns = now;
    p.capture_wall_ns = wallNowNs() - (now - p.capture_monotonic_ns);
    // Replayed timestamps are from the recording's past: no latency to measure.
    if (!config_.replay()) latency_.add(now - p.capture_monotonic_ns);
    if (observer_) observer_(p);
    publisher_.publish(std::move(*pose));
    ++poses_published_;
  }
  std::lock_guard lock(drained_mutex_);
  drained_ = true;
  drained_signal_.notify_all();
}

RecordingStatus Pipeline::recordingStatusLocked() const {
  if (!recorder_) return last_recording_;
  RecordingStatus status;
  status.active = true;
  status.path = recording_path_;
  status.frame_sets = recorder_->stats().sets_written;
  status.started_wall_ns = recording_started_wall_ns_;
  return status;
}

RecordingResult Pipeline::startRecording(const std::string& relative_path) {
  RecordingResult result;
  if (config_.recording_directory.empty()) {
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
  const Expected<std::filesystem::path> inside =
      resolveInsideRoot(config_.recording_directory, requested);
  if (!inside.ok()) return {RecordingError::kOutsideRoot, inside.error(), {}};
  if (std::filesystem::exists(inside.value()))
    return {RecordingError::kBusy, "session " + relative_path + " already exists", {}};
  std::lock_guard session(session_body_mutex_);
  {
    std::lock_guard lock(capture_mutex_);
    if (fit_applies_) {
      return {RecordingError::kBusy,
              "a body fit that will change the tracked body is under way (FitBody with apply); "
              "record once it has answered",
              {}};
    }
  }

  std::vector<SessionCamera> cameras;
  std::vector<std::shared_ptr<const BackgroundModel>> backgrounds;
  {
    std::lock_guard lock(recording_mutex_);
    if (recorder_) return {RecordingError::kBusy, "already recording to " + recording_path_, {}};
    backgrounds = backgrounds_in_use_;
    for (std::size_t c = 0; c < cameras_.size(); ++c) {
      if (camera_cv_types_[c] < 0)
        return {
            RecordingError::kBusy, "camera " + std::to_string(c) + " has sent no frame yet", {}};
      SessionCamera camera;
      camera.name = cameras_[c].info.id;
      camera.width = cameras_[c].config.width;
      camera.height = cameras_[c].config.height;
      camera.pixel_format = camera_cv_types_[c] == CV_8UC1 ? kPixelGray : kPixelBgr;
      camera.fps = cameras_[c].config.fps;
      cameras.push_back(camera);
    }
  }
  // Opening writes files: done outside the lock so the mask thread never waits on the disk.
  auto recorder = std::make_unique<Recorder>(config_.recording_directory);
  SessionTracking tracking;
  const TrackedBody body = trackedBody();
  tracking.body = body.model.get();
  tracking.tracker_settings = config_.tracker.keyValues();
  if (reference_pose_) {
    for (const Dof& dof : model_.dofs) tracking.truth_dofs.push_back(dof.name);
    // The truth is of the subject's own body when it has one, else of the configured body, which
    // a fitted body applied since is not.
    if (reference_model_)
      tracking.truth_body = reference_model_.get();
    else if (body.version > 0)
      tracking.truth_body = &model_;
  }
  const Status opened = recorder->open(requested, rig_, cameras, tracking);
  if (!opened.ok()) return {RecordingError::kIo, opened.message(), {}};
  std::lock_guard lock(recording_mutex_);
  if (recorder_) return {RecordingError::kBusy, "already recording to " + recording_path_, {}};
  recorder_ = std::move(recorder);
  // The backgrounds in use now apply from each camera's first recorded frame (later ones, from
  // useBackground, from a later frame).
  for (std::size_t c = 0; c < cameras_.size(); ++c)
    if (backgrounds_in_use_[c]) recorder_->writeBackground(static_cast<int>(c), 0, backgrounds_in_use_[c]);
  recording_path_ = relative_path;
  recording_started_wall_ns_ = wallNowNs();
  logInfo() << "recording to " << recorder_->sessionPath().string();
  result.status = recordingStatusLocked();
  return result;
}

RecordingResult Pipeline::stopRecording() {
  std::unique_ptr<Recorder> recorder;
  RecordingStatus final_status;
  {
    std::lock_guard lock(recording_mutex_);
    if (!recorder_)
      return {RecordingError::kNotRecording, "no recording is running", last_recording_};
    final_status = recordingStatusLocked();
    recorder = std::move(recorder_);
  }
  // Flushing the queue to disk happens outside the lock, while the mask thread goes on.
  const Status closed = recorder->close();
  final_status.active = false;
  final_status.frame_sets = recorder->stats().sets_written;
  const RecorderStats stats = recorder->stats();
  {
    std::lock_guard lock(recording_mutex_);
    last_recording_ = final_status;
  }
  logInfo() << "recording " << recorder->sessionPath().string() << " closed: " << stats.sets_written
            << " frame sets written, " << stats.sets_dropped << " dropped (disk too slow)";
  if (!closed.ok()) return {RecordingError::kIo, closed.message(), final_status};
  return {RecordingError::kNone, "", final_status};
}

PipelineStatus Pipeline::status() const {
  PipelineStatus status;
  const int64_t now = monotonicNowNs();
  status.running = running_;
  const SyncStats sync = synchronizer_->stats();
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    CameraRuntimeStatus camera;
    camera.measured_fps = camera_rates_[c]->rate(now);
    const int64_t since = camera_rates_[c]->sinceLast(now);
    camera.streaming = since >= 0 && since <= RateMeter::kWindowNs;
    if (c < sync.cameras.size()) camera.sync = sync.cameras[c];
    status.cameras.push_back(camera);
  }
  {
    std::lock_guard lock(silhouette_mutex_);
    for (std::size_t c = 0; c < cameras_.size(); ++c)
      status.cameras[c].silhouettes = silhouette_sources_[c];
    status.background_warnings = background_warnings_;
  }
  status.tracker_fps = tracker_rate_.rate(now);
  status.poses_published = poses_published_;
  status.frame_sets_skipped = sync.sets_superseded + masks_.superseded() + poses_.superseded();
  status.evaluations_per_frame = evaluations_per_frame_;
  status.tracking = tracking_;
  status.acquisitions = acquisitions_;
  status.losses = losses_;
  {
    std::lock_guard lock(search_mutex_);
    status.search_failure = search_failure_;
  }
  status.refinements_cut = refinements_cut_;
  status.latency = latency_.summary();
  std::lock_guard lock(recording_mutex_);
  status.recording = recordingStatusLocked();
  return status;
}

}  // namespace mocap
