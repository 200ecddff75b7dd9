// mocapctl subcommands that talk to a running mocapd (each also takes --server HOST:PORT,
// --token TOKEN or $MOCAP_TOKEN, --tls-ca PEM, --tls-cert PEM --tls-key PEM, and --timeout
// SECONDS).
#pragma once

namespace mocapctl {

inline constexpr const char* kStreamUsage =
    "stream [--joints a,b,...] [--count N] [--summary]   poses as JSON lines, one a line\n"
    "                         (--summary: one short line a pose, with the error vs the truth)";
inline constexpr const char* kStatusUsage = "status                   the daemon's status as JSON";
inline constexpr const char* kSkeletonUsage =
    "skeleton                 the tracked skeleton as JSON";
inline constexpr const char* kRecordUsage =
    "record start [PATH] | record stop   (PATH relative to the daemon's recording directory)";
inline constexpr const char* kReacquireUsage =
    "reacquire                the tracker finds the subject again (poses resume once found)";
inline constexpr const char* kBackgroundUsage =
    "background [--frames N]  learn the empty scene (nobody in view) as every camera's background\n"
    "                         from its next N frames (default 25): silhouettes are then extracted";
inline constexpr const char* kFitBodyUsage =
    "fit-body [--frames N] [--out FILE] [--apply]\n"
    "                         fit the body model to the subject, who stands in its\n"
    "                         fit pose (the human's: arms 45 degrees out), turning in place,\n"
    "                         from N frame sets half a second apart (default 5, at most 250);\n"
    "                         prints the proportions, the scale and the sets used as JSON and\n"
    "                         writes the fitted body model (YAML, for body_model:) to FILE,\n"
    "                         replacing it atomically; without --out prints that YAML instead,\n"
    "                         the figures as comments at its top; --apply: the daemon also\n"
    "                         tracks with it from then on (until it restarts)";
inline constexpr const char* kBenchUsage =
    "bench [--seconds N] [--latencies]\n"
    "                         capture-to-pose-on-the-wire latency, sustained pose rate and,\n"
    "                         from the fake scene, the poses' error against the truth;\n"
    "                         --latencies adds every pose's latency in arrival order";

int runStream(int argc, char** argv);
int runStatus(int argc, char** argv);
int runSkeleton(int argc, char** argv);
int runRecord(int argc, char** argv);
int runReacquire(int argc, char** argv);
int runBackground(int argc, char** argv);
int runFitBody(int argc, char** argv);
int runBench(int argc, char** argv);

}  // namespace mocapctl
