// Test support: an in-memory file system for one directory that models what survives a power
// cut. Each file has its current bytes and the bytes made durable by its last fsync; the
// directory has its current entries and the entries made durable by its last fsync. PowerCut
// then keeps or drops each kind of un-fsynced state, so the store's fsync order is tested
// against the POSIX worst cases (the rename survived but the data did not, and so on).
// Test code: allocates freely.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "firmware/modules/params/store_io.h"

namespace mfns::fw::testing {

class SimFs final : public StoreIo {
 public:
  // What a crash keeps of the state not yet fsynced.
  enum class Crash : unsigned char {
    kProcessKill = 0,  // everything (the kernel's page cache survives a killed process)
    kLoseAll,          // nothing: entries and data revert to their last fsync
    kKeepEntries,      // un-fsynced renames/creates survive, un-fsynced data is lost
    kKeepData,         // un-fsynced data survives, un-fsynced entries are lost
  };
  static constexpr Crash kAllCrashes[] = {Crash::kProcessKill, Crash::kLoseAll, Crash::kKeepEntries,
                                          Crash::kKeepData};

  explicit SimFs(std::string dir) : dir_(std::move(dir)) {}

  int Open(const char* path, int flags, mode_t mode) override;
  int Close(int fd) override;
  ssize_t Read(int fd, void* buf, std::size_t n) override;
  ssize_t Write(int fd, const void* buf, std::size_t n) override;
  int Fsync(int fd) override;
  int Rename(const char* from, const char* to) override;
  int Unlink(const char* path) override;
  int Mkdir(const char* path, mode_t mode) override;
  int Fstat(int fd, struct stat* st) override;  // a regular file, or the directory
  int Flock(int fd, int operation) override;    // one process: always granted

  // The machine loses power (or the process dies): open descriptors vanish, and un-fsynced
  // state is kept or dropped as crash says.
  void PowerCut(Crash crash);

  // Direct access for tests (current state).
  void PutFile(const std::string& name, const std::vector<std::uint8_t>& bytes, bool durable = true);
  bool HasFile(const std::string& name) const { return names_.count(name) != 0; }
  std::vector<std::uint8_t> FileBytes(const std::string& name) const;
  std::vector<std::string> Names() const;
  // Every current entry with its bytes (to tell apart the states two crashes leave).
  std::map<std::string, std::vector<std::uint8_t>> Contents() const;
  int open_fds() const { return static_cast<int>(fds_.size()); }
  const std::string& dir() const { return dir_; }

 private:
  struct Inode {
    std::vector<std::uint8_t> data, durable;
  };
  struct Fd {
    int ino = -1;  // -1: the directory itself
    std::size_t pos = 0;
    bool writable = false;
  };
  // name inside dir_ for path, "" for dir_ itself; false when path is elsewhere.
  bool Split(const char* path, std::string* name) const;

  std::string dir_;
  std::vector<Inode> inodes_;
  std::map<std::string, int> names_, durable_names_;
  std::map<int, Fd> fds_;
  int next_fd_ = 100;
};

}  // namespace mfns::fw::testing
