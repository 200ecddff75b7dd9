// The mocapctl subcommands that talk to mocapd: stream, status, skeleton, record, reacquire,
// background, fit-body, bench.
#include "clients/mocapctl/daemon_commands.h"

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <google/protobuf/util/json_util.h>
#include <nlohmann/json.hpp>

#include "clients/mocapctl/command_flags.h"
#include "clients/mocapctl/daemon_client.h"

namespace mocapctl {
namespace {

using Clock = std::chrono::steady_clock;

std::string toJson(const google::protobuf::Message& message) {
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.always_print_primitive_fields = true;
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

int64_t monotonicNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Writes `text` to `path` under a hidden temporary name in the same folder, then renames it over
// `path`: a reader never sees a half-written file, and a failure leaves the old one as it was.
void writeFileAtomically(const std::string& path, const std::string& text) {
  const std::filesystem::path target(path);
  const std::filesystem::path temporary =
      target.parent_path() /
      ("." + target.filename().string() + ".tmp-" + std::to_string(::getpid()));
  {
    std::ofstream out(temporary, std::ios::trunc);
    if (!out) throw std::runtime_error(path + ": cannot write in its folder");
    out << text;
    if (!out.flush()) {
      std::filesystem::remove(temporary);
      throw std::runtime_error(path + ": write failed");
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, target, error);
  if (error) {
    std::filesystem::remove(temporary);
    throw std::runtime_error(path + ": " + error.message());
  }
}

}  // namespace

int runStream(int argc, char** argv) {
  DaemonFlags flags;
  std::vector<std::string> args = parseDaemonFlags(argc, argv, flags);
  const std::string joints = takeFlag(args, "--joints");
  const std::string count_text = takeFlag(args, "--count");
  const bool summary = takeSwitch(args, "--summary");
  noMoreArguments(args);
  const long count = count_text.empty() ? 0 : positiveNumber("--count", count_text);

  DaemonClient client(flags);
  mocap::v1::StreamPosesRequest request;
  for (std::size_t start = 0; start < joints.size();) {
    const std::size_t comma = std::min(joints.find(',', start), joints.size());
    if (comma > start) request.add_joints(joints.substr(start, comma - start));
    start = comma + 1;
  }
  std::unique_ptr<grpc::ClientContext> context = client.context();
  std::unique_ptr<grpc::ClientReader<mocap::v1::Pose>> reader =
      client.stub().StreamPoses(context.get(), request);
  mocap::v1::Pose pose;
  long received = 0;
  while (reader->Read(&pose)) {
    if (summary) {  // one short human-readable line per pose
      char text[160];
      const double latency_ms = (monotonicNowNs() - pose.capture_monotonic_ns()) / 1e6;
      std::snprintf(text, sizeof text, "frame %6llu  latency %6.1f ms  spread %6.3f  missed %llu",
                    static_cast<unsigned long long>(pose.frame_sequence()), latency_ms,
                    pose.spread(), static_cast<unsigned long long>(pose.missed_before()));
      std::cout << text;
      if (pose.has_silhouette_fit())
        std::cout << "  fit " << std::fixed << std::setprecision(3) << pose.silhouette_fit();
      if (pose.has_reference_error_mm())
        std::cout << "  error vs truth " << std::fixed << std::setprecision(1)
                  << pose.reference_error_mm() << " mm";
      std::cout << "\n" << std::flush;
      if (count > 0 && ++received >= count) {
        context->TryCancel();
        break;
      }
      continue;
    }
    nlohmann::json line;
    line["frame"] = pose.frame_sequence();
    line["capture_monotonic_ns"] = pose.capture_monotonic_ns();
    line["capture_wall_ns"] = pose.capture_wall_ns();
    line["publish_monotonic_ns"] = pose.publish_monotonic_ns();
    nlohmann::json positions = nlohmann::json::object();
    for (const mocap::v1::JointPosition& joint : pose.joints()) {
      positions[joint.name()] = {joint.position().x(), joint.position().y(), joint.position().z()};
    }
    line["joints"] = positions;
    line["dofs"] = std::vector<double>(pose.dofs().begin(), pose.dofs().end());
    line["score"] = pose.score();
    line["spread"] = pose.spread();
    line["missed_before"] = pose.missed_before();
    if (pose.has_silhouette_fit()) line["silhouette_fit"] = pose.silhouette_fit();
    if (pose.has_reference_error_mm()) line["reference_error_mm"] = pose.reference_error_mm();
    std::cout << line.dump() << "\n" << std::flush;
    if (count > 0 && ++received >= count) {
      context->TryCancel();
      break;
    }
  }
  const grpc::Status status = reader->Finish();
  if (count > 0 && received >= count) return 0;
  check(status, "StreamPoses");
  return 0;
}

int runStatus(int argc, char** argv) {
  DaemonFlags flags;
  noMoreArguments(parseDaemonFlags(argc, argv, flags));
  DaemonClient client(flags);
  mocap::v1::Status status;
  client.call("GetStatus", &DaemonClient::Stub::GetStatus, {}, status, DaemonClient::kQuickTimeout);
  std::cout << toJson(status);
  return 0;
}

int runSkeleton(int argc, char** argv) {
  DaemonFlags flags;
  noMoreArguments(parseDaemonFlags(argc, argv, flags));
  DaemonClient client(flags);
  mocap::v1::Skeleton skeleton;
  client.call("GetSkeleton", &DaemonClient::Stub::GetSkeleton, {}, skeleton,
              DaemonClient::kQuickTimeout);
  std::cout << toJson(skeleton);
  return 0;
}

int runRecord(int argc, char** argv) {
  DaemonFlags flags;
  std::vector<std::string> args = parseDaemonFlags(argc, argv, flags);
  if (args.empty()) throw std::runtime_error("expected 'start [PATH]' or 'stop'");
  const std::string action = args.front();
  args.erase(args.begin());
  DaemonClient client(flags);
  mocap::v1::RecordingState state;
  if (action == "start") {
    mocap::v1::StartRecordingRequest request;
    if (!args.empty()) {
      request.set_path(args.front());
      args.erase(args.begin());
    }
    noMoreArguments(args);
    client.call("StartRecording", &DaemonClient::Stub::StartRecording, request, state,
                DaemonClient::kRecordingStartTimeout);
  } else if (action == "stop") {
    noMoreArguments(args);
    client.call("StopRecording", &DaemonClient::Stub::StopRecording, {}, state,
                DaemonClient::kRecordingStopTimeout);
  } else {
    throw std::runtime_error("expected 'start [PATH]' or 'stop', got '" + action + "'");
  }
  std::cout << toJson(state);
  return 0;
}

int runReacquire(int argc, char** argv) {
  DaemonFlags flags;
  noMoreArguments(parseDaemonFlags(argc, argv, flags));
  DaemonClient client(flags);
  mocap::v1::ReacquireResponse response;
  client.call("Reacquire", &DaemonClient::Stub::Reacquire, {}, response,
              DaemonClient::kQuickTimeout);
  return 0;
}

int runBackground(int argc, char** argv) {
  DaemonFlags flags;
  std::vector<std::string> args = parseDaemonFlags(argc, argv, flags);
  const std::string frames_text = takeFlag(args, "--frames");
  noMoreArguments(args);
  mocap::v1::CaptureBackgroundRequest request;
  if (!frames_text.empty())
    request.set_frames(static_cast<uint32_t>(positiveNumber("--frames", frames_text)));
  DaemonClient client(flags);
  // The daemon answers DEADLINE_EXCEEDED itself when frames stop coming; this bound (cameras at
  // 1 Hz at least) only keeps a daemon that never answers from hanging the command.
  mocap::v1::CaptureBackgroundResponse response;
  client.call("CaptureBackground", &DaemonClient::Stub::CaptureBackground, request, response,
              std::chrono::seconds(60 + std::max<uint32_t>(request.frames(), 25)));
  // What each camera extracts against now, what was doubtful about this capture, and any saved
  // background that could not be used.
  mocap::v1::Status status;
  client.call("GetStatus", &DaemonClient::Stub::GetStatus, {}, status, DaemonClient::kQuickTimeout);
  nlohmann::json warnings = response.warnings();
  for (const std::string& warning : status.background_warnings()) warnings.push_back(warning);
  nlohmann::json out = {{"frames_used", response.frames_used()},
                        {"cameras", nlohmann::json::array()},
                        {"warnings", warnings}};
  for (const mocap::v1::CameraStatus& camera : status.cameras())
    out["cameras"].push_back({{"id", camera.id()}, {"silhouettes", camera.silhouettes()}});
  std::cout << out.dump(1) << "\n";
  return 0;
}

int runFitBody(int argc, char** argv) {
  DaemonFlags flags;
  std::vector<std::string> args = parseDaemonFlags(argc, argv, flags);
  const std::string frames_text = takeFlag(args, "--frames");
  const std::string out_path = takeFlag(args, "--out");
  const bool apply = takeSwitch(args, "--apply");
  noMoreArguments(args);
  mocap::v1::FitBodyRequest request;
  request.set_apply(apply);
  if (!frames_text.empty())
    request.set_frame_sets(static_cast<int32_t>(positiveNumber("--frames", frames_text)));
  DaemonClient client(flags);
  // The daemon answers DEADLINE_EXCEEDED itself when frames stop coming; this bound (half a second
  // to collect each set and about as much to fit it, slower on a loaded core) only keeps a daemon
  // that never answers from hanging the command.
  mocap::v1::FitBodyResponse response;
  client.call("FitBody", &DaemonClient::Stub::FitBody, request, response,
              std::chrono::seconds(60 + 3 * std::max(request.frame_sets(), 5)));
  nlohmann::ordered_json out = {{"frame_sets_used", response.frame_sets_used()},
                                {"proportions", nlohmann::ordered_json::object()},
                                {"scale", response.scale()},
                                {"log_likelihood", response.log_likelihood()},
                                {"evaluations", response.evaluations()},
                                {"fit_seconds", response.fit_seconds()}};
  if (apply) out["body_version"] = response.body_version();
  for (const mocap::v1::BodyProportion& proportion : response.proportions())
    out["proportions"][proportion.name()] = proportion.factor();
  if (!out_path.empty()) {
    writeFileAtomically(out_path, response.body_model_yaml());
    out["written"] = out_path;
    std::cout << out.dump(1) << "\n";
    return 0;
  }
  // A body model file as it is: the figures as YAML comments above it.
  std::istringstream summary(out.dump(1));
  for (std::string line; std::getline(summary, line);) std::cout << "# " << line << "\n";
  std::cout << response.body_model_yaml();
  if (!response.body_model_yaml().empty() && response.body_model_yaml().back() != '\n')
    std::cout << "\n";
  return 0;
}

int runBench(int argc, char** argv) {
  DaemonFlags flags;
  std::vector<std::string> args = parseDaemonFlags(argc, argv, flags);
  const std::string seconds_text = takeFlag(args, "--seconds");
  const bool with_latencies = takeSwitch(args, "--latencies");
  noMoreArguments(args);
  const long seconds = seconds_text.empty() ? 10 : positiveNumber("--seconds", seconds_text);

  DaemonClient client(flags);
  std::unique_ptr<grpc::ClientContext> context = client.context();
  mocap::v1::StreamPosesRequest request;
  std::unique_ptr<grpc::ClientReader<mocap::v1::Pose>> reader =
      client.stub().StreamPoses(context.get(), request);
  // The first pose starts the window, so connection set-up is not measured.
  mocap::v1::Pose pose;
  if (!reader->Read(&pose)) {
    check(reader->Finish(), "StreamPoses");
    throw std::runtime_error("the stream ended before the first pose");
  }
  const uint64_t first_frame = pose.frame_sequence();
  const auto start = Clock::now();
  const auto end = start + std::chrono::seconds(seconds);
  auto last_progress = start;
  std::vector<double> latencies_ms, errors_mm;
  // Where each pose's latency went, stage by stage (the names of the JSON's "stages_ms").
  static const char* const kStages[] = {"capture_to_silhouettes", "silhouettes",
                                        "silhouettes_to_tracker", "track",
                                        "tracker_to_publisher",   "publisher_to_client"};
  constexpr std::size_t kStageCount = std::size(kStages);
  std::vector<double> stage_ms[kStageCount];
  uint64_t missed = 0, last_frame = first_frame;
  while (Clock::now() < end && reader->Read(&pose)) {
    // Same host, same CLOCK_MONOTONIC: arrival minus exposure is the whole capture-to-wire path.
    const int64_t arrival_ns = monotonicNowNs();
    latencies_ms.push_back(static_cast<double>(arrival_ns - pose.capture_monotonic_ns()) / 1e6);
    // A daemon older than the stage times sends none: its latency is not split.
    if (pose.has_stages()) {
      const mocap::v1::StageTimes& stages = pose.stages();
      const int64_t times[kStageCount + 1] = {pose.capture_monotonic_ns(),
                                              stages.silhouettes_start_ns(),
                                              stages.silhouettes_end_ns(),
                                              stages.track_start_ns(),
                                              stages.track_end_ns(),
                                              pose.publish_monotonic_ns(),
                                              arrival_ns};
      for (std::size_t k = 0; k < kStageCount; ++k)
        stage_ms[k].push_back(static_cast<double>(times[k + 1] - times[k]) / 1e6);
    }
    if (pose.has_reference_error_mm()) errors_mm.push_back(pose.reference_error_mm());
    missed += pose.missed_before();
    last_frame = pose.frame_sequence();
    if (Clock::now() - last_progress >= std::chrono::seconds(1)) {
      last_progress = Clock::now();
      progress("bench: " + std::to_string(latencies_ms.size()) + " poses");
    }
  }
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  context->TryCancel();
  reader->Finish();
  std::cerr << "\n";
  if (latencies_ms.empty()) throw std::runtime_error("no pose arrived after the first one");
  const std::vector<double> in_arrival_order =
      with_latencies ? latencies_ms : std::vector<double>{};
  std::sort(latencies_ms.begin(), latencies_ms.end());
  std::sort(errors_mm.begin(), errors_mm.end());
  for (std::vector<double>& times : stage_ms) std::sort(times.begin(), times.end());
  const auto percentile = [](const std::vector<double>& sorted, double p) {
    return sorted[static_cast<std::size_t>(p * static_cast<double>(sorted.size() - 1) + 0.5)];
  };
  nlohmann::json summary = {
      {"seconds", elapsed},
      {"poses", latencies_ms.size()},
      {"poses_per_second", static_cast<double>(latencies_ms.size()) / elapsed},
      {"frame_sets_spanned", last_frame - first_frame},
      {"missed_by_this_client", missed},
      {"latency_ms",
       {{"p50", percentile(latencies_ms, 0.5)},
        {"p99", percentile(latencies_ms, 0.99)},
        {"max", latencies_ms.back()}}},
  };
  for (std::size_t k = 0; k < kStageCount && !stage_ms[k].empty(); ++k)
    summary["stages_ms"][kStages[k]] = {{"p50", percentile(stage_ms[k], 0.5)},
                                        {"p99", percentile(stage_ms[k], 0.99)}};
  // A source that knows the truth (the fake scene): how far the poses were from it.
  if (!errors_mm.empty()) {
    double sum = 0;
    long over_100 = 0;
    for (double e : errors_mm) sum += e, over_100 += e > 100;
    summary["reference_error_mm"] = {
        {"median", percentile(errors_mm, 0.5)},
        {"mean", sum / static_cast<double>(errors_mm.size())},
        {"share_over_100", static_cast<double>(over_100) / static_cast<double>(errors_mm.size())}};
  }
  if (with_latencies) summary["latencies_ms"] = in_arrival_order;
  std::cout << summary.dump(2) << "\n";
  return 0;
}

}  // namespace mocapctl
