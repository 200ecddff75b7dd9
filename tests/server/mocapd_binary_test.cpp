// The real mocapd binary: a bad configuration is refused with its message; SIGTERM ends the pose
// streams with OK and exits 0.
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

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

TEST(MocapdBinaryTest, SigtermEndsStreamsAndExitsZero) {
  const int port = freePort();
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    const std::string listen = "127.0.0.1:" + std::to_string(port);
    execl(MOCAP_BIN_DIR "/mocapd", "mocapd", "--listen", listen.c_str(), "--log-level", "warning",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  auto stub = test::connect(port);
  // Wait until it serves (a generous limit, not a timing assertion).
  bool serving = false;
  for (int attempt = 0; attempt < 300 && !serving; ++attempt) {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(200));
    v1::Status status;
    serving = stub->GetStatus(&context, {}, &status).ok() && status.poses_published() > 0;
    if (!serving) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(serving);
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

}  // namespace
}  // namespace mocap
