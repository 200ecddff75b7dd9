// The daemon under soak as a child process: the real mocapd binary, started, watched for an end
// nobody asked for (a crash), SIGKILLed and restarted, and its resident memory read from /proc.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <optional>
#include <string>

namespace mocap::soak {

class DaemonProcess {
 public:
  // `binary --config <config>`, its output appended to `log`.
  DaemonProcess(std::string binary, std::string config, std::string log);
  ~DaemonProcess();
  DaemonProcess(const DaemonProcess&) = delete;
  DaemonProcess& operator=(const DaemonProcess&) = delete;

  // Starts a new process; throws std::runtime_error if it cannot.
  void start();
  // Whether the process has ended by itself (without kill() or terminate()), and if so how
  // ("exit 1", "signal 11"); reaps it. Never blocks.
  std::optional<std::string> endedBySelf();
  // SIGKILL and wait: the daemon has no chance to close anything.
  void kill();
  // SIGTERM and wait up to `grace` (then SIGKILL). How it ended: "exit 0" is a clean shutdown.
  std::string terminate(std::chrono::seconds grace);
  // Resident memory in kB (VmRSS), 0 when no process runs. Safe from any thread.
  long residentKb() const;
  bool running() const { return pid_ > 0; }

 private:
  const std::string binary_, config_, log_;
  std::atomic<pid_t> pid_{0};
};

// How a waitpid() status ended: "exit N" or "signal N".
std::string describeEnd(int wait_status);

}  // namespace mocap::soak
