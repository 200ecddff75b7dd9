// The soak's JSON report and its targets: 0 crashes; live subscribers get at least 99 % of the
// poses published to them; resident memory grows at most 5 % after warm-up; closed recordings
// lose no frame set; a SIGKILLed recording reads back whole up to its last complete set.
#include "soak_report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <tuple>
#include <utility>

namespace mocap::soak {
namespace {

using json = nlohmann::json;

double rounded(double value, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(value * scale) / scale;
}

// The lowest and the highest RSS of run `incarnation` between `from` and `to` (seconds), in MB.
std::pair<double, double> rssRangeMb(const std::vector<Sample>& samples, int incarnation,
                                     double from, double to) {
  long low = 0, high = 0;
  for (const Sample& s : samples) {
    if (s.incarnation != incarnation || s.t < from || s.t > to) continue;
    low = low == 0 ? s.rss_kb : std::min(low, s.rss_kb);
    high = std::max(high, s.rss_kb);
  }
  return {low / 1024.0, high / 1024.0};
}

json target(const json& value, const std::string& goal, bool pass) {
  return {{"value", value}, {"target", goal}, {"pass", pass}};
}

json liveSubscribers(const std::vector<SubscriberCounts>& live, double& fraction) {
  SubscriberCounts sum;
  double min_fraction = 1;
  double min_rate = 1e9;
  for (const SubscriberCounts& s : live) {
    sum.received += s.received;
    sum.missed += s.missed;
    sum.streams += s.streams;
    sum.streaming_seconds += s.streaming_seconds;
    if (s.received + s.missed > 0)
      min_fraction = std::min(min_fraction, static_cast<double>(s.received) /
                                                static_cast<double>(s.received + s.missed));
    if (s.streaming_seconds > 0)
      min_rate = std::min(min_rate, static_cast<double>(s.received) / s.streaming_seconds);
  }
  const uint64_t offered = sum.received + sum.missed;
  fraction = offered == 0 ? 0 : static_cast<double>(sum.received) / static_cast<double>(offered);
  return {{"subscribers", live.size()},
          {"poses_received", sum.received},
          {"poses_missed", sum.missed},
          {"fraction_received", rounded(fraction, 5)},
          {"lowest_fraction_received", rounded(min_fraction, 5)},
          {"poses_per_second",
           sum.streaming_seconds > 0
               ? rounded(static_cast<double>(sum.received) / sum.streaming_seconds, 2)
               : 0.0},
          {"lowest_poses_per_second", live.empty() ? 0.0 : rounded(min_rate, 2)},
          {"streams", sum.streams}};
}

// Per run of the daemon: poses it published per second (from its status), memory growth.
json incarnations(const SoakFigures& figures, std::optional<double>& worst_growth) {
  const std::vector<std::optional<MemoryGrowth>> growth = memoryGrowth(figures);
  json runs = json::array();
  for (std::size_t i = 0; i < figures.incarnation_starts.size(); ++i) {
    const Sample* first = nullptr;
    const Sample* last = nullptr;
    for (const Sample& s : figures.samples) {
      if (s.incarnation != static_cast<int>(i) || !s.answered) continue;
      if (!first) first = &s;
      last = &s;
    }
    json run = {{"started_s", rounded(figures.incarnation_starts[i], 1)}};
    if (first && last != first)
      run["poses_published_per_second"] =
          rounded(static_cast<double>(last->poses_published - first->poses_published) /
                      (last->t - first->t),
                  2);
    if (growth[i]) {
      run["rss_growth"] = {{"from_s", rounded(growth[i]->from_s, 1)},
                           {"to_s", rounded(growth[i]->to_s, 1)},
                           {"warm_floor_mb", rounded(growth[i]->warm_floor_mb, 1)},
                           {"end_floor_mb", rounded(growth[i]->end_floor_mb, 1)},
                           {"percent", rounded(growth[i]->percent, 2)},
                           {"warm_peak_mb", rounded(growth[i]->warm_peak_mb, 1)},
                           {"end_peak_mb", rounded(growth[i]->end_peak_mb, 1)},
                           {"peak_percent", rounded(growth[i]->peak_percent, 2)}};
      worst_growth = std::max(worst_growth.value_or(-1e9), growth[i]->percent);
    }
    runs.push_back(run);
  }
  return runs;
}

// Every 10th sample (20 s apart): [seconds, MB].
json rssTimeline(const std::vector<Sample>& samples) {
  json timeline = json::array();
  for (std::size_t i = 0; i < samples.size(); i += 10)
    timeline.push_back({rounded(samples[i].t, 1), rounded(samples[i].rss_kb / 1024.0, 1)});
  if (!samples.empty())
    timeline.push_back({rounded(samples.back().t, 1), rounded(samples.back().rss_kb / 1024.0, 1)});
  return timeline;
}

// Per session name, the sets its recorder dropped because the disk did not keep up, from the
// line the daemon logs when a recording closes (none for a killed one).
std::map<std::string, uint64_t> setsDroppedByRecorder(const std::string& log) {
  std::map<std::string, uint64_t> dropped;
  const std::regex closed(R"(recording (\S+) closed: \d+ frame sets written, (\d+) dropped)");
  std::ifstream in(log);
  std::smatch match;
  for (std::string line; std::getline(in, line);)
    if (std::regex_search(line, match, closed))
      dropped[std::filesystem::path(match[1].str()).filename().string()] = std::stoull(match[2]);
  return dropped;
}

}  // namespace

std::vector<std::optional<MemoryGrowth>> memoryGrowth(const SoakFigures& figures) {
  std::vector<std::optional<MemoryGrowth>> growth;
  const double cycle = figures.options.cycle_seconds;
  for (std::size_t i = 0; i < figures.incarnation_starts.size(); ++i) {
    const double warm = figures.incarnation_starts[i] + figures.options.warmup_seconds;
    double end = 0;
    for (const Sample& s : figures.samples)
      if (s.incarnation == static_cast<int>(i)) end = std::max(end, s.t);
    if (end - cycle < warm + cycle) {
      growth.emplace_back();
      continue;
    }
    MemoryGrowth g;
    g.from_s = warm;
    g.to_s = end;
    const int run = static_cast<int>(i);
    std::tie(g.warm_floor_mb, g.warm_peak_mb) =
        rssRangeMb(figures.samples, run, warm, warm + cycle);
    std::tie(g.end_floor_mb, g.end_peak_mb) = rssRangeMb(figures.samples, run, end - cycle, end);
    g.percent = 100.0 * (g.end_floor_mb / g.warm_floor_mb - 1.0);
    g.peak_percent = 100.0 * (g.end_peak_mb / g.warm_peak_mb - 1.0);
    growth.push_back(g);
  }
  return growth;
}

json soakReport(const SoakFigures& figures) {
  double live_fraction = 0;
  const json live = liveSubscribers(figures.live, live_fraction);
  std::optional<double> worst_growth;
  const json runs = incarnations(figures, worst_growth);

  const std::map<std::string, uint64_t> dropped = setsDroppedByRecorder(figures.daemon_log);
  json recordings = json::array();
  uint64_t closed_lost = 0;
  uint64_t closed_dropped = 0;
  int closed = 0, closed_unreadable = 0, killed = 0, killed_readable = 0;
  for (const RecordingCheck& r : figures.recordings) {
    const std::string name = r.directory.filename().string();
    const auto found = dropped.find(name);
    recordings.push_back(
        {{"name", name},
         {"ended", r.killed ? "SIGKILL" : "StopRecording"},
         {"reported_sets", r.reported_sets},
         {"readable", r.readable},
         {"sets_read", r.sets_read},
         {"sets_lost", r.sets_lost},
         {"sets_dropped_by_recorder", found == dropped.end() ? json(nullptr) : json(found->second)},
         {"reader_notes", r.notes},
         {"error", r.error}});
    if (!r.killed && found != dropped.end()) closed_dropped += found->second;
    if (r.killed) {
      ++killed;
      killed_readable += r.readable && r.sets_read > 0;
    } else {
      ++closed;
      closed_lost += r.sets_lost;
      closed_unreadable += !r.readable;
    }
  }

  json targets;
  targets["crashes"] = target(figures.crashes.size(), "0", figures.crashes.empty());
  targets["live_fraction_received"] =
      target(rounded(live_fraction, 5), ">= 0.99", live_fraction >= 0.99);
  targets["rss_growth_percent_after_warmup"] =
      worst_growth ? target(rounded(*worst_growth, 2), "<= 5", *worst_growth <= 5.0)
                   : target(nullptr, "<= 5 (run too short to measure)", true);
  targets["closed_recordings_sets_lost"] =
      target(closed_lost, "0 (and every closed recording readable)",
             closed_lost == 0 && closed_unreadable == 0 && closed > 0);
  targets["killed_recordings_readable"] =
      target(std::to_string(killed_readable) + " of " + std::to_string(killed), "all",
             killed > 0 && killed_readable == killed);
  bool pass = true;
  for (const auto& [name, t] : targets.items()) pass = pass && t["pass"].get<bool>();

  return {
      {"pass", pass},
      {"seconds", rounded(figures.seconds, 1)},
      {"targets", targets},
      {"live_subscribers", live},
      {"stalled_subscribers",
       {{"subscribers", figures.options.stalled}, {"poses_received", figures.stalled.received}}},
      {"reconnecting_subscribers",
       {{"subscribers", figures.options.reconnecting},
        {"streams", figures.reconnecting.streams},
        {"poses_received", figures.reconnecting.received}}},
      {"daemon_runs", runs},
      {"rss_mb_over_time", rssTimeline(figures.samples)},
      {"recordings", recordings},
      {"closed_recordings_sets_dropped_by_recorder", closed_dropped},
      {"recordings_refused", figures.recordings_refused},
      {"crashes", figures.crashes},
      {"events", figures.events},
      {"daemon_log", figures.daemon_log}};
}

}  // namespace mocap::soak
