// Camera projection against OpenCV's projectPoints, and rig files against OpenCV's own reader and
// in the forms it read.
#include "tracker/model/camera.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

namespace mocap {
namespace {

using ::testing::HasSubstr;

CameraModel distortedCamera() {
  CameraModel c =
      CameraModel::lookAt("cam", Eigen::Vector3d(1.5, -2.0, 1.2), Eigen::Vector3d(0, 0, 0.9),
                          Eigen::Vector3d::UnitZ(), 780, 580, 900);
  c.fy = 905;
  c.cx = 385.5;
  c.cy = 292.25;
  c.distortion = {-0.21, 0.08, 0.0012, -0.0007, -0.01};
  return c;
}

TEST(Camera, ProjectionMatchesOpenCvProjectPoints) {
  const CameraModel cam = distortedCamera();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  std::vector<cv::Point3d> world;
  for (int i = 0; i < 200; ++i) world.emplace_back(u(rng), u(rng), 0.9 + u(rng));
  cv::Mat r, rvec, t, k, dist;
  cv::eigen2cv(cam.rotation, r);
  cv::Rodrigues(r, rvec);
  cv::eigen2cv(cam.translation, t);
  k = (cv::Mat_<double>(3, 3) << cam.fx, 0, cam.cx, 0, cam.fy, cam.cy, 0, 0, 1);
  dist = cv::Mat(cam.distortion.size(), 1, CV_64F, const_cast<double*>(cam.distortion.data()));
  std::vector<cv::Point2d> expected;
  cv::projectPoints(world, rvec, t, k, dist, expected);
  for (std::size_t i = 0; i < world.size(); ++i) {
    Eigen::Vector2d px;
    ASSERT_TRUE(cam.project(Eigen::Vector3d(world[i].x, world[i].y, world[i].z), px));
    EXPECT_NEAR(px.x(), expected[i].x, 1e-6);
    EXPECT_NEAR(px.y(), expected[i].y, 1e-6);
  }
}

TEST(Camera, BackProjectionIsTheRayThroughTheProjectedPoint) {
  const CameraModel cam = distortedCamera();
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  double worst = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d world(u(rng), u(rng), 0.9 + u(rng));
    Eigen::Vector2d px;
    ASSERT_TRUE(cam.project(world, px));
    const Eigen::Vector3d ray = cam.backProject(px);
    EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
    const Eigen::Vector3d to_point = world - cam.center();
    ASSERT_GT(to_point.dot(ray), 0) << "the ray points away from the point";
    worst = std::max(worst, (to_point - to_point.dot(ray) * ray).norm());
  }
  EXPECT_LT(worst, 1e-7);  // metres: the distortion undone to far below a pixel
}

TEST(Camera, LookAtPutsTheTargetAtThePrincipalPointWithZUpOnScreen) {
  const CameraModel cam =
      CameraModel::lookAt("c", Eigen::Vector3d(0, -3, 1), Eigen::Vector3d(0, 0, 1),
                          Eigen::Vector3d::UnitZ(), 780, 580, 1000);
  Eigen::Vector2d px;
  ASSERT_TRUE(cam.project(Eigen::Vector3d(0, 0, 1), px));
  EXPECT_NEAR(px.x(), 390, 1e-9);
  EXPECT_NEAR(px.y(), 290, 1e-9);
  ASSERT_TRUE(cam.project(Eigen::Vector3d(0, 0, 1.3), px));
  EXPECT_LT(px.y(), 290);  // higher in the world is higher in the image
  EXPECT_TRUE(cam.center().isApprox(Eigen::Vector3d(0, -3, 1)));
  EXPECT_FALSE(cam.project(Eigen::Vector3d(0, -4, 1), px));  // behind the camera
}

std::string tempPath(const std::string& name) { return (testing::TempDir() + "/") + name; }

TEST(Camera, RigRoundTripIsReadableByOpenCv) {
  Rig rig = {distortedCamera(),
             CameraModel::lookAt("side", Eigen::Vector3d(3, 0, 1), Eigen::Vector3d(0, 0, 1),
                                 Eigen::Vector3d::UnitZ(), 640, 480, 700)};
  const std::string path = tempPath("rig.yaml");
  saveRig(path, rig);

  cv::FileStorage fs(path, cv::FileStorage::READ);  // OpenCV's own reader sees the standard fields
  ASSERT_TRUE(fs.isOpened());
  EXPECT_EQ(static_cast<int>(fs["camera_count"]), 2);
  cv::Mat k;
  fs["camera_0"]["camera_matrix"] >> k;
  EXPECT_DOUBLE_EQ(k.at<double>(1, 1), 905);
  EXPECT_EQ(static_cast<int>(fs["camera_1"]["image_width"]), 640);

  const Rig back = loadRig(path);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].name, "cam");
  EXPECT_EQ(back[1].height, 480);
  EXPECT_DOUBLE_EQ(back[0].cx, 385.5);
  EXPECT_EQ(back[0].distortion, rig[0].distortion);
  EXPECT_TRUE(back[0].rotation.isApprox(rig[0].rotation, 1e-12));
  EXPECT_TRUE(back[1].translation.isApprox(rig[1].translation, 1e-12));
}

