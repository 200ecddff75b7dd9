// The `calibration` experiment: a board rendered into known virtual cameras (perspective warp plus
// the cameras' lens distortion, blur and sensor noise), detected by the same detector, perturbed by
// a chosen corner noise, calibrated by calibrateRig and compared with the truth.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tracker/calibration/calibrate.h"

namespace mocap {

struct CalibrationExperimentConfig {
  int cameras = 4;
  int views = 30;         // board views including the floor view
  double noise_px = 0.2;  // Gaussian noise added to every detected corner, pixels
  uint64_t seed = 1;
  BoardType board = BoardType::kCheckerboard;
  std::optional<BoardSpec> custom_board;  // replaces experimentBoard(board)
  int width = 780;
  int height = 580;
  std::string write_images;  // non-empty: also write <dir>/<camera>/<view>.png
};

// The experiment's default boards (docs/vision.md): checkerboard 9x6 squares of 6 cm; ChArUco 7x5
// squares of 11 cm (an A1 print), markers 0.75 of the square, dictionary 5X5_100.
BoardSpec experimentBoard(BoardType type);

struct RenderedCalibration {
  BoardSpec board;
  Rig truth;                                             // world = the floor board's frame, Z up
  std::map<std::string, Eigen::Isometry3d> board_poses;  // true board -> world, by view name
  std::vector<CameraObservations> observations;
  std::vector<RejectedView> rejected;  // views where the detector found no board
  // Detected corners (before the added noise) against the true corners projected by the true
  // camera: the detector's own error.
  double detector_rms_px = 0;
  double detector_max_px = 0;
  long corners_detected = 0;
  int partial_views = 0;  // detected views with some of the board's corners missing
  std::string floor_view = "floor";
};

RenderedCalibration renderCalibrationViews(const CalibrationExperimentConfig& config);

// {"reprojection_rms_px", "focal_error_pct", "principal_point_error_px",
//  "extrinsic_translation_error_mm", "extrinsic_rotation_error_deg", per-camera details...}.
nlohmann::json compareWithTruth(const Rig& truth, const CalibrationResult& result);
nlohmann::json runCalibrationExperiment(const CalibrationExperimentConfig& config);

}  // namespace mocap
