// Shared set-up of the refinement's tests: small bodies (a pelvis on two legs, legs with feet), a
// track of the refinement alone, and the starts its moves are meant to undo.
#pragma once

#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "tests/tracker/filters/filter_test_support.h"
#include "tracker/filters/filter.h"
#include "tracker/model/body_model.h"
#include "tracker/model/kinematics.h"

namespace mocap::testing_support {

// A pelvis turning about the vertical with two legs on ball joints (flex, abduct, twist).
inline BodyModel pelvisAndLegs() {
  return parseBodyModel(R"(
name: pelvis_and_legs
segments:
  - name: pelvis
    dofs:
      - {name: yaw, axis: [0, 0, 1], min: -180, max: 180, max_speed: 6}
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.2, 0.1, 0.12]}
  - name: r_leg
    parent: pelvis
    offset: [0.12, 0, -0.08]
    dofs:
      - {name: r_flex, axis: [1, 0, 0], min: -90, max: 90, max_speed: 6}
      - {name: r_abduct, axis: [0, -1, 0], min: -90, max: 90, max_speed: 6}
      - {name: r_twist, axis: [0, 0, 1], min: -90, max: 90, max_speed: 6}
    shape: {type: cone, axis: [0, 0, -1], length: 0.8, radius_start: 0.07, radius_end: 0.05}
    points: [{name: r_foot, at: [0, 0, -0.8]}]
  - name: l_leg
    parent: pelvis
    offset: [-0.12, 0, -0.08]
    dofs:
      - {name: l_flex, axis: [1, 0, 0], min: -90, max: 90, max_speed: 6}
      - {name: l_abduct, axis: [0, 1, 0], min: -90, max: 90, max_speed: 6}
      - {name: l_twist, axis: [0, 0, -1], min: -90, max: 90, max_speed: 6}
    shape: {type: cone, axis: [0, 0, -1], length: 0.8, radius_start: 0.07, radius_end: 0.05}
    points: [{name: l_foot, at: [0, 0, -0.8]}]
)",
                        "pelvis_and_legs.yaml");
}

// The estimate after 10 frames of the factored filter from `start` with `options` (400
// evaluations) and its refinement alone: at a share of 0.95 the layers sample only the interval's
// centre, and nothing is injected.
inline Eigen::VectorXd refineAlone(const BodyModel& model, const Rig& rig,
                                   const std::vector<SilhouetteMask>& masks,
                                   const Eigen::VectorXd& start, FilterOptions options) {
  WorkerPool pool(1);
  options.evaluations_per_frame = 400;
  options.refine.share = 0.95;
  options.injection.share = 0;
  auto filter = makeFilter("factored", model, rig, options, pool);
  filter->reset(start);
  FrameEstimate e;
  for (int f = 0; f < 10; ++f) e = filter->step(masks);
  return e.q;
}

// The start of a track that went wrong from `truth` (the pelvis's yaw, then each leg's three
// angles, segments 1 and 2): the pelvis turned 40 degrees, each leg's angles solved so it points
// as in truth.
inline Eigen::VectorXd turnedPelvis(const BodyModel& model, const Eigen::VectorXd& truth) {
  const double deg = M_PI / 180;
  Eigen::VectorXd start = truth;
  start[0] = 40 * deg;
  for (int leg = 0; leg < 2; ++leg) {
    const Segment& seg = model.segments[1 + leg];
    const Eigen::Matrix3d local = Eigen::AngleAxisd(-start[0], Eigen::Vector3d::UnitZ()) *
                                  localTransform(model, 1 + leg, truth).linear();
    // Of the two angle triples giving that rotation, the one with the smaller angles.
    const auto wrapped = [](const Eigen::Vector3d& a) {
      return Eigen::Vector3d(a.unaryExpr([](double x) { return std::remainder(x, 2 * M_PI); }));
    };
    const Eigen::Vector3d euler = local.eulerAngles(0, 1, 2);
    Eigen::Vector3d xyz = wrapped(euler);
    const Eigen::Vector3d other =
        wrapped(Eigen::Vector3d(euler[0] + M_PI, M_PI - euler[1], euler[2] + M_PI));
    if (other.cwiseAbs().sum() < xyz.cwiseAbs().sum()) xyz = other;
    for (int j = 0; j < 3; ++j) {
      const Dof& dof = model.dofs[seg.dofs[j]];
      start[seg.dofs[j]] = dof.axis.sum() * xyz[j];
      EXPECT_GT(start[seg.dofs[j]], dof.min) << dof.name;
      EXPECT_LT(start[seg.dofs[j]], dof.max) << dof.name;
    }
    EXPECT_TRUE(localTransform(model, 1 + leg, start).linear().isApprox(local, 1e-9)) << leg;
  }
  return start;
}

// A pelvis that moves up and down on two legs of hip, knee and foot, with the model's `feet`.
inline BodyModel legsWithFeet() {
  return parseBodyModel(R"(
name: legs_with_feet
feet: [r_foot, l_foot]
segments:
  - name: pelvis
    offset: [0, 0, 0.9]
    dofs:
      - {name: height, type: translation, axis: [0, 0, 1], min: -0.5, max: 0.5, max_speed: 0.03}
    shape: {type: ellipsoid, center: [0, 0, 0], radii: [0.12, 0.08, 0.06]}
  - name: r_thigh
    parent: pelvis
    offset: [0.1, 0, -0.05]
    dofs: [{name: r_hip, axis: [1, 0, 0], min: -30, max: 120, max_speed: 20}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.04, radius_end: 0.03}
  - name: r_shin
    parent: r_thigh
    offset: [0, 0, -0.42]
    dofs: [{name: r_knee, axis: [-1, 0, 0], min: 0, max: 150, max_speed: 32}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.03, radius_end: 0.025}
  - name: r_foot
    parent: r_shin
    offset: [0, 0, -0.42]
    shape: {type: ellipsoid, center: [0, 0.08, -0.04], radii: [0.07, 0.16, 0.05]}
  - name: l_thigh
    parent: pelvis
    offset: [-0.1, 0, -0.05]
    dofs: [{name: l_hip, axis: [1, 0, 0], min: -30, max: 120, max_speed: 20}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.04, radius_end: 0.03}
  - name: l_shin
    parent: l_thigh
    offset: [0, 0, -0.42]
    dofs: [{name: l_knee, axis: [-1, 0, 0], min: 0, max: 150, max_speed: 32}]
    shape: {type: cone, axis: [0, 0, -1], length: 0.42, radius_start: 0.03, radius_end: 0.025}
  - name: l_foot
    parent: l_shin
    offset: [0, 0, -0.42]
    shape: {type: ellipsoid, center: [0, 0.08, -0.04], radii: [0.07, 0.16, 0.05]}
)",
                        "legs_with_feet.yaml");
}

// Two cameras at 480x360 on legsWithFeet (twoCameras' geometry, twice the focal length and size),
// so the legs cover enough pixels for the swap's default margin and the chase's blobs.
inline Rig twoCamerasOnTheLegs() {
  Rig rig;
  for (const CameraModel& small : twoCameras(Eigen::Vector3d(0, 0, 0.5), 0.6))
    rig.push_back(CameraModel::lookAt(small.name, small.center(), Eigen::Vector3d(0, 0, 0.5),
                                      Eigen::Vector3d::UnitZ(), 480, 360, 400));
  return rig;
}

}  // namespace mocap::testing_support
