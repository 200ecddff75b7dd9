// The board as command-line flags (--board, --cols, --rows, --square, --marker, --dictionary),
// shared by `mocapctl calibrate` and `mocap-experiment calibration` so both refuse the same
// mistakes with messages naming the flag.
#pragma once

#include "tracker/calibration/board.h"
#include "tracker/cli/args.h"

namespace mocap {

// `defaults` supplies what the flags leave out (its type too, unless --board is given). Throws
// std::invalid_argument naming the flag: sizes out of range, --marker not below --square, unknown
// --dictionary or one with fewer markers than the board needs, --marker/--dictionary given for a
// checkerboard, a checkerboard with cols + rows even. "DICT_5X5_100" is accepted for "5X5_100".
BoardSpec boardFromFlags(const Args& args, BoardSpec defaults);

}  // namespace mocap
