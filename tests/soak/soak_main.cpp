// mocap-soak: a fault and load soak of the real mocapd binary on loopback, bounded in time. Fake
// cameras drop frames, stall, vanish and come back; 50 subscribers read (some stall, some
// reconnect every second); a recording starts every cycle; once, mid-recording, the daemon is
// SIGKILLed and restarted. It prints a JSON report and exits 1 if a target is missed.
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>

#include "soak_run.h"

namespace {

namespace fs = std::filesystem;
using mocap::soak::SoakOptions;

constexpr const char* kUsage = R"(usage: mocap-soak [options]
  --seconds N          how long to run (default 600)
  --mocapd PATH        the daemon (default: mocapd beside this program)
  --work DIR           its configuration, log and recordings (default: a fresh temporary folder)
  --out FILE           also write the JSON report there
  --cycle N            seconds from one recording's start to the next (default 30)
  --record N           seconds each recording lasts (default 10)
  --warmup N           seconds after each start before memory growth is measured (default 60)
  --live N --stalled N --reconnecting N   subscribers of each kind (default 30, 10, 10)
  --keep               keep the recordings (by default each is deleted once checked)
)";

[[noreturn]] void usage(const std::string& error) {
  std::cerr << "mocap-soak: " << error << "\n" << kUsage;
  std::exit(2);
}

int number(int argc, char** argv, int& i) {
  if (i + 1 >= argc) usage(std::string(argv[i]) + " needs a value");
  const std::string text = argv[++i];
  try {
    std::size_t used = 0;
    const int value = std::stoi(text, &used);
    if (used == text.size() && value >= 0) return value;
  } catch (const std::exception&) {
  }
  usage(std::string(argv[i - 1]) + ": expected a whole number, got '" + text + "'");
}

SoakOptions parseOptions(int argc, char** argv) {
  SoakOptions options;
  options.mocapd = (fs::canonical("/proc/self/exe").parent_path() / "mocapd").string();
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto text = [&] {
      if (i + 1 >= argc) usage(arg + " needs a value");
      return std::string(argv[++i]);
    };
    if (arg == "--seconds")
      options.seconds = number(argc, argv, i);
    else if (arg == "--mocapd")
      options.mocapd = text();
    else if (arg == "--work")
      options.work = text();
    else if (arg == "--out")
      options.out = text();
    else if (arg == "--cycle")
      options.cycle_seconds = number(argc, argv, i);
    else if (arg == "--record")
      options.record_seconds = number(argc, argv, i);
    else if (arg == "--warmup")
      options.warmup_seconds = number(argc, argv, i);
    else if (arg == "--live")
      options.live = number(argc, argv, i);
    else if (arg == "--stalled")
      options.stalled = number(argc, argv, i);
    else if (arg == "--reconnecting")
      options.reconnecting = number(argc, argv, i);
    else if (arg == "--keep")
      options.keep = true;
    else if (arg == "--help" || arg == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else {
      usage("unknown option " + arg);
    }
  }
  if (options.cycle_seconds < 4 || options.record_seconds < 2 ||
      options.record_seconds >= options.cycle_seconds)
    usage("needs --cycle of at least 4 s and --record from 2 s to less than --cycle");
  if (options.seconds < options.cycle_seconds) usage("--seconds is shorter than one --cycle");
  if (options.work.empty())
    options.work =
        (fs::temp_directory_path() / ("mocap-soak-" + std::to_string(getpid()))).string();
  // Absolute: the daemon reads the paths in its configuration from the configuration's folder.
  options.work = fs::absolute(options.work).string();
  return options;
}

// A port nobody listens on now, for the daemon to keep across its restart.
int freePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof address;
  if (bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
    std::cerr << "mocap-soak: cannot find a free port\n";
    std::exit(1);
  }
  close(fd);
  return ntohs(address.sin_port);
}

}  // namespace

int main(int argc, char** argv) {
  SoakOptions options = parseOptions(argc, argv);
  options.port = freePort();
  const nlohmann::json report = mocap::soak::runSoak(options);
  const std::string text = report.dump(2);
  std::cout << text << std::endl;
  if (!options.out.empty()) std::ofstream(options.out) << text << "\n";
  return report.value("pass", false) ? 0 : 1;
}
