#include "firmware/modules/params/store_io.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>

#include "common/limits.h"

namespace mfns::fw {

int LinuxStoreIo::Open(const char* path, int flags, mode_t mode) { return ::open(path, flags, mode); }

int LinuxStoreIo::Close(int fd) { return ::close(fd); }

ssize_t LinuxStoreIo::Read(int fd, void* buf, std::size_t n) { return ::read(fd, buf, n); }

ssize_t LinuxStoreIo::Write(int fd, const void* buf, std::size_t n) { return ::write(fd, buf, n); }

int LinuxStoreIo::Fsync(int fd) { return ::fsync(fd); }

int LinuxStoreIo::Rename(const char* from, const char* to) { return std::rename(from, to); }

int LinuxStoreIo::Unlink(const char* path) { return ::unlink(path); }

int LinuxStoreIo::Mkdir(const char* path, mode_t mode) { return ::mkdir(path, mode); }

int LinuxStoreIo::Fstat(int fd, struct stat* st) { return ::fstat(fd, st); }

int LinuxStoreIo::Flock(int fd, int operation) { return ::flock(fd, operation); }

int OpenRegularForRead(StoreIo* io, const char* path, bool* not_regular, struct stat* out) {
  if (not_regular != nullptr) *not_regular = false;
  const int fd = io->Open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC, 0);
  if (fd < 0) return -1;
  struct stat local {};
  struct stat& st = out != nullptr ? *out : local;
  if (io->Fstat(fd, &st) != 0) {
    const int saved = errno;
    io->Close(fd);
    errno = saved;
    return -1;
  }
  if (!S_ISREG(st.st_mode)) {
    io->Close(fd);
    if (not_regular != nullptr) *not_regular = true;
    errno = EINVAL;
    return -1;
  }
  return fd;
}

ssize_t ReadAll(StoreIo* io, int fd, std::uint8_t* buf, std::size_t cap) {
  std::size_t got = 0;
  int interrupted = 0;
  const std::size_t max_passes = cap + limits::kMaxEintrRetries + 1;
  for (std::size_t pass = 0; pass < max_passes && got < cap; ++pass) {
    const ssize_t r = io->Read(fd, buf + got, cap - got);
    if (r < 0) {
      if (errno == EINTR && interrupted++ < limits::kMaxEintrRetries) continue;
      return -1;
    }
    if (r == 0) break;
    got += static_cast<std::size_t>(r);
  }
  return static_cast<ssize_t>(got);
}

bool WriteAll(StoreIo* io, int fd, std::span<const std::uint8_t> data) {
  std::size_t put = 0;
  int interrupted = 0;
  const std::size_t max_passes = data.size() + limits::kMaxEintrRetries + 1;
  for (std::size_t pass = 0; pass < max_passes && put < data.size(); ++pass) {
    const ssize_t r = io->Write(fd, data.data() + put, data.size() - put);
    if (r < 0) {
      if (errno == EINTR && interrupted++ < limits::kMaxEintrRetries) continue;
      return false;
    }
    if (r == 0) {
      errno = EIO;
      return false;
    }
    put += static_cast<std::size_t>(r);
  }
  if (put != data.size()) errno = EIO;
  return put == data.size();
}

StoreIo* DefaultStoreIo() {
  static LinuxStoreIo io;  // stateless; constructed once, no heap
  return &io;
}

}  // namespace mfns::fw
