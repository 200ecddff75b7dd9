// `mocapctl calibrate`: detects the board in per-camera image folders or a recorded session,
// calibrates the rig and writes the rig file the tracker reads. Prints per-camera reprojection RMS
// and every rejected view.
#include <iomanip>
#include <iostream>

#include "clients/mocapctl/commands.h"
#include "clients/mocapctl/session_views.h"
#include "tracker/calibration/board_flags.h"
#include "tracker/calibration/calibrate.h"
#include "tracker/cli/args.h"

namespace mocapctl {

int runCalibrate(int argc, char** argv) {
  const mocap::Args args(argc, argv, 2, kCalibrateUsage);
  if (args.has("images") == args.has("session"))
    throw std::invalid_argument(
        "give exactly one of --images DIR and --session DIR\nusage: mocapctl " +
        std::string(kCalibrateUsage));
  for (const char* required : {"board", "cols", "rows", "square", "out"})
    if (!args.has(required))
      throw std::invalid_argument(std::string("--") + required + " is required\nusage: mocapctl " +
                                  kCalibrateUsage);
  // A guessed marker size would scale nothing but could silently mismatch the print: required.
  if (args.text("board", "") == "charuco" && !args.has("marker"))
    throw std::invalid_argument(
        "--marker is required for --board charuco (printed marker side, "
        "metres)\nusage: mocapctl " +
        std::string(kCalibrateUsage));
  const mocap::BoardSpec board = mocap::boardFromFlags(args, mocap::BoardSpec{});

  mocap::CalibrationOptions options;
  options.floor_view = args.text("floor-view", "");
  options.min_views = static_cast<int>(args.integer("min-views", options.min_views, 3, 10000));

  std::vector<mocap::RejectedView> not_detected;
  const auto cameras =
      args.has("images")
          ? mocap::detectImageFolders(args.text("images", ""), board, not_detected)
          : detectSession(args.text("session", ""), board,
                          static_cast<int>(args.integer("every", 1, 1, 1'000'000)), not_detected);
  for (const auto& r : not_detected)
    std::cout << "rejected " << r.camera << "/" << r.view << ": " << r.reason << "\n";
  const mocap::CalibrationResult result = mocap::calibrateRig(cameras, board, options);
  for (const auto& r : result.rejected)
    std::cout << "rejected " << r.camera << "/" << r.view << ": " << r.reason << "\n";
  for (const auto& w : result.warnings) std::cout << "warning: " << w << "\n";
  std::cout << std::fixed << std::setprecision(3);
  for (std::size_t i = 0; i < result.cameras.size(); ++i) {
    const auto& c = result.cameras[i];
    const auto& m = result.rig[i];
    std::cout << c.name << ": " << c.views_used << " views, intrinsic RMS " << c.intrinsic_rms_px
              << " px, rig RMS " << c.rig_rms_px << " px, f = (" << m.fx << ", " << m.fy
              << "), c = (" << m.cx << ", " << m.cy << ")\n";
  }
  const std::string out = args.text("out", "");
  mocap::saveRig(out, result.rig);
  std::cout << "rig RMS " << result.rig_rms_px << " px; wrote " << out << "\n";
  return 0;
}

}  // namespace mocapctl
