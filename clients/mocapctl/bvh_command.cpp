// `mocapctl bvh`: poses as a BVH file, from a running daemon (--seconds N) or from a recorded
// session's true poses without one (--session DIR).
#include <chrono>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "clients/mocapctl/bvh_export.h"
#include "clients/mocapctl/command_flags.h"
#include "clients/mocapctl/commands.h"
#include "clients/mocapctl/daemon_client.h"
#include "clients/mocapctl/session_bvh.h"

namespace mocapctl {
namespace {

using Clock = std::chrono::steady_clock;

BvhExportOptions exportOptions(std::vector<std::string>& args) {
  BvhExportOptions options;
  options.y_up = !takeSwitch(args, "--z-up");
  const std::string units = takeFlag(args, "--units");
  if (units == "cm") {
    options.units_per_metre = 100;
  } else if (!units.empty() && units != "m") {
    throw std::runtime_error("--units: expected m or cm, got '" + units + "'");
  }
  return options;
}

// The daemon's poses for `seconds`: one frame per pose received, the frame time their mean
// capture interval (poses this client missed counted), so the clip plays at the captured pace.
BvhClip streamedClip(const DaemonFlags& flags, long seconds) {
  DaemonClient client(flags);
  BvhClip clip;
  client.call("GetSkeleton", &DaemonClient::Stub::GetSkeleton, {}, clip.skeleton,
              DaemonClient::kQuickTimeout);
  std::unique_ptr<grpc::ClientContext> context = client.context();
  context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  mocap::v1::StreamPosesRequest request;
  // BVH needs only the DOFs: one joint keeps the poses small.
  if (clip.skeleton.points_size() > 0) request.add_joints(clip.skeleton.points(0).name());
  std::unique_ptr<grpc::ClientReader<mocap::v1::Pose>> reader =
      client.stub().StreamPoses(context.get(), request);
  int64_t first_capture = 0, last_capture = 0;
  uint64_t missed = 0;
  const auto start = Clock::now();
  auto last_progress = start;
  mocap::v1::Pose pose;
  while (reader->Read(&pose)) {
    if (clip.frames.empty()) first_capture = pose.capture_monotonic_ns();
    last_capture = pose.capture_monotonic_ns();
    missed += clip.frames.empty() ? 0 : pose.missed_before();
    clip.frames.emplace_back(pose.dofs().begin(), pose.dofs().end());
    if (Clock::now() - last_progress >= std::chrono::seconds(1)) {
      last_progress = Clock::now();
      const auto elapsed = std::chrono::duration_cast<std::chrono::seconds>(last_progress - start);
      progress("bvh: " + std::to_string(elapsed.count()) + "/" + std::to_string(seconds) + " s, " +
               std::to_string(clip.frames.size()) + " poses");
    }
  }
  const grpc::Status status = reader->Finish();
  if (status.error_code() != grpc::StatusCode::DEADLINE_EXCEEDED) check(status, "StreamPoses");
  if (clip.frames.empty())
    throw std::runtime_error("no pose arrived in " + std::to_string(seconds) + " s");
  clip.frame_time_s = clip.frames.size() > 1
                          ? static_cast<double>(last_capture - first_capture) / 1e9 /
                                static_cast<double>(clip.frames.size() - 1 + missed)
                          : 0.04;
  clip.held_sets = static_cast<int>(missed);
  return clip;
}

}  // namespace

int runBvh(int argc, char** argv) {
  DaemonFlags flags;
  std::vector<std::string> args = parseDaemonFlags(argc, argv, flags);
  const std::string seconds_text = takeFlag(args, "--seconds");
  const std::string session_dir = takeFlag(args, "--session");
  const BvhExportOptions options = exportOptions(args);
  if (args.size() != 1 || args.front().rfind("--", 0) == 0)
    throw std::runtime_error(std::string("expected one output file\nusage: mocapctl ") + kBvhUsage);
  if (seconds_text.empty() == session_dir.empty())
    throw std::runtime_error(std::string("give exactly one of --seconds N and --session DIR\n"
                                         "usage: mocapctl ") +
                             kBvhUsage);
  const std::string out_path = args.front();

  BvhClip clip;
  std::string source;
  if (!session_dir.empty()) {
    mocap::Expected<std::unique_ptr<mocap::SessionReader>> session =
        mocap::SessionReader::open(session_dir);
    if (!session.ok()) throw std::runtime_error(session.error());
    clip = truthClip(*session.value());
    source = "true poses of " + session_dir + ", " + std::to_string(clip.held_sets) +
             " set(s) without one held";
  } else {
    clip = streamedClip(flags, positiveNumber("--seconds", seconds_text));
    source = std::to_string(clip.held_sets) + " missed";
  }
  std::ofstream out(out_path);
  if (!out) throw std::runtime_error(out_path + ": cannot write");
  writeBvh(out, clip.skeleton, clip.frames, clip.frame_time_s, options);
  if (!out.flush()) throw std::runtime_error(out_path + ": write failed");
  progress("bvh: wrote " + std::to_string(clip.frames.size()) + " poses to " + out_path + " (" +
           source + ")\n");
  return 0;
}

}  // namespace mocapctl
