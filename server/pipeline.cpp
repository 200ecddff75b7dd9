// The capture-to-pose pipeline: stage threads, hand-offs, the wiring of its components and the
// meters.
#include "server/pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "drivers/fake/replay_pump.h"
#include "drivers/thread_name.h"
#include "server/log.h"

namespace mocap {
namespace {

// How often a stage waiting for input rechecks whether the pipeline is stopping.
constexpr auto kPollInterval = std::chrono::milliseconds(100);

// The true pose of a frame: as given, else a replayed session's stored truth (if any).
std::function<Eigen::VectorXd(uint64_t)> referencePose(
    std::function<Eigen::VectorXd(uint64_t)> given,
    const std::shared_ptr<const SessionReader>& replay) {
  if (given || !replay || !replay->hasTruth()) return given;
  return [session = replay](uint64_t frame_sequence) {
    const Eigen::VectorXd* truth = session->truth(frame_sequence);
    return truth ? *truth : Eigen::VectorXd();
  };
}

}  // namespace

Pipeline::Pipeline(const ServerConfig& config, const BodyModel& model, const Rig& rig,
                   PipelineInputs inputs, PosePublisher& publisher)
    : config_(config),
      model_(model),
      rig_(rig),
      cameras_(std::move(inputs.cameras)),
      replay_(std::move(inputs.replay)),
      true_silhouettes_(inputs.ground_truth != nullptr),
      reference_pose_(referencePose(std::move(inputs.reference_pose), replay_)),
      reference_model_(std::move(inputs.reference_model)),
      publisher_(publisher),
      masks_(config.replay() ? Handoff<MaskSet>::Mode::kLossless
                             : Handoff<MaskSet>::Mode::kLatestWins),
      poses_(config.replay() ? Handoff<std::shared_ptr<Pose>>::Mode::kLossless
                             : Handoff<std::shared_ptr<Pose>>::Mode::kLatestWins),
      recording_(config_, rig_, cameras_,
                 RecordedTracking{&model_, reference_model_, reference_pose_,
                                  [this] { return body_fit_.appliedBody(); }},
                 std::move(inputs.scene_backgrounds)),
      body_fit_(config_, model_, rig_, std::move(inputs.fit_model),
                cameras_.empty() ? 0.0 : cameras_.front().config.fps, recording_),
      backgrounds_(config_, cameras_, replay_, std::move(inputs.ground_truth), recording_),
      can_acquire_(canAcquire(model)),
      finds_subject_(inputs.acquire),
      kinematics_(model),
      reference_kinematics_(reference_model_ ? *reference_model_ : model) {
  if (cameras_.empty()) throw std::invalid_argument("no cameras");
  checkRig();
  for (std::size_t c = 0; c < cameras_.size(); ++c)
    camera_rates_.push_back(std::make_unique<RateMeter>());
  backgrounds_.initialize();
  synchronizer_ = makeSynchronizer();

  pool_ = std::make_unique<WorkerPool>(config.tracker.threads);
  body_ = body_fit_.appliedBody();
  makeTrackerFilter(false);
  if (finds_subject_) {
    if (!acquiring_) throw std::invalid_argument("tracker.start: the body's root cannot be placed");
    tracking_ = false;
  } else {
    filter_->reset(inputs.initial_pose.size() == static_cast<long>(model_.dofs.size())
                       ? inputs.initial_pose
                       : model_.neutralPose());
  }
}

void Pipeline::checkRig() const {
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
  }
}

