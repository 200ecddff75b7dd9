// Test-scene generator for silhouette extraction (see test_scene.h).
#include "tracker/sim/test_scene.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace mocap {

namespace {

// A person 1.8 m tall facing the camera (-Y), Z up, feet on the floor (z = 0). Angles in degrees.
constexpr const char* kPersonYaml = R"yaml(
name: person
segments:
  - name: pelvis
    offset: [0, 0, 1.0]
    dofs: [{name: sway, type: translation, axis: [1, 0, 0], min: -0.5, max: 0.5, max_speed: 0.05}]
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.17, 0.11, 0.12]}
  - name: torso
    parent: pelvis
    offset: [0, 0, 0.05]
    shape: {type: cone, axis: [0, 0, 1], length: 0.47, radius_start: 0.15, radius_end: 0.19}
  - name: head
    parent: torso
    offset: [0, 0, 0.63]
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.085, 0.095, 0.115]}
  - name: l_upper_arm
    parent: torso
    offset: [0.23, 0, 0.45]
    dofs: [{name: l_shoulder, axis: [0, -1, 0], min: -10, max: 150, max_speed: 8}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.3, radius_start: 0.055, radius_end: 0.043}
  - name: l_forearm
    parent: l_upper_arm
    offset: [0, 0, -0.3]
    dofs: [{name: l_elbow, axis: [0, -1, 0], min: 0, max: 140, max_speed: 8}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.3, radius_start: 0.042, radius_end: 0.032}
  - name: r_upper_arm
    parent: torso
    offset: [-0.23, 0, 0.45]
    dofs: [{name: r_shoulder, axis: [0, 1, 0], min: -10, max: 150, max_speed: 8}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.3, radius_start: 0.055, radius_end: 0.043}
  - name: r_forearm
    parent: r_upper_arm
    offset: [0, 0, -0.3]
    dofs: [{name: r_elbow, axis: [1, 0, 0], min: 0, max: 140, max_speed: 8}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.3, radius_start: 0.042, radius_end: 0.032}
  - name: l_thigh
    parent: pelvis
    offset: [0.09, 0, -0.05]
    dofs: [{name: l_hip, axis: [1, 0, 0], min: -45, max: 45, max_speed: 6}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.45, radius_start: 0.08, radius_end: 0.055}
  - name: l_shin
    parent: l_thigh
    offset: [0, 0, -0.45]
    dofs: [{name: l_knee, axis: [1, 0, 0], min: -90, max: 0, max_speed: 8}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.44, radius_start: 0.052, radius_end: 0.04}
  - name: l_foot
    parent: l_shin
    offset: [0, -0.05, -0.46]
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.045, 0.11, 0.035]}
  - name: r_thigh
    parent: pelvis
    offset: [-0.09, 0, -0.05]
    dofs: [{name: r_hip, axis: [1, 0, 0], min: -45, max: 45, max_speed: 6}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.45, radius_start: 0.08, radius_end: 0.055}
  - name: r_shin
    parent: r_thigh
    offset: [0, 0, -0.45]
    dofs: [{name: r_knee, axis: [1, 0, 0], min: -90, max: 0, max_speed: 8}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.44, radius_start: 0.052, radius_end: 0.04}
  - name: r_foot
    parent: r_shin
    offset: [0, -0.05, -0.46]
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.045, 0.11, 0.035]}
)yaml";

Rig sceneRig(int width, int height) {
  const double focal = 640.0 * height / 580.0;
  return {CameraModel::lookAt("scene", Eigen::Vector3d(0.8, -3.8, 1.4),
                              Eigen::Vector3d(0.0, 0.0, 0.9), Eigen::Vector3d::UnitZ(), width,
                              height, focal)};
}

// Smooth random field in [lo, hi]: uniform noise on a coarse grid, upsampled.
cv::Mat smoothNoise(cv::RNG& rng, cv::Size size, int cell, int channels, double lo, double hi) {
  cv::Mat coarse(std::max(2, size.height / cell), std::max(2, size.width / cell),
                 CV_32FC(channels));
  rng.fill(coarse, cv::RNG::UNIFORM, lo, hi);
  cv::Mat field;
  cv::resize(coarse, field, size, 0, 0, cv::INTER_CUBIC);
  return field;
}

}  // namespace

