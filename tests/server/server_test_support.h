// Shared by the server tests: a daemon configuration on the fake scene, a loopback client, a
// background capture request, a body fit request, and a pose reader that counts what it receives.
// For the end-to-end suites (their targets define MOCAP_PYTHON_STUBS and MOCAP_BIN_DIR), also: the
// daemon in-process, the clients as commands, recordings, replays and the walking person.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include <grpcpp/grpcpp.h>

#ifdef MOCAP_PYTHON_STUBS
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "drivers/builtin_drivers.h"
#include "server/mocap_server.h"
#endif

#include "mocap/v1/mocap.grpc.pb.h"
#include "server/config.h"

namespace mocap::test {

// How many times slower than a plain build the daemon runs here: MOCAP_TEST_SLOWDOWN (1 to 100,
// default 1), which deploy/test sets for sanitizer builds. The person's scene plays that much
// slower (scene_slow_motion; the hand's tracker keeps up) and the tests' waits for a tracker or a
// fit last that much longer, so a slow tracker still sees every frame set and the same assertions
// hold.
inline double testSlowdown() {
  const char* text = std::getenv("MOCAP_TEST_SLOWDOWN");
  const double slowdown = text ? std::atof(text) : 1.0;
  return std::clamp(slowdown, 1.0, 100.0);
}

// `wait` scaled by testSlowdown().
template <typename Duration>
std::chrono::milliseconds slowed(Duration wait) {
  return std::chrono::milliseconds(static_cast<int64_t>(
      std::chrono::duration<double, std::milli>(wait).count() * testSlowdown()));
}

// The embedded default (fake scene, 2 cameras, 780x580, 25 Hz) on a port the OS picks, without
// the web view (its own suite turns it on): the view subscribes to the poses, and the other
// suites count subscribers.
inline ServerConfig sceneConfig() {
  ServerConfig config = parseConfig(kDefaultConfigYaml, "<embedded default>", ".");
  config.listen = "127.0.0.1:0";
  config.web.enabled = false;
  config.log_level = LogLevel::kWarning;
  return config;
}

inline std::unique_ptr<v1::MocapService::Stub> connect(int port) {
  return v1::MocapService::NewStub(grpc::CreateChannel("127.0.0.1:" + std::to_string(port),
                                                       grpc::InsecureChannelCredentials()));
}

// Asks the daemon to learn the background from `frames` frames, waiting at most `deadline`
// (slowed()).
inline grpc::Status captureBackground(v1::MocapService::Stub& stub, uint32_t frames,
                                      v1::CaptureBackgroundResponse& response,
                                      std::chrono::seconds deadline = std::chrono::seconds(30)) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + slowed(deadline));
  v1::CaptureBackgroundRequest request;
  request.set_frames(frames);
  return stub.CaptureBackground(&context, request, &response);
}

// Asks the daemon to fit the body from `frame_sets` frame sets (and to track with it, with
// `apply`), waiting at most `deadline` (slowed()).
inline grpc::Status fitBody(v1::MocapService::Stub& stub, int frame_sets,
                            v1::FitBodyResponse& response, bool apply = false,
                            std::chrono::seconds deadline = std::chrono::seconds(60)) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + slowed(deadline));
  v1::FitBodyRequest request;
  request.set_frame_sets(frame_sets);
  request.set_apply(apply);
  return stub.FitBody(&context, request, &response);
}

