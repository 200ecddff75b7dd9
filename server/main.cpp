// mocapd: the motion-capture daemon. Reads its configuration, starts the cameras, the tracker and
// the gRPC service, and runs until SIGTERM or SIGINT, which end the streams, close the recording
// and exit 0.
#include <pthread.h>
#include <signal.h>

#include <chrono>
#include <cstring>
#include <iostream>
#include <string>
#include <thread>

#include "drivers/builtin_drivers.h"
#include "server/config.h"
#include "server/log.h"
#include "server/mocap_server.h"

namespace {

constexpr const char* kUsage = R"(usage: mocapd [options]
  --config FILE           YAML configuration (default: the built-in fake two-camera scene)
  --listen HOST:PORT      overrides the configuration's listen address (default 127.0.0.1:50051)
  --log-level LEVEL       debug, info, warning or error
  --list-cameras          print every camera every compiled-in driver sees, then exit
  --replay DIR            track a recorded session instead of the cameras; exits at its end
  --as-fast-as-possible   replay without waiting for the recorded pace
  --recorded-silhouettes  replay the silhouettes the session recorded instead of extracting them
                          from its images again (the same ones, without decoding an image)
  --help                  this text
)";

struct Flags {
  std::string config_path;
  std::string listen;
  std::string log_level;
  std::string replay;
  bool list_cameras = false;
  bool as_fast_as_possible = false;
  bool recorded_silhouettes = false;
};

// Exits with status 2 and a message on a bad command line.
Flags parseFlags(int argc, char** argv) {
  Flags flags;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::cerr << "mocapd: " << arg << " needs a value\n" << kUsage;
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--config") {
      flags.config_path = value();
    } else if (arg == "--listen") {
      flags.listen = value();
    } else if (arg == "--log-level") {
      flags.log_level = value();
    } else if (arg == "--replay") {
      flags.replay = value();
    } else if (arg == "--list-cameras") {
      flags.list_cameras = true;
    } else if (arg == "--as-fast-as-possible") {
      flags.as_fast_as_possible = true;
    } else if (arg == "--recorded-silhouettes") {
      flags.recorded_silhouettes = true;
    } else if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else {
      std::cerr << "mocapd: unknown option '" << arg << "'\n" << kUsage;
      std::exit(2);
    }
  }
  if (flags.as_fast_as_possible && flags.replay.empty()) {
    std::cerr << "mocapd: --as-fast-as-possible applies to --replay only\n";
    std::exit(2);
  }
  if (flags.recorded_silhouettes && flags.replay.empty()) {
    std::cerr << "mocapd: --recorded-silhouettes applies to --replay only\n";
    std::exit(2);
  }
  return flags;
}

}  // namespace

int main(int argc, char** argv) {
  const Flags flags = parseFlags(argc, argv);
  mocap::registerBuiltinDrivers(mocap::DriverRegistry::instance());
  if (flags.list_cameras) {
    std::cout << mocap::describeAvailableCameras();
    return 0;
  }

  mocap::ServerConfig config;
  try {
    config = flags.config_path.empty()
                 ? mocap::parseConfig(mocap::kDefaultConfigYaml, "<embedded default>", ".")
                 : mocap::loadConfigFile(flags.config_path);
  } catch (const mocap::ConfigError& e) {
    std::cerr << "mocapd: " << e.what() << "\n";
    return 2;
  }
  if (!flags.listen.empty()) config.listen = flags.listen;
  if (!flags.log_level.empty()) {
    const std::optional<mocap::LogLevel> level = mocap::parseLogLevel(flags.log_level);
    if (!level) {
      std::cerr << "mocapd: --log-level: expected debug, info, warning or error\n";
      return 2;
    }
    config.log_level = *level;
  }
  config.replay_directory = flags.replay;
  config.as_fast_as_possible = flags.as_fast_as_possible;
  config.recorded_silhouettes = flags.recorded_silhouettes;
  mocap::setLogLevel(config.log_level);

  // Blocked before any thread exists, so every thread inherits the mask and only sigwait below
  // sees them. SIGUSR1 is the replay's own "finished" signal.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGUSR1);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  mocap::Expected<std::unique_ptr<mocap::MocapServer>> created = mocap::MocapServer::create(config);
  if (!created.ok()) {
    mocap::logError() << created.error();
    return 1;
  }
  mocap::MocapServer& server = *created.value();
  const auto start_time = std::chrono::steady_clock::now();
  if (const mocap::Status started = server.start(); !started.ok()) {
    mocap::logError() << started.message();
    return 1;
  }
  if (config.replay()) {
    std::thread([&server, start_time] {
      server.pipeline().waitForReplayEnd();
      // The replay's own pace: the daemon's set-up and shutdown left out.
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
      const uint64_t poses = server.pipeline().status().poses_published;
      mocap::logInfo() << "replay: " << poses << " poses in " << seconds << " s ("
                       << static_cast<double>(poses) / seconds << " a second)";
      kill(getpid(), SIGUSR1);
    }).detach();
  }

  int received = 0;
  sigwait(&signals, &received);
  if (received == SIGUSR1) {
    mocap::logInfo() << "replay finished";
  } else {
    mocap::logInfo() << "received " << strsignal(received) << ", shutting down";
  }
  server.shutdown();
  return 0;
}
