// mocapctl's connection to mocapd: a request the daemon never answers fails at its deadline with
// an error that says so and names the daemon's address; the daemon's own DEADLINE_EXCEEDED (a
// background capture whose frames stopped) is reported as the daemon's; --timeout is checked.
#include "clients/mocapctl/daemon_client.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>

#include "tests/clients/mocapctl/hanging_daemon.h"

namespace mocapctl {
namespace {

using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

// The message of what `request` throws; empty if it throws nothing.
template <typename Request>
std::string errorOf(Request request) {
  try {
    request();
  } catch (const std::runtime_error& error) {
    return error.what();
  }
  return "";
}

TEST(DaemonClient, GivesUpOnADaemonThatNeverAnswersAtTheDeadline) {
  test::HangingDaemon daemon;
  DaemonFlags flags;
  flags.server = daemon.address();
  DaemonClient client(flags);
  mocap::v1::RecordingState state;
  const std::string error = errorOf([&] {
    client.call("StopRecording", &DaemonClient::Stub::StopRecording, {}, state,
                std::chrono::seconds(1));
  });
  EXPECT_THAT(error, AllOf(HasSubstr("StopRecording: DEADLINE_EXCEEDED"),
                           HasSubstr("no answer from mocapd at " + daemon.address()),
                           HasSubstr("within 1 s")));
}

TEST(DaemonClient, TimeoutFlagOverridesTheRequestsOwnBound) {
  test::HangingDaemon daemon;
  DaemonFlags flags;
  flags.server = daemon.address();
  flags.timeout = "0.2";
  DaemonClient client(flags);
  mocap::v1::RecordingState state;
  // Without the flag this would wait the request's own two minutes.
  EXPECT_THAT(errorOf([&] {
                client.call("StopRecording", &DaemonClient::Stub::StopRecording, {}, state,
                            DaemonClient::kRecordingStopTimeout);
              }),
              HasSubstr("no answer from mocapd at " + daemon.address() + " within 0.2 s"));
}

// Answers CaptureBackground at once with DEADLINE_EXCEEDED, as mocapd does when frames stop.
class StalledCameras final : public mocap::v1::MocapService::Service {
 public:
  grpc::Status CaptureBackground(grpc::ServerContext*, const mocap::v1::CaptureBackgroundRequest*,
                                 mocap::v1::CaptureBackgroundResponse*) override {
    return {grpc::StatusCode::DEADLINE_EXCEEDED, "camera 0 sent no frame for 2 s"};
  }
};

TEST(DaemonClient, ReportsTheDaemonsOwnDeadlineExceededAsItsAnswer) {
  StalledCameras service;
  int port = 0;
  grpc::ServerBuilder builder;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  DaemonFlags flags;
  flags.server = "127.0.0.1:" + std::to_string(port);
  DaemonClient client(flags);
  mocap::v1::CaptureBackgroundResponse response;
  const std::string error = errorOf([&] {
    client.call("CaptureBackground", &DaemonClient::Stub::CaptureBackground, {}, response,
                std::chrono::seconds(60));
  });
  EXPECT_EQ(error, "CaptureBackground: DEADLINE_EXCEEDED: camera 0 sent no frame for 2 s");
  EXPECT_THAT(error, Not(HasSubstr("no answer")));
  server->Shutdown();
}

TEST(DaemonClient, RefusesATimeoutThatIsNotAPositiveNumberOfSeconds) {
  for (const char* timeout : {"0", "-1", "soon", "1s", "inf", "100000"}) {
    DaemonFlags flags;
    flags.timeout = timeout;
    EXPECT_THAT(errorOf([&] { DaemonClient client(flags); }), HasSubstr("--timeout")) << timeout;
  }
}

}  // namespace
}  // namespace mocapctl
