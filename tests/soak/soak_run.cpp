// The soak's schedule: the daemon started with faulty fake cameras, subscribers attached, one
// recording per cycle (stopped, or once SIGKILLed mid-way and the daemon restarted), memory and
// status sampled every 2 s, the daemon restarted if it ever ends by itself (counted as a crash).
#include "soak_run.h"

#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>

#include "daemon_process.h"
#include "mocap/v1/mocap.grpc.pb.h"
#include "pose_subscribers.h"
#include "recording_checks.h"
#include "soak_report.h"

namespace mocap::soak {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using json = nlohmann::json;

// The fake two-camera scene, each camera with faults of its own (drivers/fake/fake_driver.h):
// both lose 1 % of their frames; camera 0 stalls for 2 s every 45 s, camera 1 is disconnected for
// 3 s every 70 s.
std::string daemonConfig(const SoakOptions& options, const fs::path& recordings) {
  return "# mocap-soak's daemon: the fake scene with faulty cameras.\n"
         "cameras:\n"
         "  - {driver: fake, device: \"scene:0?drop_rate=0.01&stall=2@20/45\", width: 780, "
         "height: 580, fps: 25}\n"
         "  - {driver: fake, device: \"scene:1?drop_rate=0.01&disconnect=3@35/70\", width: 780, "
         "height: 580, fps: 25}\n"
         "tracker: {threads: 1}\n"
         "listen: 127.0.0.1:" +
         std::to_string(options.port) +
         "\n"
         "recording_directory: " +
         recordings.string() +
         "\n"
         "web: {enabled: false}\n"
         "log_level: info\n";
}

class Soak {
 public:
  explicit Soak(const SoakOptions& options)
      : options_(options),
        address_("127.0.0.1:" + std::to_string(options.port)),
        recordings_(fs::path(options.work) / "recordings"),
        daemon_(options.mocapd, (fs::path(options.work) / "mocapd.yaml").string(),
                (fs::path(options.work) / "mocapd.log").string()),
        subscribers_(address_, options.live, options.stalled, options.reconnecting),
        checker_(options.keep) {}
  ~Soak() { stopSampling(); }

  json run();

 private:
  double now() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  void event(const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    events_.push_back({{"t", now()}, {"event", what}});
  }
  std::unique_ptr<v1::MocapService::Stub> stub() const {
    return v1::MocapService::NewStub(grpc::CreateCustomChannel(
        address_, grpc::InsecureChannelCredentials(), quickReconnectArguments()));
  }
  // Starts the daemon and waits until it answers GetStatus (60 s at most).
  void startDaemon();
  // Sleeps until `until`, watching for the daemon ending by itself.
  void watchUntil(Clock::time_point until);
  void restartAfterCrash(const std::string& how);
  // StartRecording, retried while the daemon says it is not ready (a camera not yet seen).
  bool startRecording(const std::string& name);
  void recordCycle(int cycle, bool kill);
  // Hands the recording that just ended to the checker.
  void checkRecording(bool killed, uint64_t reported_sets) {
    RecordingCheck check;
    check.directory = *recording_;
    check.killed = killed;
    check.reported_sets = reported_sets;
    checker_.add(std::move(check));
    recording_.reset();
  }
  void sampleEvery2s();
  void stopSampling() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      sampling_ = false;
    }
    if (sampler_.joinable()) sampler_.join();
  }

  const SoakOptions options_;
  const std::string address_;
  const fs::path recordings_;
  DaemonProcess daemon_;
  PoseSubscribers subscribers_;
  RecordingChecker checker_;
  std::unique_ptr<v1::MocapService::Stub> control_;
  Clock::time_point start_;
  std::mutex mutex_;  // guards what the sampler and the schedule both write
  std::vector<Sample> samples_;
  std::vector<double> incarnation_starts_;
  json events_ = json::array();
  json crashes_ = json::array();
  int recordings_refused_ = 0;
  std::optional<fs::path> recording_;  // the recording under way
  bool sampling_ = true;
  std::thread sampler_;
};

void Soak::startDaemon() {
  daemon_.start();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    incarnation_starts_.push_back(now());
  }
  const Clock::time_point give_up = Clock::now() + std::chrono::seconds(60);
  while (Clock::now() < give_up) {
    if (const std::optional<std::string> ended = daemon_.endedBySelf())
      throw std::runtime_error("mocapd ended at start (" + *ended + "); see its log");
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(1));
    v1::Status status;
    if (control_->GetStatus(&context, {}, &status).ok()) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  throw std::runtime_error("mocapd did not answer within 60 s of its start");
}

void Soak::watchUntil(Clock::time_point until) {
  while (Clock::now() < until) {
    if (const std::optional<std::string> ended = daemon_.endedBySelf()) restartAfterCrash(*ended);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

void Soak::restartAfterCrash(const std::string& how) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    crashes_.push_back({{"t", now()}, {"how", how}});
  }
  event("mocapd ended by itself (" + how + "); restarting it");
  if (recording_) checkRecording(/*killed=*/true, 0);
  startDaemon();
  subscribers_.daemonRestarted();
}

