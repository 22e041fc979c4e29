// What mfns-navd uses to get its calibration: `--params FILE|DIR` (DESIGN.md, "Firmware").
//
//   ParamLoader loader;                                   // at start (owns ~40 KB of buffers)
//   if (loader.Open(path, expected_rig_id_or_null, &rig, &info) != StoreStatus::kOk) {
//     char why[256]; loader.Describe(why, sizeof why);     // e.g. "slot-a.bin: missing; ..."
//     refuse to navigate, print why, exit 1
//   }
//   between frame sets:
//   if (reload_requested_by_SIGHUP || loader.Changed()) {
//     Rig next; BlobInfo next_info;
//     if (loader.Reload(&next, &next_info) == StoreStatus::kOk && !SameBlob(next_info, info)) {
//       switch to next (log its generation); else keep the current rig (log why, count)
//   }
//
// DIR is a parameter store (param_store.h: newest valid slot wins); anything else is read as
// one blob file. expected_rig_id (optional) makes a blob for another rig invalid. Changed() is
// a StoreWatcher (store_watcher.h) on the two slot names or on the file, started by Open: no
// signal is needed for a reload, SIGHUP from mfns-paramctl just makes it immediate.
// No heap; Open, Changed and Reload are bounded.
#pragma once

#include <array>
#include <cstddef>

#include "common/blob/param_blob.h"
#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/params/param_store.h"
#include "firmware/modules/params/store_io.h"
#include "firmware/modules/params/store_watcher.h"

namespace mfns::fw {

class ParamLoader {
 public:
  explicit ParamLoader(StoreIo* io = DefaultStoreIo());
  ParamLoader(const ParamLoader&) = delete;
  ParamLoader& operator=(const ParamLoader&) = delete;

  // path: a store directory or a blob file. expected_rig_id: nullptr = any (copied).
  // kOk: *rig, *info hold the newest valid blob and the watcher runs. Otherwise *rig and *info
  // are untouched and Describe() says why (kNotFound, kNoValidBlob, kIoError, kBadPath).
  // force_stat_watch: use the stat fallback instead of inotify (tests, odd file systems).
  StoreStatus Open(const char* path, const char* expected_rig_id, Rig* rig, BlobInfo* info,
                   bool force_stat_watch = false);

  // From now on only blobs for rig `id` are valid (nullptr: any). navd pins the id of the rig
  // it started with, so that a reload never switches to another flyer's parameters.
  void ExpectRigId(const char* id);

  // Non-blocking: true when a slot (or the file) changed since the last call.
  bool Changed() { return watcher_.Changed(); }

  // Loads again by the same rule; *rig and *info untouched unless kOk.
  StoreStatus Reload(Rig* rig, BlobInfo* info);

  // One line: which slot/file is in use and why the others are not, or why nothing is valid.
  void Describe(char* buf, std::size_t n) const;

  bool is_store() const { return is_store_; }
  // Slot of the last successful load (-1 for a blob file or before any).
  int active_slot() const { return is_store_ ? snapshot_.active : -1; }
  const StoreSnapshot& snapshot() const { return snapshot_; }
  const StoreWatcher& watcher() const { return watcher_; }
  const StoreCounters& store_counters() const { return store_.counters(); }

 private:
  StoreStatus LoadFile(Rig* rig, BlobInfo* info);

  StoreIo* io_;
  ParamStore store_;
  StoreWatcher watcher_;
  bool is_store_ = false;
  StoreStatus last_ = StoreStatus::kNotFound;
  int last_errno_ = 0;
  std::array<char, limits::kMaxPathChars + 1> path_{};
  std::array<char, limits::kMaxRigIdChars + 1> expected_{};
  bool has_expected_ = false;
  StoreSnapshot snapshot_;  // for a file: slots[0] describes it
  std::array<std::uint8_t, limits::kMaxBlobBytes + 1> file_bytes_{};
};

}  // namespace mfns::fw
