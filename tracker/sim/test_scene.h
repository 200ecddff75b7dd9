// A synthetic camera view for testing and measuring silhouette extraction with known truth: a
// textured wall and tiled floor, a simple articulated person (rendered by the tracker's
// SceneRenderer, or any person layer, e.g. a simulated subject) with shading, a cast shadow on the
// floor, a patch on the body coloured like the background behind it, sensor noise and a slow global
// illumination change.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>

#include <opencv2/core.hpp>

#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/sim/person_layer.h"
#include "tracker/sim/scene.h"

namespace mocap {

struct TestSceneOptions {
  int width = 780;
  int height = 580;
  // The camera the scene is seen from, of width x height pixels; empty: one 3.9 m in front of the
  // person, looking at its hips. The wall and floor are painted in the image either way.
  std::optional<CameraModel> camera;
  bool color = true;  // BGR, else gray
  uint64_t seed = 1;
  double noise_sigma = 2.5;           // gray levels, per channel
  double illumination_drift = 0.001;  // relative brightness change per frame
  double side_drift = 0.0;            // extra relative change per frame, left half only
  double shadow_factor = 0.55;        // brightness left in the shadow's core
  bool camouflage = true;             // a patch on the torso close to the wall's colour
  bool moving = true;                 // false: the person stands still in one pose
  // Draws the person of frame t (at t = 0 too, before any frame, to place the floor) into the
  // scene's camera. Empty: the built-in articulated person of pose(t), shirt and trousers painted
  // by the scene. A painter's layer (mask and colours) replaces it; the shadow, light and noise
  // fall on it alike, and the camouflage patch goes on layer.chest when it is set.
  std::function<void(int t, const CameraModel& camera, PersonLayer& layer)> person;
};

// One generated frame: the image and its truth (body: the person only; shadow: darkened pixels off
// the body). Buffers are reused across render() calls.
struct TestSceneFrame {
  cv::Mat image;   // CV_8UC3 or CV_8UC1
  cv::Mat body;    // CV_8UC1, 255 = person
  cv::Mat shadow;  // CV_8UC1, 255 = cast shadow, never on the body
};

class SilhouetteTestScene {
 public:
  explicit SilhouetteTestScene(const TestSceneOptions& options);

  // Frame `t` (illumination and pose follow t); without the person for background learning.
  void render(int t, bool with_person, TestSceneFrame& out);

  const CameraModel& camera() const { return rig_[0]; }
  const BodyModel& model() const { return model_; }
  Eigen::VectorXd pose(int t) const;

 private:
  void paintBuiltInPerson(double sway, const cv::Mat& body_mask);
  void paintLayer(const cv::Mat& body_mask);

  TestSceneOptions options_;
  BodyModel model_;
  Rig rig_;
  SceneRenderer renderer_;
  cv::RNG rng_;
  cv::Mat wall_;       // CV_32FC3, the lit scene without person at gain 1
  cv::Mat side_mask_;  // CV_32FC3, 1 on the left half
  int feet_row_ = 0;
  std::vector<cv::Mat> silhouettes_;
  cv::Mat shaded_, shadow_soft_, distance_, noise_, scratch_;
  PersonLayer layer_;  // the painter's
};

}  // namespace mocap
