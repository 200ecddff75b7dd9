// What the cameras of the human experiment see, and the truth they are scored against: the
// tracker's own body (a lab figure) or a simulated subject unlike it (subject.h), and silhouettes
// either rendered exactly or extracted, as mocapd does, from colour images against a background
// learned from the empty room first.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/search/body_size.h"
#include "tracker/sim/scene.h"
#include "tracker/sim/subject_render.h"
#include "tracker/sim/test_scene.h"
#include "tracker/vision/silhouette_extractor.h"

namespace mocap {

// Frames of the empty room each camera's background is learned from: mocapd's default capture.
inline constexpr int kBackgroundFrames = 25;

struct HumanSceneOptions {
  std::optional<uint64_t> subject_seed;  // empty: the subject is the tracker's body (`model`)
  bool extracted = false;                // false: the true silhouettes
  uint64_t seed = 1;                     // the rooms' paint and the sensor noise
};

class HumanScene {
 public:
  // `model`: the body the motion's poses are of (it drives the subject). `first_pose`: where the
  // person stands when the rooms are set up (their floor is placed under its feet).
  HumanScene(const BodyModel& model, const Rig& rig, const HumanSceneOptions& options,
             const Eigen::VectorXd& first_pose);
  ~HumanScene();

  // Extracted silhouettes: learns every camera's background from kBackgroundFrames frames of the
  // empty room (no-op otherwise). Call once before the first render().
  void learnBackground();
  // Each camera's silhouette (CV_8UC1, 0/255) of the person in pose `q`, at the next frame time.
  void renderSilhouettes(const Eigen::VectorXd& q, std::vector<cv::Mat>& images);
  void hideSegment(int camera, int segment);
  void clearHidden();
  // The person's joints at pose `q`, in the model's point order: the model's points, or the
  // subject's own joints (retargeted to its bone lengths), which the tracker is scored against.
  std::vector<Eigen::Vector3d> truthPoints(const Eigen::VectorXd& q);

  // The subject's build against `shipped` (the body model file the tracker's body is fitted from),
  // measured as BodyProportions are applied (proportionedBodyModel): legs and arms by the summed
  // bone lengths of both limbs, trunk by pelvis-neck, head by neck-head top, width by the hip plus
  // shoulder spacings, each over the shipped body's at its neutral pose; each girth by the mean
  // radius of its part's pieces as drawn standing (close clothes and sleeves included, skirts and
  // coats not): the trunk's ellipsoids across, the upper arms' and forearms', the thighs' and
  // shins', over the shipped body's; thigh_end_girth NaN, a garment's and not the body's. Empty
  // without a subject.
  std::optional<BodyProportions> subjectProportions(const BodyModel& shipped) const;
  const SubjectParams* subjectParams() const;

  // Extracted silhouettes against the person's true ones, over every camera frame rendered so
  // far: mean IoU, and the shares of the person missed, of the cast shadow taken as person, and of
  // the rest of the room taken as person. Empty for true silhouettes.
  struct ExtractionScore {
    double iou = 0, missed = 0, shadow_taken = 0, room_taken = 0;
    long frames = 0;
  };
  std::optional<ExtractionScore> extractionScore() const;

 private:
  void renderLayers(const Eigen::VectorXd& q);
  void countExtraction(const cv::Mat& extracted);

  BodyModel model_;
  Rig rig_;
  HumanSceneOptions options_;
  std::optional<SubjectParams> params_;
  std::unique_ptr<SceneRenderer> model_renderer_;  // no subject
  std::unique_ptr<SubjectSceneRenderer> subject_renderer_;
  KinematicsData kinematics_;
  // Extraction: one room and one extractor per camera, and the person's layers they paint.
  std::vector<PersonLayer> layers_;
  std::vector<std::unique_ptr<SilhouetteTestScene>> rooms_;
  std::vector<std::unique_ptr<SilhouetteExtractor>> extractors_;
  TestSceneFrame frame_;
  std::vector<cv::Mat> model_masks_;
  struct ExtractionCounts {
    double iou_sum = 0;
    long frames = 0, person = 0, missed = 0, shadow = 0, shadow_taken = 0, room = 0, room_taken = 0;
  } extraction_counts_;
  int time_ = 0;  // the rooms' frame count: light drift and noise move on with it
};

}  // namespace mocap
