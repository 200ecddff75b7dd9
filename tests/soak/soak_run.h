// The soak itself: the schedule of faults, recordings and the kill around a live mocapd, and the
// JSON report of what held.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace mocap::soak {

struct SoakOptions {
  int seconds = 600;
  std::string mocapd;  // the daemon's binary
  std::string work;    // configuration, log and recordings go here
  std::string out;     // also write the report here, if set
  int port = 0;        // the daemon's, on 127.0.0.1, kept across its restart
  int cycle_seconds = 30;
  int record_seconds = 10;
  int warmup_seconds = 60;
  int live = 30;
  int stalled = 10;
  int reconnecting = 10;
  bool keep = false;
};

// Runs the soak; the report has "pass" and each target's figures.
nlohmann::json runSoak(const SoakOptions& options);

}  // namespace mocap::soak
