// Board detections from a recorded session, for `mocapctl calibrate --session DIR`: the session's
// cameras become the rig's cameras (by their recorded names), and each frame set becomes one view
// named by its sequence number, so a board seen by several cameras in one set ties them together.
#pragma once

#include <string>
#include <vector>

#include "tracker/calibration/calibrate.h"

namespace mocapctl {

// Uses every `every`-th frame set (1: all). Frames without a board, or missing from a set, go to
// `rejected` with the reason. Throws mocap::CalibrationError naming the session and what is wrong
// when it cannot be opened or holds no frame set.
std::vector<mocap::CameraObservations> detectSession(const std::string& dir,
                                                     const mocap::BoardSpec& board, int every,
                                                     std::vector<mocap::RejectedView>& rejected);

}  // namespace mocapctl
