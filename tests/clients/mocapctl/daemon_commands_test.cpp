// Every mocapctl subcommand that asks mocapd something, run as the real binary against a daemon
// that never answers: each gives up at its deadline (--timeout here, to keep the test short),
// says which request went unanswered by which daemon, and exits non-zero.
#include <sys/wait.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <ostream>
#include <string>

#include "tests/clients/mocapctl/hanging_daemon.h"

namespace mocapctl {
namespace {

using ::testing::HasSubstr;

struct Outcome {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

// Runs mocapctl with `args`. A command with no deadline would wait for ever: coreutils' timeout
// ends it after a minute (exit code 124), so that shows as a failure, not a hung test.
Outcome mocapctl(const std::string& args) {
  Outcome run;
  const std::string command = "timeout -k 5 60 " MOCAP_BIN_DIR "/mocapctl " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return run;
  char buffer[4096];
  for (std::size_t n; (n = fread(buffer, 1, sizeof buffer, pipe)) > 0;)
    run.output.append(buffer, n);
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

struct Case {
  const char* command;  // the subcommand and its arguments
  const char* request;  // the request it makes first
  const char* name;     // of the test
};

void PrintTo(const Case& c, std::ostream* out) { *out << "mocapctl " << c.command; }

class DaemonCommands : public ::testing::TestWithParam<Case> {};

TEST_P(DaemonCommands, GiveUpOnADaemonThatNeverAnswers) {
  test::HangingDaemon daemon;
  const std::string command = GetParam().command;
  const Outcome run = mocapctl(command + " --server " + daemon.address() + " --timeout 1");
  ASSERT_NE(run.exit_code, 124) << command << " ran a minute: no deadline, or not --timeout's";
  EXPECT_EQ(run.exit_code, 1) << run.output;
  const std::string name = command.substr(0, command.find(' '));
  EXPECT_THAT(run.output, HasSubstr("mocapctl " + name + ": " + GetParam().request +
                                    ": DEADLINE_EXCEEDED: no answer from mocapd at " +
                                    daemon.address() + " within 1 s"));
}

INSTANTIATE_TEST_SUITE_P(
    EveryRequest, DaemonCommands,
    ::testing::Values(Case{"status", "GetStatus", "Status"},
                      Case{"skeleton", "GetSkeleton", "Skeleton"},
                      Case{"record start take", "StartRecording", "RecordStart"},
                      Case{"record stop", "StopRecording", "RecordStop"},
                      Case{"reacquire", "Reacquire", "Reacquire"},
                      Case{"background --frames 5", "CaptureBackground", "Background"},
                      Case{"fit-body --frames 1", "FitBody", "FitBody"},
                      Case{"bvh /dev/null --seconds 1", "GetSkeleton", "Bvh"}),
    [](const ::testing::TestParamInfo<Case>& test) { return std::string(test.param.name); });

}  // namespace
}  // namespace mocapctl