// Names YAML would read as other values, OpenCV's writer as structures ("[", "{") or without their
// quotes or trailing spaces, and the longest name a rig file holds.
TEST(Camera, RigRoundTripKeepsNamesYamlOrOpenCvWouldReadOtherwise) {
  Rig rig;
  std::vector<std::string> names = {"null", "~", "NULL", "5", "true", "cam #1", "a: b", "-x", ""};
  names.insert(names.end(),
               {"[a", "{b}", "]c", "}", "\\{e", "'q'", "\"q\"", "trail ", "back\\slash"});
  names.insert(names.end(), {"tab\tnew\nline\x01", "caf\xc3\xa9", std::string(4094, 'x')});
  for (const std::string& name : names)
    rig.push_back(CameraModel::lookAt(name, Eigen::Vector3d(0, -3, 1), Eigen::Vector3d(0, 0, 1),
                                      Eigen::Vector3d::UnitZ(), 640, 480, 700));
  const std::string path = tempPath("names.yaml");
  saveRig(path, rig);
  const Rig back = loadRig(path);
  ASSERT_EQ(back.size(), rig.size());
  for (std::size_t i = 0; i < rig.size(); ++i) EXPECT_EQ(back[i].name, rig[i].name);
}

// Forms OpenCV's reader took beyond what saveRig writes: "%YAML 1.0", untagged and flow matrices,
// integer and float elements, a translation in a row, a size given as `sizes`, no name.
TEST(Camera, RigFilesInOtherOpenCvFormsLoad) {
  const std::string path = tempPath("other_forms.yaml");
  std::ofstream(path)
      << "%YAML 1.0\n---\ncamera_count: 1\ncamera_0:\n  image_width: 640\n  image_height: 0x1E0\n"
         "  camera_matrix: {rows: 3, cols: 3, dt: i, data: [800.4, 0, 320, 0, 801, 240, 0, 0, 1]}\n"
         "  distortion_coefficients: !!opencv-matrix {rows: 1, cols: 4, dt: f, data: [0.1, 0, 0, "
         "-.5]}\n"
         "  R: !!opencv-nd-matrix {sizes: [3, 3], dt: d, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}\n"
         "  T: {rows: 1, cols: 3, dt: d, data: [0.5, -0.25, 2e0]}\n";
  const Rig rig = loadRig(path);
  ASSERT_EQ(rig.size(), 1u);
  EXPECT_EQ(rig[0].name, "camera_0");
  EXPECT_EQ(rig[0].height, 480);
  EXPECT_EQ(rig[0].fx, 800);  // rounded to the integer type, as OpenCV does
  EXPECT_EQ(rig[0].fy, 801);
  EXPECT_EQ(rig[0].distortion, (std::array<double, 5>{static_cast<double>(0.1f), 0, 0, -0.5, 0}));
  EXPECT_EQ(rig[0].translation, Eigen::Vector3d(0.5, -0.25, 2));
}

// saveRig's message for `rig`, which must not leave a file behind.
std::string saveError(const Rig& rig) {
  const std::string path = tempPath("refused_rig.yaml");
  std::filesystem::remove(path);
  try {
    saveRig(path, rig);
  } catch (const std::runtime_error& e) {
    EXPECT_FALSE(std::filesystem::exists(path)) << "a file was written for " << e.what();
    return e.what();
  }
  return "";
}

TEST(Camera, RigsThatWouldNotLoadBackAreNotWritten) {
  constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
  constexpr double kInf = std::numeric_limits<double>::infinity();
  CameraModel c = distortedCamera();
  c.fx = kInf;
  EXPECT_THAT(saveError({c}), HasSubstr("refused_rig.yaml: camera_0.camera_matrix: not a finite"));
  c = distortedCamera();
  c.distortion[4] = kNan;
  EXPECT_THAT(saveError({c}), HasSubstr("camera_0.distortion_coefficients: not a finite number"));
  c = distortedCamera();
  c.rotation(1, 2) = kNan;
  EXPECT_THAT(saveError({distortedCamera(), c}), HasSubstr("camera_1.R: not a finite number"));
  c = distortedCamera();
  c.translation.z() = -kInf;
  EXPECT_THAT(saveError({c}), HasSubstr("camera_0.T: not a finite number"));
  c = distortedCamera();
  c.name = std::string(4095, 'x');  // quoted, one byte more than OpenCV writes
  EXPECT_THAT(saveError({c}), HasSubstr("camera_0.name: 4095 bytes, too long for a rig file"));
  // Finite, but what loadRig refuses all the same.
  c = distortedCamera();
  c.fy = 0;
  EXPECT_THAT(saveError({c}), HasSubstr("camera_0.camera_matrix: focal lengths must be positive"));
  c = distortedCamera();
  c.rotation(0, 0) *= 1.1;
  EXPECT_THAT(saveError({c}), HasSubstr("camera_0.R: not a rotation matrix"));
  c = distortedCamera();
  c.height = 0;
  EXPECT_THAT(saveError({c}), HasSubstr("camera_0: image size must be positive, got 780x0"));
}

