// mocapctl subcommands: each parses its own flags (argv[2...]) and returns the exit code; main.cpp
// lists them in one table.
#pragma once

namespace mocapctl {

inline constexpr const char* kCalibrateUsage =
    "calibrate --board checkerboard|charuco --cols N --rows N --square M [--marker M]\n"
    "          [--dictionary 4X4_250] (--images DIR | --session DIR [--every N])\n"
    "          [--floor-view NAME] [--min-views N] --out RIG.yaml\n"
    "          (cols/rows count squares; --images: one folder of images per camera, matched by "
    "file name; --session: a recorded session, one view per frame set named by its sequence "
    "number, every N-th set used)";
int runCalibrate(int argc, char** argv);

inline constexpr const char* kBvhUsage =
    "bvh OUT.bvh (--seconds N | --session DIR) [--units m|cm] [--z-up]\n"
    "                         poses as a BVH file: N seconds of the daemon's poses, or,\n"
    "                         without a daemon, a recorded session's true poses (a session\n"
    "                         stores frames and, from the fake scene, the truth, not the tracked\n"
    "                         poses: for those, replay it through mocapd and use --seconds).\n"
    "                         Y up and metres by default, as animation tools import BVH;\n"
    "                         --units cm: centimetres; --z-up: the daemon's own Z-up frame";
int runBvh(int argc, char** argv);

}  // namespace mocapctl
