// mocapctl: command-line client of mocapd. Subcommands are listed once in kCommands; each lives in
// its own file. Some (calibrate, bvh --session) work without a running daemon.
#include <iostream>
#include <string>

#include "clients/mocapctl/commands.h"
#include "clients/mocapctl/daemon_commands.h"

namespace {

struct Command {
  const char* name;
  const char* usage;
  int (*run)(int argc, char** argv);  // argv[1] is the subcommand; its flags follow
};

constexpr Command kCommands[] = {
    {"calibrate", mocapctl::kCalibrateUsage, mocapctl::runCalibrate},
    {"stream", mocapctl::kStreamUsage, mocapctl::runStream},
    {"status", mocapctl::kStatusUsage, mocapctl::runStatus},
    {"skeleton", mocapctl::kSkeletonUsage, mocapctl::runSkeleton},
    {"record", mocapctl::kRecordUsage, mocapctl::runRecord},
    {"reacquire", mocapctl::kReacquireUsage, mocapctl::runReacquire},
    {"background", mocapctl::kBackgroundUsage, mocapctl::runBackground},
    {"fit-body", mocapctl::kFitBodyUsage, mocapctl::runFitBody},
    {"bvh", mocapctl::kBvhUsage, mocapctl::runBvh},
    {"bench", mocapctl::kBenchUsage, mocapctl::runBench},
};

void printUsage() {
  std::cerr << "usage: mocapctl <command> [flags]\n";
  for (const Command& c : kCommands) std::cerr << "  " << c.usage << "\n";
  std::cerr << "commands that talk to mocapd also take --server HOST:PORT (default "
               "127.0.0.1:50051), --token TOKEN (or $MOCAP_TOKEN), --tls-ca PEM (TLS, trusting "
               "the daemon's certificate), --tls-cert PEM --tls-key PEM (this client's, for a "
               "daemon that asks for one) and --timeout SECONDS (how long a request waits for the "
               "daemon's answer; by default 10 s to a few minutes, by what it asks; the pose "
               "stream has no limit)\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    printUsage();
    return argc < 2 ? 2 : 0;
  }
  const std::string name = argv[1];
  for (const Command& c : kCommands) {
    if (name != c.name) continue;
    try {
      return c.run(argc, argv);
    } catch (const std::exception& error) {
      std::cerr << "mocapctl " << name << ": " << error.what() << "\n";
      return 1;
    }
  }
  std::cerr << "mocapctl: unknown command '" << name << "'\n";
  printUsage();
  return 2;
}
