#include "firmware/modules/params/store_watcher.h"

#include <sys/inotify.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace mfns::fw {
namespace {

constexpr std::uint32_t kEventMask =
    IN_CLOSE_WRITE | IN_MOVED_TO | IN_MOVED_FROM | IN_CREATE | IN_DELETE | IN_DELETE_SELF | IN_MOVE_SELF;

bool SameTime(const timespec& a, const timespec& b) { return a.tv_sec == b.tv_sec && a.tv_nsec == b.tv_nsec; }

}  // namespace

const char* ToString(WatchStatus s) {
  switch (s) {
    case WatchStatus::kOk: return "ok";
    case WatchStatus::kBadArgument: return "bad watch argument (names or directory)";
    case WatchStatus::kError: return "cannot watch the directory";
  }
  return "unknown watch status";
}

StoreWatcher::~StoreWatcher() { Stop(); }

void StoreWatcher::Stop() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  mode_ = Mode::kOff;
}

WatchStatus StoreWatcher::Start(const char* dir, const char* const* names, int num_names, bool force_stat) {
  Stop();
  if (dir == nullptr || names == nullptr || num_names < 1 || num_names > kMaxNames) return WatchStatus::kBadArgument;
  const std::size_t dir_len = strnlen(dir, dir_.size());
  if (dir_len == 0 || dir_len >= dir_.size()) return WatchStatus::kBadArgument;
  std::memcpy(dir_.data(), dir, dir_len + 1);
  for (int i = 0; i < num_names; ++i) {
    const char* n = names[i];
    const std::size_t len = n != nullptr ? strnlen(n, names_[0].size()) : 0;
    if (len == 0 || len >= names_[0].size() || std::strchr(n, '/') != nullptr) return WatchStatus::kBadArgument;
    std::memcpy(names_[static_cast<std::size_t>(i)].data(), n, len + 1);
  }
  num_names_ = num_names;
  if (!force_stat) {
    fd_ = inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (fd_ >= 0 && inotify_add_watch(fd_, dir_.data(), kEventMask) >= 0) {
      mode_ = Mode::kInotify;
      return WatchStatus::kOk;
    }
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  // Stat mode: the directory must at least exist now.
  struct stat st {};
  if (::stat(dir_.data(), &st) != 0 || !S_ISDIR(st.st_mode)) return WatchStatus::kError;
  for (int i = 0; i < num_names_; ++i) last_[static_cast<std::size_t>(i)] = StatName(i);
  mode_ = Mode::kStat;
  return WatchStatus::kOk;
}

bool StoreWatcher::Matches(const char* name) const {
  for (int i = 0; i < num_names_; ++i) {
    if (std::strcmp(name, names_[static_cast<std::size_t>(i)].data()) == 0) return true;
  }
  return false;
}

bool StoreWatcher::Changed() {
  ++counters_.polls;
  bool changed = false;
  if (mode_ == Mode::kInotify) changed = PollInotify();
  if (mode_ == Mode::kStat) changed = PollStat();
  if (changed) ++counters_.changes;
  return changed;
}

bool StoreWatcher::PollInotify() {
  // Aligned for inotify_event; large enough for several events with NAME_MAX names.
  alignas(inotify_event) char buf[4096];
  bool changed = false;
  for (int r = 0; r < limits::kMaxStoreEventReads; ++r) {
    const ssize_t n = ::read(fd_, buf, sizeof buf);
    if (n < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) ++counters_.errors;
      return changed;
    }
    if (n == 0) return changed;
    // Walk the events; each has a fixed header and len bytes of NUL-padded name.
    std::size_t off = 0;
    for (int e = 0; e < static_cast<int>(sizeof buf) && off + sizeof(inotify_event) <= static_cast<std::size_t>(n);
         ++e) {
      const auto* ev = reinterpret_cast<const inotify_event*>(buf + off);
      ++counters_.events;
      if ((ev->mask & (IN_Q_OVERFLOW | IN_DELETE_SELF | IN_MOVE_SELF | IN_IGNORED)) != 0) {
        if ((ev->mask & IN_Q_OVERFLOW) != 0) ++counters_.overflows;
        changed = true;
      } else if (ev->len > 0 && Matches(ev->name)) {
        changed = true;
      }
      off += sizeof(inotify_event) + ev->len;
    }
  }
  // Still events after kMaxStoreEventReads reads: treat as changed (the caller rescans).
  ++counters_.overflows;
  return true;
}

StoreWatcher::Signature StoreWatcher::StatName(int i) const {
  Signature s;
  std::array<char, limits::kMaxPathChars * 2 + 2> path{};
  std::snprintf(path.data(), path.size(), "%s/%s", dir_.data(), names_[static_cast<std::size_t>(i)].data());
  struct stat st {};
  if (::stat(path.data(), &st) != 0) return s;
  s.exists = true;
  s.ino = static_cast<std::uint64_t>(st.st_ino);
  s.dev = static_cast<std::uint64_t>(st.st_dev);
  s.size = static_cast<std::int64_t>(st.st_size);
  s.mtime = st.st_mtim;
  s.ctime = st.st_ctim;
  return s;
}

bool StoreWatcher::PollStat() {
  bool changed = false;
  for (int i = 0; i < num_names_; ++i) {
    const Signature now = StatName(i);
    Signature& was = last_[static_cast<std::size_t>(i)];
    if (now.exists != was.exists || now.ino != was.ino || now.dev != was.dev || now.size != was.size ||
        !SameTime(now.mtime, was.mtime) || !SameTime(now.ctime, was.ctime)) {
      changed = true;
    }
    was = now;
  }
  return changed;
}

}  // namespace mfns::fw
