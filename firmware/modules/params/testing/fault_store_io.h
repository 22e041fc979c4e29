// Test support: a StoreIo wrapper that logs every call and makes the N-th call fail, or makes
// the process "die" at the N-th call or after N bytes of a temp file were written (every later
// call fails with EIO, so nothing of the store's own cleanup reaches the disk). A hook before
// each call lets a forked child SIGKILL itself at a chosen call. Test code: allocates freely.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "firmware/modules/params/store_io.h"

namespace mfns::fw::testing {

class FaultStoreIo final : public StoreIo {
 public:
  explicit FaultStoreIo(StoreIo* inner) : inner_(inner) {}

  // Call number k (0-based, counting every call) and all later ones fail with EIO.
  void DieAtCall(int k) { die_at_call_ = k; }
  // Only call number k fails, with errno err; later calls go through.
  void FailAtCall(int k, int err = EIO) {
    fail_at_call_ = k;
    fail_errno_ = err;
  }
  // Writes to "*.tmp" files pass only until `bytes` bytes went through in total; the call that
  // would cross it writes the remainder, then the process is dead.
  void DieAfterTempBytes(std::size_t bytes) { temp_byte_budget_ = static_cast<long long>(bytes); }
  // Every read and write moves at most this many bytes (short transfers, 0 = no limit).
  void ShortTransfers(std::size_t max_bytes) { short_ = max_bytes; }
  // Called before each call with its index and log text.
  std::function<void(int, const std::string&)> before_call;

  int calls() const { return calls_; }
  bool dead() const { return dead_; }
  // One entry per call: "open slot-a.bin.tmp", "write slot-a.bin.tmp 1234", "fsync slot-a.bin.tmp",
  // "fsync <dir>", "rename slot-a.bin.tmp slot-a.bin", ... (paths relative to the last '/').
  const std::vector<std::string>& log() const { return log_; }

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

 private:
  // Logs the call, runs the hook; false when this call must fail (errno set).
  bool Enter(const std::string& text);
  std::string FdName(int fd) const;

  StoreIo* inner_;
  int calls_ = 0;
  int die_at_call_ = -1;
  int fail_at_call_ = -1;
  int fail_errno_ = EIO;
  long long temp_byte_budget_ = -1;  // NOLINT(runtime/int)
  std::size_t short_ = 0;
  bool dead_ = false;
  std::vector<std::string> log_;
  std::map<int, std::string> fd_names_;
};

}  // namespace mfns::fw::testing
