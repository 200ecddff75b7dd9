// End to end on loopback, with the daemon in-process on the fake scene (2 cameras, 780x580,
// 25 Hz): C++ and Python subscribers keep up with the frame rate while another subscriber never
// reads; health; the bearer token; TLS; recording paths; replay determinism; background capture.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "drivers/builtin_drivers.h"
#include "drivers/record/session_reader.h"
#include "server/mocap_server.h"
#include "server/server_test_support.h"
#include "server/tls_test_support.h"
#include "tracker/search/body_size.h"
#include "tracker/model/builtin_models.h"
#include "tracker/motion/bvh.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/retarget.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;

// Window of the rate test: 10 s at 25 Hz is 250 frame sets.
constexpr int kWindowSeconds = 10;
constexpr int kWindowFrames = kWindowSeconds * 25;

std::unique_ptr<MocapServer> startServer(const ServerConfig& config) {
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  EXPECT_TRUE(server.ok()) << server.error();
  if (!server.ok()) return nullptr;
  const Status started = server.value()->start();
  EXPECT_TRUE(started.ok()) << started.message();
  return std::move(server.value());
}

// What a command printed, stdout and stderr together.
std::string outputOf(const std::string& command) {
  std::string output;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return "popen failed";
  char buffer[4096];
  while (fgets(buffer, sizeof buffer, pipe)) output += buffer;
  pclose(pipe);
  return output;
}

std::string python(const std::string& args) {
  return outputOf("/usr/bin/python3 " MOCAP_SOURCE_DIR "/clients/python/mocap_client.py --stubs " +
                  std::string(MOCAP_PYTHON_STUBS) + " " + args);
}

std::string mocapctl(const std::string& args) {
  return outputOf(MOCAP_BIN_DIR "/mocapctl " + args);
}

fs::path freshDirectory(const std::string& name) {
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

TEST_F(EndToEndTest, SubscribersKeepUpWhileOneNeverReads) {
  std::unique_ptr<MocapServer> server = startServer(test::sceneConfig());
  ASSERT_TRUE(server);
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  EXPECT_EQ(python("health --server " + address), "SERVING\n");

  auto stub = test::connect(server->port());
  // A subscriber that opens the stream and never reads a pose.
  grpc::ClientContext stalled_context;
  std::unique_ptr<grpc::ClientReader<v1::Pose>> stalled =
      stub->StreamPoses(&stalled_context, v1::StreamPosesRequest());
  test::PoseCounter cpp_client(*stub);
  // Let the tracker settle in before the window opens.
  std::this_thread::sleep_for(std::chrono::seconds(2));

  std::string python_output;
  std::thread python_client([&] {
    python_output =
        python("stream --server " + address + " --count " + std::to_string(kWindowFrames));
  });
  cpp_client.startCounting();
  std::this_thread::sleep_for(std::chrono::seconds(kWindowSeconds));
  cpp_client.stopCounting();
  python_client.join();

  // C++: at least 95 % of the frame sets of the window, and of the nominal 25 Hz.
  EXPECT_GE(cpp_client.received(), 0.95 * static_cast<double>(cpp_client.spanned()));
  EXPECT_GE(static_cast<double>(cpp_client.received()), 0.95 * kWindowFrames);

  std::vector<uint64_t> frames;
  std::istringstream lines(python_output);
  for (std::string line; std::getline(lines, line);) {
    const nlohmann::json pose = nlohmann::json::parse(line, nullptr, false);
    ASSERT_FALSE(pose.is_discarded()) << "not JSON: " << line;
    frames.push_back(pose["frame"].get<uint64_t>());
  }
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(kWindowFrames)) << python_output;
  EXPECT_GE(static_cast<double>(frames.size()),
            0.95 * static_cast<double>(frames.back() - frames.front() + 1));

  v1::Status status;
  grpc::ClientContext status_context;
  ASSERT_TRUE(stub->GetStatus(&status_context, {}, &status).ok());
  EXPECT_EQ(status.subscribers(), 2u);  // the stalled one and the C++ one
  EXPECT_EQ(status.cameras_size(), 2);
  EXPECT_EQ(status.cameras(0).state(), v1::CAMERA_STATE_STREAMING);
  EXPECT_GT(status.cameras(0).measured_fps(), 20.0);
  EXPECT_GT(status.latency().samples(), 0u);

  stalled_context.TryCancel();
  server->shutdown();
  EXPECT_TRUE(cpp_client.finish().ok());
}

