// The capture-to-pose pipeline of the daemon, one thread per stage with bounded hand-offs:
//
//   camera drivers (their own threads) -> FrameSynchronizer
//     -> mask thread: FrameSet -> silhouette masks (and the recorder tap)
//     -> tracker thread: masks -> PoseFilter::step -> Pose
//     -> publisher thread: stamps the pose, feeds the latency meter, fans out to subscribers.
//
// Live mode drops stale work between stages (latest wins); replay mode loses nothing and its
// poses depend only on the recorded frames and the filter's seed.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "drivers/camera_driver.h"
#include "drivers/record/recorder.h"
#include "drivers/record/session_reader.h"
#include "drivers/sync/frame_synchronizer.h"
#include "server/config.h"
#include "server/handoff.h"
#include "server/pose.h"
#include "server/pose_publisher.h"
#include "server/stats.h"
#include "tracker/search/acquire.h"
#include "tracker/model/body_model.h"
#include "tracker/search/body_size.h"
#include "tracker/model/camera.h"
#include "tracker/filters/filter.h"
#include "tracker/model/kinematics.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/vision/background_model.h"
#include "tracker/vision/silhouette_extractor.h"
#include "tracker/filters/worker_pool.h"

namespace mocap {

// A camera of the rig: the configuration it was opened with, what its driver says of it, and the
// camera itself (null when a recorded session stands in for it).
struct OpenedCamera {
  CameraConfig config;
  CameraInfo info;
  std::unique_ptr<Camera> camera;
};

// The silhouettes of frame `frame_sequence` on every camera, when the source knows them (the fake
// scene's ground truth); empty otherwise.
using GroundTruthSilhouettes = std::function<std::vector<cv::Mat>(uint64_t frame_sequence)>;

struct PipelineInputs {
  std::vector<OpenedCamera> cameras;
  // Replay: the session that feeds the synchronizer instead of the cameras.
  std::shared_ptr<const SessionReader> replay;
  // Used instead of extracting silhouettes from the images when set: the fake scene's demo
  // measures tracking, not segmentation.
  GroundTruthSilhouettes ground_truth;
  // With ground_truth, per camera: the empty scene (the fake scene's room, its sensor noise as the
  // deviation). A recording stores it as the camera's background, so a replay, which has no truth,
  // extracts silhouettes from the recorded images.
  std::vector<std::shared_ptr<const BackgroundModel>> scene_backgrounds;
  // The true pose of a frame (the camera sequence of a set's first frame), when the source knows
  // it (the fake scene; a replayed session that stores it): published poses then carry their error
  // against it, and recordings store it. An empty vector: no subject in view then, no error.
  std::function<Eigen::VectorXd(uint64_t sequence)> reference_pose;
  // The body those poses are of, when not the tracked one (the fake scene's subject, tracked with
  // the configured body): the true joints are placed on it. Same DOFs as the tracked body.
  std::shared_ptr<const BodyModel> reference_model;
  // The body fitBody() fits, when not the tracked one (which tracker.dofs: gait has frozen).
  std::shared_ptr<const BodyModel> fit_model;
  // Where the subject starts; empty: the model's neutral pose.
  Eigen::VectorXd initial_pose;
  // Instead: the tracker finds the subject in the first frame sets (tracker/search/acquire.h). Needs a
  // body whose root can be placed (canAcquire).
  bool acquire = false;
};

struct CameraRuntimeStatus {
  double measured_fps = 0;
  bool streaming = false;  // a frame arrived within the last two seconds
  CameraSyncStats sync;
  // Where its silhouettes come from: "ground truth", "threshold" (with the reason when a saved
  // background was refused), "background captured" or "background loaded from <file>".
  std::string silhouettes;
};

struct RecordingStatus {
  bool active = false;
  std::string path;  // relative to the recording directory
  uint64_t frame_sets = 0;
  int64_t started_wall_ns = 0;
};

struct PipelineStatus {
  bool running = false;
  std::vector<CameraRuntimeStatus> cameras;
  double tracker_fps = 0;
  uint64_t poses_published = 0;
  uint64_t frame_sets_skipped = 0;  // live: superseded in the synchronizer or between stages
  double evaluations_per_frame = 0;
  uint64_t refinements_cut = 0;  // live: steps whose refinement gave way to a newer frame set
  // False while the tracker looks for the subject (at start with PipelineInputs::acquire, after
  // reacquire()): no pose is published then. search_failure says why the last look found none.
  bool tracking = true;
  std::string search_failure;
  uint64_t acquisitions = 0;  // times the tracker found the subject by itself
  uint64_t losses = 0;        // times it declared itself lost (tracker.lost_below)
  LatencySummary latency;
  RecordingStatus recording;
  // Saved backgrounds refused or ignored at start-up, one line each naming the file (also logged).
  std::vector<std::string> background_warnings;
};

// Why a recording request failed, so the service can pick the gRPC code.
enum class RecordingError {
  kNone,
  kBadPath,
  kOutsideRoot,
  kNotConfigured,
  kBusy,
  kNotRecording,
  kIo
};
struct RecordingResult {
  RecordingError error = RecordingError::kNone;
  std::string message;
  RecordingStatus status;
};

// Why a background capture failed, so the service can pick the gRPC code.
// kNotSaved: learned and in use, but a file of background_directory could not be written.
enum class BackgroundError { kNone, kReplay, kBusy, kStalled, kStopped, kUnusable, kNotSaved };
struct BackgroundResult {
  BackgroundError error = BackgroundError::kNone;
  std::string message;
  int frames_used = 0;  // per camera
  // Learned and in use, but doubtful: a camera whose image changed during the capture, or differs
  // from the background it replaced.
  std::vector<std::string> warnings;
};

// Why a body fit failed, so the service can pick the gRPC code. kCannotFit: the body has no
// fit_pose or its root cannot be placed; kCannotApply: asked to apply it in a replay or while a
// recording is open; kNoSubject: none found in the frame sets; kStalled: no frame set with
// silhouettes from every camera for a while; kFailed: the fit threw.
enum class BodyFitError {
  kNone,
  kCannotFit,
  kCannotApply,
  kBusy,
  kNoSubject,
  kStalled,
  kStopped,
  kFailed
};
struct FitBodyResult {
  BodyFitError error = BodyFitError::kNone;
  std::string message;
  int frame_sets_used = 0;  // collected, or once fitted, those the subject was found in
  BodyFit fit;              // without an error
  BodyModel body;           // the fitted body: the fitted model with fit.proportions
  double fit_seconds = 0;   // the fit itself, after the frame sets were collected
  uint32_t body_version = 0;  // applied: the version the tracker tracks it as; else 0
};

// The body the tracker tracks: the configured one (version 0), or the latest fitted one applied.
struct TrackedBody {
  std::shared_ptr<const BodyModel> model;
  uint32_t version = 0;
};

class Pipeline {
 public:
  // The model, rig and publisher are borrowed and must outlive the pipeline; `model` is the
  // configured body (trackedBody() may be a fitted one since). Throws
  // std::invalid_argument if the rig does not match the cameras or the tracker settings are
  // unusable.
  Pipeline(const ServerConfig& config, const BodyModel& model, const Rig& rig,
           PipelineInputs inputs, PosePublisher& publisher);
  ~Pipeline();
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  // With a background_directory (live only), each camera's saved background is loaded here: a file
  // that cannot be used is a warning (see PipelineStatus::background_warnings) and that camera is
  // thresholded until the next capture. Throws std::invalid_argument if two cameras would share a
  // background file.
  //
  // Starts the stage threads, then the cameras (or the replay). An error names the camera that
  // failed.
  Status start();
  // Replay: blocks until the whole session has been tracked and published.
  void waitForReplayEnd();
  // Stops the cameras, drains the stages and closes the recording. Idempotent.
  void stop();

