// The fake driver's synthetic scene: a body model moving along a motion, seen by calibrated virtual
// cameras. Renders each camera's image (textured background, the body painted a shade per segment
// or a simulated person posed by it, sensor noise) and answers ground-truth queries (DOF vector,
// joints and silhouettes of any frame).
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "drivers/status.h"
#include "tracker/likelihood/raster.h"
#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/motion.h"
#include "tracker/sim/person_layer.h"
#include "tracker/sim/scene.h"
#include "tracker/sim/subject.h"
#include "tracker/sim/subject_render.h"

namespace mocap {

// A stretch of frames during which one camera delivers nothing, once or over and over.
struct FakeOutage {
  int camera = -1;                       // -1: no outage
  uint64_t after_frames = 0;             // starts at this frame sequence
  std::chrono::nanoseconds duration{0};  // rounded up to whole frame periods
  // Positive: starts again this long after each start (rounded up to whole frame periods, and
  // never shorter than the outage plus one frame), so a long run sees a camera come and go.
  std::chrono::nanoseconds every{0};
};

// Fault knobs, all off by default. Deterministic for a given seed.
struct FakeFaults {
  double drop_rate = 0;  // chance each frame is lost; the next one counts it in dropped_before
  std::chrono::nanoseconds timestamp_jitter{
      0};                 // uniform in +-jitter (capped at a third of a period)
  FakeOutage stall;       // silent: frames just stop, then resume
  FakeOutage disconnect;  // reported through the event sink when it goes and when it comes back
};

enum class FakePacing {
  kRealTime,  // each camera's thread delivers frame N at its exposure time on CLOCK_MONOTONIC
  kAsFastAsPossible,  // no waiting; timestamps still advance by one period per frame
};

struct FakeSceneOptions {
  // The injection point for other bodies and motions (a human model, BVH clips): any model, with a
  // motion in its DOF order. Null model: the built-in hand. Null motion: generateMotion(model,
  // generated_frames, seed). The motion plays forward then backward, so it never jumps.
  std::shared_ptr<const BodyModel> model;
  std::shared_ptr<const Motion> motion;
  int generated_frames = 500;
  // Empty: defaultFakeRig(model, motion, cameras, width, height).
  Rig rig;
  int cameras = 2;
  int width = 780;
  int height = 580;
  double fps = 25.0;
  // Wall-clock seconds per second of the scene (at least 1): the scene plays in slow motion, its
  // frames delivered that much further apart in real time (their timestamps with them), for a
  // consumer too slow to follow it live, such as the daemon under a sanitizer. The motion, the fit
  // pose's turn and the faults keep the scene's own time, so the frames are the same.
  double slow_motion = 1.0;
  uint64_t seed = 1;
  double noise_sigma = 3.0;  // grey levels
  bool gray = false;         // CV_8UC1 images instead of BGR
  FakePacing pacing = FakePacing::kRealTime;
  // Frames per camera before the stream ends (the thread stops delivering); 0: endless.
  uint64_t frame_limit = 0;
  // Frames the cameras see the empty scene before the subject walks in, as a real room before
  // the session starts: time to capture the background. The motion starts at its first frame then.
  uint64_t empty_frames = 0;
  // Then, frames the subject stands in the model's fit_pose (tracker/search/body_size.h) before the
  // motion starts, as a real subject asked to while the body is fitted to them, turning in place
  // back and forth by up to 45 degrees (a 4 s cycle) to show the cameras more sides: the motion's
  // first frame with every DOF but the root's translations and its rotation about Z (where it
  // stands and faces, once the turns are over) replaced by the fit pose's. Needs a model with a
  // fit_pose.
  uint64_t fit_pose_frames = 0;
  // Then, frames in which the subject moves from the fit pose into the motion's first pose, every
  // DOF eased from one to the other, as a person lowers the arms and sets off instead of jumping
  // there in one frame (which no tracker follows). Needs fit_pose_frames.
  uint64_t step_out_frames = 0;
  // Set: the cameras see a person with these proportions and clothes (tracker/sim/subject.h), not
  // the model: the subject is posed by the model's joints at each true pose, and the truth
  // (silhouettes, joints) is the subject's. Needs a model with the human's points. Unset: the
  // model itself, each segment a flat shade.
  std::optional<SubjectParams> subject;
  FakeFaults faults;
};

// The rig used when none is given: for a body taller than half a metre the lab rig framed on the
// motion's path (labRig in tracker/sim/scene.h), otherwise one framed for a hand-sized model (the
// hand experiment's rig), so the default scene fills the image.
Rig defaultFakeRig(const BodyModel& model, const Motion& motion, int cameras, int width,
                   int height);

struct GroundTruth {
  uint64_t sequence = 0;
  std::size_t motion_frame = 0;      // which frame of the motion was shown
  Eigen::VectorXd q;                 // the DOF vector; empty while the scene is empty
  std::vector<cv::Mat> silhouettes;  // per camera, CV_8UC1, 255 where the body is
  // The true joints as the model's points (model point order, world metres): what a tracked pose
  // is scored against. The model's points at q, or the subject's joints. Empty while empty.
  std::vector<Eigen::Vector3d> points;
};

// Per-thread render scratch: one per camera thread.
struct FakeRenderScratch {
  explicit FakeRenderScratch(const BodyModel& model, int max_rows);
  KinematicsData kinematics;
  ShapeRasterizer rasterizer;
  std::vector<RowSpan> spans;
  // With a subject (FakeSceneOptions::subject):
  SubjectRasterizer subject_rasterizer;
  PosedSubject posed;
  PersonLayer layer;
  cv::Mat gray_layer;  // the layer's colours in gray, for gray scenes
};

// Shared by every camera opened from one FakeDriver. Immutable after create() except for the
// start epoch and the ground-truth renderer, both guarded.
class FakeScene {
 public:
  // Builds the model, motion and rig (the tracker's loaders throw; caught here) and checks that the
  // motion matches the model and the rig has cameras.
  static Expected<std::shared_ptr<FakeScene>> create(FakeSceneOptions options);

