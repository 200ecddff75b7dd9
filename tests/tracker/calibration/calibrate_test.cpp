// Calibration: rendered views recover known cameras; degenerate inputs are refused with messages
// naming the camera and the problem; the rig file reads back with OpenCV's own FileStorage.
#include "tracker/calibration/calibrate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "tracker/calibration/board_flags.h"
#include "tracker/experiments/calibration_experiment.h"

namespace mocap {
namespace {

CalibrationExperimentConfig smallConfig() {
  CalibrationExperimentConfig config;
  config.cameras = 3;
  config.views = 16;
  config.width = 480;
  config.height = 360;
  config.noise_px = 0;  // the detector's own error only
  config.seed = 21;
  return config;
}

const RenderedCalibration& rendered() {
  static const RenderedCalibration views = renderCalibrationViews(smallConfig());
  return views;
}

std::string refusal(const std::vector<CameraObservations>& cameras, const BoardSpec& board,
                    const CalibrationOptions& options) {
  try {
    calibrateRig(cameras, board, options);
  } catch (const CalibrationError& e) {
    return e.what();
  }
  return "";
}

CalibrationOptions floorOptions() {
  CalibrationOptions options;
  options.floor_view = "floor";
  return options;
}

// Rendering and detection agree with the camera model: corners detected in the rendered views
// (no added noise) sit where cv::projectPoints puts the true board corners. Before supersampling
// the edges snapped to the pixel grid (0.14 px RMS) and the classic finder left some outer corners
// of oblique boards 3-4 px off; now 0.04 px RMS and at most 0.2 px (seeds 101-105, 780x580).
TEST(Calibrate, RenderedCornersMatchProjection) {
  const RenderedCalibration& views = rendered();
  double squared = 0, worst = 0;
  long count = 0;
  for (std::size_t c = 0; c < views.truth.size(); ++c) {
    const CameraModel& camera = views.truth[c];
    const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
    cv::Matx33d rotation;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) rotation(a, b) = camera.rotation(a, b);
    cv::Vec3d r;
    cv::Rodrigues(rotation, r);
    const cv::Vec3d t(camera.translation.x(), camera.translation.y(), camera.translation.z());
    ASSERT_GE(views.observations[c].views.size(), 5u) << camera.name;
    for (const auto& [name, detection] : views.observations[c].views) {
      std::vector<cv::Point3f> world;
      for (int id : detection.ids) {
        const cv::Point3f p = views.board.corner(id);
        const Eigen::Vector3d w = views.board_poses.at(name) * Eigen::Vector3d(p.x, p.y, p.z);
        world.emplace_back(static_cast<float>(w.x()), static_cast<float>(w.y()),
                           static_cast<float>(w.z()));
      }
      std::vector<cv::Point2f> projected;
      cv::projectPoints(world, r, t, k,
                        std::vector<double>(camera.distortion.begin(), camera.distortion.end()),
                        projected);
      for (std::size_t i = 0; i < projected.size(); ++i) {
        const double error = cv::norm(projected[i] - detection.pixels[i]);
        squared += error * error;
        worst = std::max(worst, error);
        ++count;
      }
    }
  }
  ASSERT_GT(count, 0);
  EXPECT_LT(std::sqrt(squared / count), 0.08);
  EXPECT_LT(worst, 0.3);
}

// The issue's targets on its configuration (4 cameras, 30 views, 0.2 px noise per coordinate;
// docs/vision.md reports seeds 1-5, this is seed 1). Before the fix: 0.37 px, 0.93 %, 11 px,
// 26.6 mm, 0.88 deg.
TEST(Calibrate, RecoversRenderedCameras) {
  CalibrationExperimentConfig config;
  config.seed = 1;
  const RenderedCalibration views = renderCalibrationViews(config);
  const CalibrationResult result = calibrateRig(views.observations, views.board, floorOptions());
  const nlohmann::json error = compareWithTruth(views.truth, result);
  EXPECT_LE(error["reprojection_rms_px"].get<double>(), 0.3) << error.dump(2);
  EXPECT_LE(error["focal_error_pct"].get<double>(), 0.5) << error.dump(2);
  EXPECT_LE(error["principal_point_error_px"].get<double>(), 5.0) << error.dump(2);
  EXPECT_LE(error["extrinsic_translation_error_mm"].get<double>(), 5.0) << error.dump(2);
  EXPECT_LE(error["extrinsic_rotation_error_deg"].get<double>(), 0.3) << error.dump(2);
}

TEST(Calibrate, RefusesTooFewViews) {
  auto cameras = rendered().observations;
  while (cameras[1].views.size() > 3) cameras[1].views.erase(std::prev(cameras[1].views.end()));
  const std::string message = refusal(cameras, rendered().board, floorOptions());
  EXPECT_NE(message.find("camera cam1: only 3 views"), std::string::npos) << message;
}

TEST(Calibrate, RefusesFrontoParallelViews) {
  // Synthetic detections of boards all facing camera 0 squarely, at different places.
  const BoardSpec& board = rendered().board;
  const CameraModel& camera = rendered().truth[0];
  CameraObservations observed{"cam0", {camera.width, camera.height}, {}};
  const cv::Matx33d k(camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  for (int v = 0; v < 8; ++v) {
    BoardDetection detection;
    std::vector<cv::Point3f> object;
    for (int id = 0; id < board.cornerCount(); ++id) {
      detection.ids.push_back(id);
      object.push_back(board.corner(id));
    }
    const cv::Vec3d t(-0.2 + 0.05 * (v % 3), -0.15 + 0.05 * (v / 3), 1.5 + 0.1 * v);
    cv::projectPoints(object, cv::Vec3d(0, 0, 0), t, k, cv::noArray(), detection.pixels);
    observed.views["view_" + std::to_string(v)] = detection;
  }
  const std::string message = refusal({observed}, board, {});
  EXPECT_NE(message.find("nearly parallel"), std::string::npos) << message;
}

TEST(Calibrate, RefusesCameraSharingNoView) {
  auto cameras = rendered().observations;
  std::map<std::string, BoardDetection> renamed;
  for (auto& [name, detection] : cameras[2].views) renamed["only_cam2_" + name] = detection;
  cameras[2].views = renamed;
  const std::string message = refusal(cameras, rendered().board, floorOptions());
  EXPECT_NE(message.find("cam2 share no board view"), std::string::npos) << message;
}

TEST(Calibrate, RefusesUnseenFloorView) {
  CalibrationOptions options;
  options.floor_view = "no_such_view";
  const std::string message = refusal(rendered().observations, rendered().board, options);
  EXPECT_NE(message.find("floor view 'no_such_view'"), std::string::npos) << message;
}

TEST(Calibrate, RigFileReadsBackWithOpenCV) {
  const CalibrationResult result =
      calibrateRig(rendered().observations, rendered().board, floorOptions());
  const std::string path = (std::filesystem::temp_directory_path() / "mocap_rig_test.yaml").string();
  saveRig(path, result.rig);
  cv::FileStorage fs(path, cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  EXPECT_EQ(static_cast<int>(fs["camera_count"]), static_cast<int>(result.rig.size()));
  for (std::size_t i = 0; i < result.rig.size(); ++i) {
    cv::FileNode node = fs["camera_" + std::to_string(i)];
    cv::Mat k, r, t, d;
    node["camera_matrix"] >> k;
    node["R"] >> r;
    node["T"] >> t;
    node["distortion_coefficients"] >> d;
    EXPECT_DOUBLE_EQ(k.at<double>(0, 0), result.rig[i].fx);
    EXPECT_DOUBLE_EQ(k.at<double>(1, 2), result.rig[i].cy);
    EXPECT_DOUBLE_EQ(r.at<double>(1, 2), result.rig[i].rotation(1, 2));
    EXPECT_DOUBLE_EQ(t.at<double>(2), result.rig[i].translation.z());
    EXPECT_DOUBLE_EQ(d.at<double>(0), result.rig[i].distortion[0]);
  }
  const Rig loaded = loadRig(path);
  ASSERT_EQ(loaded.size(), result.rig.size());
  EXPECT_EQ(loaded[1].name, result.rig[1].name);
  std::filesystem::remove(path);
}

// ChArUco: the experiment's board (7x5 squares of 11 cm, 5X5_100) in 3 cameras at full size
// (markers need their 3-4 px per bit), 12 views, no added noise: about a second.
const RenderedCalibration& renderedCharuco() {
  static const RenderedCalibration views = [] {
    CalibrationExperimentConfig config;
    config.board = BoardType::kCharuco;
    config.cameras = 3;
    config.views = 12;
    config.noise_px = 0;
    config.seed = 21;
    return renderCalibrationViews(config);
  }();
  return views;
}

// Partial views are rendered (the board partly out of the image) and their corners keep their ids:
// each detected corner sits where its id's board point projects. Seeds 1-5 of the full experiment
// give 0.065-0.079 px RMS, at most 1.34 px; a wrong id is a square (>= 15 px) off, and OpenCV's
// unrefined corners were 0.69 px RMS.
TEST(CalibrateCharuco, PartialDetectionsKeepTheirIds) {
  const RenderedCalibration& views = renderedCharuco();
  int partial = 0;
  for (const CameraObservations& camera : views.observations)
    for (const auto& [name, detection] : camera.views)
      if (static_cast<int>(detection.ids.size()) < views.board.cornerCount()) ++partial;
  EXPECT_GE(partial, 3);
  EXPECT_EQ(partial, views.partial_views);
  EXPECT_LT(views.detector_rms_px, 0.12);
  EXPECT_LT(views.detector_max_px, 1.5);
}

// The ChArUco path calibrates the rendered rig, partial views included. Thresholds from the full
// experiment without noise (seeds 1-5: 0.06-0.08 px, <= 0.07 %, <= 0.5 px, <= 3.3 mm, <= 0.07 deg)
// with room for 3 cameras and 12 views instead of 4 and 30.
TEST(CalibrateCharuco, RecoversRenderedCameras) {
  const RenderedCalibration& views = renderedCharuco();
  const CalibrationResult result = calibrateRig(views.observations, views.board, floorOptions());
  const nlohmann::json error = compareWithTruth(views.truth, result);
  EXPECT_LE(error["reprojection_rms_px"].get<double>(), 0.12) << error.dump(2);
  EXPECT_LE(error["focal_error_pct"].get<double>(), 0.5) << error.dump(2);
  EXPECT_LE(error["principal_point_error_px"].get<double>(), 3.0) << error.dump(2);
  EXPECT_LE(error["extrinsic_translation_error_mm"].get<double>(), 8.0) << error.dump(2);
  EXPECT_LE(error["extrinsic_rotation_error_deg"].get<double>(), 0.3) << error.dump(2);
  // Partial views are kept by the calibration, not only detected.
  int partial_used = 0;
  for (const CameraObservations& camera : views.observations)
    for (const auto& [name, detection] : camera.views)
      if (static_cast<int>(detection.ids.size()) < views.board.cornerCount()) ++partial_used;
  int rejected_partial = 0;
  for (const RejectedView& r : result.rejected)
    for (const CameraObservations& camera : views.observations)
      if (camera.name == r.camera && camera.views.count(r.view) &&
          static_cast<int>(camera.views.at(r.view).ids.size()) < views.board.cornerCount())
        ++rejected_partial;
  EXPECT_GT(partial_used - rejected_partial, 0);
}

// A board seen face on, 30 px per square, its right part hidden: only corners of the visible part
// are reported, each with the id of the corner at that place.
TEST(CalibrateCharuco, OccludedBoardGivesVisibleCornersById) {
  const BoardSpec board = experimentBoard(BoardType::kCharuco);
  const int pps = 30;
  cv::Matx33d to_board;
  cv::Mat image = renderBoardImage(board, pps, to_board);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.6);
  // Hide everything right of the board's 4th column of squares (corner columns 0-2 stay clear).
  const int hidden_from = 5 * pps;
  image(cv::Rect(hidden_from, 0, image.cols - hidden_from, image.rows)).setTo(110);
  BoardDetection detection;
  std::string why;
  ASSERT_TRUE(BoardDetector(board).detect(image, detection, why)) << why;
  EXPECT_GE(detection.ids.size(), 6u);
  EXPECT_LT(static_cast<int>(detection.ids.size()), board.cornerCount());
  for (std::size_t i = 0; i < detection.ids.size(); ++i) {
    const int id = detection.ids[i];
    // Corner (col, row) lies on the texture's pixel edge (2 + col, 2 + row) squares in.
    const cv::Point2f expected((2 + id % board.innerCols()) * pps - 0.5f,
                               (2 + id / board.innerCols()) * pps - 0.5f);
    EXPECT_LT(expected.x, hidden_from) << "id " << id;
    EXPECT_LT(cv::norm(detection.pixels[i] - expected), 0.1) << "id " << id;
  }
}

TEST(CalibrateCharuco, RefusesBoardWithTooFewCorners) {
  const BoardSpec board = experimentBoard(BoardType::kCharuco);
  const int pps = 30;
  cv::Matx33d to_board;
  cv::Mat image = renderBoardImage(board, pps, to_board);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.6);
  // Only the first two columns of squares stay visible: at most 4 corners between their markers.
  image(cv::Rect(3 * pps, 0, image.cols - 3 * pps, image.rows)).setTo(110);
  BoardDetection detection;
  std::string why;
  EXPECT_FALSE(BoardDetector(board).detect(image, detection, why));
  EXPECT_NE(why.find("board corners (need 6)"), std::string::npos) << why;
}

// Views that cannot fix a board pose are dropped with their reason, and a camera left with too few
// views is refused with a message saying why.
TEST(CalibrateCharuco, RefusesCameraWhoseViewsAreOnOneLine) {
  auto cameras = renderedCharuco().observations;
  const BoardSpec& board = renderedCharuco().board;
  // cam1 sees only the first row of corners in every view (a board edge peeking into the image).
  for (auto& [name, detection] : cameras[1].views) {
    BoardDetection row;
    for (int id = 0; id < board.innerCols(); ++id) {
      row.ids.push_back(id);
      row.pixels.emplace_back(100.0f + 20 * id, 100.0f);
    }
    detection = row;
  }
  const std::string message = refusal(cameras, board, floorOptions());
  EXPECT_NE(message.find("camera cam1: only 0 views"), std::string::npos) << message;
  EXPECT_NE(message.find("lie on one line"), std::string::npos) << message;
}

TEST(CalibrateCharuco, DetectionProblems) {
  BoardSpec board;
  board.type = BoardType::kCharuco;
  board.cols = 9;
  board.rows = 7;  // 8 x 6 inner corners
  auto problem = [&](std::vector<int> ids) {
    BoardDetection detection;
    detection.ids = ids;
    detection.pixels.resize(ids.size());
    return detectionProblem(board, detection);
  };
  EXPECT_EQ(problem({0, 1, 2, 3, 4, 9}), "");
  EXPECT_NE(problem({0, 1, 2, 3, 4}).find("only 5 board corners (need 6)"), std::string::npos);
  EXPECT_NE(problem({0, 9, 18, 27, 36, 45}).find("one line"), std::string::npos);   // diagonal
  EXPECT_NE(problem({3, 11, 19, 27, 35, 43}).find("one line"), std::string::npos);  // column
  EXPECT_NE(problem({0, 1, 2, 3, 4, 4}).find("corner id 4 found twice"), std::string::npos);
  EXPECT_NE(problem({0, 1, 2, 3, 4, 48}).find("corner id 48 is not on a 9x7 board"),
            std::string::npos);
}

std::string flagError(std::vector<std::string> words) {
  words.insert(words.begin(), {"mocapctl", "calibrate"});
  std::vector<char*> argv;
  for (auto& w : words) argv.push_back(w.data());
  try {
    const Args args(static_cast<int>(argv.size()), argv.data(), 2,
                    "calibrate [--board TYPE] [--cols N] [--rows N] [--square M] [--marker M] "
                    "[--dictionary NAME]");
    boardFromFlags(args, BoardSpec{});
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(CalibrateCharuco, BoardFlagsAreCheckedByName) {
  const std::vector<std::string> charuco = {"--board", "charuco", "--cols",   "7",
                                            "--rows",  "5",       "--square", "0.11"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> words = charuco;
    words.insert(words.end(), extra.begin(), extra.end());
    return flagError(words);
  };
  EXPECT_EQ(with({"--marker", "0.0825", "--dictionary", "DICT_5X5_100"}), "");
  EXPECT_NE(with({"--marker", "0.12"}).find("--marker 0.12 must be smaller than --square 0.11"),
            std::string::npos);
  EXPECT_NE(with({"--marker", "0.08", "--dictionary", "5X5_99"}).find("--dictionary '5X5_99'"),
            std::string::npos);
  EXPECT_NE(flagError({"--board", "charuco", "--cols", "12", "--rows", "10", "--square", "0.05",
                       "--marker", "0.03", "--dictionary", "4X4_50"})
                .find("--dictionary 4X4_50 holds 50 markers but a 12x10 ChArUco board needs 60"),
            std::string::npos);
  EXPECT_NE(flagError({"--board", "checkerboard", "--cols", "9", "--rows", "6", "--square", "0.06",
                       "--marker", "0.04"})
                .find("--marker applies to --board charuco only"),
            std::string::npos);
  EXPECT_NE(flagError({"--board", "charucco"}).find("--board 'charucco'"), std::string::npos);
}

}  // namespace
}  // namespace mocap
