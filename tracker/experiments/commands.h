// The command-line entry points of mocap-experiment, one per experiment. Each parses its flags
// (argv[2...]), prints one JSON object on stdout and returns the exit code; bad flags throw
// std::invalid_argument with a message naming the flag.
#pragma once

namespace mocap {

inline constexpr const char* kHandUsage =
    "hand [--method factored|condensation] [--evals N] [--frames N] [--seed S] [--cameras N]\n"
    "       [--motion FILE.csv] [--model FILE.yaml] [--threads N] [--keep K] [--samples S]\n"
    "       [--injection SHARE] [--beta B] [--describe]";
int runHandCommand(int argc, char** argv);

}  // namespace mocap