  // Called on the publisher thread with every published pose, before the subscribers get it.
  // Set before start().
  void setPoseObserver(std::function<void(const Pose&)> observer);
  // Called on the mask thread with every frame set and the silhouettes handed to the tracker for
  // it (a camera with no frame in the set repeats its previous one). Must be quick. Set before
  // start().
  using MaskObserver = std::function<void(const FrameSet&, const std::vector<SilhouetteMask>&)>;
  void setMaskObserver(MaskObserver observer);

  RecordingResult startRecording(const std::string& relative_path);
  RecordingResult stopRecording();

  // Has the mask thread learn the empty scene from the next `frames` frames of every camera, then
  // extract silhouettes against it. `done` is called once: at once on a refusal, else on the mask
  // thread when the backgrounds are installed, when no usable frame came for a while, or when the
  // pipeline stops; with a background_directory, on a saver thread once the files are written
  // (the mask thread never waits on the disk). It must not block.
  void captureBackground(int frames, std::function<void(const BackgroundResult&)> done);

  // Fits the body (PipelineInputs::fit_model, else the tracked one) to the subject standing in its
  // fit_pose (tracker/search/body_size.h fitBodyInPose): the mask thread collects the silhouettes of
  // `frame_sets` of the sets it hands the tracker, one every half second (so a subject turning
  // in place is seen from several sides), then a thread of its own fits (seconds; the mask and
  // tracker threads go on, and the tracker keeps its body). `done` is called once: at once on a
  // refusal (no fit pose, a root that cannot be placed, a fit under way, the pipeline not running),
  // on the mask thread when no set came for a while or the pipeline stops, else on the fit thread.
  // It must not block. stop() ends a fit under way at its next frame set's search.
  //
  // With `apply`, the fitted proportions are applied to the configured tracked body and the tracker
  // switches to it at its next frame set, finding the subject anew (refused in a replay, whose
  // poses depend on the session alone, and while a recording is open, which stores one body;
  // startRecording is refused until such a fit has answered).
  void fitBody(int frame_sets, bool apply, std::function<void(const FitBodyResult&)> done);
  TrackedBody trackedBody() const;

