// The thin seam between the parameter store and the kernel: every file syscall the store
// makes. LinuxStoreIo calls libc; tests substitute wrappers that fail, crash or lose
// un-fsynced data at any chosen call (testing/fault_store_io.h, testing/sim_fs.h), so the
// power-cut behaviour of the real store code is tested call by call.
//
// Every method has its libc twin's contract: -1 with errno set on error.
#pragma once

#include <sys/stat.h>
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
  virtual int Fstat(int fd, struct stat* st) = 0;
  virtual int Flock(int fd, int operation) = 0;
};

// The real thing: open(2), close(2), read(2), write(2), fsync(2), rename(2), unlink(2),
// mkdir(2), fstat(2), flock(2).
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
  int Fstat(int fd, struct stat* st) override;
  int Flock(int fd, int operation) override;
};

// One process-wide LinuxStoreIo (stateless), for callers that do not inject a seam.
StoreIo* DefaultStoreIo();

// Opens path for reading without ever blocking: O_NONBLOCK, so a FIFO (or a device) named like
// a slot or a blob cannot hang the caller in open(2) or read(2), then fstat: only a regular
// file is returned (and its stat in *st, optional). -1 with errno set on failure; *not_regular
// (optional) is true when the file exists but is not a regular file (then errno is EINVAL and
// nothing stays open).
int OpenRegularForRead(StoreIo* io, const char* path, bool* not_regular, struct stat* st = nullptr);

// Reads until cap bytes or end of file, retrying EINTR at most limits::kMaxEintrRetries times;
// every pass moves a byte, ends or is such a retry, so the loop is bounded by cap + retries.
// Returns the byte count (== cap may mean more follows), or -1 with errno set.
ssize_t ReadAll(StoreIo* io, int fd, std::uint8_t* buf, std::size_t cap);

// Writes all of data, bounded like ReadAll; a write(2) of 0 bytes counts as EIO.
bool WriteAll(StoreIo* io, int fd, std::span<const std::uint8_t> data);

}  // namespace mfns::fw