SilhouetteTestScene::SilhouetteTestScene(const TestSceneOptions& options)
    : options_(options),
      model_(parseBodyModel(kPersonYaml, "builtin person")),
      rig_(options.camera ? Rig{*options.camera} : sceneRig(options.width, options.height)),
      renderer_(model_, rig_),
      rng_(options.seed * 7919 + 17) {
  const cv::Size size(options.width, options.height);
  if (rig_[0].width != options.width || rig_[0].height != options.height)
    throw std::invalid_argument("test scene: the camera's image is not width x height");
  if (options.person) {
    options.person(0, rig_[0], layer_);
  } else {
    renderer_.renderSilhouettes(pose(0), silhouettes_);
  }
  cv::Rect person = cv::boundingRect(options.person ? layer_.mask : silhouettes_[0]);
  feet_row_ = person.empty() ? size.height * 3 / 4 : person.br().y;
  const int horizon = std::clamp(feet_row_ - size.height / 4, 1, size.height - 1);

  // Wall: slowly varying paint, mid-frequency texture, fine grain and a few posters.
  wall_ = smoothNoise(rng_, size, 160, 3, 80, 170) + smoothNoise(rng_, size, 10, 3, -18, 18) +
          smoothNoise(rng_, size, 2, 3, -6, 6);
  for (int i = 0; i < 6; ++i) {
    const int w = rng_.uniform(size.width / 20, size.width / 6);
    const int h = rng_.uniform(size.height / 20, size.height / 5);
    const cv::Rect poster(rng_.uniform(0, size.width - w), rng_.uniform(0, horizon), w, h);
    cv::Mat area = wall_(poster & cv::Rect(0, 0, size.width, horizon));
    area += cv::Scalar(rng_.uniform(-50, 50), rng_.uniform(-50, 50), rng_.uniform(-50, 50));
  }
  // Floor: tiles with grout lines and their own grain.
  const int tile = std::max(8, size.width / 16);
  const cv::Vec3f tile_colors[2] = {
      {rng_.uniform(90.f, 130.f), rng_.uniform(90.f, 130.f), rng_.uniform(90.f, 130.f)},
      {rng_.uniform(120.f, 170.f), rng_.uniform(120.f, 170.f), rng_.uniform(120.f, 170.f)}};
  cv::Mat floor_grain = smoothNoise(rng_, size, 3, 3, -8, 8);
  for (int y = horizon; y < size.height; ++y) {
    auto* row = wall_.ptr<cv::Vec3f>(y);
    const auto* grain = floor_grain.ptr<cv::Vec3f>(y);
    for (int x = 0; x < size.width; ++x) {
      const bool grout = x % tile < 2 || (y - horizon) % (tile / 2) < 2;
      row[x] = grout ? cv::Vec3f(60, 60, 60)
                     : tile_colors[((x / tile) + (y - horizon) / (tile / 2)) % 2];
      row[x] += grain[x];
    }
  }
  side_mask_ = cv::Mat::zeros(size, CV_32FC3);
  side_mask_(cv::Rect(0, 0, size.width / 2, size.height)).setTo(cv::Scalar::all(1));
}

Eigen::VectorXd SilhouetteTestScene::pose(int t) const {
  const double time = options_.moving ? t : 0;
  const double degrees = M_PI / 180;
  Eigen::VectorXd q = model_.neutralPose();
  auto set = [&](const char* name, double value) { q[model_.dofIndex(name)] = value; };
  auto wave = [&](double period, double phase) {
    return std::sin(2 * M_PI * time / period + phase);
  };
  set("sway", 0.25 * wave(160, 0));
  set("l_shoulder", (45 + 40 * wave(50, 0.3)) * degrees);
  set("l_elbow", (40 + 35 * wave(37, 1.0)) * degrees);
  set("r_shoulder", (30 + 25 * wave(61, 2.0)) * degrees);
  set("r_elbow", (50 + 40 * wave(43, 0.5)) * degrees);
  set("l_hip", 20 * wave(64, 0) * degrees);
  set("l_knee", (-15 - 15 * wave(64, 1.5)) * degrees);
  set("r_hip", -20 * wave(64, 0) * degrees);
  set("r_knee", (-15 + 15 * wave(64, 1.5)) * degrees);
  return q;
}

void SilhouetteTestScene::paintBuiltInPerson(double sway, const cv::Mat& body_mask) {
  // Shirt with stripes above the hips, trousers below, darker toward the outline.
  const cv::Size size(options_.width, options_.height);
  cv::distanceTransform(body_mask, distance_, cv::DIST_L2, 3);
  Eigen::Vector2d hips;
  const bool hips_seen = rig_[0].project(Eigen::Vector3d(sway, 0, 0.95), hips);
  const int hip_row = hips_seen ? static_cast<int>(hips.y()) : size.height / 2;
  for (int y = 0; y < size.height; ++y) {
    auto* row = shaded_.ptr<cv::Vec3f>(y);
    const uint8_t* body = body_mask.ptr<uint8_t>(y);
    const float* inside = distance_.ptr<float>(y);
    const bool shirt = y < hip_row;
    const float stripe = shirt && (y / 12) % 2 ? 25.f : 0.f;
    const cv::Vec3f cloth =
        shirt ? cv::Vec3f(60 + stripe, 85 + stripe, 170) : cv::Vec3f(120, 75, 45);
    for (int x = 0; x < size.width; ++x) {
      if (!body[x]) continue;
      row[x] = cloth * (0.55f + 0.45f * std::min(1.0f, inside[x] / 12.0f));
    }
  }
}