  // Why reacquire() was refused, so the service can pick the gRPC code.
  enum class ReacquireError { kNone, kReplay, kCannotPlace };
  // The tracker finds the subject again from the next frame set, as at start. Refused in replay
  // (its poses depend on the recording alone) and for a body whose root cannot be placed.
  ReacquireError reacquire();

  PipelineStatus status() const;
  const std::vector<OpenedCamera>& cameras() const { return cameras_; }
  // The file camera `camera`'s background is saved to and loaded from: "<driver>-<camera id>" with
  // characters other than letters, digits, '.', '_' and '-' replaced by '_', then
  // ".background.yml", in the background directory. Empty without one.
  std::string backgroundFile(std::size_t camera) const;

 private:
  struct MaskSet {
    uint64_t sequence = 0;
    uint64_t frame_sequence = 0;  // the camera sequence of the set's first frame
    int64_t timestamp_ns = 0;
    std::vector<SilhouetteMask> masks;
  };
  struct BackgroundCapture {
    int frames = 0;
    std::function<void(const BackgroundResult&)> done;
    std::vector<BackgroundLearner> learners;  // per camera
    int64_t last_progress_ns = 0;
  };
  struct BodyFitCollection {
    int frame_sets = 0;
    bool apply = false;
    int every = 1;  // one set kept out of this many handed to the tracker
    int seen = 0;
    std::function<void(const FitBodyResult&)> done;
    std::vector<std::vector<SilhouetteMask>> frames;
    int64_t last_progress_ns = 0;
  };

