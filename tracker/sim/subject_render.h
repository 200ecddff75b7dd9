// Rendering simulated subjects (subject.h) into calibrated cameras: a binary silhouette, and a
// person layer (mask, Lambert-shaded colours, depth) for the colour scenes to composite. Each
// primitive's projection is convex: the hull of its projected contour points is scan-converted,
// and only the layer's pixels inside it are ray-tested against the primitive, through a z-buffer.
#pragma once

#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core/mat.hpp>

#include "tracker/model/body_model.h"
#include "tracker/model/camera.h"
#include "tracker/model/kinematics.h"
#include "tracker/sim/person_layer.h"
#include "tracker/sim/subject.h"

namespace mocap {

struct SubjectLighting {
  Eigen::Vector3d toward_light = Eigen::Vector3d(0.35, -0.6, 0.72).normalized();  // world
  double ambient = 0.35;  // the shade of a surface facing away from the light
};

// Renders posed subjects. Holds the scratch (outlines, spans, the camera's per-pixel rays): one
// per thread.
class SubjectRasterizer {
 public:
  explicit SubjectRasterizer(SubjectLighting lighting = {}) : lighting_(lighting) {}

  // CV_8UC1 sized to the camera: 255 where the subject is, else 0.
  void renderSilhouette(const PosedSubject& subject, const CameraModel& camera, cv::Mat& mask);
  // The silhouette (layer.mask, the same pixels as renderSilhouette's), the shaded colours of the
  // nearest surface and its depth; layer.chest set.
  void renderLayer(const PosedSubject& subject, const CameraModel& camera, PersonLayer& layer);

 private:
  struct Rows {  // one primitive's scan-converted projection: columns [x0, x1) of rows [y0, y1)
    int y0 = 0, y1 = 0;
    std::vector<int> x0, x1;
  };
  bool scanPrimitive(const SubjectPrimitive& p, const CameraModel& camera);
  void addContour(const Eigen::Vector3d& centre, const Eigen::Matrix3d& shape,
                  const CameraModel& camera);
  void addDisc(const Eigen::Vector3d& centre, const Eigen::Matrix3d& shape,
               const CameraModel& camera);
  const cv::Mat* pixelRays(const CameraModel& camera);
  void shadePrimitive(const SubjectPrimitive& p, const CameraModel& camera, const cv::Mat* rays,
                      const Clothing& clothing, PersonLayer& layer);

  SubjectLighting lighting_;
  bool behind_ = false;  // a contour point of the current primitive is behind the camera
  std::vector<Eigen::Vector2d> points_, hull_;
  std::vector<double> lo_, hi_;
  Rows rows_;
  struct RayTable {
    CameraModel camera;
    cv::Mat rays;  // CV_32FC2: the undistorted normalised image coordinates of each pixel
  };
  std::vector<RayTable> ray_tables_;  // cameras with distortion only
};

// The first hit of the ray origin + t * direction (world, t > 0) on the primitive's surface: t and
// the unit outward normal. False if the ray misses it. Exposed for tests.
bool intersectSubjectPrimitive(const SubjectPrimitive& p, const Eigen::Vector3d& origin,
                               const Eigen::Vector3d& direction, double& t,
                               Eigen::Vector3d& normal);

// A drop-in for SceneRenderer (scene.h) that draws a subject instead of the model: posed by the
// model's joints at each q, with the subject's own proportions and clothes. The truth to score a
// tracker against is then truthPoints(), not the model's points at q.
class SubjectSceneRenderer {
 public:
  // `model` needs the subject's joints as points (the human model's). Throws
  // std::invalid_argument otherwise.
  SubjectSceneRenderer(const BodyModel& model, const Rig& rig, const SubjectParams& params);

  std::vector<cv::Mat> renderSilhouettes(const Eigen::VectorXd& q);
  void renderSilhouettes(const Eigen::VectorXd& q, std::vector<cv::Mat>& images);
  void renderLayers(const Eigen::VectorXd& q, std::vector<PersonLayer>& layers);
  // Poses the subject only (renders call it).
  const PosedSubject& pose(const Eigen::VectorXd& q);
  // Leaves the subject's pieces on model segment `segment` (the bones from the joints the
  // segment carries: l_forearm, the forearm and hand) out of camera `camera`'s images until
  // cleared, as SceneRenderer::hideSegment does (a limb missed by segmentation).
  void hideSegment(int camera, int segment);
  void clearHidden() { hidden_.clear(); }

  // The subject's joints in the last pose, as the model's points (model point order).
  const std::vector<Eigen::Vector3d>& truthPoints() const { return truth_; }
  const PosedSubject& posed() const { return posed_; }
  Subject& subject() { return subject_; }
  const Rig& rig() const { return rig_; }

 private:
  BodyModel model_;
  Rig rig_;
  Subject subject_;
  KinematicsData kinematics_;
  PosedSubject posed_;
  SubjectRasterizer rasterizer_;
  std::vector<Eigen::Vector3d> truth_;
  std::vector<std::pair<int, int>> hidden_;  // (camera, subject joint ending the bone)
  PosedSubject visible_;                     // posed_ less the hidden bones of one camera
  const PosedSubject& visibleIn(int camera);
};

}  // namespace mocap
