// The daemon under soak as a child process: fork and exec, waitpid, /proc/<pid>/status.
#include "daemon_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <stdexcept>
#include <thread>

namespace mocap::soak {

std::string describeEnd(int wait_status) {
  if (WIFEXITED(wait_status)) return "exit " + std::to_string(WEXITSTATUS(wait_status));
  if (WIFSIGNALED(wait_status)) return "signal " + std::to_string(WTERMSIG(wait_status));
  return "status " + std::to_string(wait_status);
}

DaemonProcess::DaemonProcess(std::string binary, std::string config, std::string log)
    : binary_(std::move(binary)), config_(std::move(config)), log_(std::move(log)) {}

DaemonProcess::~DaemonProcess() {
  if (running()) kill();
}

void DaemonProcess::start() {
  if (running()) throw std::runtime_error("the daemon already runs");
  const int log = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (log < 0) throw std::runtime_error("cannot open " + log_ + ": " + std::strerror(errno));
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    dup2(log, STDOUT_FILENO);
    dup2(log, STDERR_FILENO);
    execl(binary_.c_str(), binary_.c_str(), "--config", config_.c_str(), nullptr);
    _exit(127);
  }
  ::close(log);
  pid_ = pid;
}

std::optional<std::string> DaemonProcess::endedBySelf() {
  if (!running()) return std::nullopt;
  int status = 0;
  if (waitpid(pid_, &status, WNOHANG) != pid_) return std::nullopt;
  pid_ = 0;
  return describeEnd(status);
}

void DaemonProcess::kill() {
  if (!running()) return;
  ::kill(pid_, SIGKILL);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = 0;
}

std::string DaemonProcess::terminate(std::chrono::seconds grace) {
  if (!running()) return "not running";
  ::kill(pid_, SIGTERM);
  const auto give_up = std::chrono::steady_clock::now() + grace;
  int status = 0;
  while (waitpid(pid_, &status, WNOHANG) != pid_) {
    if (std::chrono::steady_clock::now() > give_up) {
      kill();
      return "did not stop within " + std::to_string(grace.count()) + " s of SIGTERM";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  pid_ = 0;
  return describeEnd(status);
}

long DaemonProcess::residentKb() const {
  const pid_t pid = pid_;
  if (pid <= 0) return 0;
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return 0;
}

}  // namespace mocap::soak
