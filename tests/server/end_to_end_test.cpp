// End to end on loopback, with the daemon in-process on the fake scene (2 cameras, 780x580,
// 25 Hz): C++ and Python subscribers keep up with the frame rate while another subscriber never
// reads; the skeleton; the bearer token; TLS; recording paths; background capture while poses
// flow. The people, body-fit and replay suites are beside it.
#include <algorithm>
#include <iterator>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <set>
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
#include "tracker/model/builtin_models.h"
#include "tracker/model/kinematics.h"
#include "tracker/motion/bvh.h"
#include "tracker/motion/retarget.h"
#include "tracker/search/body_size.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using test::EndToEndTest;
using test::freshDirectory;
using test::mocapctl;
using test::python;
using test::record;
using test::startRecording;
using test::startServer;

// Window of the rate test: 10 s at 25 Hz is 250 frame sets.
constexpr int kWindowSeconds = 10;
constexpr int kWindowFrames = kWindowSeconds * 25;

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
  // The latency split by stage, in pipeline order, the step taking time.
  std::vector<std::string> stages;
  for (const v1::StageLatency& stage : status.stage_latency()) {
    stages.push_back(stage.stage());
    EXPECT_GT(stage.latency().samples(), 0u) << stage.stage();
    EXPECT_GE(stage.latency().p50_ms(), 0) << stage.stage();
  }
  EXPECT_THAT(stages,
              ::testing::ElementsAre("capture_to_silhouettes", "silhouettes",
                                     "silhouettes_to_tracker", "track", "tracker_to_publisher"));
  ASSERT_EQ(status.stage_latency_size(), 5);
  EXPECT_GT(status.stage_latency(3).latency().p50_ms(), 0);

  stalled_context.TryCancel();
  server->shutdown();
  EXPECT_TRUE(cpp_client.finish().ok());
}

// The names of this process's threads, as `top -H` shows them.
std::multiset<std::string> threadNames() {
  std::multiset<std::string> names;
  for (const auto& task : fs::directory_iterator("/proc/self/task")) {
    std::ifstream comm(task.path() / "comm");
    std::string name;
    if (std::getline(comm, name)) names.insert(name);
  }
  return names;
}

// Each thread names itself once it runs, which may be after the daemon has started: the names are
// read again until every expected name is there (or ten seconds pass).
TEST_F(EndToEndTest, TheDaemonsThreadsAreNamed) {
  std::unique_ptr<MocapServer> server = startServer(test::sceneConfig());
  ASSERT_TRUE(server);
  const std::map<std::string, std::size_t> expected = {
      {"mocapd-camera", 2}, {"mocapd-mask", 1}, {"mocapd-track", 1}, {"mocapd-publish", 1}};
  std::multiset<std::string> names = threadNames();
  const auto all_named = [&] {
    return std::all_of(expected.begin(), expected.end(),
                       [&](const auto& e) { return names.count(e.first) == e.second; });
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!all_named() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    names = threadNames();
  }
  for (const auto& [name, count] : expected) EXPECT_EQ(names.count(name), count) << name;
}

// gRPC would let a second daemon share the port (SO_REUSEPORT) and split the clients between the
// two: it is refused, naming the address.
TEST_F(EndToEndTest, ASecondDaemonOnTheSamePortIsRefused) {
  std::unique_ptr<MocapServer> first = startServer(test::sceneConfig());
  ASSERT_TRUE(first);
  ServerConfig config = test::sceneConfig();
  config.listen = "127.0.0.1:" + std::to_string(first->port());
  const Expected<std::unique_ptr<MocapServer>> second = MocapServer::create(config);
  ASSERT_FALSE(second.ok());
  EXPECT_NE(second.error().find("cannot listen on " + config.listen), std::string::npos)
      << second.error();
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
  // The stages' times follow the frame set from capture to the publisher, in order.
  const v1::StageTimes& stages = pose.stages();
  const int64_t times[] = {pose.capture_monotonic_ns(), stages.silhouettes_start_ns(),
                           stages.silhouettes_end_ns(), stages.track_start_ns(),
                           stages.track_end_ns(),       pose.publish_monotonic_ns()};
  for (std::size_t k = 1; k < std::size(times); ++k) EXPECT_LE(times[k - 1], times[k]) << k;
  EXPECT_LT(stages.track_start_ns(), stages.track_end_ns());
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
    tls.pem_root_certs = test::fileText(trusted->cert);
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
    tls.pem_root_certs = test::fileText(daemon.cert);
    if (presented) {
      tls.pem_cert_chain = test::fileText(presented->cert);
      tls.pem_private_key = test::fileText(presented->key);
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

}  // namespace
}  // namespace mocap