std::unique_ptr<FrameSynchronizer> Pipeline::makeSynchronizer() const {
  SyncConfig sync;
  sync.camera_count = static_cast<int>(cameras_.size());
  // A fake scene in slow motion delivers its frames that many periods apart.
  const double slow_motion = replay_ ? 1.0 : config_.scene_slow_motion;
  sync.frame_period = std::chrono::nanoseconds(
      static_cast<int64_t>(1e9 * slow_motion / cameras_.front().config.fps));
  if (config_.sync.tolerance_ms)
    sync.tolerance =
        std::chrono::nanoseconds(static_cast<int64_t>(*config_.sync.tolerance_ms * 1e6));
  if (config_.sync.deadline_ms)
    sync.deadline = std::chrono::nanoseconds(static_cast<int64_t>(*config_.sync.deadline_ms * 1e6));
  sync.mode = replay_ ? SyncMode::kReplay : SyncMode::kLive;
  Expected<std::unique_ptr<FrameSynchronizer>> created = FrameSynchronizer::create(sync);
  if (!created.ok()) throw std::invalid_argument("synchronizer: " + created.error());
  return std::move(created.value());
}

void Pipeline::makeTrackerFilter(bool in_fit_pose) {
  const FilterOptions options = config_.tracker.filter;
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
    // Challenges belong to finding the subject: a track from a given first pose (the fake scene's
    // lab path) has none, as in the experiment.
    acquiring_options.challenge_every = finds_subject_ ? config_.tracker.challenge_every : 0;
    acquiring_options.trial_drop_margin = config_.tracker.trial_drop_margin;
    acquiring_options.search.uncross = options.refine.uncross;
    // With one tracker thread the hypotheses' filters share a pool that runs inline, so a
    // challenge's rivals can take the second core on the trial's slowest frame.
    acquiring_options.concurrent_rivals = config_.tracker.threads <= 1;
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
  TrackedBody applied = body_fit_.appliedBody();
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
  // on the fake scene's subject (see tracker/experiments/log/service.md).
  makeTrackerFilter(true);  // acquiring: fitBody fits only bodies that can be placed
  logInfo() << "tracking with the fitted body (body version " << body_.version << ")";
}

TrackedBody Pipeline::trackedBody() const { return body_fit_.appliedBody(); }

Pipeline::ReacquireError Pipeline::reacquire() {
  if (config_.replay()) return ReacquireError::kReplay;
  if (!can_acquire_) return ReacquireError::kCannotPlace;
  reacquire_requested_ = true;
  return ReacquireError::kNone;
}

Pipeline::~Pipeline() {
  stop();
  // stop() returns early if never started
  backgrounds_.joinSaver();
}

void Pipeline::setPoseObserver(std::function<void(const Pose&)> observer) {
  observer_ = std::move(observer);
}

void Pipeline::setMaskObserver(MaskObserver observer) { mask_observer_ = std::move(observer); }

