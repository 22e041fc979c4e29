// A cheap, non-blocking "did the parameters change?" for mfns-navd's frame loop: watches up to
// two names in one directory (the store's two slots, or one --params blob file).
//
// kInotify: one inotify descriptor (IN_NONBLOCK) on the directory, opened at Start; Changed()
// drains the queue (at most limits::kMaxStoreEventReads reads) and reports whether any event
// named a watched entry: written and closed, renamed to or from, created or deleted. The
// store's temp files (slot-?.bin.tmp) never match, so an install is seen once, at its rename.
// kStat: fallback when inotify is unavailable (or forced): Changed() stat(2)s each name and
// compares inode, size, mtime and ctime with the last call.
// A queue overflow, or the directory itself going away, counts as a change. No heap; Changed()
// costs one read(2) (EAGAIN) per frame set when nothing happened.
#pragma once

#include <array>
#include <cstdint>
#include <ctime>

#include "common/limits.h"

namespace mfns::fw {

enum class WatchStatus : unsigned char {
  kOk = 0,
  kBadArgument,  // no names, more than two, empty or too long
  kError,        // the directory cannot be watched (and stat mode was not possible either)
};
const char* ToString(WatchStatus s);

class StoreWatcher {
 public:
  enum class Mode : unsigned char { kOff = 0, kInotify, kStat };
  static constexpr int kMaxNames = 2;

  StoreWatcher() = default;
  ~StoreWatcher();
  StoreWatcher(const StoreWatcher&) = delete;
  StoreWatcher& operator=(const StoreWatcher&) = delete;

  // Watches names (plain file names, no '/') in dir. force_stat skips inotify.
  WatchStatus Start(const char* dir, const char* const* names, int num_names, bool force_stat = false);
  // True when a watched entry changed since the last call (or since Start).
  bool Changed();
  void Stop();
  Mode mode() const { return mode_; }

  struct Counters {
    std::uint64_t polls = 0;
    std::uint64_t changes = 0;    // polls that returned true
    std::uint64_t events = 0;     // inotify events read (any name)
    std::uint64_t overflows = 0;  // IN_Q_OVERFLOW, or more queued than kMaxStoreEventReads reads
    std::uint64_t errors = 0;     // read(2) failures other than EAGAIN
  };
  const Counters& counters() const { return counters_; }

 private:
  struct Signature {
    bool exists = false;
    std::uint64_t ino = 0, dev = 0;
    std::int64_t size = 0;
    timespec mtime{}, ctime{};
  };
  bool Matches(const char* name) const;
  Signature StatName(int i) const;
  bool PollInotify();
  bool PollStat();

  Mode mode_ = Mode::kOff;
  int fd_ = -1;
  int num_names_ = 0;
  std::array<char, limits::kMaxPathChars + 1> dir_{};
  std::array<std::array<char, limits::kMaxPathChars + 1>, kMaxNames> names_{};
  std::array<Signature, kMaxNames> last_{};
  Counters counters_;
};

}  // namespace mfns::fw
