// The V4L2 driver's only door to the operating system: device-node listing, open/close, ioctl,
// mmap/munmap and poll. The driver takes an implementation of this seam so the tests can replace
// the kernel with an emulation of its V4L2 protocol.
#pragma once

#include <poll.h>
#include <sys/types.h>

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace mocap {

// Same contracts as the libc functions of the same names: failures return -1 (MAP_FAILED for
// mmap) and set errno. Implementations must be safe to call from several threads at once.
class V4l2Syscalls {
 public:
  virtual ~V4l2Syscalls() = default;
  // Candidate device nodes (/dev/video*), sorted by their number.
  virtual std::vector<std::string> listDeviceNodes() = 0;
  virtual int open(const std::string& path, int flags) = 0;
  virtual int close(int fd) = 0;
  virtual int ioctl(int fd, unsigned long request, void* arg) = 0;
  virtual void* mmap(size_t length, int prot, int flags, int fd, off_t offset) = 0;
  virtual int munmap(void* address, size_t length) = 0;
  virtual int poll(pollfd* fds, nfds_t count, int timeout_ms) = 0;
};

// The seam backed by the real kernel.
std::shared_ptr<V4l2Syscalls> makeSystemV4l2Syscalls();

}  // namespace mocap
