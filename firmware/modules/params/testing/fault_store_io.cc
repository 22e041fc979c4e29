#include "firmware/modules/params/testing/fault_store_io.h"

#include <algorithm>
#include <cerrno>

namespace mfns::fw::testing {
namespace {

std::string Base(const char* path) {
  const std::string p(path);
  const std::size_t slash = p.rfind('/');
  return slash == std::string::npos ? p : (slash + 1 == p.size() ? p : p.substr(slash + 1));
}

bool EndsWith(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

bool FaultStoreIo::Enter(const std::string& text) {
  const int k = calls_++;
  log_.push_back(text);
  if (before_call) before_call(k, text);
  if (k == die_at_call_) dead_ = true;
  if (dead_ || k == fail_at_call_) {
    errno = dead_ ? EIO : fail_errno_;
    return false;
  }
  return true;
}

std::string FaultStoreIo::FdName(int fd) const {
  auto it = fd_names_.find(fd);
  return it == fd_names_.end() ? "?" : it->second;
}

int FaultStoreIo::Open(const char* path, int flags, mode_t mode) {
  if (!Enter("open " + Base(path))) return -1;
  const int fd = inner_->Open(path, flags, mode);
  if (fd >= 0) fd_names_[fd] = Base(path);
  return fd;
}

int FaultStoreIo::Close(int fd) {
  const std::string name = FdName(fd);
  if (!Enter("close " + name)) {
    // A dead process's descriptors are closed by the kernel; a failed close(2) closes it too.
    inner_->Close(fd);
    fd_names_.erase(fd);
    return -1;
  }
  fd_names_.erase(fd);
  return inner_->Close(fd);
}

ssize_t FaultStoreIo::Read(int fd, void* buf, std::size_t n) {
  if (!Enter("read " + FdName(fd))) return -1;
  return inner_->Read(fd, buf, short_ > 0 ? std::min(n, short_) : n);
}

ssize_t FaultStoreIo::Write(int fd, const void* buf, std::size_t n) {
  const std::string name = FdName(fd);
  if (!Enter("write " + name + " " + std::to_string(n))) return -1;
  if (short_ > 0) n = std::min(n, short_);
  if (temp_byte_budget_ >= 0 && EndsWith(name, ".tmp")) {
    if (static_cast<long long>(n) > temp_byte_budget_) {  // NOLINT(runtime/int)
      // The writer dies in the middle of this write: only the budget reaches the file.
      if (temp_byte_budget_ > 0) inner_->Write(fd, buf, static_cast<std::size_t>(temp_byte_budget_));
      temp_byte_budget_ = 0;
      dead_ = true;
      errno = EIO;
      return -1;
    }
    temp_byte_budget_ -= static_cast<long long>(n);  // NOLINT(runtime/int)
  }
  return inner_->Write(fd, buf, n);
}

int FaultStoreIo::Fsync(int fd) {
  if (!Enter("fsync " + FdName(fd))) return -1;
  return inner_->Fsync(fd);
}

int FaultStoreIo::Rename(const char* from, const char* to) {
  if (!Enter("rename " + Base(from) + " " + Base(to))) return -1;
  return inner_->Rename(from, to);
}

int FaultStoreIo::Unlink(const char* path) {
  if (!Enter("unlink " + Base(path))) return -1;
  return inner_->Unlink(path);
}

int FaultStoreIo::Mkdir(const char* path, mode_t mode) {
  if (!Enter("mkdir " + Base(path))) return -1;
  return inner_->Mkdir(path, mode);
}

int FaultStoreIo::Fstat(int fd, struct stat* st) {
  if (!Enter("fstat " + FdName(fd))) return -1;
  return inner_->Fstat(fd, st);
}

int FaultStoreIo::Flock(int fd, int operation) {
  if (!Enter("flock " + FdName(fd))) return -1;
  return inner_->Flock(fd, operation);
}

}  // namespace mfns::fw::testing