TEST_F(EndToEndTest, SkeletonDescribesEveryDofAndPoint) {
  std::unique_ptr<MocapServer> server = startServer(test::sceneConfig());
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  v1::Skeleton skeleton;
  grpc::ClientContext context;
  ASSERT_TRUE(stub->GetSkeleton(&context, {}, &skeleton).ok());
  EXPECT_EQ(skeleton.segments_size(), static_cast<int>(server->model().segments.size()));
  EXPECT_EQ(skeleton.dofs_size(), static_cast<int>(server->model().dofs.size()));
  EXPECT_EQ(skeleton.points_size(), static_cast<int>(server->model().points.size()));
  EXPECT_EQ(skeleton.segments(0).parent(), -1);

  grpc::ClientContext stream_context;
  v1::StreamPosesRequest request;
  request.add_joints(skeleton.points(0).name());
  auto reader = stub->StreamPoses(&stream_context, request);
  v1::Pose pose;
  ASSERT_TRUE(reader->Read(&pose));
  ASSERT_EQ(pose.joints_size(), 1);
  EXPECT_EQ(pose.joints(0).name(), skeleton.points(0).name());
  EXPECT_EQ(pose.dofs_size(), skeleton.dofs_size());
  EXPECT_EQ(pose.segment_orientations_size(), skeleton.segments_size());
  EXPECT_GE(pose.publish_monotonic_ns(), pose.capture_monotonic_ns());
  stream_context.TryCancel();

  grpc::ClientContext bad_context;
  v1::StreamPosesRequest bad;
  bad.add_joints("no_such_joint");
  auto refused = stub->StreamPoses(&bad_context, bad);
  EXPECT_FALSE(refused->Read(&pose));
  EXPECT_EQ(refused->Finish().error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

TEST_F(EndToEndTest, TokenIsRequiredOnEveryCall) {
  ServerConfig config = test::sceneConfig();
  config.bearer_token = "0123456789abcdef-secret";
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  v1::Status status;
  {
    grpc::ClientContext context;
    EXPECT_EQ(stub->GetStatus(&context, {}, &status).error_code(),
              grpc::StatusCode::UNAUTHENTICATED);
  }
  {
    grpc::ClientContext context;
    context.AddMetadata("authorization", "Bearer 0123456789abcdef-wrong!");
    EXPECT_EQ(stub->GetStatus(&context, {}, &status).error_code(),
              grpc::StatusCode::UNAUTHENTICATED);
  }
  {
    grpc::ClientContext context;
    context.AddMetadata("authorization", "Bearer " + config.bearer_token);
    EXPECT_TRUE(stub->GetStatus(&context, {}, &status).ok());
  }
  {
    grpc::ClientContext context;
    auto reader = stub->StreamPoses(&context, {});
    v1::Pose pose;
    EXPECT_FALSE(reader->Read(&pose));
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::UNAUTHENTICATED);
  }
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  EXPECT_THAT(python("status --server " + address), ::testing::HasSubstr("UNAUTHENTICATED"));
  EXPECT_THAT(python("status --server " + address + " --token " + config.bearer_token),
              ::testing::HasSubstr("\"mode\": \"live\""));
}

std::string fileText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The status code of a GetStatus call over `channel` (10 s deadline): UNAVAILABLE when the
// handshake is refused.
grpc::StatusCode statusCodeOver(const std::shared_ptr<grpc::Channel>& channel) {
  auto stub = v1::MocapService::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
  v1::Status status;
  return stub->GetStatus(&context, {}, &status).error_code();
}

// With a certificate and key configured, the daemon serves TLS only: clients that trust the
// certificate (C++, mocapctl, Python) get status and poses; a plain-text client, or one trusting
// another certificate, is refused rather than served in the clear.
TEST_F(EndToEndTest, ServesTlsToClientsThatTrustItsCertificateOnly) {
  const fs::path dir = freshDirectory("tls");
  const test::TlsFiles daemon = test::writeSelfSignedCertificate(dir, "daemon");
  const test::TlsFiles stranger = test::writeSelfSignedCertificate(dir, "stranger");
  ServerConfig config = test::sceneConfig();
  config.tls_cert_file = daemon.cert;
  config.tls_key_file = daemon.key;
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  auto channel = [&](const test::TlsFiles* trusted) {
    if (!trusted) return grpc::CreateChannel(address, grpc::InsecureChannelCredentials());
    grpc::SslCredentialsOptions tls;
    tls.pem_root_certs = fileText(trusted->cert);
    return grpc::CreateChannel(address, grpc::SslCredentials(tls));
  };
  auto statusCode = [&](const test::TlsFiles* trusted) { return statusCodeOver(channel(trusted)); };
  EXPECT_EQ(statusCode(&daemon), grpc::StatusCode::OK);
  EXPECT_EQ(statusCode(nullptr), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(statusCode(&stranger), grpc::StatusCode::UNAVAILABLE);

  auto stub = v1::MocapService::NewStub(channel(&daemon));
  grpc::ClientContext stream_context;
  auto reader = stub->StreamPoses(&stream_context, v1::StreamPosesRequest());
  v1::Pose pose;
  EXPECT_TRUE(reader->Read(&pose));
  EXPECT_GT(pose.dofs_size(), 0);
  stream_context.TryCancel();

  EXPECT_THAT(mocapctl("status --server " + address + " --tls-ca " + daemon.cert),
              ::testing::HasSubstr("\"mode\": \"live\""));
  EXPECT_THAT(mocapctl("status --server " + address), ::testing::HasSubstr("UNAVAILABLE"));
  EXPECT_THAT(python("status --server " + address + " --tls-ca " + daemon.cert),
              ::testing::HasSubstr("\"mode\": \"live\""));
  EXPECT_THAT(python("status --server " + address + " --tls-ca " + stranger.cert),
              ::testing::HasSubstr("UNAVAILABLE"));
  fs::remove_all(dir);
}

// With tls.client_ca the daemon asks every client for a certificate that authority signed: a
// client presenting one (C++, mocapctl, Python) is served; one presenting none, or another, is
// refused in the handshake.
TEST_F(EndToEndTest, AsksClientsForACertificateWhenTheConfigurationNamesTheirAuthority) {
  const fs::path dir = freshDirectory("mtls");
  const test::TlsFiles daemon = test::writeSelfSignedCertificate(dir, "daemon");
  // Self-signed, so each is its own authority: the daemon trusts "client" and not "stranger".
  const test::TlsFiles client = test::writeSelfSignedCertificate(dir, "client");
  const test::TlsFiles stranger = test::writeSelfSignedCertificate(dir, "stranger");
  ServerConfig config = test::sceneConfig();
  config.tls_cert_file = daemon.cert;
  config.tls_key_file = daemon.key;
  config.tls_client_ca_file = client.cert;
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  auto statusCode = [&](const test::TlsFiles* presented) {
    grpc::SslCredentialsOptions tls;
    tls.pem_root_certs = fileText(daemon.cert);
    if (presented) {
      tls.pem_cert_chain = fileText(presented->cert);
      tls.pem_private_key = fileText(presented->key);
    }
    return statusCodeOver(grpc::CreateChannel(address, grpc::SslCredentials(tls)));
  };
  EXPECT_EQ(statusCode(&client), grpc::StatusCode::OK);
  EXPECT_EQ(statusCode(nullptr), grpc::StatusCode::UNAVAILABLE);
  EXPECT_EQ(statusCode(&stranger), grpc::StatusCode::UNAVAILABLE);

  const std::string trusted = " --server " + address + " --tls-ca " + daemon.cert;
  EXPECT_THAT(
      mocapctl("status" + trusted + " --tls-cert " + client.cert + " --tls-key " + client.key),
      ::testing::HasSubstr("\"mode\": \"live\""));
  EXPECT_THAT(mocapctl("status" + trusted), ::testing::HasSubstr("UNAVAILABLE"));
  EXPECT_THAT(mocapctl("status" + trusted + " --tls-cert " + client.cert),
              ::testing::HasSubstr("--tls-cert and --tls-key go together"));
  EXPECT_THAT(
      python("status" + trusted + " --tls-cert " + client.cert + " --tls-key " + client.key),
      ::testing::HasSubstr("\"mode\": \"live\""));
  EXPECT_THAT(
      python("status" + trusted + " --tls-cert " + stranger.cert + " --tls-key " + stranger.key),
      ::testing::HasSubstr("UNAVAILABLE"));
  fs::remove_all(dir);
}

grpc::StatusCode startRecording(v1::MocapService::Stub& stub, const std::string& path) {
  grpc::ClientContext context;
  v1::StartRecordingRequest request;
  request.set_path(path);
  v1::RecordingState state;
  return stub.StartRecording(&context, request, &state).error_code();
}

// Starts recording into `root`/`name`. A recording starts once every camera has sent a frame,
// and a first pose does not prove it (a set may lack a camera that is late, as under a loaded
// machine): the start is retried for up to 5 s while the daemon says so.
void startRecordingWhenReady(v1::MocapService::Stub& stub, const std::string& name) {
  grpc::StatusCode started = startRecording(stub, name);
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (started == grpc::StatusCode::FAILED_PRECONDITION &&
         std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    started = startRecording(stub, name);
  }
  ASSERT_EQ(started, grpc::StatusCode::OK);
}

// Waits until the recording under way holds at least `sets` frame sets.
void waitForRecordedSets(v1::MocapService::Stub& stub, uint64_t sets) {
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
void record(v1::MocapService::Stub& stub, const std::string& name, uint64_t sets) {
  ASSERT_NO_FATAL_FAILURE(startRecordingWhenReady(stub, name));
  ASSERT_NO_FATAL_FAILURE(waitForRecordedSets(stub, sets));
  grpc::ClientContext context;
  v1::RecordingState state;
  ASSERT_TRUE(stub.StopRecording(&context, {}, &state).ok());
  EXPECT_FALSE(state.active());
  EXPECT_GE(state.frame_sets(), sets);
}

TEST_F(EndToEndTest, RecordingStaysInsideItsDirectory) {
  const fs::path root = freshDirectory("paths");
  const fs::path outside = freshDirectory("outside");
  fs::create_directory_symlink(outside, root / "link_out");
  ServerConfig config = test::sceneConfig();
  config.recording_directory = fs::canonical(root).string();
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // first frames in

  EXPECT_EQ(startRecording(*stub, "../escape"), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(startRecording(*stub, "a/../../escape"), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(startRecording(*stub, "/tmp/escape"), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(startRecording(*stub, "link_out/take"), grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_TRUE(fs::is_empty(outside));
  record(*stub, "day1/take1", 10);
  EXPECT_TRUE(fs::exists(root / "day1" / "take1" / "sets.csv"));
  grpc::ClientContext context;
  v1::RecordingState state;
  EXPECT_EQ(stub->StopRecording(&context, {}, &state).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  server->shutdown();
  fs::remove_all(root);
  fs::remove_all(outside);
}

TEST_F(EndToEndTest, CaptureBackgroundLearnsWhilePosesFlow) {
  std::unique_ptr<MocapServer> server = startServer(test::sceneConfig());
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  test::PoseCounter poses(*stub);
  {
    v1::CaptureBackgroundResponse response;
    const grpc::Status status =
        test::captureBackground(*stub, 10, response, std::chrono::seconds(10));
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(response.frames_used(), 10u);
  }
  {
    v1::CaptureBackgroundResponse response;
    const grpc::Status status = test::captureBackground(*stub, 1'000'000, response);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_THAT(status.error_message(), ::testing::HasSubstr("frames"));
  }
  // The fake scene keeps its ground-truth silhouettes: tracking goes on after the capture.
  poses.startCounting();
  std::this_thread::sleep_for(std::chrono::seconds(1));
  poses.stopCounting();
  EXPECT_GE(poses.received(), 15u);
  grpc::ClientContext context;
  v1::Status status;
  ASSERT_TRUE(stub->GetStatus(&context, {}, &status).ok());
  EXPECT_EQ(status.cameras(0).state(), v1::CAMERA_STATE_STREAMING);
  EXPECT_GT(status.poses_published(), 0u);
  server->shutdown();
}

// The poses a replay of `session` publishes, frame sequence and DOF vector (and, if asked, its
// status at the end, the poses' errors, the poses whole; every frame set's silhouettes go to
// `masks`).
std::vector<std::pair<uint64_t, std::vector<double>>> replay(
    const fs::path& session, PipelineStatus* end_status = nullptr,
    Pipeline::MaskObserver masks = {}, std::vector<double>* reference_errors = nullptr,
    std::vector<Pose>* published = nullptr) {
  ServerConfig config = test::sceneConfig();
  config.replay_directory = session.string();
  config.as_fast_as_possible = true;
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

v1::Skeleton skeletonOf(v1::MocapService::Stub& stub) {
  v1::Skeleton skeleton;
  grpc::ClientContext context;
  EXPECT_TRUE(stub.GetSkeleton(&context, {}, &skeleton).ok());
  return skeleton;
}

// The fake scene playing the CMU walk, tracked with docs/human.md's options for people.
ServerConfig walkingPersonConfig() {
  ServerConfig config = test::sceneConfig();
  config.body_model = "builtin:human";
  config.scene_motion = MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh";
  const int threads = config.tracker.threads;
  config.tracker = TrackerSettings::forPeople();
  config.tracker.threads = threads;
  return config;
}

// The first `count` poses of a new stream that `keep` accepts (all by default), fewer only if the
// stream ends.
std::vector<v1::Pose> readPoses(v1::MocapService::Stub& stub, std::size_t count,
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
double median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values.empty() ? std::nan("") : values[values.size() / 2];
}

double median(const std::vector<v1::Pose>& poses, double (v1::Pose::*value)() const) {
  std::vector<double> values;
  for (const v1::Pose& pose : poses) values.push_back((pose.*value)());
  return median(std::move(values));
}

TEST_F(EndToEndTest, TracksAPersonWalkingInTheFakeScene) {
  const ServerConfig config = walkingPersonConfig();
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const v1::Skeleton skeleton = skeletonOf(*stub);
  EXPECT_EQ(skeleton.dofs_size(), 31);
  EXPECT_EQ(skeleton.points_size(), 19);

  const std::vector<v1::Pose> poses = readPoses(*stub, 50);
  ASSERT_EQ(poses.size(), 50u);
  for (const v1::Pose& pose : poses) ASSERT_TRUE(pose.has_reference_error_mm());
  // The person is tracked: the median joint is within 50 mm of the truth over the first 2 s (the
  // experiment's 200-frame walk measures 33 mm; a lost body is 100 mm and more).
  EXPECT_LT(median(poses, &v1::Pose::reference_error_mm), 50.0);

  // The status names the tracker settings in use: the people defaults here.
  grpc::ClientContext status_context;
  v1::Status status;
  ASSERT_TRUE(stub->GetStatus(&status_context, {}, &status).ok());
  const auto& settings = status.tracker_settings();
  const auto setting = [&](const std::string& key) {
    const auto found = settings.find(key);
    return found == settings.end() ? std::string("<missing>") : found->second;
  };
  EXPECT_EQ(setting("evaluations"), std::to_string(config.tracker.evaluations));
  EXPECT_EQ(setting("lookahead"), "body");
  EXPECT_EQ(setting("refine_plant"), "true");
  EXPECT_EQ(setting("threads"), std::to_string(config.tracker.threads));
}

// As on real cameras, the tracker is not told where the person starts: it finds them in the
// first frame sets' silhouettes, then tracks them.
TEST_F(EndToEndTest, FindsAndTracksAPersonItIsNotToldTheStartOf) {
  ServerConfig config = walkingPersonConfig();
  config.tracker.start = "acquire";
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const std::vector<v1::Pose> poses = readPoses(*stub, 50);
  ASSERT_EQ(poses.size(), 50u);
  // Both measures below are medians over the first 2 s, as from the true pose, not over the last
  // second alone: this walk's frames 28-35 and 45-50 lose the heading for a while even from the
  // true pose (50-130 mm in the experiment).
  // Every pose says how well it explains the silhouettes; tracked, the fake scene's are well
  // explained (its true poses score about 0.97).
  for (const v1::Pose& pose : poses) ASSERT_TRUE(pose.has_silhouette_fit());
  EXPECT_GT(median(poses, &v1::Pose::silhouette_fit), 0.85);
  // The neutral stance at the origin, where it would start otherwise, is metres off. Found, the
  // person is tracked as from the true pose: the median joint within 50 mm.
  EXPECT_LT(median(poses, &v1::Pose::reference_error_mm), 50.0);
  grpc::ClientContext status_context;
  v1::Status status;
  ASSERT_TRUE(stub->GetStatus(&status_context, {}, &status).ok());
  EXPECT_TRUE(status.tracking());
  EXPECT_EQ(status.acquisitions(), 1u);
  EXPECT_EQ(status.losses(), 0u);
  EXPECT_EQ(status.search_failure(), "");
  EXPECT_EQ(status.tracker_settings().at("start"), "acquire");
  const std::string python_poses =
      python("stream --count 1 --server 127.0.0.1:" + std::to_string(server->port()));
  EXPECT_THAT(python_poses, ::testing::HasSubstr("\"silhouette_fit\": 0."));
}

// A session as on real cameras: the room is empty at first, the background is captured then
// (the Python client's background, then mocapctl's), the person walks in, and the tracker finds and
// tracks them on the silhouettes extracted from the cameras' images, not the scene's true ones.
TEST_F(EndToEndTest, TracksAPersonOnExtractedSilhouettesAfterTheEmptyRoomIsLearnt) {
  ServerConfig config = walkingPersonConfig();
  config.scene_empty_seconds = 3;
  config.true_silhouettes = false;
  config.tracker.start = "acquire";
  constexpr uint64_t kEntranceFrame = 75;  // 3 s at 25 Hz
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  EXPECT_EQ(python("background --frames 5 --server " + address),
            "{\"frames_used\": 5, \"warnings\": []}\n");
  const std::string learnt = mocapctl("background --frames 20 --server " + address);
  EXPECT_THAT(learnt, ::testing::HasSubstr("\"frames_used\": 20")) << learnt;
  EXPECT_THAT(learnt, ::testing::HasSubstr("\"silhouettes\": \"background captured\""));
  EXPECT_THAT(learnt, ::testing::HasSubstr("\"warnings\": []"));  // the room was empty

  auto stub = test::connect(server->port());
  const std::vector<v1::Pose> poses = readPoses(*stub, 50, [&](const v1::Pose& pose) {
    // Before the person is in view there is no truth to compare with.
    EXPECT_EQ(pose.has_reference_error_mm(), pose.frame_sequence() >= kEntranceFrame)
        << pose.frame_sequence();
    return pose.frame_sequence() >= kEntranceFrame;
  });
  ASSERT_EQ(poses.size(), 50u);
  // Tracked as on the true silhouettes, where the extraction failing gives 1.4 m (thresholded
  // images, no background). The median joint over the first 2 s: 18.8-45.3 mm in ten runs here,
  // 54.7 once in CI and 50.6 once under ctest -j2 (the walk's kneel, in the first 4 s, is lost in
  // some runs whatever the silhouettes, and a loaded machine skips frame sets). Bounded at 75 mm,
  // above that spread and far below a failed extraction; the accuracy itself is measured by the
  // benches in docs/service.md.
  const double error = median(poses, &v1::Pose::reference_error_mm);
  std::printf("extracted silhouettes: median error %.1f mm over the first 50 poses\n", error);
  EXPECT_LT(error, 75.0);
  grpc::ClientContext status_context;
  v1::Status status;
  ASSERT_TRUE(stub->GetStatus(&status_context, {}, &status).ok());
  EXPECT_TRUE(status.tracking());
  for (const v1::CameraStatus& camera : status.cameras())
    EXPECT_EQ(camera.silhouettes(), "background captured");
}

// A background learnt while someone walks through holds them: it is installed (the operator
// decides), and the answer says, per camera, how much of the image changed during the capture and
// how much differs from the background it replaces (what a person standing still would show).
TEST_F(EndToEndTest, ABackgroundCapturedWithSomeoneMovingInViewIsReported) {
  std::unique_ptr<MocapServer> server = startServer(walkingPersonConfig());
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  v1::CaptureBackgroundResponse response;
  const grpc::Status status = test::captureBackground(*stub, 25, response);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(response.frames_used(), 25u);
  // Per camera: it moved during the capture, and it is not in the background replaced (the
  // scene's empty room, which the true silhouettes' session keeps for its recordings).
  ASSERT_EQ(response.warnings_size(), 4);
  for (int c = 0; c < 2; ++c) {
    const std::string camera =
        "camera " + std::to_string(c) + " (scene:" + std::to_string(c) + "): ";
    EXPECT_THAT(response.warnings(c), ::testing::HasSubstr(camera));
    EXPECT_THAT(response.warnings(c),
                ::testing::HasSubstr(" % of the image changed during the capture"));
    EXPECT_THAT(response.warnings(2 + c), ::testing::HasSubstr(camera));
    EXPECT_THAT(response.warnings(2 + c),
                ::testing::HasSubstr(" % of the image differs from the background it replaces"));
  }
}

// A client that sees the poses have gone wrong asks the tracker to find the person again; the
// hand, whose palm is fixed, cannot be found that way, and the daemon says so.
TEST_F(EndToEndTest, ReacquireFindsThePersonAgainOrSaysWhyNot) {
  {
    std::unique_ptr<MocapServer> server = startServer(walkingPersonConfig());
    ASSERT_TRUE(server);
    auto stub = test::connect(server->port());
    auto acquisitions = [&] {
      grpc::ClientContext context;
      v1::Status status;
      EXPECT_TRUE(stub->GetStatus(&context, {}, &status).ok());
      return status.acquisitions();
    };
    EXPECT_EQ(acquisitions(), 0u);  // started from the scene's true first pose
    grpc::ClientContext context;
    v1::ReacquireResponse response;
    ASSERT_TRUE(stub->Reacquire(&context, {}, &response).ok());
    // Found within the next frame sets (a generous limit, not a timing assertion).
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (acquisitions() == 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_EQ(acquisitions(), 1u);
  }
  std::unique_ptr<MocapServer> hand = startServer(test::sceneConfig());
  ASSERT_TRUE(hand);
  auto stub = test::connect(hand->port());
  grpc::ClientContext context;
  v1::ReacquireResponse response;
  const grpc::Status refused = stub->Reacquire(&context, {}, &response);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("'hand' has no free root"));
  EXPECT_THAT(python("reacquire --server 127.0.0.1:" + std::to_string(hand->port())),
              ::testing::HasSubstr("FAILED_PRECONDITION: the body model 'hand'"));
  // Nor can it be told to start that way.
  ServerConfig acquire_hand = test::sceneConfig();
  acquire_hand.tracker.start = "acquire";
  const Expected<std::unique_ptr<MocapServer>> refused_start = MocapServer::create(acquire_hand);
  ASSERT_FALSE(refused_start.ok());
  EXPECT_THAT(refused_start.error(),
              ::testing::HasSubstr("tracker.start: acquire, but the body model 'hand'"));
}

// `body`'s build against the built-in human's: the summed rest lengths of `bones` (names of
// modelBoneLengths, tracker/motion/retarget.h) over the built-in human's.
double boneRatio(const BodyModel& body, const std::vector<std::string>& bones) {
  const auto total = [&](const std::vector<BoneLength>& lengths) {
    double sum = 0;
    for (const BoneLength& bone : lengths)
      for (const std::string& name : bones)
        if (bone.name == name) sum += bone.length;
    return sum;
  };
  return total(modelBoneLengths(body)) / total(modelBoneLengths(builtinHumanModel()));
}

// As a user with real cameras would: the daemon tracks the shipped human (1.75 m), the person
// (the walk's subject, much smaller) first stands in the body's fit pose, and FitBody fits the
// body to them; its answer is a body model file whose legs and arms are the subject's. One fit at
// a time; the clients print it; a fit the daemon stops during ends with UNAVAILABLE.
TEST_F(EndToEndTest, FitsTheBodyToThePersonStandingInTheFitPose) {
  ServerConfig config = walkingPersonConfig();
  config.track_subject_body = false;
  // Covers the fits below with room to spare (about 6 s here); the walk starts after.
  config.scene_fit_pose_seconds = 30;
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const BodyModel human = builtinHumanModel();
  // The tracker tracks the configured body as given, not the subject's.
  const v1::Skeleton skeleton = skeletonOf(*stub);
  ASSERT_EQ(skeleton.segments_size(), static_cast<int>(human.segments.size()));
  EXPECT_DOUBLE_EQ(skeleton.segments(0).rest_offset().z(), human.segments[0].offset.z());

  // Two at once (the default number of frame sets, 5): one fits, the other is told a fit is under
  // way.
  v1::FitBodyResponse first, second;
  grpc::Status first_status, second_status;
  std::thread other([&] { second_status = test::fitBody(*stub, 0, second); });
  first_status = test::fitBody(*stub, 0, first);
  other.join();
  ASSERT_NE(first_status.ok(), second_status.ok())
      << first_status.error_message() << " / " << second_status.error_message();
  const v1::FitBodyResponse& fitted = first_status.ok() ? first : second;
  const grpc::Status& refused = first_status.ok() ? second_status : first_status;
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("a body fit is already under way"));

  EXPECT_EQ(fitted.frame_sets_used(), 5u);
  ASSERT_EQ(fitted.proportions_size(), BodyProportions::kCount);
  for (int k = 0; k < BodyProportions::kCount; ++k)
    EXPECT_EQ(fitted.proportions(k).name(), BodyProportions::name(k));
  // The body the scene shows: the built-in human fitted to the walk's subject.
  const BodyModel subject =
      fitModelToBvh(human, loadBvh(MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh").skeleton);
  const BodyModel file = parseBodyModel(fitted.body_model_yaml(), "fitted.yaml");
  const std::vector<std::string> legs = {"l_thigh", "l_shin", "r_thigh", "r_shin"};
  const std::vector<std::string> arms = {"l_upper_arm", "l_forearm", "l_hand",
                                         "r_upper_arm", "r_forearm", "r_hand"};
  // For the record (docs/service.md): the factors, and the fitted body's bones against the
  // built-in human's, the subject's in brackets.
  std::printf("fitted from %u frame sets in %.2f s, scale %.3f; factors:", fitted.frame_sets_used(),
              fitted.fit_seconds(), fitted.scale());
  for (const v1::BodyProportion& proportion : fitted.proportions())
    std::printf(" %s %.3f", proportion.name().c_str(), proportion.factor());
  std::printf("\nbones against the built-in human's, fitted (subject):");
  for (const auto& [what, bones] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"legs", legs},
           {"feet", {"l_foot", "r_foot"}},
           {"arms", arms},
           {"pelvis_neck", {"pelvis_neck"}},
           {"neck_head_top", {"neck_head_top"}},
           {"hip_width", {"hip_width"}},
           {"shoulder_width", {"shoulder_width"}}})
    std::printf(" %s %.3f (%.3f)", what.c_str(), boneRatio(file, bones), boneRatio(subject, bones));
  std::printf("\n");
  // The sets fall on whatever headings the turning subject shows when they are taken, so the
  // factors vary from run to run (the experiment's fits: legs 0.875-0.95, arms 0.71-0.76 against
  // the subject's 0.943 and 0.725). The arms tell the bodies apart: the fitted ones are the
  // subject's within 6 % of the built-in human's, which is 27.5 % off. The legs are shorter than
  // the built-in human's by more than 3 % (the subject's by 5.7 %).
  constexpr double kArmTolerance = 0.06;
  ASSERT_GT(1 - boneRatio(subject, arms), 4 * kArmTolerance);
  EXPECT_NEAR(boneRatio(file, arms), boneRatio(subject, arms), kArmTolerance);
  EXPECT_LT(boneRatio(file, legs), 0.97);
  EXPECT_LT(fitted.scale(), 0.95);
  EXPECT_GT(fitted.evaluations(), 0);
  EXPECT_GT(fitted.fit_seconds(), 0);

  // The answer is a body model file: configured as body_model (rescaled to the cameras' 25 Hz, as
  // the daemon does) it is the body the daemon tracks with those proportions, speeds included.
  EXPECT_EQ(file.frame_rate, 25);
  EXPECT_TRUE(file.person);
  ASSERT_TRUE(file.fit_pose);
  BodyProportions proportions;
  for (int k = 0; k < BodyProportions::kCount; ++k) proportions[k] = fitted.proportions(k).factor();
  const BodyModel expected = proportionedBodyModel(server->model(), proportions);
  const BodyModel loaded = atFrameRate(file, config.cameras.front().fps);
  ASSERT_EQ(loaded.dofs.size(), expected.dofs.size());
  for (std::size_t d = 0; d < loaded.dofs.size(); ++d)
    EXPECT_NEAR(loaded.dofs[d].max_speed, expected.dofs[d].max_speed, 1e-12) << loaded.dofs[d].name;
  ASSERT_EQ(loaded.segments.size(), expected.segments.size());
  for (std::size_t s = 0; s < loaded.segments.size(); ++s)
    EXPECT_LT((loaded.segments[s].offset - expected.segments[s].offset).norm(), 1e-9)
        << loaded.segments[s].name;
  // Smaller than the body it was fitted from: the pelvis stands lower.
  EXPECT_LT(loaded.segments[0].offset.z(), human.segments[0].offset.z() - 0.05);

  // mocapctl writes the file (atomically: no temporary left) and prints the figures; Python prints
  // the file with the figures as comments.
  const fs::path dir = freshDirectory("fit_body");
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  const std::string printed = mocapctl("fit-body --frames 1 --out " +
                                       (dir / "subject.yaml").string() + " --server " + address);
  EXPECT_THAT(printed, ::testing::HasSubstr("\"frame_sets_used\": 1")) << printed;
  EXPECT_THAT(printed, ::testing::HasSubstr("\"legs\": 0.")) << printed;
  EXPECT_THAT(printed, ::testing::HasSubstr("\"written\": ")) << printed;
  EXPECT_EQ(loadBodyModel((dir / "subject.yaml").string()).segments.size(), human.segments.size());
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  const std::string python_file = python("fit-body --frames 1 --server " + address);
  EXPECT_THAT(python_file, ::testing::StartsWith("# {")) << python_file;
  EXPECT_EQ(parseBodyModel(python_file, "python").segments.size(), human.segments.size());
  fs::remove_all(dir);

  // The daemon stops while a fit collects its frame sets: it says so, and stops.
  grpc::Status stopped;
  std::thread stopped_fit([&] {
    v1::FitBodyResponse response;
    stopped = test::fitBody(*stub, 250, response);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  server->shutdown();
  stopped_fit.join();
  EXPECT_EQ(stopped.error_code(), grpc::StatusCode::UNAVAILABLE) << stopped.error_message();
  EXPECT_THAT(stopped.error_message(), ::testing::HasSubstr("of 250 frame sets"));
}

// FitBody with apply: the tracker finds the subject anew with the fitted body. The skeleton and the
// poses say which body they are of, the silhouettes are explained better, and a recording started
// afterwards stores the fitted body (and the subject's, which the truth is of). A fit cannot be
// applied while a recording is open, nor a recording start while such a fit runs: a session stores
// one tracked body.
TEST_F(EndToEndTest, TracksWithTheFittedBodyOnceAFitIsApplied) {
  ServerConfig config = walkingPersonConfig();
  config.track_subject_body = false;
  config.scene_fit_pose_seconds = 60;  // the subject stands in the fit pose throughout
  const fs::path root = freshDirectory("fit_apply");
  config.recording_directory = fs::canonical(root).string();
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  auto stopRecording = [&] {
    grpc::ClientContext context;
    v1::RecordingState state;
    return stub->StopRecording(&context, {}, &state);
  };
  const auto ofVersion = [](uint32_t version) {
    return [version](const v1::Pose& pose) { return pose.body_version() == version; };
  };
  EXPECT_EQ(skeletonOf(*stub).body_version(), 0u);
  const std::vector<v1::Pose> before = readPoses(*stub, 50, ofVersion(0));
  ASSERT_EQ(before.size(), 50u);

  // While a recording is open, a fit may not change the body it stores.
  startRecordingWhenReady(*stub, "before");
  v1::FitBodyResponse response;
  const grpc::Status recording = test::fitBody(*stub, 0, response, true);
  EXPECT_EQ(recording.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(recording.error_message(), ::testing::HasSubstr("a recording is open"));
  ASSERT_TRUE(stopRecording().ok());

  // Nor may a recording start while such a fit runs.
  grpc::Status applied;
  std::thread fit([&] { applied = test::fitBody(*stub, 0, response, true); });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  grpc::ClientContext refused_context;
  v1::StartRecordingRequest request;
  request.set_path("during");
  v1::RecordingState state;
  const grpc::Status refused = stub->StartRecording(&refused_context, request, &state);
  fit.join();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_THAT(refused.error_message(), ::testing::HasSubstr("FitBody with apply"));
  ASSERT_TRUE(applied.ok()) << applied.error_message();
  EXPECT_EQ(response.body_version(), 1u);

  // The skeleton is the configured body with the fitted proportions, and says so.
  BodyProportions proportions;
  for (int k = 0; k < BodyProportions::kCount; ++k)
    proportions[k] = response.proportions(k).factor();
  const BodyModel expected = proportionedBodyModel(server->model(), proportions);
  const v1::Skeleton skeleton = skeletonOf(*stub);
  EXPECT_EQ(skeleton.body_version(), 1u);
  ASSERT_EQ(skeleton.segments_size(), static_cast<int>(expected.segments.size()));
  for (std::size_t s = 0; s < expected.segments.size(); ++s) {
    const v1::Vec3& offset = skeleton.segments(static_cast<int>(s)).rest_offset();
    EXPECT_LT(
        (Eigen::Vector3d(offset.x(), offset.y(), offset.z()) - expected.segments[s].offset).norm(),
        1e-9)
        << expected.segments[s].name;
  }

  // The fitted body explains the silhouettes of the same standing, turning subject better than
  // the built-in human (28 % longer arms, 6 % longer legs) could, over 6 s of it: within them the
  // fitted body can lose a limb for 2 s or so and find it again (silhouette fit 0.71-0.81 against
  // 0.89-0.92; docs/service.md), so a 2 s window failed once in CI. The joints' error is printed,
  // not asserted: an A-pose seen by two cameras looks much the same from behind, and a tracker
  // that takes the subject facing the other way is about 400 mm off with silhouettes just as well
  // explained.
  const std::vector<v1::Pose> after = readPoses(*stub, 150, ofVersion(1));
  ASSERT_EQ(after.size(), 150u);
  const double before_fit = median(before, &v1::Pose::silhouette_fit);
  const double after_fit = median(after, &v1::Pose::silhouette_fit);
  std::printf(
      "in the fit pose, median silhouette fit / error: configured body %.3f / %.1f mm, "
      "fitted %.3f / %.1f mm\n",
      before_fit, median(before, &v1::Pose::reference_error_mm), after_fit,
      median(after, &v1::Pose::reference_error_mm));
  EXPECT_GT(after_fit, before_fit + 0.05);

  // A recording started now stores the fitted body, so a replay tracks the same one.
  startRecordingWhenReady(*stub, "after");
  ASSERT_TRUE(stopRecording().ok());
  const BodyModel stored = loadBodyModel((root / "after" / kBodyModelFile).string());
  ASSERT_EQ(stored.segments.size(), expected.segments.size());
  for (std::size_t s = 0; s < expected.segments.size(); ++s)
    EXPECT_LT((stored.segments[s].offset - expected.segments[s].offset).norm(), 1e-9);
  EXPECT_TRUE(fs::exists(root / "after" / kTruthBodyModelFile));

  // Both clients apply a fit too, each raising the version.
  const std::string address = "127.0.0.1:" + std::to_string(server->port());
  EXPECT_THAT(mocapctl("fit-body --frames 1 --apply --out " + (root / "subject.yaml").string() +
                       " --server " + address),
              ::testing::HasSubstr("\"body_version\": 2"));
  EXPECT_THAT(python("fit-body --frames 1 --apply --server " + address),
              ::testing::HasSubstr("\"body_version\": 3"));
  server->shutdown();
  fs::remove_all(root);
}

// FitBody refuses a body without a fit pose (the hand), a number of frame sets out of range, and,
// when no frame set with every camera's silhouettes comes (no background captured yet), gives up.
TEST_F(EndToEndTest, FitBodyRefusesWhatItCannotFitOrWaitsForNothing) {
  {
    std::unique_ptr<MocapServer> hand = startServer(test::sceneConfig());
    ASSERT_TRUE(hand);
    auto stub = test::connect(hand->port());
    v1::FitBodyResponse response;
    const grpc::Status no_pose = test::fitBody(*stub, 0, response);
    EXPECT_EQ(no_pose.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
    EXPECT_THAT(no_pose.error_message(),
                ::testing::HasSubstr("the body model 'hand' has no fit_pose"));
    for (int frame_sets : {251, -1}) {
      const grpc::Status out_of_range = test::fitBody(*stub, frame_sets, response);
      EXPECT_EQ(out_of_range.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << frame_sets;
      EXPECT_THAT(out_of_range.error_message(), ::testing::HasSubstr("from 1 to 250"));
    }
    EXPECT_THAT(mocapctl("fit-body --server 127.0.0.1:" + std::to_string(hand->port())),
                ::testing::HasSubstr("FitBody: FAILED_PRECONDITION: the body model 'hand'"));
  }
  ServerConfig waiting = walkingPersonConfig();
  waiting.true_silhouettes = false;  // nothing reaches the tracker until a background is captured
  std::unique_ptr<MocapServer> server = startServer(waiting);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  v1::FitBodyResponse response;
  const grpc::Status stalled = test::fitBody(*stub, 5, response);
  EXPECT_EQ(stalled.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED);
  EXPECT_THAT(stalled.error_message(), ::testing::HasSubstr("waiting for a background"));
  EXPECT_THAT(stalled.error_message(), ::testing::HasSubstr("0 of 5"));
}

// Speed limits are per frame: cameras at 50 Hz give the tracker frames half as far apart in time,
// so it tracks the body with half the per-frame limits of the model's 25 Hz: a configured person,
// the hand the fake scene brings, and the person fitted to a scene motion.
TEST_F(EndToEndTest, TracksWithSpeedLimitsPerFrameAtTheCamerasRate) {
  const std::string walk = MOCAP_SHARED_DIR "/data/motion/cmu_131_01_walk.bvh";
  for (const auto& [body, motion] :
       {std::pair<std::string, std::string>{"builtin:human", ""}, {"", ""}, {"", walk}}) {
    SCOPED_TRACE(body + " " + motion);
    ServerConfig config = test::sceneConfig();
    config.body_model = body;
    config.scene_motion = motion;
    for (CameraConfig& camera : config.cameras) camera.fps = 50;
    Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
    ASSERT_TRUE(server.ok()) << server.error();
    const BodyModel& tracked = server.value()->model();
    const BodyModel file =
        body.empty() && motion.empty() ? builtinHandModel() : builtinHumanModel();
    EXPECT_EQ(file.frame_rate, 25);
    EXPECT_EQ(tracked.frame_rate, 50);
    ASSERT_EQ(tracked.dofs.size(), file.dofs.size());
    for (std::size_t d = 0; d < file.dofs.size(); ++d)
      EXPECT_DOUBLE_EQ(tracked.dofs[d].max_speed, file.dofs[d].max_speed / 2) << file.dofs[d].name;
  }
}

// The body model file is read once, by the configuration check: the server tracks that model even
// if the file has changed (here: broken) since.
TEST_F(EndToEndTest, TracksTheBodyFileAsTheConfigurationReadIt) {
  const std::filesystem::path dir = std::filesystem::path(testing::TempDir()) / "body_read_once";
  std::filesystem::create_directories(dir);
  std::filesystem::copy_file(MOCAP_SOURCE_DIR "/tracker/models/human.yaml", dir / "subject.yaml",
                             std::filesystem::copy_options::overwrite_existing);
  const ServerConfig config = parseConfig(
      "cameras:\n  - {driver: fake, width: 780, height: 580}\nbody_model: subject.yaml\n",
      "test.yaml", dir.string());
  std::ofstream(dir / "subject.yaml", std::ios::trunc) << "kind: horse\n";
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  ASSERT_TRUE(server.ok()) << server.error();
  EXPECT_EQ(server.value()->model().segments.size(), builtinHumanModel().segments.size());
  EXPECT_TRUE(server.value()->model().person);
}

// tracker.dofs: gait tracks the 17 gait DOFs of the walking person; the others hold the starting
// pose in every published pose. A body without gait DOFs (the hand) is refused naming the key.
TEST_F(EndToEndTest, TracksTheGaitDofsWhenTheConfigurationSaysSo) {
  ServerConfig config = walkingPersonConfig();
  config.tracker.evaluations = 800;
  config.tracker.dofs = "gait";
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const v1::Skeleton skeleton = skeletonOf(*stub);
  ASSERT_EQ(skeleton.dofs_size(), 31);
  std::vector<int> held;
  for (int d = 0; d < skeleton.dofs_size(); ++d)
    if (skeleton.dofs(d).min() == skeleton.dofs(d).max()) held.push_back(d);
  EXPECT_EQ(held.size(), 31u - 17u);

  grpc::ClientContext stream_context;
  auto reader = stub->StreamPoses(&stream_context, v1::StreamPosesRequest());
  v1::Pose pose;
  int received = 0;
  for (; received < 10 && reader->Read(&pose); ++received)
    for (int d : held) EXPECT_EQ(pose.dofs(d), skeleton.dofs(d).min()) << skeleton.dofs(d).name();
  stream_context.TryCancel();
  EXPECT_EQ(received, 10);
  server->shutdown();

  ServerConfig hand = test::sceneConfig();
  hand.tracker.dofs = "gait";
  Expected<std::unique_ptr<MocapServer>> refused = MocapServer::create(hand);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.error(),
              ::testing::HasSubstr("tracker.dofs: gait, but the body model 'hand'"));
}

// Live, a tracker whose refinement cannot fit in a frame period gives it up when the next frame
// set is waiting, and says how often in its status; the poses keep coming. A replay of the same
// frames, which queues every set, never gives it up (it stays repeatable).
TEST_F(EndToEndTest, ARefinementLongerThanAFrameGivesWayToTheNextSetLiveOnly) {
  const fs::path root = freshDirectory("yield");
  ServerConfig config = test::sceneConfig();
  // The hand's layers alone take 23,925 evaluations, more than a frame period on any machine
  // (about 0.2 s here), so the next set is waiting whenever the refinement starts.
  config.tracker.evaluations = 30000;
  config.tracker.refine = 0.2;
  config.recording_directory = fs::canonical(root).string();
  {
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    auto stub = test::connect(server->port());
    grpc::ClientContext stream_context;
    auto reader = stub->StreamPoses(&stream_context, v1::StreamPosesRequest());
    v1::Pose pose;
    ASSERT_TRUE(reader->Read(&pose));  // recording starts once every camera has sent a frame
    record(*stub, "session", 3);
    int received = 1;
    for (; received < 3 && reader->Read(&pose); ++received) {
    }
    stream_context.TryCancel();
    EXPECT_EQ(received, 3);
    grpc::ClientContext context;
    v1::Status status;
    ASSERT_TRUE(stub->GetStatus(&context, {}, &status).ok());
    EXPECT_GE(status.refinements_cut(), 2u);
    EXPECT_GT(status.evaluations_per_frame(), 0);
    EXPECT_LT(status.evaluations_per_frame(), 25000);
  }
  PipelineStatus replayed;
  EXPECT_GE(replay(root / "session", &replayed).size(), 3u);
  EXPECT_EQ(replayed.refinements_cut, 0u);
  fs::remove_all(root);
}

TEST_F(EndToEndTest, ASceneMotionThatDoesNotLoadStopsTheStartUpNamingIt) {
  const fs::path dir = freshDirectory("bad_bvh");
  std::ofstream(dir / "broken.bvh") << "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n";
  ServerConfig config = test::sceneConfig();
  config.scene_motion = (dir / "broken.bvh").string();
  Expected<std::unique_ptr<MocapServer>> server = MocapServer::create(config);
  ASSERT_FALSE(server.ok());
  EXPECT_THAT(server.error(), ::testing::HasSubstr("scene_motion: "));
  EXPECT_THAT(server.error(), ::testing::HasSubstr("broken.bvh"));
  fs::remove_all(dir);
}

// Per camera and frame (its camera sequence), the silhouettes a pipeline extracted.
class SilhouetteLog {
 public:
  Pipeline::MaskObserver observer() {
    return [this](const FrameSet& set, const std::vector<SilhouetteMask>& masks) {
      std::lock_guard lock(mutex_);
      for (std::size_t c = 0; c < set.frames.size() && c < masks.size(); ++c)
        if (set.frames[c]) masks_[{c, set.frames[c]->sequence}] = masks[c].toMat();
    };
  }
  const cv::Mat* find(std::size_t camera, uint64_t sequence) const {
    std::lock_guard lock(mutex_);
    const auto found = masks_.find({camera, sequence});
    return found == masks_.end() ? nullptr : &found->second;
  }
  std::size_t size() const {
    std::lock_guard lock(mutex_);
    return masks_.size();
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::pair<std::size_t, uint64_t>, cv::Mat> masks_;
};

double intersectionOverUnion(const cv::Mat& a, const cv::Mat& b) {
  const double both = cv::countNonZero(a & b), either = cv::countNonZero(a | b);
  return either == 0 ? 1.0 : both / either;
}

// The median over a recorded session's frames of the agreement (intersection over union) of two
// pipelines' silhouettes of the same frame.
double medianAgreement(const fs::path& session, const SilhouetteLog& a, const SilhouetteLog& b) {
  auto reader = SessionReader::open(session);
  EXPECT_TRUE(reader.ok()) << reader.error();
  std::vector<double> agreement;
  if (!reader.ok()) return 0;
  for (const SessionSet& set : reader.value()->sets()) {
    for (std::size_t c = 0; c < set.frames.size(); ++c) {
      if (!set.frames[c]) continue;
      const cv::Mat* mask_a = a.find(c, set.frames[c]->camera_sequence);
      const cv::Mat* mask_b = b.find(c, set.frames[c]->camera_sequence);
      EXPECT_TRUE(mask_a && mask_b)
          << "camera " << c << " frame " << set.frames[c]->camera_sequence;
      if (mask_a && mask_b) agreement.push_back(intersectionOverUnion(*mask_a, *mask_b));
    }
  }
  return median(std::move(agreement));  // NaN, failing every bar, if no frame was compared
}

// Also: a session tracked on the scene's true silhouettes stores the empty scene as each camera's
// background, so its replay, which has no truth, extracts silhouettes close to the truth.
TEST_F(EndToEndTest, ReplayGivesIdenticalPosesEveryRun) {
  const fs::path root = freshDirectory("replay");
  SilhouetteLog truth;
  {
    ServerConfig config = test::sceneConfig();
    config.recording_directory = fs::canonical(root).string();
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    server->pipeline().setMaskObserver(truth.observer());
    auto stub = test::connect(server->port());
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    record(*stub, "session", 100);
  }
  SilhouetteLog extracted;
  PipelineStatus status;
  const auto first = replay(root / "session", &status, extracted.observer());
  EXPECT_EQ(status.cameras[0].silhouettes,
            "background recorded in the session (cam0/background_000000.yml)");
  const double agreement = medianAgreement(root / "session", truth, extracted);
  std::printf("replayed against true silhouettes, IoU median %.4f\n", agreement);
  EXPECT_GE(agreement, 0.9);
  const auto second = replay(root / "session");
  EXPECT_GE(first.size(), 100u);
  ASSERT_EQ(first.size(), second.size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    ASSERT_EQ(first[i].first, second[i].first) << "pose " << i;
    ASSERT_EQ(first[i].second, second[i].second) << "pose " << i;
  }
  fs::remove_all(root);
}

TEST_F(EndToEndTest, ReplayTracksTheBodyAndSettingsTheSessionWasRecordedWith) {
  const fs::path root = freshDirectory("replay_body");
  {
    ServerConfig config = walkingPersonConfig();
    config.tracker.evaluations = 600;  // not the replay configuration's 375, nor the people's 2000
    config.recording_directory = fs::canonical(root).string();
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    auto stub = test::connect(server->port());
    {  // recording starts once every camera has sent a frame: wait for the first pose
      grpc::ClientContext context;
      v1::Pose pose;
      ASSERT_TRUE(stub->StreamPoses(&context, v1::StreamPosesRequest())->Read(&pose));
      context.TryCancel();
    }
    // More sets than the replay's acquisition trial (its hypotheses are tracked for 10 frames,
    // each spending the budget): the last frame is tracked by the one kept.
    record(*stub, "session", 15);
  }
  // The replay's configuration names no body and no tracker keys: the session's own body (31
  // DOFs) is tracked, not the built-in hand (15), with the session's settings.
  PipelineStatus status;
  std::vector<double> errors;
  const auto poses = replay(root / "session", &status, {}, &errors);
  ASSERT_FALSE(poses.empty());
  for (const auto& [sequence, dofs] : poses) ASSERT_EQ(dofs.size(), 31u) << "frame " << sequence;
  EXPECT_EQ(status.evaluations_per_frame, 600 + 1);  // and the fit of the estimate
  // The session stores the scene's truth, so every replayed pose has its error against it: the
  // person found and tracked on silhouettes extracted against the stored empty room.
  ASSERT_EQ(errors.size(), poses.size());
  const double error = median(errors);
  std::printf("replayed poses against the recorded truth: median %.1f mm over %zu\n", error,
              errors.size());
  EXPECT_LT(error, 100.0);
  fs::remove_all(root);
}

// A session of a subject tracked with a body not its own (track_subject_body: false) stores the
// subject's body beside the tracked one, so its replay measures each pose against the subject's
// joints, as the live daemon did, and not against the truth's DOFs on the tracked body.
TEST_F(EndToEndTest, ReplayMeasuresTheErrorOnTheSubjectsBody) {
  const fs::path root = freshDirectory("replay_subject");
  {
    ServerConfig config = walkingPersonConfig();
    config.track_subject_body = false;
    config.recording_directory = fs::canonical(root).string();
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    auto stub = test::connect(server->port());
    ASSERT_EQ(readPoses(*stub, 1).size(), 1u);
    record(*stub, "session", 15);
  }
  Expected<std::unique_ptr<SessionReader>> session = SessionReader::open(root / "session");
  ASSERT_TRUE(session.ok()) << session.error();
  const BodyModel* tracked = session.value()->bodyModel();
  const BodyModel* subject = session.value()->truthBodyModel();
  ASSERT_TRUE(tracked && subject && subject != tracked);
  std::vector<Eigen::VectorXd> truths;
  for (const SessionSet& set : session.value()->sets())
    for (const std::optional<IndexRecord>& frame : set.frames)
      if (const Eigen::VectorXd* truth =
              frame ? session.value()->truth(frame->camera_sequence) : nullptr)
        truths.push_back(*truth);
  ASSERT_FALSE(truths.empty());

  std::vector<Pose> poses;
  replay(root / "session", nullptr, {}, nullptr, &poses);
  ASSERT_FALSE(poses.empty());
  // The mean distance of a pose's joints from a truth's placed on `body`, in millimetres; the
  // reported error must be that of some frame's truth on the subject's body, and of none on the
  // tracked body (whose legs and arms are longer).
  const auto nearestError = [&](const BodyModel& body, const Pose& pose) {
    KinematicsData kinematics(body);
    double nearest = INFINITY;
    for (const Eigen::VectorXd& truth : truths) {
      forwardKinematics(body, kinematics, truth);
      const std::vector<Eigen::Vector3d> joints = pointPositions(body, kinematics);
      double sum = 0;
      for (std::size_t p = 0; p < joints.size(); ++p) sum += (joints[p] - pose.points[p]).norm();
      nearest = std::min(nearest, std::abs(1000 * sum / joints.size() - *pose.reference_error_mm));
    }
    return nearest;
  };
  for (const Pose& pose : poses) {
    ASSERT_TRUE(pose.reference_error_mm) << "frame " << pose.frame_sequence;
    EXPECT_LT(nearestError(*subject, pose), 1e-6) << "frame " << pose.frame_sequence;
    EXPECT_GT(nearestError(*tracked, pose), 1.0) << "frame " << pose.frame_sequence;
  }
  fs::remove_all(root);
}

// A session keeps the backgrounds its silhouettes were extracted against, the one in use when the
// recording started and one captured during it, so a replay extracts the same silhouettes from the
// recorded images instead of thresholding them.
TEST_F(EndToEndTest, ReplayExtractsSilhouettesAgainstTheSessionsBackgrounds) {
  const fs::path root = freshDirectory("replay_backgrounds");
  SilhouetteLog live;
  {
    ServerConfig config = test::sceneConfig();
    config.true_silhouettes = false;
    config.recording_directory = fs::canonical(root).string();
    std::unique_ptr<MocapServer> server = startServer(config);
    ASSERT_TRUE(server);
    server->pipeline().setMaskObserver(live.observer());
    auto stub = test::connect(server->port());
    v1::CaptureBackgroundResponse response;
    ASSERT_TRUE(test::captureBackground(*stub, 10, response).ok());
    ASSERT_NO_FATAL_FAILURE(startRecordingWhenReady(*stub, "session"));
    ASSERT_NO_FATAL_FAILURE(waitForRecordedSets(*stub, 10));
    ASSERT_TRUE(test::captureBackground(*stub, 10, response).ok());
    ASSERT_NO_FATAL_FAILURE(waitForRecordedSets(*stub, 40));
    grpc::ClientContext context;
    v1::RecordingState state;
    ASSERT_TRUE(stub->StopRecording(&context, {}, &state).ok());
    server->shutdown();
  }
  // Per camera: the background in use at the start, from its first frame, and the one captured
  // during the recording, from a later frame.
  std::ifstream lines(root / "session" / kBackgroundsFile);
  std::string line;
  std::getline(lines, line);
  EXPECT_EQ(line, kBackgroundsHeader);
  std::vector<BackgroundRecord> records;
  while (std::getline(lines, line)) {
    Expected<BackgroundRecord> record = parseBackgroundLine(line, 2);
    ASSERT_TRUE(record.ok()) << line << ": " << record.error();
    records.push_back(record.value());
  }
  ASSERT_EQ(records.size(), 4u);
  for (int c = 0; c < 2; ++c) {
    std::vector<uint64_t> from;
    for (const BackgroundRecord& record : records)
      if (record.camera == c) from.push_back(record.from_sequence);
    ASSERT_EQ(from.size(), 2u) << "camera " << c;
    EXPECT_EQ(from[0], 0u);
    EXPECT_GT(from[1], 0u);
  }

  SilhouetteLog replayed;
  PipelineStatus status;
  replay(root / "session", &status, replayed.observer());
  ASSERT_GE(replayed.size(), 80u);  // 40 sets of 2 cameras at the least
  for (std::size_t c = 0; c < 2; ++c) {
    EXPECT_THAT(status.cameras[c].silhouettes,
                ::testing::StartsWith("background recorded in the session (cam" +
                                      std::to_string(c) + "/background_0"));
    EXPECT_THAT(status.cameras[c].silhouettes, ::testing::Not(::testing::HasSubstr("_000000")));
  }
  // Live silhouettes came from extractors that had adapted since their capture, the replayed ones
  // from the model as captured: the same up to pixels at the threshold.
  const double agreement = medianAgreement(root / "session", live, replayed);
  std::printf("replayed against live silhouettes, IoU median %.4f\n", agreement);
  EXPECT_GE(agreement, 0.98);
  fs::remove_all(root);
}

}  // namespace
}  // namespace mocap