void SilhouetteTestScene::paintLayer(const cv::Mat& body_mask) {
  for (int y = 0; y < body_mask.rows; ++y) {
    auto* row = shaded_.ptr<cv::Vec3f>(y);
    const uint8_t* body = body_mask.ptr<uint8_t>(y);
    const cv::Vec3b* colour = layer_.colour.ptr<cv::Vec3b>(y);
    for (int x = 0; x < body_mask.cols; ++x)
      if (body[x]) row[x] = cv::Vec3f(colour[x][0], colour[x][1], colour[x][2]);
  }
}

void SilhouetteTestScene::render(int t, bool with_person, TestSceneFrame& out) {
  const cv::Size size(options_.width, options_.height);
  wall_.copyTo(shaded_);
  out.body.create(size, CV_8UC1);
  out.shadow.create(size, CV_8UC1);
  out.body.setTo(0);
  out.shadow.setTo(0);

  if (with_person) {
    const Eigen::VectorXd q = pose(t);
    const double sway = q[model_.dofIndex("sway")];
    if (options_.person) {
      options_.person(t, rig_[0], layer_);
      layer_.mask.copyTo(out.body);
    } else {
      renderer_.renderSilhouettes(q, silhouettes_);
      silhouettes_[0].copyTo(out.body);
    }

    // Cast shadow: the silhouette sheared sideways and flattened onto the floor from the feet row,
    // with a soft edge (penumbra).
    const double shear = 0.6, flatten = 0.45, feet = feet_row_;
    const cv::Matx23d to_floor(1, -shear, shear * feet, 0, flatten, feet * (1 - flatten));
    cv::warpAffine(out.body, scratch_, to_floor, size, cv::INTER_LINEAR);
    scratch_.convertTo(shadow_soft_, CV_32F, 1.0 / 255);
    cv::GaussianBlur(shadow_soft_, shadow_soft_, cv::Size(9, 9), 2.5);
    for (int y = 0; y < size.height; ++y) {
      auto* row = shaded_.ptr<cv::Vec3f>(y);
      const float* soft = shadow_soft_.ptr<float>(y);
      uint8_t* truth = out.shadow.ptr<uint8_t>(y);
      const uint8_t* body = out.body.ptr<uint8_t>(y);
      for (int x = 0; x < size.width; ++x) {
        if (soft[x] < 0.02f) continue;
        row[x] *= static_cast<float>(1 - (1 - options_.shadow_factor) * soft[x]);
        truth[x] = body[x] ? 0 : 255;
      }
    }

    if (options_.person) {
      paintLayer(out.body);
    } else {
      paintBuiltInPerson(sway, out.body);
    }
    // Camouflage: a patch on the chest of the wall's average colour there, slightly shifted.
    Eigen::Vector2d chest;
    const Eigen::Vector3d chest_point = options_.person
                                            ? layer_.chest.value_or(Eigen::Vector3d::Zero())
                                            : Eigen::Vector3d(sway, -0.2, 1.3);
    if (options_.camouflage && (!options_.person || layer_.chest) &&
        rig_[0].project(chest_point, chest)) {
      const int radius = std::max(4, options_.height / 30);
      const cv::Point centre(static_cast<int>(chest.x()), static_cast<int>(chest.y()));
      const cv::Rect box =
          cv::Rect(centre.x - radius, centre.y - radius, 2 * radius + 1, 2 * radius + 1) &
          cv::Rect(0, 0, size.width, size.height);
      cv::Scalar behind = cv::mean(wall_(box));
      cv::Mat patch_mask = cv::Mat::zeros(size, CV_8UC1);
      cv::circle(patch_mask, centre, radius, 255, cv::FILLED);
      patch_mask &= out.body;
      shaded_.setTo(behind + cv::Scalar(6, -5, 6), patch_mask);
    }
  }

  // Light: global drift, optionally more on the left half; the same light falls on the person.
  const double gain = 1 + options_.illumination_drift * t;
  shaded_ *= gain;
  if (options_.side_drift != 0) shaded_ += shaded_.mul(side_mask_) * (options_.side_drift * t);

  cv::Mat* source = &shaded_;
  if (!options_.color) {
    cv::cvtColor(shaded_, scratch_, cv::COLOR_BGR2GRAY);
    source = &scratch_;
  }
  noise_.create(source->size(), source->type());
  rng_.fill(noise_, cv::RNG::NORMAL, 0, options_.noise_sigma);
  *source += noise_;
  source->convertTo(out.image, CV_8U);
}

}  // namespace mocap
