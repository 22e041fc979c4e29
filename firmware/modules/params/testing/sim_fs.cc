#include "firmware/modules/params/testing/sim_fs.h"

#include <fcntl.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace mfns::fw::testing {

bool SimFs::Split(const char* path, std::string* name) const {
  const std::string p(path);
  if (p == dir_) {
    name->clear();
    return true;
  }
  if (p.size() > dir_.size() + 1 && p.compare(0, dir_.size(), dir_) == 0 && p[dir_.size()] == '/' &&
      p.find('/', dir_.size() + 1) == std::string::npos) {
    *name = p.substr(dir_.size() + 1);
    return true;
  }
  return false;
}

int SimFs::Open(const char* path, int flags, mode_t /*mode*/) {
  std::string name;
  if (!Split(path, &name)) {
    errno = ENOENT;
    return -1;
  }
  if (name.empty()) {
    if ((flags & O_ACCMODE) != O_RDONLY) {
      errno = EISDIR;
      return -1;
    }
    fds_[next_fd_] = Fd{};
    return next_fd_++;
  }
  if ((flags & O_DIRECTORY) != 0) {
    errno = names_.count(name) != 0 ? ENOTDIR : ENOENT;
    return -1;
  }
  auto it = names_.find(name);
  if (it == names_.end()) {
    if ((flags & O_CREAT) == 0) {
      errno = ENOENT;
      return -1;
    }
    inodes_.push_back(Inode{});
    it = names_.emplace(name, static_cast<int>(inodes_.size()) - 1).first;
  }
  const bool writable = (flags & O_ACCMODE) != O_RDONLY;
  if (writable && (flags & O_TRUNC) != 0) inodes_[static_cast<std::size_t>(it->second)].data.clear();
  fds_[next_fd_] = Fd{it->second, 0, writable};
  return next_fd_++;
}

int SimFs::Close(int fd) {
  if (fds_.erase(fd) == 0) {
    errno = EBADF;
    return -1;
  }
  return 0;
}

ssize_t SimFs::Read(int fd, void* buf, std::size_t n) {
  auto it = fds_.find(fd);
  if (it == fds_.end() || it->second.ino < 0) {
    errno = it == fds_.end() ? EBADF : EISDIR;
    return -1;
  }
  const auto& data = inodes_[static_cast<std::size_t>(it->second.ino)].data;
  const std::size_t pos = std::min(it->second.pos, data.size());
  const std::size_t k = std::min(n, data.size() - pos);
  if (k > 0) std::memcpy(buf, data.data() + pos, k);
  it->second.pos = pos + k;
  return static_cast<ssize_t>(k);
}

ssize_t SimFs::Write(int fd, const void* buf, std::size_t n) {
  auto it = fds_.find(fd);
  if (it == fds_.end() || it->second.ino < 0 || !it->second.writable) {
    errno = EBADF;
    return -1;
  }
  auto& data = inodes_[static_cast<std::size_t>(it->second.ino)].data;
  if (data.size() < it->second.pos + n) data.resize(it->second.pos + n);
  if (n > 0) std::memcpy(data.data() + it->second.pos, buf, n);
  it->second.pos += n;
  return static_cast<ssize_t>(n);
}

int SimFs::Fsync(int fd) {
  auto it = fds_.find(fd);
  if (it == fds_.end()) {
    errno = EBADF;
    return -1;
  }
  if (it->second.ino < 0) {
    durable_names_ = names_;
  } else {
    Inode& node = inodes_[static_cast<std::size_t>(it->second.ino)];
    node.durable = node.data;
  }
  return 0;
}

int SimFs::Rename(const char* from, const char* to) {
  std::string a, b;
  if (!Split(from, &a) || !Split(to, &b) || a.empty() || b.empty()) {
    errno = EXDEV;
    return -1;
  }
  auto it = names_.find(a);
  if (it == names_.end()) {
    errno = ENOENT;
    return -1;
  }
  const int ino = it->second;
  names_.erase(it);
  names_[b] = ino;
  return 0;
}

int SimFs::Unlink(const char* path) {
  std::string name;
  if (!Split(path, &name) || name.empty() || names_.erase(name) == 0) {
    errno = ENOENT;
    return -1;
  }
  return 0;
}

int SimFs::Mkdir(const char* path, mode_t /*mode*/) {
  std::string name;
  errno = Split(path, &name) && name.empty() ? EEXIST : EACCES;
  return -1;
}

int SimFs::Fstat(int fd, struct stat* st) {
  auto it = fds_.find(fd);
  if (it == fds_.end()) {
    errno = EBADF;
    return -1;
  }
  *st = {};
  st->st_dev = 1;
  st->st_ino = static_cast<ino_t>(it->second.ino + 2);  // the directory is inode 1
  st->st_mode = it->second.ino < 0 ? (S_IFDIR | 0755) : (S_IFREG | 0644);
  if (it->second.ino >= 0) st->st_size = static_cast<off_t>(inodes_[static_cast<std::size_t>(it->second.ino)].data.size());
  return 0;
}

int SimFs::Flock(int fd, int /*operation*/) {
  if (fds_.count(fd) == 0) {
    errno = EBADF;
    return -1;
  }
  return 0;
}

void SimFs::PowerCut(Crash crash) {
  fds_.clear();
  const bool keep_entries = crash == Crash::kProcessKill || crash == Crash::kKeepEntries;
  const bool keep_data = crash == Crash::kProcessKill || crash == Crash::kKeepData;
  if (!keep_entries) names_ = durable_names_;
  if (!keep_data) {
    for (Inode& node : inodes_) node.data = node.durable;
  }
  // What the machine sees after it comes back is now the durable state too.
  durable_names_ = names_;
  for (Inode& node : inodes_) node.durable = node.data;
}

void SimFs::PutFile(const std::string& name, const std::vector<std::uint8_t>& bytes, bool durable) {
  inodes_.push_back(Inode{bytes, durable ? bytes : std::vector<std::uint8_t>{}});
  names_[name] = static_cast<int>(inodes_.size()) - 1;
  if (durable) durable_names_[name] = names_[name];
}

std::vector<std::uint8_t> SimFs::FileBytes(const std::string& name) const {
  auto it = names_.find(name);
  return it == names_.end() ? std::vector<std::uint8_t>{} : inodes_[static_cast<std::size_t>(it->second)].data;
}

std::vector<std::string> SimFs::Names() const {
  std::vector<std::string> out;
  for (const auto& [name, ino] : names_) out.push_back(name);
  return out;
}

std::map<std::string, std::vector<std::uint8_t>> SimFs::Contents() const {
  std::map<std::string, std::vector<std::uint8_t>> out;
  for (const auto& [name, ino] : names_) out[name] = inodes_[static_cast<std::size_t>(ino)].data;
  return out;
}

}  // namespace mfns::fw::testing