  const FakeSceneOptions& options() const { return options_; }
  const BodyModel& model() const { return *model_; }
  const Motion& motion() const { return *motion_; }
  const Rig& rig() const { return rig_; }
  int64_t periodNs() const { return period_ns_; }
  // Real time between two frames: the period in slow motion (FakeSceneOptions::slow_motion).
  int64_t intervalNs() const { return interval_ns_; }

  // Frame 0's exposure time (CLOCK_MONOTONIC ns), fixed by the first call: the cameras share it,
  // so frame N of every camera is the same instant and the same pose.
  int64_t epochNs();
  int64_t exposureTimeNs(uint64_t sequence) {
    return epochNs() + static_cast<int64_t>(sequence) * interval_ns_;
  }
  // Whether the subject is in view in frame `sequence` (options().empty_frames), whether it stands
  // in the fit pose then (options().fit_pose_frames), and which frame of the motion it shows (0
  // while it stands and steps out of the fit pose).
  bool subjectInView(uint64_t sequence) const { return sequence >= options_.empty_frames; }
  bool inFitPose(uint64_t sequence) const {
    return subjectInView(sequence) && sequence - options_.empty_frames < options_.fit_pose_frames;
  }
  bool steppingOut(uint64_t sequence) const {
    return subjectInView(sequence) && !inFitPose(sequence) &&
           sequence - options_.empty_frames - options_.fit_pose_frames < options_.step_out_frames;
  }
  std::size_t motionFrame(uint64_t sequence) const;
  // The subject's DOF vector in frame `sequence` (the standing pose while it stands in the fit
  // pose), empty while the scene is empty. Cheap: no render.
  Eigen::VectorXd truePose(uint64_t sequence) const;

  // The ground truth of frame `sequence`. Thread-safe (serialized); renders on each call.
  GroundTruth groundTruth(uint64_t sequence) const;
  // The subject the cameras see in place of the model, if any (FakeSceneOptions::subject).
  const Subject* subject() const { return subject_.get(); }
  // The body whose points at truePose() are the true joints: the model itself, or with a subject
  // the model refitted to the subject's rest joints (fitModelToRestPoints), which has the model's
  // DOFs, so a truth carried as DOFs (scoring, recordings) stays the subject's. It matches the
  // subject's joints to under a centimetre while the pelvis stays within a few centimetres of its
  // standing height, as a person's does (the subject scales the pelvis height, the body shifts it).
  std::shared_ptr<const BodyModel> truthBody() const { return truth_body_; }

  // Renders camera `camera`'s image of frame `sequence` into `image` (reallocated only if needed).
  // Deterministic: the same (camera, sequence) gives the same pixels. Thread-safe with distinct
  // scratch objects.
  void render(int camera, uint64_t sequence, FakeRenderScratch& scratch, cv::Mat& image) const;
  // The background alone (no body, no noise), for tests.
  const cv::Mat& background(int camera) const { return backgrounds_[camera]; }

  // Fault decisions for (camera, sequence): deterministic per seed. `faults` is the camera's: the
  // scene's, or those its device string gives (fake_driver.h).
  bool dropped(const FakeFaults& faults, int camera, uint64_t sequence) const;
  int64_t jitterNs(int camera, uint64_t sequence) const;
  bool inOutage(const FakeOutage& outage, int camera, uint64_t sequence) const;

 private:
  explicit FakeScene(FakeSceneOptions options);
  uint64_t hash(int camera, uint64_t sequence, uint64_t salt) const;
  void paintSubject(const CameraModel& camera, uint64_t sequence, FakeRenderScratch& scratch,
                    cv::Mat& image) const;
  void paintPerson(const CameraModel& camera, uint64_t sequence, FakeRenderScratch& scratch,
                   cv::Mat& image) const;
  // Poses scratch.posed as the subject stands in frame `sequence` (in view).
  void poseSubject(uint64_t sequence, FakeRenderScratch& scratch) const;
  void addNoise(int camera, uint64_t sequence, cv::Mat& image) const;

  FakeSceneOptions options_;
  std::shared_ptr<const BodyModel> model_;
  std::shared_ptr<const Motion> motion_;
  Eigen::VectorXd fit_pose_;  // with fit_pose_frames: the pose the subject stands in, unturned
  int fit_turn_dof_ = -1;     // the root's rotation about Z, which the turns change
  Rig rig_;
  int64_t period_ns_ = 0;
  int64_t interval_ns_ = 0;  // period_ns_ in slow motion
  std::vector<cv::Mat> backgrounds_;
  // A long strip of Gaussian noise, split into its positive and negative parts, read at a
  // per-frame offset.
  std::vector<uint8_t> noise_up_, noise_down_;
  std::vector<cv::Vec3b> segment_colors_;
  std::shared_ptr<const Subject> subject_;  // shared by the camera threads (const)
  std::shared_ptr<const BodyModel> truth_body_;

  std::mutex epoch_mutex_;
  std::optional<int64_t> epoch_ns_;
  mutable std::mutex truth_mutex_;
  mutable std::unique_ptr<SceneRenderer> truth_renderer_;  // built on the first query
  mutable std::unique_ptr<FakeRenderScratch> truth_scratch_;  // with a subject, likewise
};

}  // namespace mocap
