// The thin seam between the V4L2 capture code and the kernel: the six syscalls it makes.
// LinuxV4l2Io calls libc; tests substitute FakeV4l2Io (fake_v4l2_io.h), an in-memory driver,
// so the real capture code runs on machines without cameras.
//
// Every method has its libc twin's contract: -1 (MAP_FAILED for Mmap) with errno set on error.
#pragma once

#include <poll.h>
#include <sys/types.h>

#include <cstddef>

namespace mfns::fw {

class V4l2Io {
 public:
  virtual ~V4l2Io() = default;
  virtual int Open(const char* path, int flags) = 0;
  virtual int Close(int fd) = 0;
  virtual int Ioctl(int fd, unsigned long request, void* arg) = 0;  // NOLINT(runtime/int)
  virtual void* Mmap(std::size_t length, int prot, int flags, int fd, off_t offset) = 0;
  virtual int Munmap(void* addr, std::size_t length) = 0;
  virtual int Poll(pollfd* fds, nfds_t nfds, int timeout_ms) = 0;
};

// The real thing: open(2), close(2), ioctl(2), mmap(2) (address chosen by the kernel),
// munmap(2), poll(2).
class LinuxV4l2Io final : public V4l2Io {
 public:
  int Open(const char* path, int flags) override;
  int Close(int fd) override;
  int Ioctl(int fd, unsigned long request, void* arg) override;  // NOLINT(runtime/int)
  void* Mmap(std::size_t length, int prot, int flags, int fd, off_t offset) override;
  int Munmap(void* addr, std::size_t length) override;
  int Poll(pollfd* fds, nfds_t nfds, int timeout_ms) override;
};

}  // namespace mfns::fw