// Reads a pose stream on its own thread, counting poses and the frame-set sequences they span.
class PoseCounter {
 public:
  PoseCounter(v1::MocapService::Stub& stub, const std::string& token = "") {
    if (!token.empty()) context_.AddMetadata("authorization", "Bearer " + token);
    reader_ = stub.StreamPoses(&context_, v1::StreamPosesRequest());
    thread_ = std::thread([this] {
      v1::Pose pose;
      while (reader_->Read(&pose)) {
        if (counting_) {
          if (received_ == 0) first_ = pose.frame_sequence();
          last_ = pose.frame_sequence();
          ++received_;
        }
      }
      status_ = reader_->Finish();
    });
  }
  ~PoseCounter() {
    context_.TryCancel();
    thread_.join();
  }
  void startCounting() { counting_ = true; }
  void stopCounting() { counting_ = false; }
  uint64_t received() const { return received_; }
  // Frame sets from the first to the last counted pose: what a perfect subscriber would get.
  uint64_t spanned() const { return received_ == 0 ? 0 : last_ - first_ + 1; }
  // Waits for the stream to end (daemon shutdown) and returns its status.
  grpc::Status finish() {
    thread_.join();
    thread_ = std::thread([] {});
    return status_;
  }

 private:
  grpc::ClientContext context_;
  std::unique_ptr<grpc::ClientReader<v1::Pose>> reader_;
  std::thread thread_;
  std::atomic<bool> counting_{false};
  std::atomic<uint64_t> received_{0};
  std::atomic<uint64_t> first_{0};
  std::atomic<uint64_t> last_{0};
  grpc::Status status_;
};

#ifdef MOCAP_PYTHON_STUBS

namespace fs = std::filesystem;

inline std::unique_ptr<MocapServer> startServer(const ServerConfig& config) {
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  EXPECT_TRUE(server.ok()) << server.error();
  if (!server.ok()) return nullptr;
  const Status started = server.value()->start();
  EXPECT_TRUE(started.ok()) << started.message();
  return std::move(server.value());
}

// What a command printed, stdout and stderr together.
inline std::string outputOf(const std::string& command) {
  std::string output;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return "popen failed";
  char buffer[4096];
  while (fgets(buffer, sizeof buffer, pipe)) output += buffer;
  pclose(pipe);
  return output;
}

inline std::string python(const std::string& args) {
  return outputOf("/usr/bin/python3 " MOCAP_SOURCE_DIR "/clients/python/mocap_client.py --stubs " +
                  std::string(MOCAP_PYTHON_STUBS) + " " + args);
}

inline std::string mocapctl(const std::string& args) {
  return outputOf(MOCAP_BIN_DIR "/mocapctl " + args);
}

inline fs::path freshDirectory(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("mocap_e2e_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

class EndToEndTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { registerBuiltinDrivers(DriverRegistry::instance()); }
};

inline grpc::StatusCode startRecording(v1::MocapService::Stub& stub, const std::string& path) {
  grpc::ClientContext context;
  v1::StartRecordingRequest request;
  request.set_path(path);
  v1::RecordingState state;
  return stub.StartRecording(&context, request, &state).error_code();
}

// Starts recording into `root`/`name`. A recording starts once every camera has sent a frame,
// and a first pose does not prove it (a set may lack a camera that is late, as under a loaded
// machine): the start is retried for up to 5 s (slowed()) while the daemon says so.
inline void startRecordingWhenReady(v1::MocapService::Stub& stub, const std::string& name) {
  grpc::StatusCode started = startRecording(stub, name);
  const auto give_up = std::chrono::steady_clock::now() + slowed(std::chrono::seconds(5));
  while (started == grpc::StatusCode::FAILED_PRECONDITION &&
         std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    started = startRecording(stub, name);
  }
  ASSERT_EQ(started, grpc::StatusCode::OK);
}

// Waits until the recording under way holds at least `sets` frame sets.
inline void waitForRecordedSets(v1::MocapService::Stub& stub, uint64_t sets) {
  for (;;) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    grpc::ClientContext context;
    v1::Status status;
    ASSERT_TRUE(stub.GetStatus(&context, {}, &status).ok());
    ASSERT_TRUE(status.recording().active());
    if (status.recording().frame_sets() >= sets) break;
  }
}

