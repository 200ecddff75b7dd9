// Simulated subjects: their own shape and proportions, clothes that change the outline but not the
// joints, a shaded colour layer whose mask is the silhouette, and the test scene drawing them.
#include "tracker/sim/subject.h"
#include "tests/shared_data.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tracker/model/builtin_models.h"
#include "tracker/motion/retarget.h"
#include "tracker/sim/scene.h"
#include "tracker/sim/subject_render.h"
#include "tracker/sim/test_scene.h"

namespace mocap {
namespace {

using Eigen::Vector3d;

// Mid-stride, the arms swinging and a little out: limbs apart from the trunk in most views.
Eigen::VectorXd stridePose(const BodyModel& model) {
  Eigen::VectorXd q = model.neutralPose();
  const double deg = M_PI / 180;
  auto set = [&](const char* dof, double value) { q[model.dofIndex(dof)] = value; };
  set("r_hip_flex", 25 * deg);
  set("l_hip_flex", -15 * deg);
  set("l_knee_flex", 30 * deg);
  set("r_shoulder_flex", -25 * deg);
  set("l_shoulder_flex", 30 * deg);
  set("r_shoulder_abd", 15 * deg);
  set("l_shoulder_abd", 15 * deg);
  set("l_elbow_flex", 40 * deg);
  set("root_yaw", 20 * deg);
  return q;
}

Rig labRigFor(const BodyModel& model) { return labRig(2, model, {model.neutralPose()}); }

// A camera 4 m in front of the subject (the model faces +Y), level with the hips.
CameraModel frontCamera() {
  return CameraModel::lookAt("front", Vector3d(0, 4, 0.9), Vector3d(0, 0, 0.9), Vector3d::UnitZ(),
                             780, 580, 900);
}

double iou(const cv::Mat& a, const cv::Mat& b) {
  return static_cast<double>(cv::countNonZero(a & b)) / cv::countNonZero(a | b);
}

// The width of the mask's row `y` from its first to its last set pixel.
int rowWidth(const cv::Mat& mask, int y) {
  int first = -1, last = -1;
  for (int x = 0; x < mask.cols; ++x)
    if (mask.at<uint8_t>(y, x)) last = x, first = first < 0 ? x : first;
  return first < 0 ? 0 : last - first + 1;
}

// Inside the round cone (hull of spheres ra at a, rb at b): the nearest swept sphere holds p.
double roundConeDistance(const Vector3d& p, const Vector3d& a, double ra, const Vector3d& b,
                         double rb) {
  double best = 1e9;
  for (int i = 0; i <= 4000; ++i) {
    const double s = i / 4000.0;
    best = std::min(best, (p - (a + s * (b - a))).norm() - (ra + s * (rb - ra)));
  }
  return best;
}

TEST(Subject, RoundConeRayHitsLieOnItsSurface) {
  SubjectPrimitive cone;
  cone.kind = SubjectPrimitive::Kind::kRoundCone;
  cone.origin = Vector3d(0.1, -0.2, 0.3);
  cone.linear = Eigen::AngleAxisd(0.7, Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
  cone.length = 0.4;
  cone.radius0 = 0.09;
  cone.radius1 = 0.04;
  const Vector3d b = cone.origin + cone.linear.col(2) * cone.length;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  int hits = 0;
  for (int i = 0; i < 300; ++i) {
    const Vector3d eye = Vector3d(u(rng), u(rng), u(rng)).normalized() * 2;
    const Vector3d aim = 0.5 * (cone.origin + b) + 0.15 * Vector3d(u(rng), u(rng), u(rng));
    const Vector3d dir = (aim - eye) * 0.7;  // not unit: t scales with it
    double t;
    Vector3d normal;
    if (!intersectSubjectPrimitive(cone, eye, dir, t, normal)) {
      for (int k = 0; k <= 200; ++k)
        EXPECT_GT(roundConeDistance(eye + dir * (k * 0.02), cone.origin, 0.09, b, 0.04), -1e-3);
      continue;
    }
    ++hits;
    const Vector3d hit = eye + t * dir;
    EXPECT_NEAR(roundConeDistance(hit, cone.origin, 0.09, b, 0.04), 0, 1e-3);
    EXPECT_GT(roundConeDistance(eye + 0.97 * t * dir, cone.origin, 0.09, b, 0.04), 0);
    EXPECT_LT(normal.dot(dir), 0);
  }
  EXPECT_GT(hits, 100);
}

TEST(Subject, FrustumAndEllipsoidRayHits) {
  SubjectPrimitive frustum;
  frustum.kind = SubjectPrimitive::Kind::kFrustum;
  frustum.length = 0.5;
  frustum.radius0 = 0.1;
  frustum.radius1 = 0.3;
  double t;
  Vector3d n;
  // Sideways at mid-height: radius 0.2.
  ASSERT_TRUE(intersectSubjectPrimitive(frustum, Vector3d(-2, 0, 0.25), Vector3d(1, 0, 0), t, n));
  EXPECT_NEAR(t, 1.8, 1e-9);
  // From below into the small flat end.
  ASSERT_TRUE(intersectSubjectPrimitive(frustum, Vector3d(0.05, 0, -1), Vector3d(0, 0, 2), t, n));
  EXPECT_NEAR(t, 0.5, 1e-9);
  EXPECT_NEAR(n.z(), -1, 1e-9);
  // Beside the small end, it meets the widening side from outside.
  ASSERT_TRUE(intersectSubjectPrimitive(frustum, Vector3d(0.2, 0, -1), Vector3d(0, 0, 1), t, n));
  EXPECT_NEAR(t, 1.25, 1e-9);
  EXPECT_FALSE(intersectSubjectPrimitive(frustum, Vector3d(0.35, 0, -1), Vector3d(0, 0, 1), t, n));
  SubjectPrimitive ellipsoid;
  ellipsoid.linear = Eigen::Vector3d(0.2, 0.1, 0.3).asDiagonal();
  ASSERT_TRUE(intersectSubjectPrimitive(ellipsoid, Vector3d(0, -1, 0), Vector3d(0, 1, 0), t, n));
  EXPECT_NEAR(t, 0.9, 1e-9);
  EXPECT_NEAR(n.y(), -1, 1e-9);
}

TEST(Subject, SeedsVaryHeightGirthAndWidthsWithinTheirRanges) {
  const BodyModel model = builtinHumanModel();
  const SubjectJoints rest = subjectJointsAt(model, model.neutralPose());
  double shortest = 9, tallest = 0, slimmest = 9, heaviest = 0;
  for (uint64_t seed = 1; seed <= 60; ++seed) {
    const SubjectParams p = drawSubjectParams(seed);
    EXPECT_GE(p.height, 1.50);
    EXPECT_LE(p.height, 1.95);
    for (double f :
         {p.thigh, p.shin, p.upper_arm, p.forearm, p.trunk, p.shoulder_width, p.hip_width}) {
      EXPECT_GE(f, 0.9);
      EXPECT_LE(f, 1.1);
    }
    EXPECT_GE(p.girth, 0.85);
    EXPECT_LE(p.girth, 1.35);
    const Subject subject(p, rest);
    const SubjectJoints& j = subject.rest();
    EXPECT_NEAR(j[kHeadTop].z(), p.height, 1e-9) << "seed " << seed;
    const double shoulders = (j[kRShoulder] - j[kLShoulder]).norm() / p.height;
    const double hips = (j[kRHip] - j[kLHip]).norm() / p.height;
    EXPECT_NEAR(shoulders, 0.22 * p.shoulder_width, 0.02) << "seed " << seed;
    EXPECT_NEAR(hips, 0.105 * p.hip_width, 0.01) << "seed " << seed;
    // Standing on the floor: the soles touch z = 0 within a centimetre.
    EXPECT_NEAR(std::min(j[kRAnkle].z(), j[kLAnkle].z()), 0.041 * p.height, 1e-9);
    shortest = std::min(shortest, p.height), tallest = std::max(tallest, p.height);
    slimmest = std::min(slimmest, p.girth), heaviest = std::max(heaviest, p.girth);
  }
  EXPECT_LT(shortest, 1.6);
  EXPECT_GT(tallest, 1.85);
  EXPECT_LT(slimmest, 0.95);
  EXPECT_GT(heaviest, 1.25);
  // Different seeds, different outlines.
  const CameraModel camera = frontCamera();
  const Rig rig = {camera};
  SubjectSceneRenderer a(model, rig, drawSubjectParams(1)), b(model, rig, drawSubjectParams(2));
  EXPECT_LT(
      iou(a.renderSilhouettes(model.neutralPose())[0], b.renderSilhouettes(model.neutralPose())[0]),
      0.9);
}

// The hips and shoulders are the subject's own, whatever skeleton drives it: the shipped body
// (hips level with its pelvis point) and the CMU walk's fitted body (its own layout) pose the same
// person, and the hips turn with the driver's pelvis.
TEST(Subject, TheHipsAndShouldersAreTheSubjectsWhateverTheDriver) {
  const std::string path = testing_support::kSharedMotionDir + "cmu_131_01_walk.bvh";
  REQUIRE_SHARED_FILE(path);
  const BodyModel shipped = builtinHumanModel();
  const BodyModel cmu = fitModelToBvh(shipped, loadBvh(path).skeleton);
  const SubjectParams params = drawSubjectParams(3);
  const Subject a(params, subjectJointsAt(shipped, shipped.neutralPose()));
  const Subject b(params, subjectJointsAt(cmu, cmu.neutralPose()));
  // Each subject is scaled to its height as its driver stands, so compare in thigh lengths.
  auto thigh = [](const Subject& s) { return (s.rest()[kRKnee] - s.rest()[kRHip]).norm(); };
  for (int j : {kRHip, kLHip, kRShoulder, kLShoulder}) {
    const int parent = subjectJointParent(j);
    const Vector3d from_a = a.rest()[j] - a.rest()[parent], from_b = b.rest()[j] - b.rest()[parent];
    EXPECT_LT((from_a / thigh(a) - from_b / thigh(b)).norm(), 1e-3) << kSubjectJointNames[j];
    // Below their parent joint: 0.057 and 0.015 of the height.
    EXPECT_NEAR(-from_a.z() / params.height, j == kRHip || j == kLHip ? 0.057 : 0.015, 1e-3)
        << kSubjectJointNames[j];
  }
  // Tipped 40 degrees at the root and bent 30 more at the spine: the hips turn with the pelvis,
  // rigidly, given how the shipped body's pelvis turned (its hips are in line with its pelvis
  // point, so its joints alone do not say).
  Eigen::VectorXd bowed = shipped.neutralPose();
  bowed[shipped.dofIndex("root_pitch")] = 40 * M_PI / 180;
  bowed[shipped.dofIndex("spine_flex")] = 30 * M_PI / 180;
  KinematicsData kinematics(shipped);
  forwardKinematics(shipped, kinematics, bowed);
  const Eigen::Matrix3d turn = pelvisTurnAt(shipped, kinematics);
  EXPECT_TRUE(turn.isApprox(Eigen::AngleAxisd(40 * M_PI / 180, Vector3d::UnitX()).matrix()));
  const SubjectJoints posed = a.retarget(subjectJointsAt(shipped, bowed), &turn);
  for (int hip : {kRHip, kLHip})
    EXPECT_LT((posed[hip] - posed[kPelvis] - turn * (a.rest()[hip] - a.rest()[kPelvis])).norm(),
              1e-9);
  // The CMU body's hips hang below its pelvis joint: its joints alone turn the hips as rigidly.
  KinematicsData cmu_kinematics(cmu);
  Eigen::VectorXd cmu_bowed = cmu.neutralPose();
  cmu_bowed[cmu.dofIndex("root_pitch")] = 40 * M_PI / 180;
  cmu_bowed[cmu.dofIndex("spine_flex")] = 30 * M_PI / 180;
  forwardKinematics(cmu, cmu_kinematics, cmu_bowed);
  const Eigen::Matrix3d cmu_turn = pelvisTurnAt(cmu, cmu_kinematics);
  const SubjectJoints by_joints = b.retarget(subjectJointsAt(cmu, cmu_bowed));
  const SubjectJoints by_turn = b.retarget(subjectJointsAt(cmu, cmu_bowed), &cmu_turn);
  for (int j = 0; j < kSubjectJointCount; ++j)
    EXPECT_LT((by_joints[j] - by_turn[j]).norm(), 1e-9) << kSubjectJointNames[j];
}

TEST(Subject, SilhouetteIsNotTheModelsYetCoversTheTruthJoints) {
  const BodyModel model = builtinHumanModel();
  const Rig rig = labRigFor(model);
  SceneRenderer model_renderer(model, rig);
  const Eigen::VectorXd q = stridePose(model);
  const std::vector<cv::Mat> model_images = model_renderer.renderSilhouettes(q);
  for (uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    SubjectSceneRenderer renderer(model, rig, drawSubjectParams(seed));
    const std::vector<cv::Mat> images = renderer.renderSilhouettes(q);
    ASSERT_EQ(images.size(), rig.size());
    for (std::size_t c = 0; c < rig.size(); ++c) {
      EXPECT_LT(iou(images[c], model_images[c]), 0.85) << "seed " << seed << " camera " << c;
      EXPECT_GT(iou(images[c], model_images[c]), 0.3) << "seed " << seed << " camera " << c;
      for (std::size_t p = 0; p < model.points.size(); ++p) {
        Eigen::Vector2d pixel;
        ASSERT_TRUE(rig[c].project(renderer.truthPoints()[p], pixel));
        const int x = static_cast<int>(std::lround(pixel.x()));
        const int y = static_cast<int>(std::lround(pixel.y()));
        ASSERT_TRUE(x >= 0 && y >= 0 && x < images[c].cols && y < images[c].rows);
        EXPECT_EQ(images[c].at<uint8_t>(y, x), 255)
            << model.points[p].name << " seed " << seed << " camera " << c;
      }
    }
  }
}

TEST(Subject, AHiddenSegmentLeavesItsLimbOutOfOneCamera) {
  const BodyModel model = builtinHumanModel();
  const Rig rig = labRigFor(model);
  SubjectSceneRenderer renderer(model, rig, drawSubjectParams(4));
  const Eigen::VectorXd q = stridePose(model);
  const std::vector<cv::Mat> whole = renderer.renderSilhouettes(q);
  renderer.hideSegment(0, model.segmentIndex("l_forearm"));
  const std::vector<cv::Mat> missed = renderer.renderSilhouettes(q);
  EXPECT_GT(cv::countNonZero(whole[0] & ~missed[0]), 200);
  EXPECT_EQ(cv::countNonZero(missed[0] & ~whole[0]), 0);
  EXPECT_EQ(cv::countNonZero(whole[1] != missed[1]), 0);
  Eigen::Vector2d wrist;
  ASSERT_TRUE(rig[0].project(renderer.posed().joints[kLWrist], wrist));
  EXPECT_EQ(missed[0].at<uint8_t>(static_cast<int>(std::lround(wrist.y())),
                                  static_cast<int>(std::lround(wrist.x()))),
            0);
  renderer.clearHidden();
  EXPECT_EQ(cv::countNonZero(renderer.renderSilhouettes(q)[0] != whole[0]), 0);
}

TEST(Subject, PosesFromRealMotionCaptureJoints) {
  // Driven by the CMU walk's own joints (model axes, metres), not by a model pose fitted to them.
  const std::string path = testing_support::kSharedMotionDir + "cmu_131_01_walk.bvh";
  REQUIRE_SHARED_FILE(path);
  const Bvh bvh = loadBvh(path);
  const BodyModel body = fitModelToBvh(builtinHumanModel(), bvh.skeleton);
  const RetargetResult walk = retargetBvh(body, bvh.skeleton, bvh.motion, 25, 40);
  const Rig rig = labRig(2, body, walk.motion);
  const Subject subject(drawSubjectParams(8), subjectJointsAt(body, body.neutralPose()));
  SubjectRasterizer rasterizer;
  PosedSubject posed;
  cv::Mat mask;
  for (std::size_t f = 0; f < walk.targets.size(); f += 13) {
    subject.pose(subjectJointsFromPoints(body, walk.targets[f]), posed);
    // The subject's feet stay near the floor as the mocap subject's do.
    EXPECT_LT(std::min(posed.joints[kLAnkle].z(), posed.joints[kRAnkle].z()), 0.2) << f;
    for (const CameraModel& camera : rig) {
      rasterizer.renderSilhouette(posed, camera, mask);
      for (const Eigen::Vector3d& joint : posed.joints) {
        Eigen::Vector2d pixel;
        ASSERT_TRUE(camera.project(joint, pixel));
        EXPECT_EQ(mask.at<uint8_t>(static_cast<int>(std::lround(pixel.y())),
                                   static_cast<int>(std::lround(pixel.x()))),
                  255)
            << "frame " << f;
      }
    }
  }
}

Clothing withLower(Clothing c, LowerGarment lower) {
  c.lower = lower;
  return c;
}

TEST(Subject, ClothingChangesTheOutlineButNotTheJoints) {
  const BodyModel model = builtinHumanModel();
  const Rig rig = {frontCamera()};
  SubjectParams params = drawSubjectParams(7);
  const Clothing plain = [&] {
    Clothing c = params.clothing;
    c.lower = LowerGarment::kTrousers;
    c.coat = c.long_hair = false;
    c.shoes = false;
    return c;
  }();
  params.clothing = plain;
  SubjectSceneRenderer renderer(model, rig, params);
  const Eigen::VectorXd q = stridePose(model);
  const cv::Mat base = renderer.renderSilhouettes(q)[0].clone();
  const std::vector<Eigen::Vector3d> joints = renderer.truthPoints();
  std::vector<Clothing> variants;
  for (LowerGarment lower :
       {LowerGarment::kLooseTrousers, LowerGarment::kSkirt, LowerGarment::kDress})
    variants.push_back(withLower(plain, lower));
  variants.push_back(plain), variants.back().coat = true;
  variants.push_back(plain), variants.back().long_hair = true;
  variants.push_back(plain), variants.back().shoes = true;
  for (std::size_t v = 0; v < variants.size(); ++v) {
    renderer.subject().clothing() = variants[v];
    const cv::Mat image = renderer.renderSilhouettes(q)[0];
    EXPECT_GT(cv::countNonZero(image != base), 150) << "variant " << v;
    EXPECT_GT(cv::countNonZero(image & ~base), 150) << "variant " << v;  // it adds to the outline
    ASSERT_EQ(renderer.truthPoints().size(), joints.size());
    for (std::size_t p = 0; p < joints.size(); ++p)
      EXPECT_EQ(renderer.truthPoints()[p], joints[p]) << "variant " << v;
  }
}

TEST(Subject, ASkirtWidensTheOutlineBetweenHipsAndKnees) {
  const BodyModel model = builtinHumanModel();
  const CameraModel camera = frontCamera();
  const Rig rig = {camera};
  SubjectParams params = drawSubjectParams(11);
  params.clothing.coat = params.clothing.long_hair = false;
  params.clothing.lower = LowerGarment::kTrousers;
  SubjectSceneRenderer renderer(model, rig, params);
  const Eigen::VectorXd q = model.neutralPose();
  const cv::Mat trousers = renderer.renderSilhouettes(q)[0].clone();
  renderer.subject().clothing().lower = LowerGarment::kSkirt;
  const cv::Mat skirt = renderer.renderSilhouettes(q)[0].clone();
  const auto row = [&](int joint) {
    Eigen::Vector2d pixel;
    EXPECT_TRUE(camera.project(renderer.posed().joints[joint], pixel));
    return static_cast<int>(pixel.y());
  };
  const int hip = row(kRHip), knee = row(kRKnee), chest = row(kNeck) + (hip - row(kNeck)) / 3;
  for (double along : {0.3, 0.6, 0.85}) {
    const int y = hip + static_cast<int>(along * (knee - hip));
    EXPECT_GT(rowWidth(skirt, y), rowWidth(trousers, y) + 10) << "row " << y;
  }
  EXPECT_EQ(rowWidth(skirt, chest), rowWidth(trousers, chest));
}

TEST(Subject, ColourLayerIsShadedAndItsMaskIsTheSilhouette) {
  const BodyModel model = builtinHumanModel();
  Rig rig = labRigFor(model);
  rig.push_back(rig[0]);
  rig.back().distortion = {-0.2, 0.05, 0.001, -0.001, 0};  // per-pixel rays through a table
  const Eigen::VectorXd q = stridePose(model);
  for (uint64_t seed : {1, 2, 3}) {
    SubjectSceneRenderer renderer(model, rig, drawSubjectParams(seed));
    const std::vector<cv::Mat> silhouettes = renderer.renderSilhouettes(q);
    std::vector<PersonLayer> layers;
    renderer.renderLayers(q, layers);
    for (std::size_t c = 0; c < rig.size(); ++c) {
      const PersonLayer& layer = layers[c];
      ASSERT_EQ(layer.mask.type(), CV_8UC1);
      ASSERT_EQ(layer.colour.type(), CV_8UC3);
      EXPECT_EQ(cv::countNonZero(layer.mask != silhouettes[c]), 0) << "camera " << c;
      EXPECT_GT(cv::countNonZero(layer.mask), 5000);
      cv::Mat gray;
      cv::extractChannel(layer.colour, gray, 1);
      EXPECT_EQ(cv::countNonZero(gray & ~layer.mask), 0);  // nothing outside the mask
      // Shaded: within one material the brightness varies over the surface.
      cv::Scalar mean, deviation;
      cv::meanStdDev(layer.colour, mean, deviation, layer.mask);
      EXPECT_GT(deviation[0] + deviation[1] + deviation[2], 20) << "seed " << seed;
      double lo, hi;
      cv::minMaxLoc(layer.depth, &lo, &hi, nullptr, nullptr, layer.mask);
      EXPECT_GT(lo, 2.5);
      EXPECT_LT(hi, 6.0);
      ASSERT_TRUE(layer.chest.has_value());
    }
  }
}

TEST(Subject, TheTestSceneDrawsAPersonLayer) {
  const BodyModel model = builtinHumanModel();
  TestSceneOptions options;
  options.width = 390;
  options.height = 290;
  const SubjectParams params = drawSubjectParams(5);
  const Subject subject(params, subjectJointsAt(model, model.neutralPose()));
  SubjectRasterizer rasterizer;
  PosedSubject posed;
  cv::Mat expected;
  options.person = [&](int t, const CameraModel& camera, PersonLayer& layer) {
    Eigen::VectorXd q = stridePose(model);
    q[model.dofIndex("root_yaw")] = 0.05 * t;
    subject.pose(subjectJointsAt(model, q), posed);
    rasterizer.renderLayer(posed, camera, layer);
    rasterizer.renderSilhouette(posed, camera, expected);
  };
  SilhouetteTestScene scene(options);
  TestSceneFrame frame;
  scene.render(3, true, frame);
  EXPECT_GT(cv::countNonZero(frame.body), 1000);
  EXPECT_EQ(cv::countNonZero(frame.body != expected), 0);
  EXPECT_GT(cv::countNonZero(frame.shadow), 100);
  scene.render(3, false, frame);
  EXPECT_EQ(cv::countNonZero(frame.body), 0);
}

// Pictures of each clothing variant from the lab rig's cameras, side by side per camera, for a
// person to look at: written to MOCAP_SUBJECT_PICTURES when it names a directory, else to the
// test's temporary directory. Each variant must show a person in every camera.
TEST(Subject, Pictures) {
  const char* named = std::getenv("MOCAP_SUBJECT_PICTURES");
  const std::string dir = named ? named : ::testing::TempDir();
  const BodyModel model = builtinHumanModel();
  const Rig rig = labRigFor(model);
  std::vector<cv::Mat> strips(rig.size());
  for (int v = 0; v < 7; ++v) {  // trousers, loose, skirt, dress, coat, long hair, barefoot
    SubjectParams params = drawSubjectParams(100 + v);
    Clothing& c = params.clothing;
    c.lower = v < 4 ? static_cast<LowerGarment>(v) : LowerGarment::kTrousers;
    c.coat = v == 4;
    c.long_hair = v == 5;
    c.shoes = v != 6;
    SubjectSceneRenderer renderer(model, rig, params);
    std::vector<PersonLayer> layers;
    renderer.renderLayers(stridePose(model), layers);
    for (std::size_t cam = 0; cam < rig.size(); ++cam) {
      EXPECT_GT(cv::countNonZero(layers[cam].mask), 5000) << "variant " << v << ", camera " << cam;
      cv::Mat picture(layers[cam].colour.size(), CV_8UC3, cv::Scalar(200, 200, 200));
      layers[cam].colour.copyTo(picture, layers[cam].mask);
      const cv::Rect box = cv::boundingRect(layers[cam].mask);
      const cv::Point centre = (box.tl() + box.br()) / 2;
      const cv::Rect tile = cv::Rect(centre.x - 120, centre.y - 240, 240, 480) &
                            cv::Rect(0, 0, picture.cols, picture.rows);
      cv::Mat framed(480, 240, CV_8UC3, cv::Scalar(200, 200, 200));
      picture(tile).copyTo(framed(cv::Rect(0, 0, tile.width, tile.height)));
      if (strips[cam].empty())
        strips[cam] = framed;
      else
        cv::hconcat(strips[cam], framed, strips[cam]);
    }
  }
  for (std::size_t cam = 0; cam < rig.size(); ++cam)
    EXPECT_TRUE(cv::imwrite(dir + "/subjects_cam" + std::to_string(cam) + ".png", strips[cam]));
  // A subject in the colour test scene: wall, floor, cast shadow, light and noise.
  TestSceneOptions options;
  const Subject subject(drawSubjectParams(3), subjectJointsAt(model, model.neutralPose()));
  SubjectRasterizer rasterizer;
  PosedSubject posed;
  options.person = [&](int, const CameraModel& camera, PersonLayer& layer) {
    Eigen::VectorXd q = stridePose(model);
    q[model.dofIndex("root_yaw")] = M_PI;  // facing the scene's camera, as its own person does
    subject.pose(subjectJointsAt(model, q), posed);
    rasterizer.renderLayer(posed, camera, layer);
  };
  SilhouetteTestScene scene(options);
  TestSceneFrame frame;
  scene.render(10, true, frame);
  EXPECT_TRUE(cv::imwrite(dir + "/subject_in_test_scene.png", frame.image));
}

}  // namespace
}  // namespace mocap