std::string loadError(const std::string& text) {
  const std::string path = tempPath("bad_rig.yaml");
  std::ofstream(path) << text;
  try {
    loadRig(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(Camera, BadRigFilesAreRefusedWithTheField) {
  const std::string path = tempPath("good.yaml");
  saveRig(path, {distortedCamera()});
  std::ifstream in(path);
  const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());

  std::string bad = good;
  bad.replace(bad.find("image_width: 780"), 16, "image_width: -5");
  EXPECT_THAT(loadError(bad), HasSubstr("camera_0.image_width: must be positive"));

  bad = good;
  bad.replace(bad.find("camera_count: 1"), 15, "camera_count: 2");
  EXPECT_THAT(loadError(bad), HasSubstr("camera_1: missing"));

  bad = good;
  bad.replace(bad.find("R:"), 2, "Q:");
  EXPECT_THAT(loadError(bad), HasSubstr("camera_0.R: missing"));

  bad = good;
  const std::size_t distortion = bad.find("distortion_coefficients");
  bad.erase(bad.find("dt: d", distortion), 5);
  EXPECT_THAT(loadError(bad), HasSubstr("camera_0.distortion_coefficients: not an OpenCV matrix"));

  bad = good;
  bad.replace(bad.find("0., 0., 1. ]"), 12, "0., zero, 1. ]");
  EXPECT_THAT(loadError(bad), HasSubstr("camera_0.camera_matrix: not an OpenCV matrix: data[7]"));

  bad = good;
  bad.replace(bad.find("image_height: 580"), 17, "image_height: \"580\"");  // text, not a number
  EXPECT_THAT(loadError(bad), HasSubstr("camera_0.image_height: missing or not an integer"));

  bad = good;
  bad.replace(bad.find("camera_count: 1"), 15, "camera_count: 4294967297");  // no wrapping to 1
  EXPECT_THAT(loadError(bad), HasSubstr("camera_count: missing or not an integer"));

  // Not-a-number and infinity, as OpenCV writes them, where the range checks do not see them.
  const auto withFirstValue = [&good](const std::string& field, const std::string& value) {
    std::string text = good;
    const std::size_t data = text.find("data: [ ", text.find(field + ":")) + 8;
    return text.replace(data, text.find(',', data) - data, value);
  };
  EXPECT_THAT(loadError(withFirstValue("camera_matrix", ".Nan")),
              HasSubstr("bad_rig.yaml: camera_0.camera_matrix: not a finite number"));
  EXPECT_THAT(loadError(withFirstValue("distortion_coefficients", "-.Inf")),
              HasSubstr("camera_0.distortion_coefficients: not a finite number"));
  EXPECT_THAT(loadError(withFirstValue("R", ".nan")), HasSubstr("camera_0.R: not a finite number"));
  EXPECT_THAT(loadError(withFirstValue("T", ".Inf")), HasSubstr("camera_0.T: not a finite number"));

  EXPECT_THAT(loadError(good + "---\ncamera_count: 1\n"),
              HasSubstr("text after the first YAML document"));
  EXPECT_THAT(loadError(good.substr(good.find('\n') + 1)),
              HasSubstr("the first line must be %YAML:1.0"));
  EXPECT_THAT(loadError("<?xml version=\"1.0\"?>\n<opencv_storage/>\n"),
              HasSubstr("XML is not read"));
  EXPECT_THAT(loadError("%YAML:1.0\n---\ncamera_count: 1\ncamera_0: [\n"),
              HasSubstr("bad_rig.yaml: not a readable YAML file: yaml-cpp: error at line 5"));
  EXPECT_THAT(loadError("%YAML:1.0\n---\nfoo: 1\n"), HasSubstr("camera_count: missing"));
  EXPECT_THROW(loadRig("/nonexistent/rig.yaml"), std::runtime_error);
}

}  // namespace
}  // namespace mocap
