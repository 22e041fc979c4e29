// The thin seam between the parameter store and the kernel: every file syscall the store
// makes. LinuxStoreIo calls libc; tests substitute wrappers that fail, crash or lose
// un-fsynced data at any chosen call (testing/fault_store_io.h, testing/sim_fs.h), so the
// power-cut behaviour of the real store code is tested call by call.
//
// Every method has its libc twin's contract: -1 with errno set on error.
#pragma once

#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <span>

namespace mfns::fw {

class StoreIo {
 public:
  virtual ~StoreIo() = default;
  virtual int Open(const char* path, int flags, mode_t mode) = 0;
  virtual int Close(int fd) = 0;
  virtual ssize_t Read(int fd, void* buf, std::size_t n) = 0;
  virtual ssize_t Write(int fd, const void* buf, std::size_t n) = 0;
  virtual int Fsync(int fd) = 0;
  virtual int Rename(const char* from, const char* to) = 0;
  virtual int Unlink(const char* path) = 0;
  virtual int Mkdir(const char* path, mode_t mode) = 0;
};

// The real thing: open(2), close(2), read(2), write(2), fsync(2), rename(2), unlink(2),
// mkdir(2).
class LinuxStoreIo final : public StoreIo {
 public:
  int Open(const char* path, int flags, mode_t mode) override;
  int Close(int fd) override;
  ssize_t Read(int fd, void* buf, std::size_t n) override;
  ssize_t Write(int fd, const void* buf, std::size_t n) override;
  int Fsync(int fd) override;
  int Rename(const char* from, const char* to) override;
  int Unlink(const char* path) override;
  int Mkdir(const char* path, mode_t mode) override;
};

// One process-wide LinuxStoreIo (stateless), for callers that do not inject a seam.
StoreIo* DefaultStoreIo();

// Reads until cap bytes or end of file, retrying EINTR at most limits::kMaxEintrRetries times;
// every pass moves a byte, ends or is such a retry, so the loop is bounded by cap + retries.
// Returns the byte count (== cap may mean more follows), or -1 with errno set.
ssize_t ReadAll(StoreIo* io, int fd, std::uint8_t* buf, std::size_t cap);

// Writes all of data, bounded like ReadAll; a write(2) of 0 bytes counts as EIO.
bool WriteAll(StoreIo* io, int fd, std::span<const std::uint8_t> data);

}  // namespace mfns::fw
