// The daemon's defences end to end on loopback, beside the TLS tests of end_to_end_test.cpp: the
// bearer token on every RPC (alone and with a client certificate), requests over the size limit
// or the count limits refused with an error that names the limit, and the bind address of every
// configuration mocapd ships.
#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "server/server_test_support.h"
#include "server/tls_test_support.h"

namespace mocap {
namespace {

namespace fs = std::filesystem;
using test::EndToEndTest;
using test::freshDirectory;
using test::startServer;
using ::testing::HasSubstr;

constexpr const char* kToken = "0123456789abcdef-secret";

// One call of each RPC of MocapService with the metadata `prepare` adds, as its status. The
// calls that would wait on the tracker (background capture, body fit) get a short deadline: only
// whether they pass the door matters here.
using Prepare = std::function<void(grpc::ClientContext&)>;
std::vector<std::pair<std::string, grpc::Status>> callEveryRpc(v1::MocapService::Stub& stub,
                                                               const Prepare& prepare) {
  std::vector<std::pair<std::string, grpc::Status>> results;
  const auto call = [&](const std::string& name, auto&& rpc) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
    prepare(context);
    results.emplace_back(name, rpc(context));
  };
  call("StreamPoses", [&](grpc::ClientContext& context) {
    auto reader = stub.StreamPoses(&context, {});
    v1::Pose pose;
    if (reader->Read(&pose)) context.TryCancel();  // served: enough
    return reader->Finish();
  });
  call("GetSkeleton", [&](grpc::ClientContext& context) {
    v1::Skeleton skeleton;
    return stub.GetSkeleton(&context, {}, &skeleton);
  });
  call("GetStatus", [&](grpc::ClientContext& context) {
    v1::Status status;
    return stub.GetStatus(&context, {}, &status);
  });
  call("ListCameras", [&](grpc::ClientContext& context) {
    v1::ListCamerasResponse cameras;
    return stub.ListCameras(&context, {}, &cameras);
  });
  call("StartRecording", [&](grpc::ClientContext& context) {
    v1::StartRecordingRequest request;
    request.set_path("take");
    v1::RecordingState state;
    return stub.StartRecording(&context, request, &state);
  });
  call("StopRecording", [&](grpc::ClientContext& context) {
    v1::RecordingState state;
    return stub.StopRecording(&context, {}, &state);
  });
  call("CaptureBackground", [&](grpc::ClientContext& context) {
    v1::CaptureBackgroundRequest request;
    request.set_frames(1);
    v1::CaptureBackgroundResponse response;
    return stub.CaptureBackground(&context, request, &response);
  });
  call("Reacquire", [&](grpc::ClientContext& context) {
    v1::ReacquireResponse response;
    return stub.Reacquire(&context, {}, &response);
  });
  call("FitBody", [&](grpc::ClientContext& context) {
    v1::FitBodyRequest request;
    request.set_frame_sets(1);
    v1::FitBodyResponse response;
    return stub.FitBody(&context, request, &response);
  });
  return results;
}

// Every RPC: without the token, with a wrong one (of the same length, and a prefix of the right
// one) or with the wrong scheme, UNAUTHENTICATED and without effect (no session is created);
// with the token, past the door.
TEST_F(EndToEndTest, TheTokenIsRequiredOnEveryRpc) {
  const fs::path recordings = freshDirectory("token_rpcs");
  ServerConfig config = test::sceneConfig();
  config.bearer_token = kToken;
  config.recording_directory = recordings.string();
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const std::string token = kToken;
  const std::vector<std::optional<std::string>> refused = {
      std::nullopt,
      "Bearer " + std::string(token.size(), 'x'),
      "Bearer " + token.substr(0, token.size() - 1),
      "Bearer " + token + "x",
      "bearer " + token,
      token,
  };
  for (const std::optional<std::string>& authorization : refused) {
    const auto results = callEveryRpc(*stub, [&](grpc::ClientContext& context) {
      if (authorization) context.AddMetadata("authorization", *authorization);
    });
    ASSERT_EQ(results.size(), 9u);
    for (const auto& [rpc, status] : results) {
      EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED)
          << rpc << " with " << authorization.value_or("no authorization");
      EXPECT_THAT(status.error_message(), HasSubstr("authorization: Bearer <token>")) << rpc;
    }
  }
  EXPECT_TRUE(fs::is_empty(recordings));