  void replayLoop();
  void maskLoop();
  void trackerLoop();
  void publisherLoop();
  // Foreground where the image is brighter than mid-grey: a lit subject against a dark background,
  // until a background is captured.
  static SilhouetteMask thresholdMask(const cv::Mat& image);
  // Mask thread: feeds a camera's frame to the capture under way.
  static void learnBackground(BackgroundCapture& capture, std::size_t camera, const cv::Mat& image);
  // Mask thread: installs the extractors once every camera has its frames, or gives up when none
  // came for too long. True when the capture is over (its `done` called).
  bool finishBackground(BackgroundCapture& capture);
  void endCapture(const std::function<void(const BackgroundResult&)>& done,
                  const BackgroundResult& result);
  // Mask thread: adds a set's silhouettes to the collection; once it has them all, starts the fit
  // thread. True when the collection is over (handed on or given up, its `done` called).
  bool collectForFit(BodyFitCollection& collection, const std::vector<SilhouetteMask>* masks);
  // Fit thread.
  void runBodyFit(BodyFitCollection collection);
  void endBodyFit(const std::function<void(const FitBodyResult&)>& done,
                  const FitBodyResult& result);
  const BodyModel& fitModel() const { return fit_model_ ? *fit_model_ : model_; }
  // Tracker thread: (re)creates filter_ for body_ (an acquiring filter for a body that can be
  // placed, which searches the body's stances and, `in_fit_pose`, its fit pose).
  void makeTrackerFilter(bool in_fit_pose);
  // Tracker thread: tracks with the body applied since the last frame set, finding the subject
  // anew in the fit pose they stand in (see fitBody).
  void switchToAppliedBody();
  // Constructor: loads what background_directory holds for each camera.
  void loadBackgrounds();
  // Mask thread (or the constructor): camera's silhouettes are extracted against `background`
  // from its next frame on (null: thresholded), and an open recording notes it.
  void useBackground(std::size_t camera, std::shared_ptr<const BackgroundModel> background,
                     std::unique_ptr<SilhouetteExtractor> extractor = nullptr);
  // Mask thread, replay: installs the session's recorded backgrounds due by camera's `frame`.
  void replayBackgrounds(std::size_t camera, uint64_t frame_sequence);
  // Saver thread: writes the captured models, then ends the capture with `learned` (its error
  // set if a file could not be written).
  void saveBackgrounds(std::vector<std::shared_ptr<const BackgroundModel>> models,
                       BackgroundResult learned, std::function<void(const BackgroundResult&)> done);
  // The silhouette source of a camera without a background (config's before_background), and why.
  std::string withoutBackground(const std::string& why) const;
  // What becomes of such a camera's images, for messages: "thresholded" or "not tracked".
  const char* withoutBackgroundIs() const;
  // What status() reports as camera's silhouette source; ignored when the scene gives the truth.
  void setSilhouetteSource(std::size_t camera, std::string source);
  void warnBackground(const std::string& warning);
  RecordingStatus recordingStatusLocked() const;

  const ServerConfig config_;
  const BodyModel& model_;  // as configured: the subject's body without a reference_model_
  const Rig& rig_;
  std::vector<OpenedCamera> cameras_;
  std::shared_ptr<const SessionReader> replay_;
  GroundTruthSilhouettes ground_truth_;
  std::function<Eigen::VectorXd(uint64_t)> reference_pose_;
  std::shared_ptr<const BodyModel> reference_model_;  // null: the tracked model
  std::shared_ptr<const BodyModel> fit_model_;        // null: the tracked model
  PosePublisher& publisher_;
  std::unique_ptr<FrameSynchronizer> synchronizer_;
  Handoff<MaskSet> masks_;
  Handoff<std::shared_ptr<Pose>> poses_;
  std::function<void(const Pose&)> observer_;
  MaskObserver mask_observer_;

  // The latest body applied by a fit, for trackedBody() and the next recording, and whether the
  // tracker has yet to switch to it.
  mutable std::mutex body_mutex_;
  TrackedBody applied_body_;
  std::atomic<bool> body_switch_pending_{false};
  const bool can_acquire_;  // the configured body's root can be placed (fitted ones alike)

