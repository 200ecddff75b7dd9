// The command-line entry points of mocap-experiment, one per experiment. Each parses its flags
// (argv[2...]), prints one JSON object on stdout and returns the exit code; bad flags throw
// std::invalid_argument with a message naming the flag.
#pragma once

namespace mocap {

// hand and human also take the filter's options (filter_flags.h), listed after their own flags.
inline constexpr const char* kHandUsage =
    "hand [--method factored|condensation] [--evals N] [--frames N] [--seed S] [--cameras N]\n"
    "       [--motion FILE.csv] [--model FILE.yaml] [--threads N] [--describe]";
int runHandCommand(int argc, char** argv);

inline constexpr const char* kHumanUsage =
    "human --motion FILE.bvh [--method factored|condensation|annealed] [--evals N] [--cameras N]\n"
    "       [--frames N] [--seed S] [--dofs 31|17] [--noise none|realistic] [--threads N]\n"
    "       [--start-offset none|arm60|body30cm|acquire] [--start-frame N]\n"
    "       [--model FILE.yaml] [--trace FILE.csv] [--overlay DIR]\n"
    "       [--reset-every N [--reset-to truth|nearest]] [--speed-scale K] [--skip-rate P]\n"
    "       [--subject-scale K] [--tracked-body truth|default|fit|drawn] [--fit-rounds N]\n"
    "       [--limb-margin K]\n"
    "       [--lost-below FIT [--lost-after N]] [--challenge-every N]\n"
    "       [--trial-drop-margin L]\n"
    "       [--dropout-at F --dropout-frames N]\n"
    "       [--scenario lab|product] [--subject-seed N] [--silhouettes true|extracted]\n"
    "       [--motion-units auto|m|cm|mm|cmu|inch] [--motion-joint-map FILE.yaml]\n"
    "  --scenario product: --tracked-body fit (the subject first stands in the fit pose)\n"
    "  --start-offset acquire --silhouettes extracted --subject-seed 1 --cameras 2; flags given\n"
    "  override it. Output: longest_loss_frames, the longest run of frames over 100 mm;\n"
    "  frames_to_first_lock, the first frame that starts 5 frames in a row under 100 mm.";
int runHumanCommand(int argc, char** argv);

inline constexpr const char* kBvhFitUsage =
    "bvh-fit --motion FILE.bvh [--frames N] [--rate HZ] [--model FILE.yaml]";
int runBvhFitCommand(int argc, char** argv);

inline constexpr const char* kSilhouetteUsage =
    "silhouette [--seed S] [--frames N] [--width W] [--height H] [--learn N] [--threshold SIGMAS]\n"
    "       [--gray] [--no-shadows] [--no-adaptive] [--texture-sigmas X] [--texture-contrast X]\n"
    "       [--dump DIR]";
int runSilhouetteCommand(int argc, char** argv);

inline constexpr const char* kCalibrationUsage =
    "calibration [--cameras N] [--views N] [--noise PX] [--seed S] [--board checkerboard|charuco]\n"
    "       [--cols N] [--rows N] [--square M] [--marker M] [--dictionary 5X5_100] [--width W]\n"
    "       [--height H] [--write-images DIR]";
int runCalibrationCommand(int argc, char** argv);

}  // namespace mocap
