// The synthetic scene: rig choice, background texture, body or person painting, noise, ground
// truth.
#include "drivers/fake/fake_scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "drivers/clock.h"
#include "tracker/model/builtin_models.h"
#include "tracker/motion/retarget.h"
#include "tracker/search/body_size.h"

namespace mocap {
namespace {

constexpr std::size_t kNoiseOffsets = 1 << 16;

uint64_t splitmix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

double unitInterval(uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

// Far from the background's mid-range texture, and alternating light/dark so neighbouring
// segments stay apart.
const cv::Vec3b kSegmentPalette[] = {{30, 30, 235},  {30, 215, 30},  {235, 90, 20},
                                     {20, 225, 245}, {225, 30, 225}, {245, 225, 30}};
const uint8_t kSegmentGrays[] = {250, 8, 240, 18, 230, 28};

// Largest distance between two segment origins in the neutral pose, plus the largest shape.
double modelExtent(const BodyModel& model) {
  KinematicsData data(model);
  forwardKinematics(model, data, model.neutralPose());
  double extent = 0;
  for (const Eigen::Isometry3d& a : data.world) {
    for (const Eigen::Isometry3d& b : data.world)
      extent = std::max(extent, (a.translation() - b.translation()).norm());
  }
  double largest_shape = 0;
  for (const Segment& s : model.segments) {
    largest_shape = std::max({largest_shape, s.shape.length, 2 * s.shape.radii.maxCoeff()});
  }
  return extent + largest_shape;
}

// `model` with the subject's bones (fitModelToRestPoints), standing where the subject stands: its
// pelvis at the subject's at the neutral pose (the fit keeps the model's ankle height; the
// subject has its own).
BodyModel truthBodyOf(const BodyModel& model, const Subject& subject) {
  BodyModel body = fitModelToRestPoints(model, modelPointsFromJoints(model, subject.rest()));
  // The subject's pelvis joint is where the model's pelvis point is, and the root DOFs turn the
  // model about its root: the fit put the body's root between the hips instead, so it moves back to
  // where the model has it relative to the pelvis point.
  const int pelvis = body.pointIndex(kSubjectJointNames[kPelvis]);
  if (body.points[pelvis].segment == 0 && model.points[pelvis].segment == 0)
    moveSegmentOrigin(body, 0, body.points[pelvis].local - model.points[pelvis].local);
  // The subject's neck swings with the model's, scaled (Subject::retarget): so the spine bends
  // about a joint as far up the trunk as the model's, the chest's points and children staying put.
  const int neck = body.pointIndex(kSubjectJointNames[kNeck]);
  const int chest = body.segments[body.points[neck].segment].parent;
  if (chest > 0 && body.segments[chest].parent == 0 && model.points[pelvis].segment == 0) {
    const SubjectJoints model_rest = subjectJointsAt(model, model.neutralPose());
    const double scale = (subject.rest()[kNeck] - subject.rest()[kPelvis]).norm() /
                         (model_rest[kNeck] - model_rest[kPelvis]).norm();
    const Eigen::Vector3d to_chest = model.segments[chest].offset - model.points[pelvis].local;
    const Eigen::Vector3d move =
        body.points[pelvis].local + scale * to_chest - body.segments[chest].offset;
    moveSegmentOrigin(body, chest, move);
  }
  KinematicsData kinematics(body);
  forwardKinematics(body, kinematics, body.neutralPose());
  const Eigen::Vector3d standing = pointPositions(body, kinematics)[pelvis];
  // The root's offset is in the world frame.
  body.segments[0].offset += subject.rest()[kPelvis] - standing;
  return body;
}

}  // namespace

Rig defaultFakeRig(const BodyModel& model, const Motion& motion, int cameras, int width,
                   int height) {
  return modelExtent(model) > 0.5 ? labRig(cameras, model, motion, width, height)
                                  : handRig(cameras, width, height);
}

FakeRenderScratch::FakeRenderScratch(const BodyModel& model, int max_rows)
    : kinematics(model),
      rasterizer(kSimulatorPointsPerCircle),
      spans(static_cast<std::size_t>(max_rows)) {}

FakeScene::FakeScene(FakeSceneOptions options) : options_(std::move(options)) {}

Expected<std::shared_ptr<FakeScene>> FakeScene::create(FakeSceneOptions options) {
  if (!(options.fps > 0)) return Status::Error("fake scene: fps must be positive");
  if (!(options.slow_motion >= 1 && options.slow_motion <= 1000))
    return Status::Error("fake scene: slow_motion must be in [1, 1000]");
  if (options.noise_sigma < 0) return Status::Error("fake scene: noise_sigma must not be negative");
  if (options.faults.drop_rate < 0 || options.faults.drop_rate >= 1) {
    return Status::Error("fake scene: drop_rate must be in [0, 1)");
  }
  std::shared_ptr<FakeScene> scene(new FakeScene(std::move(options)));
  FakeSceneOptions& o = scene->options_;
  try {
    scene->model_ = o.model ? o.model : std::make_shared<const BodyModel>(builtinHandModel());
    scene->motion_ = o.motion ? o.motion
                              : std::make_shared<const Motion>(
                                    generateMotion(*scene->model_, o.generated_frames, o.seed));
    if (scene->motion_->empty()) return Status::Error("fake scene: the motion has no frames");
    const Eigen::Index dofs = static_cast<Eigen::Index>(scene->model_->dofs.size());
    for (std::size_t f = 0; f < scene->motion_->size(); ++f) {
      if ((*scene->motion_)[f].size() != dofs) {
        return Status::Error("fake scene: motion frame " + std::to_string(f) + " has " +
                             std::to_string((*scene->motion_)[f].size()) + " values, the model " +
                             scene->model_->name + " has " + std::to_string(dofs) + " DOFs");
      }
    }
    if (o.step_out_frames > 0 && o.fit_pose_frames == 0)
      return Status::Error("fake scene: stepping out of the fit pose needs fit pose frames");
    if (o.fit_pose_frames > 0) {
      const BodyModel& model = *scene->model_;
      if (!model.fit_pose)
        return Status::Error(
            "fake scene: the subject cannot stand in the fit pose: the body model '" + model.name +
            "' has no fit_pose");
      // Where the motion starts and the way it faces there, in the fit pose.
      const FitStance standing = fitPoseAt(model, scene->motion_->front());
      scene->fit_pose_ = standing.pose;
      scene->fit_turn_dof_ = standing.turn_dof;
    }
    if (o.subject) {
      const BodyModel& model = *scene->model_;
      std::shared_ptr<const Subject> subject;
      try {
        subject = std::make_shared<const Subject>(*o.subject,
                                                  subjectJointsAt(model, model.neutralPose()));
      } catch (const std::invalid_argument& e) {
        return Status::Error("fake scene: a subject needs a body model with the human's joints (" +
                             model.name + "): " + e.what());
      }
      scene->truth_body_ = std::make_shared<const BodyModel>(truthBodyOf(model, *subject));
      scene->subject_ = std::move(subject);
    } else {
      scene->truth_body_ = scene->model_;
    }
    if (o.rig.empty()) {
      if (o.cameras <= 0) return Status::Error("fake scene: cameras must be positive");
      o.rig = defaultFakeRig(*scene->model_, *scene->motion_, o.cameras, o.width, o.height);
    }
  } catch (const std::exception& e) {
    return Status::Error(std::string("fake scene: ") + e.what());
  }
  scene->rig_ = o.rig;
  o.cameras = static_cast<int>(scene->rig_.size());
  scene->period_ns_ = static_cast<int64_t>(std::llround(1e9 / o.fps));
  scene->interval_ns_ = static_cast<int64_t>(std::llround(1e9 * o.slow_motion / o.fps));

  std::size_t largest_image = 0;
  for (std::size_t c = 0; c < scene->rig_.size(); ++c) {
    const CameraModel& cam = scene->rig_[c];
    if (cam.width <= 0 || cam.height <= 0 || cam.height > kMaxImageRows) {
      return Status::Error("fake scene: camera " + std::to_string(c) + " has a bad size " +
                           std::to_string(cam.width) + "x" + std::to_string(cam.height));
    }
    // Smooth blotches with a finer blocky texture on top: a background a silhouette extractor has
    // to learn, never flat.
    cv::RNG rng(splitmix64(o.seed * 7919 + c));
    cv::Mat coarse(10, 13, CV_8UC3),
        fine(std::max(1, cam.height / 8), std::max(1, cam.width / 8), CV_8UC3);
    rng.fill(coarse, cv::RNG::UNIFORM, 70, 190);
    rng.fill(fine, cv::RNG::UNIFORM, 0, 40);
    cv::Mat smooth, blocks, background;
    cv::resize(coarse, smooth, cv::Size(cam.width, cam.height), 0, 0, cv::INTER_CUBIC);
    cv::resize(fine, blocks, cv::Size(cam.width, cam.height), 0, 0, cv::INTER_NEAREST);
    cv::add(smooth, blocks, background);
    cv::subtract(background, cv::Scalar::all(20), background);
    if (o.gray) cv::cvtColor(background, background, cv::COLOR_BGR2GRAY);
    scene->backgrounds_.push_back(background);
    largest_image = std::max(largest_image, background.total() * background.elemSize());
  }
  cv::RNG rng(splitmix64(o.seed ^ 0x6e6f697365ull));
  scene->noise_up_.resize(largest_image + kNoiseOffsets);
  scene->noise_down_.resize(largest_image + kNoiseOffsets);
  for (std::size_t i = 0; i < scene->noise_up_.size(); ++i) {
    const long n = std::clamp(std::lround(rng.gaussian(o.noise_sigma)), -255l, 255l);
    scene->noise_up_[i] = static_cast<uint8_t>(std::max(n, 0l));
    scene->noise_down_[i] = static_cast<uint8_t>(std::max(-n, 0l));
  }
  return scene;
}

int64_t FakeScene::epochNs() {
  std::lock_guard<std::mutex> lock(epoch_mutex_);
  if (!epoch_ns_) epoch_ns_ = monotonicNowNs();
  return *epoch_ns_;
}

std::size_t FakeScene::motionFrame(uint64_t sequence) const {
  if (!subjectInView(sequence) || inFitPose(sequence) || steppingOut(sequence)) return 0;
  sequence -= options_.empty_frames + options_.fit_pose_frames + options_.step_out_frames;
  // Forward then backward: a looped motion would jump from its last pose to its first.
  const uint64_t n = motion_->size();
  if (n == 1) return 0;
  const uint64_t cycle = 2 * (n - 1);
  const uint64_t phase = sequence % cycle;
  return static_cast<std::size_t>(phase < n ? phase : cycle - phase);
}

Eigen::VectorXd FakeScene::truePose(uint64_t sequence) const {
  if (!subjectInView(sequence)) return Eigen::VectorXd();
  if (steppingOut(sequence)) {
    // Eased in and out (smoothstep), so the subject neither starts nor arrives with a jerk; the
    // turns have ended facing the motion's way.
    const double t =
        static_cast<double>(sequence - options_.empty_frames - options_.fit_pose_frames + 1) /
        static_cast<double>(options_.step_out_frames + 1);
    const double w = t * t * (3 - 2 * t);
    return (1 - w) * fit_pose_ + w * motion_->front();
  }
  if (!inFitPose(sequence)) return (*motion_)[motionFrame(sequence)];
  Eigen::VectorXd pose = fit_pose_;
  if (fit_turn_dof_ >= 0) {
    // Turning back and forth by up to 45 degrees either way, a 4 s cycle, ending facing the
    // motion's way as it starts.
    const double left_s =
        static_cast<double>(options_.empty_frames + options_.fit_pose_frames - sequence) *
        static_cast<double>(period_ns_) / 1e9;
    pose[fit_turn_dof_] += M_PI / 4 * std::sin(2 * M_PI * left_s / 4.0);
  }
  return pose;
}

GroundTruth FakeScene::groundTruth(uint64_t sequence) const {
  GroundTruth truth;
  truth.sequence = sequence;
  truth.motion_frame = motionFrame(sequence);
  truth.q = truePose(sequence);
  if (truth.q.size() == 0) {
    for (const CameraModel& camera : rig_)
      truth.silhouettes.push_back(cv::Mat::zeros(camera.height, camera.width, CV_8UC1));
    return truth;
  }
  std::lock_guard<std::mutex> lock(truth_mutex_);
  if (subject_) {
    if (!truth_scratch_) truth_scratch_ = std::make_unique<FakeRenderScratch>(*model_, 1);
    FakeRenderScratch& scratch = *truth_scratch_;
    poseSubject(sequence, scratch);
    truth.silhouettes.resize(rig_.size());
    for (std::size_t c = 0; c < rig_.size(); ++c)
      scratch.subject_rasterizer.renderSilhouette(scratch.posed, rig_[c], truth.silhouettes[c]);
    truth.points = modelPointsFromJoints(*model_, scratch.posed.joints);
    return truth;
  }
  if (!truth_renderer_) truth_renderer_ = std::make_unique<SceneRenderer>(*model_, rig_);
  truth_renderer_->renderSilhouettes(truth.q, truth.silhouettes);
  KinematicsData kinematics(*model_);
  forwardKinematics(*model_, kinematics, truth.q);
  truth.points = pointPositions(*model_, kinematics);
  return truth;
}

void FakeScene::poseSubject(uint64_t sequence, FakeRenderScratch& scratch) const {
  forwardKinematics(*model_, scratch.kinematics, truePose(sequence));
  subject_->pose(*model_, scratch.kinematics, scratch.posed);
}

void FakeScene::render(int camera, uint64_t sequence, FakeRenderScratch& scratch,
                       cv::Mat& image) const {
  const CameraModel& cam = rig_[camera];
  backgrounds_[camera].copyTo(image);
  if (subjectInView(sequence)) {
    if (subject_)
      paintPerson(cam, sequence, scratch, image);
    else
      paintSubject(cam, sequence, scratch, image);
  }
  addNoise(camera, sequence, image);
}

void FakeScene::paintPerson(const CameraModel& cam, uint64_t sequence, FakeRenderScratch& scratch,
                            cv::Mat& image) const {
  poseSubject(sequence, scratch);
  PersonLayer& layer = scratch.layer;
  scratch.subject_rasterizer.renderLayer(scratch.posed, cam, layer);
  if (!options_.gray) {
    layer.colour.copyTo(image, layer.mask);
    return;
  }
  cv::cvtColor(layer.colour, scratch.gray_layer, cv::COLOR_BGR2GRAY);
  scratch.gray_layer.copyTo(image, layer.mask);
}

void FakeScene::paintSubject(const CameraModel& cam, uint64_t sequence, FakeRenderScratch& scratch,
                             cv::Mat& image) const {
  forwardKinematics(*model_, scratch.kinematics, truePose(sequence));

  // Painter's order, farthest segment first, so nearer segments cover it as they would.
  std::vector<std::pair<double, std::size_t>> order;
  order.reserve(model_->segments.size());
  for (std::size_t s = 0; s < model_->segments.size(); ++s) {
    order.emplace_back(-cam.toCamera(scratch.kinematics.world[s].translation()).z(), s);
  }
  std::sort(order.begin(), order.end());
  for (const auto& [depth, s] : order) {
    const Footprint f = scratch.rasterizer.rasterize(
        model_->segments[s].shape, scratch.kinematics.world[s], cam, scratch.spans.data());
    if (options_.gray) {
      fillFootprint(image, f, kSegmentGrays[s % std::size(kSegmentGrays)]);
      continue;
    }
    const cv::Vec3b colour = kSegmentPalette[s % std::size(kSegmentPalette)];
    for (int y = f.y0; y < f.y1; ++y) {
      const RowSpan& span = f.spans[y - f.y0];
      cv::Vec3b* row = image.ptr<cv::Vec3b>(y);
      std::fill(row + span.x0, row + span.x1, colour);
    }
  }
}

void FakeScene::addNoise(int camera, uint64_t sequence, cv::Mat& image) const {
  if (options_.noise_sigma <= 0) return;
  // Zero-mean noise in two saturating SIMD passes (add the positive part, subtract the negative),
  // read from the precomputed strip at a per-frame offset: cheap, and repeatable per frame.
  const std::size_t bytes = image.total() * image.elemSize();
  const std::size_t offset = hash(camera, sequence, 1) % kNoiseOffsets;
  cv::Mat flat = image.reshape(1, 1);
  // Read-only headers over the strips (cv::Mat has no const view).
  const cv::Mat up(1, static_cast<int>(bytes), CV_8UC1,
                   const_cast<uint8_t*>(noise_up_.data() + offset));
  const cv::Mat down(1, static_cast<int>(bytes), CV_8UC1,
                     const_cast<uint8_t*>(noise_down_.data() + offset));
  cv::add(flat, up, flat);
  cv::subtract(flat, down, flat);
}

uint64_t FakeScene::hash(int camera, uint64_t sequence, uint64_t salt) const {
  return splitmix64(
      splitmix64(splitmix64(options_.seed ^ (salt << 56)) ^ static_cast<uint64_t>(camera)) ^
      sequence);
}

bool FakeScene::dropped(const FakeFaults& faults, int camera, uint64_t sequence) const {
  return faults.drop_rate > 0 && unitInterval(hash(camera, sequence, 2)) < faults.drop_rate;
}

int64_t FakeScene::jitterNs(int camera, uint64_t sequence) const {
  // Capped so frames of one camera never swap order and sets still group within the tolerance.
  const int64_t amplitude =
      std::min<int64_t>(options_.faults.timestamp_jitter.count(), period_ns_ / 3);
  if (amplitude <= 0) return 0;
  return static_cast<int64_t>(
      std::llround((2 * unitInterval(hash(camera, sequence, 3)) - 1) * amplitude));
}

bool FakeScene::inOutage(const FakeOutage& outage, int camera, uint64_t sequence) const {
  if (outage.camera != camera || outage.duration.count() <= 0) return false;
  if (sequence < outage.after_frames) return false;
  const auto wholePeriods = [this](std::chrono::nanoseconds span) {
    return static_cast<uint64_t>((span.count() + period_ns_ - 1) / period_ns_);
  };
  const uint64_t frames = wholePeriods(outage.duration);
  uint64_t since_start = sequence - outage.after_frames;
  if (outage.every.count() > 0) since_start %= std::max(wholePeriods(outage.every), frames + 1);
  return since_start < frames;
}

}  // namespace mocap