  // Tracker thread only, after construction.
  std::unique_ptr<WorkerPool> pool_;
  TrackedBody body_;  // the body tracked
  std::unique_ptr<PoseFilter> filter_;
  AcquiringFilter* acquiring_ = nullptr;  // filter_ itself when the body can be placed
  int earlier_acquisitions_ = 0, earlier_losses_ = 0;  // of the filters of earlier bodies
  KinematicsData kinematics_;
  KinematicsData reference_kinematics_;

  std::vector<std::unique_ptr<RateMeter>> camera_rates_;
  RateMeter tracker_rate_;
  LatencyWindow latency_;
  std::atomic<uint64_t> poses_published_{0};
  std::atomic<double> evaluations_per_frame_{0};
  std::atomic<uint64_t> refinements_cut_{0};
  std::atomic<bool> reacquire_requested_{false};
  std::atomic<bool> tracking_{true};
  std::atomic<uint64_t> acquisitions_{0};
  std::atomic<uint64_t> losses_{0};
  mutable std::mutex search_mutex_;
  std::string search_failure_;

  // The recorder tap: the mask thread writes each frame set while a recording is open.
  mutable std::mutex recording_mutex_;
  std::unique_ptr<Recorder> recorder_;
  std::string recording_path_;
  int64_t recording_started_wall_ns_ = 0;
  RecordingStatus last_recording_;
  std::vector<int> camera_cv_types_;  // of the latest frames, -1 before the first
  // Per camera: the background a recording stores for it (the one its silhouettes are extracted
  // against, or the scene's with true silhouettes; null: thresholded), and the sequence its next
  // frame will have at the least (one past the latest).
  std::vector<std::shared_ptr<const BackgroundModel>> backgrounds_in_use_;
  std::vector<uint64_t> next_frame_sequences_;

  // A background capture, and a body fit's collection, handed from the requester to the mask
  // thread under capture_mutex_.
  std::mutex capture_mutex_;
  std::unique_ptr<BackgroundCapture> capture_request_;
  bool capture_busy_ = false;        // requested or under way
  bool accepting_captures_ = false;  // while the mask thread runs (captures and fits alike)
  std::unique_ptr<BodyFitCollection> fit_request_;
  bool fit_busy_ = false;     // requested, collecting or fitting
  bool fit_applies_ = false;  // that fit will apply its body: no recording may start
  // Held by fitBody's check that no recording is open and by startRecording throughout, so a
  // recording never opens with one body while the tracker switches to another.
  std::mutex session_body_mutex_;
  // Mask thread only: per camera, null until a background is captured; in replay, per camera, the
  // index of the first of the session's backgrounds() not installed yet.
  std::vector<std::unique_ptr<SilhouetteExtractor>> extractors_;
  std::vector<std::size_t> next_replayed_backgrounds_;
  // Saves a capture's backgrounds; joined before the next one starts and by stop().
  std::thread save_thread_;
  // Fits the body; started by the mask thread, joined before the next one starts and by stop(),
  // which sets stop_fit_ first.
  std::thread fit_thread_;
  std::atomic<bool> stop_fit_{false};
  // Read by status(): where each camera's silhouettes come from, and the start-up warnings.
  mutable std::mutex silhouette_mutex_;
  std::vector<std::string> silhouette_sources_;
  std::vector<std::string> background_warnings_;

  std::atomic<bool> running_{false};
  std::atomic<bool> input_closed_{false};
  std::vector<int> started_cameras_;
  std::atomic<bool> stop_replay_{false};
  std::thread replay_thread_;
  std::thread mask_thread_;
  std::thread tracker_thread_;
  std::thread publisher_thread_;
  // Set when the publisher thread has published its last pose.
  std::mutex drained_mutex_;
  std::condition_variable drained_signal_;
  bool drained_ = false;
};

}  // namespace mocap