Status Pipeline::start() {
  if (running_.exchange(true)) return Status::Error("the pipeline is already running");
  backgrounds_.open();
  body_fit_.open();
  mask_thread_ = std::thread([this] {
    nameThisThread("mocapd-mask");
    maskLoop();
  });
  tracker_thread_ = std::thread([this] {
    nameThisThread("mocapd-track");
    trackerLoop();
  });
  publisher_thread_ = std::thread([this] {
    nameThisThread("mocapd-publish");
    publisherLoop();
  });
  if (replay_) {
    replay_thread_ = std::thread([this] {
      nameThisThread("mocapd-replay");
      replayLoop();
    });
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
  backgrounds_.joinSaver();
  recording_.stop();
  body_fit_.stop();
}

void Pipeline::replayLoop() {
  ReplayPumpOptions options;
  options.real_time = !config_.as_fast_as_possible;
  options.silhouettes = config_.recorded_silhouettes;
  options.stop = &stop_replay_;
  const Status pumped = pumpSession(*replay_, *synchronizer_, options);
  if (!pumped.ok()) logError() << "replay: " << pumped.message();
  input_closed_ = true;
}

void Pipeline::waitForReplayEnd() {
  std::unique_lock lock(drained_mutex_);
  drained_signal_.wait(lock, [&] { return drained_; });
}

void Pipeline::maskLoop() {
  // A camera missing from a set keeps its previous silhouette: the tracker degrades gracefully
  // instead of seeing an empty view.
  std::vector<SilhouetteMask> latest(cameras_.size());
  for (std::size_t c = 0; c < cameras_.size(); ++c)
    latest[c] = SilhouetteMask(cv::Mat::zeros(rig_[c].height, rig_[c].width, CV_8UC1));
  std::vector<bool> size_warned(cameras_.size(), false);
  // Per camera: whether `latest` holds silhouettes (the truth, extracted or thresholded ones).
  std::vector<bool> has_silhouettes(cameras_.size(), true_silhouettes_);
  while (true) {
    backgrounds_.poll();
    body_fit_.poll();
    std::optional<FrameSet> set = synchronizer_->pop(kPollInterval);
    if (!set) {
      if (!input_closed_) continue;
      // The input closed before it set the flag: whatever is left comes without waiting.
      set = synchronizer_->pop(std::chrono::nanoseconds(0));
      if (!set) break;
    }
    MaskSet masks{set->sequence, 0, set->timestamp_ns, {}, {}};
    masks.stages.silhouettes_start_ns = monotonicNowNs();
    for (const std::optional<Frame>& frame : set->frames) {
      if (!frame) continue;
      masks.frame_sequence = frame->sequence;
      break;
    }
    recording_.tap(*set, masks.frame_sequence);
    updateSilhouettes(*set, latest, has_silhouettes, size_warned);
    if (std::find(has_silhouettes.begin(), has_silhouettes.end(), false) != has_silhouettes.end()) {
      tracking_ = false;  // nothing to track until every camera has a background
      continue;
    }
    if (mask_observer_) mask_observer_(*set, latest);
    body_fit_.add(latest, set->complete());
    masks.masks = latest;
    masks.stages.silhouettes_end_ns = monotonicNowNs();
    masks_.push(std::move(masks));
  }
  backgrounds_.close();
  body_fit_.close();
  masks_.close();
}

void Pipeline::updateSilhouettes(const FrameSet& set, std::vector<SilhouetteMask>& latest,
                                 std::vector<bool>& has_silhouettes,
                                 std::vector<bool>& size_warned) {
  for (std::size_t c = 0; c < cameras_.size(); ++c) {
    if (c >= set.frames.size() || !set.frames[c]) continue;
    const cv::Mat& image = set.frames[c]->image;
    // The session's silhouette of the frame; none is stored where live had none either (no
    // background yet), and then nothing is tracked, as live.
    if (config_.recorded_silhouettes && image.empty()) {
      has_silhouettes[c] = false;
      continue;
    }
    if (image.cols != rig_[c].width || image.rows != rig_[c].height || image.depth() != CV_8U) {
      if (!size_warned[c]) {
        logWarning() << "camera " << c << " delivers " << image.cols << "x" << image.rows
                     << " images but is calibrated for " << rig_[c].width << "x" << rig_[c].height
                     << "; its frames are ignored";
        size_warned[c] = true;
      }
      continue;
    }
    if (config_.recorded_silhouettes) {
      latest[c] = SilhouetteMask(image);
      has_silhouettes[c] = true;
      continue;
    }
    has_silhouettes[c] = backgrounds_.silhouette(c, image, set.frames[c]->sequence, latest[c]);
  }
}

void Pipeline::trackerLoop() {
  while (true) {
    std::optional<MaskSet> masks = masks_.pop(kPollInterval);
    if (!masks) {
      if (masks_.closed()) break;
      continue;
    }
    masks->stages.track_start_ns = monotonicNowNs();
    if (body_fit_.takeBodySwitch()) switchToAppliedBody();
    if (reacquire_requested_.exchange(false)) acquiring_->reacquire();
    const FrameEstimate estimate = filter_->step(masks->masks);
    masks->stages.track_end_ns = monotonicNowNs();
    if (acquiring_) {
      acquisitions_ = static_cast<uint64_t>(earlier_acquisitions_ + acquiring_->acquisitions());
      losses_ = static_cast<uint64_t>(earlier_losses_ + acquiring_->losses());
      std::lock_guard lock(search_mutex_);
      search_failure_ = acquiring_->lastFailure();
    }
    tracking_ = estimate.found;
    if (!estimate.found) continue;  // no subject in view: nothing to publish
    std::shared_ptr<Pose> pose = makePose(*masks, estimate);
    evaluations_per_frame_ = static_cast<double>(estimate.evaluations);
    if (estimate.cut_short) ++refinements_cut_;
    tracker_rate_.tick(monotonicNowNs());
    poses_.push(std::move(pose));
  }
  poses_.close();
}

std::shared_ptr<Pose> Pipeline::makePose(const MaskSet& masks, const FrameEstimate& estimate) {
  const BodyModel& body = *body_.model;
  forwardKinematics(body, kinematics_, estimate.q);
  auto pose = std::make_shared<Pose>();
  pose->frame_sequence = masks.sequence;
  pose->capture_monotonic_ns = masks.timestamp_ns;
  pose->stages = masks.stages;
  pose->body_version = body_.version;
  pose->body = body_.model;
  pose->points = pointPositions(body, kinematics_);
  pose->orientations.reserve(body.segments.size());
  for (const Eigen::Isometry3d& world : kinematics_.world)
    pose->orientations.emplace_back(world.rotation());
  pose->dofs = estimate.q;
  pose->score = estimate.best_log_weight;
  pose->spread = estimate.spread;
  if (!std::isnan(estimate.silhouette_fit)) pose->silhouette_fit = estimate.silhouette_fit;
  if (const Eigen::VectorXd reference =
          reference_pose_ ? reference_pose_(masks.frame_sequence) : Eigen::VectorXd();
      reference.size() == static_cast<long>(model_.dofs.size())) {
    const BodyModel& subject = reference_model_ ? *reference_model_ : model_;
    forwardKinematics(subject, reference_kinematics_, reference);
    const std::vector<Eigen::Vector3d> truth = pointPositions(subject, reference_kinematics_);
    double sum = 0;
    for (std::size_t p = 0; p < truth.size(); ++p) sum += (truth[p] - pose->points[p]).norm();
    pose->reference_error_mm = truth.empty() ? 0.0 : 1000 * sum / truth.size();
  }
  return pose;
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
    if (!config_.replay()) {
      latency_.add(now - p.capture_monotonic_ns);
      const auto durations = stageDurations(p, now);
      for (std::size_t k = 0; k < stage_latency_.size(); ++k) stage_latency_[k].add(durations[k]);
    }
    if (observer_) observer_(p);
    publisher_.publish(std::move(*pose));
    ++poses_published_;
  }
  std::lock_guard lock(drained_mutex_);
  drained_ = true;
  drained_signal_.notify_all();
}

RecordingResult Pipeline::startRecording(const std::string& relative_path) {
  return recording_.start(relative_path);
}

RecordingResult Pipeline::stopRecording() { return recording_.stop(); }

void Pipeline::captureBackground(int frames, std::function<void(const BackgroundResult&)> done) {
  backgrounds_.capture(frames, std::move(done));
}

void Pipeline::fitBody(int frame_sets, bool apply, std::function<void(const FitBodyResult&)> done) {
  body_fit_.request(frame_sets, apply, std::move(done));
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
  const std::vector<std::string> sources = backgrounds_.sources();
  for (std::size_t c = 0; c < cameras_.size(); ++c)
    status.cameras[c].silhouettes =
        config_.recorded_silhouettes ? "recorded in the session" : sources[c];
  status.background_warnings = backgrounds_.warnings();
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
  for (std::size_t k = 0; k < stage_latency_.size(); ++k)
    status.stage_latency.emplace_back(kLatencyStages[k], stage_latency_[k].summary());
  status.recording = recording_.status();
  return status;
}

}  // namespace mocap