// Records at least `sets` frame sets into `root`/`name`.
inline void record(v1::MocapService::Stub& stub, const std::string& name, uint64_t sets) {
  ASSERT_NO_FATAL_FAILURE(startRecordingWhenReady(stub, name));
  ASSERT_NO_FATAL_FAILURE(waitForRecordedSets(stub, sets));
  grpc::ClientContext context;
  v1::RecordingState state;
  ASSERT_TRUE(stub.StopRecording(&context, {}, &state).ok());
  EXPECT_FALSE(state.active());
  EXPECT_GE(state.frame_sets(), sets);
}

// The poses a replay of `session` publishes, frame sequence and DOF vector (and, if asked, its
// status at the end, the poses' errors, the poses whole; every frame set's silhouettes go to
// `masks`). `recorded_silhouettes`: ServerConfig::recorded_silhouettes.
inline std::vector<std::pair<uint64_t, std::vector<double>>> replay(
    const fs::path& session, PipelineStatus* end_status = nullptr,
    Pipeline::MaskObserver masks = {}, std::vector<double>* reference_errors = nullptr,
    std::vector<Pose>* published = nullptr, bool recorded_silhouettes = false) {
  ServerConfig config = test::sceneConfig();
  config.replay_directory = session.string();
  config.as_fast_as_possible = true;
  config.recorded_silhouettes = recorded_silhouettes;
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  EXPECT_TRUE(server.ok()) << server.error();
  std::vector<std::pair<uint64_t, std::vector<double>>> poses;
  if (!server.ok()) return poses;
  server.value()->pipeline().setPoseObserver([&](const Pose& pose) {
    poses.emplace_back(pose.frame_sequence,
                       std::vector<double>(pose.dofs.data(), pose.dofs.data() + pose.dofs.size()));
    if (reference_errors && pose.reference_error_mm)
      reference_errors->push_back(*pose.reference_error_mm);
    if (published) published->push_back(pose);
  });
  if (masks) server.value()->pipeline().setMaskObserver(std::move(masks));
  EXPECT_TRUE(server.value()->start().ok());
  server.value()->pipeline().waitForReplayEnd();
  if (end_status) *end_status = server.value()->pipeline().status();
  server.value()->shutdown();
  return poses;
}

inline v1::Skeleton skeletonOf(v1::MocapService::Stub& stub) {
  v1::Skeleton skeleton;
  grpc::ClientContext context;
  EXPECT_TRUE(stub.GetSkeleton(&context, {}, &skeleton).ok());
  return skeleton;
}

// The fake scene playing the CMU walk, tracked with docs/human.md's options for people; in slow
// motion under a sanitizer (testSlowdown()).
inline ServerConfig walkingPersonConfig() {
  ServerConfig config = test::sceneConfig();
  config.scene_slow_motion = testSlowdown();
  config.body_model = "builtin:human";
  config.scene_motion = MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh";
  const int threads = config.tracker.threads;
  config.tracker = TrackerSettings::forPeople();
  config.tracker.threads = threads;
  return config;
}

// The first `count` poses of a new stream that `keep` accepts (all by default), fewer only if the
// stream ends.
inline std::vector<v1::Pose> readPoses(v1::MocapService::Stub& stub, std::size_t count,
                                       const std::function<bool(const v1::Pose&)>& keep = {}) {
  grpc::ClientContext context;
  auto reader = stub.StreamPoses(&context, v1::StreamPosesRequest());
  std::vector<v1::Pose> poses;
  v1::Pose pose;
  while (poses.size() < count && reader->Read(&pose))
    if (!keep || keep(pose)) poses.push_back(pose);
  context.TryCancel();
  return poses;
}

// The median over the poses of `value` (error, fit, ...).
inline double median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values.empty() ? std::nan("") : values[values.size() / 2];
}

inline double median(const std::vector<v1::Pose>& poses, double (v1::Pose::*value)() const) {
  std::vector<double> values;
  for (const v1::Pose& pose : poses) values.push_back((pose.*value)());
  return median(std::move(values));
}

#endif  // MOCAP_PYTHON_STUBS

}  // namespace mocap::test
