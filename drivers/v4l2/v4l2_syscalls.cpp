// The V4L2 syscall seam backed by libc and the real kernel.
#include "drivers/v4l2/v4l2_syscalls.h"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <system_error>

namespace mocap {
namespace {

// The number after "video" in a node name, or -1 when the name is not /dev/videoN.
int videoNodeNumber(const std::string& name) {
  constexpr std::string_view kPrefix = "video";
  if (name.rfind(kPrefix, 0) != 0 || name.size() == kPrefix.size()) return -1;
  int number = -1;
  const char* first = name.data() + kPrefix.size();
  const char* last = name.data() + name.size();
  auto [end, error] = std::from_chars(first, last, number);
  return (error == std::errc() && end == last) ? number : -1;
}

class SystemV4l2Syscalls final : public V4l2Syscalls {
 public:
  std::vector<std::string> listDeviceNodes() override {
    std::vector<std::pair<int, std::string>> nodes;
    std::error_code error;
    for (const auto& entry : std::filesystem::directory_iterator("/dev", error)) {
      const int number = videoNodeNumber(entry.path().filename().string());
      if (number >= 0) nodes.emplace_back(number, entry.path().string());
    }
    std::sort(nodes.begin(), nodes.end());
    std::vector<std::string> paths;
    for (auto& node : nodes) paths.push_back(std::move(node.second));
    return paths;
  }
  int open(const std::string& path, int flags) override { return ::open(path.c_str(), flags); }
  int close(int fd) override { return ::close(fd); }
  int ioctl(int fd, unsigned long request, void* arg) override { return ::ioctl(fd, request, arg); }
  void* mmap(size_t length, int prot, int flags, int fd, off_t offset) override {
    return ::mmap(nullptr, length, prot, flags, fd, offset);
  }
  int munmap(void* address, size_t length) override { return ::munmap(address, length); }
  int poll(pollfd* fds, nfds_t count, int timeout_ms) override {
    return ::poll(fds, count, timeout_ms);
  }
};

}  // namespace

std::shared_ptr<V4l2Syscalls> makeSystemV4l2Syscalls() {
  return std::make_shared<SystemV4l2Syscalls>();
}

}  // namespace mocap