bool Soak::startRecording(const std::string& name) {
  const Clock::time_point give_up = Clock::now() + std::chrono::seconds(5);
  for (;;) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
    v1::StartRecordingRequest request;
    request.set_path(name);
    v1::RecordingState state;
    const grpc::Status started = control_->StartRecording(&context, request, &state);
    if (started.ok()) {
      recording_ = recordings_ / name;
      return true;
    }
    if (started.error_code() != grpc::StatusCode::FAILED_PRECONDITION || Clock::now() > give_up) {
      ++recordings_refused_;
      event("StartRecording " + name + " refused: " + started.error_message());
      return false;
    }
    watchUntil(Clock::now() + std::chrono::milliseconds(100));
  }
}

void Soak::recordCycle(int cycle, bool kill) {
  char name[32];
  std::snprintf(name, sizeof name, "soak_%03d", cycle);
  if (!startRecording(name)) return;
  const Clock::time_point started = Clock::now();
  if (!kill) {
    watchUntil(started + std::chrono::seconds(options_.record_seconds));
    if (!recording_) return;  // the daemon crashed meanwhile
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
    v1::RecordingState state;
    const grpc::Status stopped = control_->StopRecording(&context, {}, &state);
    if (!stopped.ok()) event(std::string("StopRecording failed: ") + stopped.error_message());
    checkRecording(/*killed=*/false, state.frame_sets());
    return;
  }
  watchUntil(started + std::chrono::milliseconds(options_.record_seconds * 500));
  if (!recording_) return;
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  v1::Status status;
  control_->GetStatus(&context, {}, &status);
  daemon_.kill();
  event("SIGKILL mid-recording " + std::string(name) + " at " +
        std::to_string(status.recording().frame_sets()) + " frame sets");
  checkRecording(/*killed=*/true, status.recording().frame_sets());
  startDaemon();
  subscribers_.daemonRestarted();
  event("mocapd restarted");
}

void Soak::sampleEvery2s() {
  const std::unique_ptr<v1::MocapService::Stub> stub = this->stub();
  for (Clock::time_point next = Clock::now();; next += std::chrono::seconds(2)) {
    std::this_thread::sleep_until(next);
    Sample sample;
    sample.rss_kb = daemon_.residentKb();
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(1));
    v1::Status status;
    if (stub->GetStatus(&context, {}, &status).ok()) {
      sample.poses_published = status.poses_published();
      sample.subscribers = status.subscribers();
      sample.answered = true;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    if (!sampling_) return;
    sample.t = now();
    sample.incarnation = static_cast<int>(incarnation_starts_.size()) - 1;
    if (sample.rss_kb > 0) samples_.push_back(sample);
  }
}

json Soak::run() {
  fs::create_directories(recordings_);
  std::ofstream(fs::path(options_.work) / "mocapd.yaml") << daemonConfig(options_, recordings_);
  control_ = stub();
  start_ = Clock::now();
  startDaemon();
  subscribers_.start();
  checker_.start();
  sampler_ = std::thread([this] { sampleEvery2s(); });

  const int cycles = options_.seconds / options_.cycle_seconds;
  const int kill_cycle = cycles / 3;
  for (int cycle = 0; cycle < cycles; ++cycle) {
    watchUntil(start_ + std::chrono::seconds(cycle * options_.cycle_seconds));
    recordCycle(cycle, cycle == kill_cycle);
  }
  watchUntil(start_ + std::chrono::seconds(options_.seconds));

  subscribers_.stop();
  stopSampling();
  const std::string shutdown = daemon_.terminate(std::chrono::seconds(30));
  if (shutdown != "exit 0") crashes_.push_back({{"t", now()}, {"how", "shutdown: " + shutdown}});

  SoakFigures figures;
  figures.options = options_;
  figures.seconds = now();
  figures.samples = samples_;
  figures.incarnation_starts = incarnation_starts_;
  figures.live = subscribers_.each(SubscriberKind::kLive);
  figures.stalled = subscribers_.total(SubscriberKind::kStalled);
  figures.reconnecting = subscribers_.total(SubscriberKind::kReconnecting);
  figures.recordings = checker_.finish();
  figures.recordings_refused = recordings_refused_;
  figures.crashes = crashes_;
  figures.events = events_;
  figures.daemon_log = (fs::path(options_.work) / "mocapd.log").string();
  return soakReport(figures);
}

}  // namespace

json runSoak(const SoakOptions& options) {
  Soak soak(options);
  try {
    return soak.run();
  } catch (const std::exception& error) {
    return {{"pass", false}, {"error", error.what()}};
  }
}

}  // namespace mocap::soak