  const auto allowed = callEveryRpc(*stub, [&](grpc::ClientContext& context) {
    context.AddMetadata("authorization", "Bearer " + token);
  });
  for (const auto& [rpc, status] : allowed)
    EXPECT_NE(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << rpc;
  server->shutdown();
  fs::remove_all(recordings);
}

// Mutual TLS and a token together: the certificate gets a client through the handshake, and the
// token is still asked for on each call.
TEST_F(EndToEndTest, AClientCertificateDoesNotReplaceTheToken) {
  const fs::path dir = freshDirectory("mtls_token");
  const test::TlsFiles daemon = test::writeSelfSignedCertificate(dir, "daemon");
  const test::TlsFiles client = test::writeSelfSignedCertificate(dir, "client");
  ServerConfig config = test::sceneConfig();
  config.tls_cert_file = daemon.cert;
  config.tls_key_file = daemon.key;
  config.tls_client_ca_file = client.cert;
  config.bearer_token = kToken;
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  grpc::SslCredentialsOptions tls;
  tls.pem_root_certs = test::fileText(daemon.cert);
  tls.pem_cert_chain = test::fileText(client.cert);
  tls.pem_private_key = test::fileText(client.key);
  auto stub = v1::MocapService::NewStub(grpc::CreateChannel(
      "127.0.0.1:" + std::to_string(server->port()), grpc::SslCredentials(tls)));
  const auto status = [&](const std::string& authorization) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    if (!authorization.empty()) context.AddMetadata("authorization", authorization);
    v1::Status answer;
    return stub->GetStatus(&context, {}, &answer).error_code();
  };
  EXPECT_EQ(status(""), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(status("Bearer wrong-token-of-some-length"), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(status(std::string("Bearer ") + kToken), grpc::StatusCode::OK);
  server->shutdown();
  fs::remove_all(dir);
}

// Requests above gRPC's 4 MB limit are refused before any handler sees them; the limits of the
// handlers (frame counts, joint names, session paths) are refused with a message naming them; the
// daemon serves on after all of it.
TEST_F(EndToEndTest, RequestsOverTheLimitsAreRefusedWithTheLimitNamed) {
  const fs::path recordings = freshDirectory("limits");
  ServerConfig config = test::sceneConfig();
  config.recording_directory = recordings.string();
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  const auto startRecording = [&](const std::string& path) {
    grpc::ClientContext context;
    v1::StartRecordingRequest request;
    request.set_path(path);
    v1::RecordingState state;
    return stub->StartRecording(&context, request, &state);
  };

  const grpc::Status huge_path = startRecording(std::string(5 << 20, 'a'));
  EXPECT_EQ(huge_path.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_THAT(huge_path.error_message(), HasSubstr("larger than max"));
  {
    grpc::ClientContext context;
    v1::StreamPosesRequest request;
    for (int i = 0; i < 100'000; ++i) request.add_joints(std::string(60, 'j'));
    auto reader = stub->StreamPoses(&context, request);
    v1::Pose pose;
    EXPECT_FALSE(reader->Read(&pose));
    EXPECT_EQ(reader->Finish().error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  }
  {
    grpc::ClientContext context;
    v1::StreamPosesRequest request;
    for (int i = 0; i < 10'000; ++i) request.add_joints("joint_" + std::to_string(i));
    auto reader = stub->StreamPoses(&context, request);
    v1::Pose pose;
    EXPECT_FALSE(reader->Read(&pose));
    const grpc::Status refused = reader->Finish();
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_THAT(refused.error_message(), HasSubstr("joint_0"));
  }

  for (const uint32_t frames : {1501u, 4'000'000'000u}) {
    v1::CaptureBackgroundResponse response;
    const grpc::Status refused = test::captureBackground(*stub, frames, response);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << frames;
    EXPECT_THAT(refused.error_message(), HasSubstr("1500")) << frames;
  }
  for (const int sets : {-1, 251, 1 << 30}) {
    v1::FitBodyResponse response;
    const grpc::Status refused = test::fitBody(*stub, sets, response);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << sets;
    EXPECT_THAT(refused.error_message(), HasSubstr("frame_sets: from 1 to 250")) << sets;
  }

  // A name longer than the file system takes, under the 4 MB limit.
  const grpc::Status long_name = startRecording(std::string(300, 'n'));
  EXPECT_FALSE(long_name.ok());
  EXPECT_THAT(long_name.error_message(), HasSubstr("too long"));
  EXPECT_EQ(startRecording("a/../../b").error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(fs::is_empty(recordings));

  grpc::ClientContext context;
  v1::Status status;
  EXPECT_TRUE(stub->GetStatus(&context, {}, &status).ok());
  server->shutdown();
  fs::remove_all(recordings);
}

// With no recording directory configured, recording is refused whatever the path.
TEST_F(EndToEndTest, RecordingIsOffWithoutARecordingDirectory) {
  std::unique_ptr<MocapServer> server = startServer(test::sceneConfig());
  ASSERT_TRUE(server);
  auto stub = test::connect(server->port());
  for (const std::string path : {"take", "", "/tmp/take"}) {
    grpc::ClientContext context;
    v1::StartRecordingRequest request;
    request.set_path(path);
    v1::RecordingState state;
    const grpc::Status refused = stub->StartRecording(&context, request, &state);
    EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << path;
    EXPECT_THAT(refused.error_message(), HasSubstr("recording is off")) << path;
  }
  server->shutdown();
}

bool isLoopbackHost(const std::string& listen) {
  const std::string host = listen.substr(0, listen.rfind(':'));
  return host == "127.0.0.1" || host == "localhost" || host == "[::1]";
}

// The default configuration listens on loopback only, for gRPC and the web view: a daemon on it
// answers through 127.0.0.1 and not through the machine's other addresses.
TEST_F(EndToEndTest, TheDefaultConfigurationListensOnLoopbackOnly) {
  ServerConfig config = parseConfig(kDefaultConfigYaml, "<embedded default>", ".");
  EXPECT_EQ(config.listen, "127.0.0.1:50051");
  EXPECT_EQ(config.web.listen, "127.0.0.1:8080");
  // Its host, on a port of its own (50051 may be taken by another daemon on this machine).
  config.listen = config.listen.substr(0, config.listen.rfind(':')) + ":0";
  config.web.enabled = false;
  std::unique_ptr<MocapServer> server = startServer(config);
  ASSERT_TRUE(server);
  const auto answers = [&](const std::string& host) {
    auto stub = v1::MocapService::NewStub(grpc::CreateChannel(
        host + ":" + std::to_string(server->port()), grpc::InsecureChannelCredentials()));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(3));
    v1::Status status;
    return stub->GetStatus(&context, {}, &status).ok();
  };
  EXPECT_TRUE(answers("127.0.0.1"));
  ifaddrs* interfaces = nullptr;
  ASSERT_EQ(getifaddrs(&interfaces), 0);
  int other_addresses = 0;
  for (const ifaddrs* i = interfaces; i; i = i->ifa_next) {
    if (!i->ifa_addr || i->ifa_addr->sa_family != AF_INET) continue;
    char text[INET_ADDRSTRLEN];
    const auto* address = reinterpret_cast<const sockaddr_in*>(i->ifa_addr);
    inet_ntop(AF_INET, &address->sin_addr, text, sizeof text);
    if (std::string(text).rfind("127.", 0) == 0) continue;
    ++other_addresses;
    EXPECT_FALSE(answers(text)) << "served on " << text;
  }
  freeifaddrs(interfaces);
  if (other_addresses == 0) GTEST_LOG_(INFO) << "no address but loopback to try";
  server->shutdown();
}

// Every configuration mocapd ships listens on loopback (or leaves `listen` to the default), and so
// does its web view, or it asks for TLS and a token for a wider address.
TEST(ShippedConfigurations, ListenOnLoopbackOrRequireTlsAndAToken) {
  std::vector<fs::path> files = {fs::path(MOCAP_SOURCE_DIR) / "deploy" / "mocapd.yaml"};
  for (const auto& entry : fs::directory_iterator(fs::path(MOCAP_SOURCE_DIR) / "deploy/configs"))
    if (entry.path().extension() == ".yaml" &&
        entry.path().filename().string().rfind("example-rig", 0) != 0)
      files.push_back(entry.path());
  ASSERT_GE(files.size(), 5u);
  for (const fs::path& file : files) {
    const YAML::Node root = YAML::LoadFile(file.string());
    const bool guarded = root["tls"] && root["auth"];
    std::vector<std::string> addresses;
    if (root["listen"]) addresses.push_back(root["listen"].as<std::string>());
    if (root["web"] && root["web"]["listen"])
      addresses.push_back(root["web"]["listen"].as<std::string>());
    for (const std::string& listen : addresses)
      EXPECT_TRUE(isLoopbackHost(listen) || guarded) << file << " listens on " << listen;
  }
}

}  // namespace
}  // namespace mocap
