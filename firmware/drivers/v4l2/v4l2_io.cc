#include "firmware/drivers/v4l2/v4l2_io.h"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

namespace mfns::fw {

int LinuxV4l2Io::Open(const char* path, int flags) { return ::open(path, flags); }

int LinuxV4l2Io::Close(int fd) { return ::close(fd); }

int LinuxV4l2Io::Ioctl(int fd, unsigned long request, void* arg) {  // NOLINT(runtime/int)
  return ::ioctl(fd, request, arg);
}

void* LinuxV4l2Io::Mmap(std::size_t length, int prot, int flags, int fd, off_t offset) {
  return ::mmap(nullptr, length, prot, flags, fd, offset);
}

int LinuxV4l2Io::Munmap(void* addr, std::size_t length) { return ::munmap(addr, length); }

int LinuxV4l2Io::Poll(pollfd* fds, nfds_t nfds, int timeout_ms) {
  return ::poll(fds, nfds, timeout_ms);
}

}  // namespace mfns::fw
