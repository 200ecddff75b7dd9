// The capture-to-pose pipeline of the daemon, one thread per stage with bounded hand-offs:
//
//   camera drivers (their own threads) -> FrameSynchronizer
//     -> mask thread: FrameSet -> silhouette masks (and the recorder tap)
//     -> tracker thread: masks -> PoseFilter::step -> Pose
//     -> publisher thread: stamps the pose, feeds the latency meter, fans out to subscribers.
//
// Live mode drops stale work between stages (latest wins); replay mode loses nothing and its
// poses depend only on the recorded frames and the filter's seed.
//
// The pipeline owns the threads and wires the components the mask thread drives: the background
// manager (each camera's silhouette source, background capture and persistence), the body-fit job
// (FitBody) and the recording control (the recorder tap, StartRecording and StopRecording). Its
// public methods are called from the service's threads unless they say otherwise.
#pragma once

#include <array>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "drivers/camera_driver.h"
#include "drivers/record/session_reader.h"
#include "drivers/sync/frame_synchronizer.h"
#include "server/background_manager.h"
#include "server/body_fit_job.h"
#include "server/config.h"
#include "server/handoff.h"
#include "server/opened_camera.h"
#include "server/pose.h"
#include "server/pose_publisher.h"
#include "server/recording_control.h"
#include "server/silhouette_source.h"
#include "server/stats.h"
#include "tracker/filters/filter.h"
#include "tracker/filters/worker_pool.h"
#include "tracker/likelihood/silhouette_mask.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/model/kinematics.h"
#include "tracker/search/acquire.h"
#include "tracker/vision/background_model.h"

namespace mocap {

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
  // Instead: the tracker finds the subject in the first frame sets (tracker/search/acquire.h).
  // Needs a body whose root can be placed (canAcquire).
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
  // Live: the same poses' latency by stage (Pose::stages), in pipeline order, named as in the
  // proto's Status.stage_latency.
  std::vector<std::pair<std::string, LatencySummary>> stage_latency;
  RecordingStatus recording;
  // Saved backgrounds refused or ignored at start-up, one line each naming the file (also logged).
  std::vector<std::string> background_warnings;
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
  // fit_pose (tracker/search/body_size.h fitBodyInPose): the mask thread collects the silhouettes
  // of `frame_sets` of the sets it hands the tracker, one every half second (so a subject turning
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
  std::string backgroundFile(std::size_t camera) const {
    return backgrounds_.backgroundFile(camera);
  }

 private:
  struct MaskSet {
    uint64_t sequence = 0;
    uint64_t frame_sequence = 0;  // the camera sequence of the set's first frame
    int64_t timestamp_ns = 0;
    std::vector<SilhouetteMask> masks;
    StageTimes stages;  // the silhouette stage's part
  };

  // Constructor: throws std::invalid_argument if the rig or the reference body does not match.
  void checkRig() const;
  std::unique_ptr<FrameSynchronizer> makeSynchronizer() const;
  void replayLoop();
  void maskLoop();
  // Mask thread: the silhouettes of `set` into `latest` (a camera without a frame keeps its
  // previous one); per camera, whether it has silhouettes.
  void updateSilhouettes(const FrameSet& set, std::vector<SilhouetteMask>& latest,
                         std::vector<bool>& has_silhouettes, std::vector<bool>& size_warned);
  void trackerLoop();
  // Tracker thread: the pose of `estimate`, with its error against the truth when known.
  std::shared_ptr<Pose> makePose(const MaskSet& masks, const FrameEstimate& estimate);
  void publisherLoop();
  // Tracker thread: (re)creates filter_ for body_ (an acquiring filter for a body that can be
  // placed, which searches the body's stances and, `in_fit_pose`, its fit pose).
  void makeTrackerFilter(bool in_fit_pose);
  // Tracker thread: tracks with the body applied since the last frame set, finding the subject
  // anew in the fit pose they stand in (see fitBody).
  void switchToAppliedBody();

  const ServerConfig config_;
  const BodyModel& model_;  // as configured: the subject's body without a reference_model_
  const Rig& rig_;
  std::vector<OpenedCamera> cameras_;
  std::shared_ptr<const SessionReader> replay_;
  const bool true_silhouettes_;
  std::function<Eigen::VectorXd(uint64_t)> reference_pose_;
  std::shared_ptr<const BodyModel> reference_model_;  // null: the tracked model
  PosePublisher& publisher_;
  std::unique_ptr<FrameSynchronizer> synchronizer_;
  Handoff<MaskSet> masks_;
  Handoff<std::shared_ptr<Pose>> poses_;
  std::function<void(const Pose&)> observer_;
  MaskObserver mask_observer_;

  // The components the mask thread drives (declared in this order: the fit job and the background
  // manager use the recording control).
  RecordingControl recording_;
  BodyFitJob body_fit_;
  BackgroundManager backgrounds_;
  const bool can_acquire_;  // the configured body's root can be placed (fitted ones alike)
  const bool finds_subject_;  // PipelineInputs::acquire: no first pose is given

  // Tracker thread only, after construction.
  std::unique_ptr<WorkerPool> pool_;
  TrackedBody body_;  // the body tracked
  std::unique_ptr<PoseFilter> filter_;
  AcquiringFilter* acquiring_ = nullptr;               // filter_ itself when the body can be placed
  int earlier_acquisitions_ = 0, earlier_losses_ = 0;  // of the filters of earlier bodies
  KinematicsData kinematics_;
  KinematicsData reference_kinematics_;

  std::vector<std::unique_ptr<RateMeter>> camera_rates_;
  RateMeter tracker_rate_;
  LatencyWindow latency_;
  std::array<LatencyWindow, kLatencyStages.size()> stage_latency_;  // one per stage
  std::atomic<uint64_t> poses_published_{0};
  std::atomic<double> evaluations_per_frame_{0};
  std::atomic<uint64_t> refinements_cut_{0};
  std::atomic<bool> reacquire_requested_{false};
  std::atomic<bool> tracking_{true};
  std::atomic<uint64_t> acquisitions_{0};
  std::atomic<uint64_t> losses_{0};
  mutable std::mutex search_mutex_;
  std::string search_failure_;

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
