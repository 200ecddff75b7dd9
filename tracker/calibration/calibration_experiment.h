// The `calibration` experiment: a board rendered into known virtual cameras (perspective warp plus
// the cameras' lens distortion, blur and sensor noise), detected by the same detector, perturbed by
// a chosen corner noise, calibrated by calibrateRig and compared with the truth.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tracker/calibration/calibrate.h"

namespace mocap {

struct CalibrationExperimentConfig {
  int cameras = 4;
  int views = 30;          // board views including the floor view
  double noise_px = 0.2;   // Gaussian noise added to every detected corner, pixels
  uint64_t seed = 1;
  BoardType board = BoardType::kCheckerboard;
  int width = 780;
  int height = 580;
  std::string write_images;  // non-empty: also write <dir>/<camera>/<view>.png
};

struct RenderedCalibration {
  BoardSpec board;
  Rig truth;                                   // world = the floor board's frame, Z up
  std::vector<CameraObservations> observations;
  std::vector<RejectedView> rejected;          // views where the detector found no board
  std::string floor_view = "floor";
};

RenderedCalibration renderCalibrationViews(const CalibrationExperimentConfig& config);

// {"reprojection_rms_px", "focal_error_pct", "principal_point_error_px",
//  "extrinsic_translation_error_mm", "extrinsic_rotation_error_deg", per-camera details...}.
nlohmann::json compareWithTruth(const Rig& truth, const CalibrationResult& result);
nlohmann::json runCalibrationExperiment(const CalibrationExperimentConfig& config);

}  // namespace mocap
