// The soak's figures turned into its JSON report: each target with its value and verdict, and
// the detail behind them (memory over time, every recording, what happened when).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pose_subscribers.h"
#include "recording_checks.h"
#include "soak_run.h"

namespace mocap::soak {

// One look at the daemon, every 2 s.
struct Sample {
  double t = 0;         // seconds since the soak started
  int incarnation = 0;  // 0 until the first restart, then 1, ...
  long rss_kb = 0;
  bool answered = false;  // GetStatus answered: the two below are set
  uint64_t poses_published = 0;
  uint32_t subscribers = 0;
};

struct SoakFigures {
  SoakOptions options;
  double seconds = 0;
  std::vector<Sample> samples;
  std::vector<double> incarnation_starts;  // seconds since the soak started
  std::vector<SubscriberCounts> live;      // one per live subscriber
  SubscriberCounts stalled;
  SubscriberCounts reconnecting;
  std::vector<RecordingCheck> recordings;
  int recordings_refused = 0;
  nlohmann::json crashes;
  nlohmann::json events;
  std::string daemon_log;
};

// Memory growth of one run of the daemon after its warm-up: its first cycle after warm-up against
// its last. Judged on the floor, the lowest RSS of each window (between recordings): the peak
// while recording is mostly the recorder's queue of frames, whose fill follows the machine's
// load. Unset when the run is too short for two such windows.
struct MemoryGrowth {
  double from_s = 0, to_s = 0;
  double warm_floor_mb = 0, end_floor_mb = 0;
  double warm_peak_mb = 0, end_peak_mb = 0;
  double percent = 0;       // of the floor
  double peak_percent = 0;  // of the peak, for the record
};
std::vector<std::optional<MemoryGrowth>> memoryGrowth(const SoakFigures& figures);

nlohmann::json soakReport(const SoakFigures& figures);

}  // namespace mocap::soak
