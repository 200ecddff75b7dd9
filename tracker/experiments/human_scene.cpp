// The human experiment's cameras: rendered or extracted silhouettes of the model or a subject.
#include "tracker/experiments/human_scene.h"

#include <cmath>
#include <stdexcept>

#include "tracker/model/kinematics.h"
#include "tracker/sim/subject.h"
#include "tracker/vision/background_model.h"

namespace mocap {

namespace {

// The summed lengths of the bones joining `joints` in order, for joints given in SubjectJoint
// order (a subject's rest, or a body's joints).
double chainLength(const SubjectJoints& j, std::initializer_list<int> joints) {
  double length = 0;
  for (auto it = joints.begin(); std::next(it) != joints.end(); ++it)
    length += (j[*std::next(it)] - j[*it]).norm();
  return length;
}

BodyProportions proportionsOf(const SubjectJoints& j) {
  BodyProportions p;
  p.legs = chainLength(j, {kLHip, kLKnee, kLAnkle, kLToe}) +
           chainLength(j, {kRHip, kRKnee, kRAnkle, kRToe});
  p.arms = chainLength(j, {kLShoulder, kLElbow, kLWrist, kLHand}) +
           chainLength(j, {kRShoulder, kRElbow, kRWrist, kRHand});
  // From between the hips, not from the pelvis joint: a subject's sits above its hips, the
  // shipped body's level with them.
  p.trunk = (j[kNeck] - 0.5 * (j[kLHip] + j[kRHip])).norm();
  p.head = (j[kHeadTop] - j[kNeck]).norm();
  p.width = (j[kLHip] - j[kRHip]).norm() + (j[kLShoulder] - j[kRShoulder]).norm();
  return p;
}

// Mean radii of the parts the three girths scale, in metres: the trunk's ellipsoids across their
// up axis, and the arms' and legs' round pieces (upper arm and forearm, thigh and shin).
struct PartRadii {
  double trunk = 0, arms = 0, legs = 0;
};

PartRadii partRadii(const PosedSubject& subject) {
  double sum[3] = {0, 0, 0};
  int count[3] = {0, 0, 0};
  for (const SubjectPrimitive& p : subject.primitives) {
    const bool ellipsoid = p.kind == SubjectPrimitive::Kind::kEllipsoid;
    if (ellipsoid && p.bone < 0) {  // the trunk's (garments are cones)
      sum[0] += 0.5 * (p.linear.col(0).norm() + p.linear.col(1).norm());
      ++count[0];
      continue;
    }
    const int part =
        p.bone == kRElbow || p.bone == kRWrist || p.bone == kLElbow || p.bone == kLWrist ? 1
        : p.bone == kRKnee || p.bone == kRAnkle || p.bone == kLKnee || p.bone == kLAnkle ? 2
                                                                                         : -1;
    if (part < 0 || ellipsoid) continue;  // the calves' ellipsoids have no counterpart
    sum[part] += 0.5 * (p.radius0 + p.radius1);
    ++count[part];
  }
  return {sum[0] / count[0], sum[1] / count[1], sum[2] / count[2]};
}

PartRadii partRadii(const BodyModel& body) {
  const auto mean = [&](std::initializer_list<const char*> names, bool ellipsoids) {
    double sum = 0;
    for (const char* name : names) {
      const Shape& shape = body.segments.at(body.segmentIndex(name)).shape;
      sum += ellipsoids ? 0.5 * (shape.radii.x() + shape.radii.y())
                        : 0.5 * (shape.radius_start + shape.radius_end);
    }
    return sum / names.size();
  };
  return {mean({"pelvis", "chest"}, true),
          mean({"r_upper_arm", "r_forearm", "l_upper_arm", "l_forearm"}, false),
          mean({"r_thigh", "r_shin", "l_thigh", "l_shin"}, false)};
}

}  // namespace

HumanScene::HumanScene(const BodyModel& model, const Rig& rig, const HumanSceneOptions& options,
                       const Eigen::VectorXd& first_pose)
    : model_(model), rig_(rig), options_(options), kinematics_(model_) {
  if (options.subject_seed) {
    params_ = drawSubjectParams(*options.subject_seed);
    subject_renderer_ = std::make_unique<SubjectSceneRenderer>(model_, rig_, *params_);
  } else {
    model_renderer_ = std::make_unique<SceneRenderer>(model_, rig_);
  }
  if (!options.extracted) return;
  renderLayers(first_pose);
  for (std::size_t c = 0; c < rig_.size(); ++c) {
    TestSceneOptions room;
    room.camera = rig_[c];
    room.width = rig_[c].width;
    room.height = rig_[c].height;
    room.seed = options.seed * 7 + c;  // every camera sees another wall
    room.person = [this, c](int /*t*/, const CameraModel& /*camera*/, PersonLayer& layer) {
      layer = layers_[c];
    };
    rooms_.push_back(std::make_unique<SilhouetteTestScene>(room));
  }
}

HumanScene::~HumanScene() = default;

void HumanScene::renderLayers(const Eigen::VectorXd& q) {
  if (subject_renderer_) {
    subject_renderer_->renderLayers(q, layers_);
    return;
  }
  // The model's cones in one flat colour: the lab's body, extracted.
  std::vector<cv::Mat> masks;
  model_renderer_->renderSilhouettes(q, masks);
  layers_.resize(masks.size());
  for (std::size_t c = 0; c < masks.size(); ++c) {
    layers_[c].mask = masks[c].clone();
    layers_[c].colour = cv::Mat(masks[c].size(), CV_8UC3, cv::Scalar(0, 0, 0));
    layers_[c].colour.setTo(cv::Scalar(60, 85, 170), masks[c]);
    layers_[c].depth = cv::Mat();
    layers_[c].chest.reset();
  }
}

void HumanScene::learnBackground() {
  if (!options_.extracted) return;
  extractors_.clear();
  for (auto& room : rooms_) {
    BackgroundLearner learner;
    for (int t = 0; t < kBackgroundFrames; ++t) {
      room->render(time_ + t, false, frame_);
      learner.add(frame_.image);
    }
    extractors_.push_back(std::make_unique<SilhouetteExtractor>(learner.model()));
  }
  time_ += kBackgroundFrames;
}

void HumanScene::renderSilhouettes(const Eigen::VectorXd& q, std::vector<cv::Mat>& images) {
  if (!options_.extracted) {
    if (subject_renderer_)
      subject_renderer_->renderSilhouettes(q, images);
    else
      model_renderer_->renderSilhouettes(q, images);
    return;
  }
  if (extractors_.empty()) throw std::logic_error("HumanScene: no background learned");
  renderLayers(q);
  images.resize(rooms_.size());
  for (std::size_t c = 0; c < rooms_.size(); ++c) {
    rooms_[c]->render(time_, true, frame_);
    if (!extractors_[c]->extract(frame_.image))
      throw std::runtime_error("silhouette extraction: " + extractors_[c]->lastError());
    extractors_[c]->foreground().copyTo(images[c]);
    countExtraction(images[c]);
  }
  ++time_;
}

void HumanScene::countExtraction(const cv::Mat& extracted) {
  // The room is what is neither person nor cast shadow (which never lies on the person).
  ExtractionCounts& n = extraction_counts_;
  const int person = cv::countNonZero(frame_.body);
  const int shadow = cv::countNonZero(frame_.shadow);
  const int found = cv::countNonZero(extracted & frame_.body);
  const int shadow_taken = cv::countNonZero(extracted & frame_.shadow);
  const int taken = cv::countNonZero(extracted);
  const int either = person + taken - found;
  n.iou_sum += either > 0 ? static_cast<double>(found) / either : 1.0;
  ++n.frames;
  n.person += person;
  n.missed += person - found;
  n.shadow += shadow;
  n.shadow_taken += shadow_taken;
  n.room += static_cast<long>(extracted.total()) - person - shadow;
  n.room_taken += taken - found - shadow_taken;
}

std::optional<HumanScene::ExtractionScore> HumanScene::extractionScore() const {
  const ExtractionCounts& n = extraction_counts_;
  if (n.frames == 0) return std::nullopt;  // true silhouettes: nothing extracted
  const auto share = [](long part, long whole) {
    return whole > 0 ? static_cast<double>(part) / static_cast<double>(whole) : 0.0;
  };
  return ExtractionScore{n.iou_sum / static_cast<double>(n.frames), share(n.missed, n.person),
                         share(n.shadow_taken, n.shadow), share(n.room_taken, n.room), n.frames};
}

void HumanScene::hideSegment(int camera, int segment) {
  if (subject_renderer_)
    subject_renderer_->hideSegment(camera, segment);
  else
    model_renderer_->hideSegment(camera, segment);
}

void HumanScene::clearHidden() {
  if (subject_renderer_)
    subject_renderer_->clearHidden();
  else
    model_renderer_->clearHidden();
}

std::vector<Eigen::Vector3d> HumanScene::truthPoints(const Eigen::VectorXd& q) {
  if (subject_renderer_) {
    subject_renderer_->pose(q);
    return subject_renderer_->truthPoints();
  }
  forwardKinematics(model_, kinematics_, q);
  return pointPositions(model_, kinematics_);
}

const SubjectParams* HumanScene::subjectParams() const { return params_ ? &*params_ : nullptr; }

std::optional<BodyProportions> HumanScene::subjectProportions(const BodyModel& shipped) const {
  if (!subject_renderer_) return std::nullopt;
  const BodyProportions subject = proportionsOf(subject_renderer_->subject().rest());
  const BodyProportions body = proportionsOf(subjectJointsAt(shipped, shipped.neutralPose()));
  BodyProportions ratio;
  for (int k = 0; k < BodyProportions::kCount; ++k) ratio[k] = subject[k] / body[k];
  PosedSubject standing;
  subject_renderer_->subject().pose(subjectJointsAt(model_, model_.neutralPose()), standing);
  const PartRadii drawn = partRadii(standing), shipped_radii = partRadii(shipped);
  ratio.trunk_girth = drawn.trunk / shipped_radii.trunk;
  ratio.arm_girth = drawn.arms / shipped_radii.arms;
  ratio.leg_girth = drawn.legs / shipped_radii.legs;
  // Not reported: a garment's where there is one.
  ratio.thigh_end_girth = std::nan("");
  return ratio;
}

}  // namespace mocap
