// The real mocapd binary: a bad configuration is refused with its message; SIGTERM ends the pose
// streams with OK and exits 0; `mocapctl bench` against it reports latency, rate and error.
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "server/server_test_support.h"

namespace mocap {
namespace {

// A port that was free a moment ago: bound to port 0, read back, released.
int freePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
  socklen_t length = sizeof address;
  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  close(fd);
  return ntohs(address.sin_port);
}

TEST(MocapdBinaryTest, BadConfigIsRefusedWithItsMessage) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("mocapd_bad_" + std::to_string(getpid()) + ".yaml");
  std::ofstream(path) << "cameras:\n  - {driver: fake}\ntracker:\n  threads: zero\n";
  const std::string command = MOCAP_BIN_DIR "/mocapd --config " + path.string() + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_TRUE(pipe);
  std::string output;
  char buffer[1024];
  while (fgets(buffer, sizeof buffer, pipe)) output += buffer;
  const int status = pclose(pipe);
  EXPECT_EQ(WEXITSTATUS(status), 2);
  EXPECT_THAT(output, ::testing::HasSubstr(path.string() + ":4: tracker.threads: expected a number"));
  std::filesystem::remove(path);
}

// Starts mocapd (the built-in fake scene) on `port` and waits until it publishes poses (a
// generous limit, not a timing assertion). Returns its pid, or -1 if it never served.
pid_t startMocapd(int port) {
  const pid_t child = fork();
  if (child == 0) {
    const std::string listen = "127.0.0.1:" + std::to_string(port);
    execl(MOCAP_BIN_DIR "/mocapd", "mocapd", "--listen", listen.c_str(), "--log-level", "warning",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  if (child < 0) return -1;
  auto stub = test::connect(port);
  for (int attempt = 0; attempt < 300; ++attempt) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(200));
    v1::Status status;
    if (stub->GetStatus(&context, {}, &status).ok() && status.poses_published() > 0) return child;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  kill(child, SIGKILL);
  waitpid(child, nullptr, 0);
  return -1;
}

TEST(MocapdBinaryTest, SigtermEndsStreamsAndExitsZero) {
  const int port = freePort();
  const pid_t child = startMocapd(port);
  ASSERT_GT(child, 0);
  auto stub = test::connect(port);
  test::PoseCounter stream(*stub);
  stream.startCounting();
  while (stream.received() < 5) std::this_thread::sleep_for(std::chrono::milliseconds(50));

  ASSERT_EQ(kill(child, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_TRUE(stream.finish().ok());
}

// The fake scene knows the truth, so the bench reports the poses' error against it besides the
// latency, split by stage, and the rate; --latencies adds every pose's latency (for benches that
// pool windows).
TEST(MocapdBinaryTest, BenchReportsLatencyRateAndErrorAgainstTheTruth) {
  const int port = freePort();
  const pid_t child = startMocapd(port);
  ASSERT_GT(child, 0);
  const std::string command = MOCAP_BIN_DIR
                              "/mocapctl bench --seconds 2 --latencies --server 127.0.0.1:" +
                              std::to_string(port) + " 2>/dev/null";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_TRUE(pipe);
  std::string output;
  char buffer[1024];
  while (fgets(buffer, sizeof buffer, pipe)) output += buffer;
  EXPECT_EQ(WEXITSTATUS(pclose(pipe)), 0) << output;
  kill(child, SIGTERM);
  waitpid(child, nullptr, 0);
  const nlohmann::json summary = nlohmann::json::parse(output);
  EXPECT_GT(summary["poses"].get<int>(), 0) << output;
  EXPECT_LE(summary["latency_ms"]["p50"].get<double>(), summary["latency_ms"]["p99"].get<double>());
  const std::vector<double> latencies = summary["latencies_ms"].get<std::vector<double>>();
  EXPECT_EQ(latencies.size(), summary["poses"].get<std::size_t>());
  if (!latencies.empty()) {
    EXPECT_EQ(*std::max_element(latencies.begin(), latencies.end()),
              summary["latency_ms"]["max"].get<double>());
  }
  // Where the latency went: every stage from capture to this client, the tracker's step taking
  // time.
  for (const char* stage : {"capture_to_silhouettes", "silhouettes", "silhouettes_to_tracker",
                            "track", "tracker_to_publisher", "publisher_to_client"}) {
    ASSERT_TRUE(summary["stages_ms"].contains(stage)) << stage << "\n" << output;
    EXPECT_GE(summary["stages_ms"][stage]["p50"].get<double>(), 0) << stage;
    EXPECT_LE(summary["stages_ms"][stage]["p50"].get<double>(),
              summary["stages_ms"][stage]["p99"].get<double>())
        << stage;
  }
  EXPECT_GT(summary["stages_ms"]["track"]["p50"].get<double>(), 0);
  ASSERT_TRUE(summary.contains("reference_error_mm")) << output;
  const nlohmann::json& error = summary["reference_error_mm"];
  EXPECT_GT(error["mean"].get<double>(), 0) << output;
  EXPECT_GE(error["share_over_100"].get<double>(), 0);
  EXPECT_LE(error["share_over_100"].get<double>(), 1);
}

}  // namespace
}  // namespace mocap
