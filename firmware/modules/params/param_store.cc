#include "firmware/modules/params/param_store.h"

#include <fcntl.h>
#include <sys/file.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace mfns::fw {
namespace {

constexpr const char* kSlotNames[kNumSlots] = {"slot-a.bin", "slot-b.bin"};
constexpr const char* kTempSuffix = ".tmp";
constexpr const char* kAsideSuffix = ".rolled-back";
constexpr mode_t kFileMode = 0644;
constexpr mode_t kDirMode = 0755;

void SetError(StoreError* err, StoreStep step) {
  if (err == nullptr) return;
  err->step = step;
  err->error = errno;
}

// The newest valid slot (ties: the lower index), or -1.
int PickActive(const StoreSnapshot& snap) {
  int best = -1;
  for (int i = 0; i < kNumSlots; ++i) {
    const SlotReport& r = snap.slots[static_cast<std::size_t>(i)];
    if (r.state != SlotState::kValid) continue;
    if (best < 0 || r.info.generation > snap.slots[static_cast<std::size_t>(best)].info.generation) best = i;
  }
  return best;
}

}  // namespace

const char* SlotFileName(int slot) {
  return slot >= 0 && slot < kNumSlots ? kSlotNames[slot] : nullptr;
}

const char* ToString(StoreStatus s) {
  switch (s) {
    case StoreStatus::kOk: return "ok";
    case StoreStatus::kBadPath: return "store path empty or too long";
    case StoreStatus::kNotFound: return "no such store directory or blob file";
    case StoreStatus::kNoValidBlob: return "no valid parameter blob";
    case StoreStatus::kIoError: return "I/O error";
    case StoreStatus::kBlobTooLarge: return "blob larger than limits::kMaxBlobBytes";
    case StoreStatus::kCorruptBlob: return "corrupt blob";
    case StoreStatus::kRigIdMismatch: return "blob is for another rig id than the active one";
    case StoreStatus::kStaleGeneration: return "generation not newer than the active one";
    case StoreStatus::kVerifyFailed: return "read-back verification failed";
    case StoreStatus::kNoRollbackTarget: return "the other slot holds no valid blob";
    case StoreStatus::kBusy: return "another install or rollback holds the store lock";
    case StoreStatus::kTooFewBeacons: return "the blob maps too few beacons to navigate";
    case StoreStatus::kCount: break;
  }
  return "unknown store status";
}

const char* ToString(SlotState s) {
  switch (s) {
    case SlotState::kMissing: return "missing";
    case SlotState::kValid: return "valid";
    case SlotState::kInvalid: return "invalid";
    case SlotState::kTooLarge: return "too large";
    case SlotState::kUnreadable: return "unreadable";
    case SlotState::kNotRegular: return "not a regular file, skipped";
  }
  return "unknown slot state";
}

const char* ToString(StoreStep s) {
  switch (s) {
    case StoreStep::kNone: return "none";
    case StoreStep::kMkdir: return "mkdir";
    case StoreStep::kOpenDirectory: return "open directory";
    case StoreStep::kReadSlot: return "read slot";
    case StoreStep::kOpenTemp: return "open temp file";
    case StoreStep::kWriteTemp: return "write temp file";
    case StoreStep::kFsyncTemp: return "fsync temp file";
    case StoreStep::kCloseTemp: return "close temp file";
    case StoreStep::kRename: return "rename temp file to slot";
    case StoreStep::kFsyncDirectory: return "fsync directory";
    case StoreStep::kReadBack: return "read back slot";
    case StoreStep::kSetAside: return "rename slot aside";
    case StoreStep::kLock: return "lock store directory";
  }
  return "unknown step";
}

bool SameBlob(const BlobInfo& a, const BlobInfo& b) {
  return a.generation == b.generation && a.payload_crc32 == b.payload_crc32 &&
         a.payload_bytes == b.payload_bytes && std::strncmp(a.rig_id.data(), b.rig_id.data(), a.rig_id.size()) == 0;
}

void DescribeSnapshot(const StoreSnapshot& snap, char* buf, std::size_t n) {
  if (buf == nullptr || n == 0) return;
  buf[0] = '\0';
  std::size_t used = 0;
  for (int i = 0; i < kNumSlots; ++i) {
    const SlotReport& r = snap.slots[static_cast<std::size_t>(i)];
    const char* sep = i == 0 ? "" : "; ";
    int w = 0;
    switch (r.state) {
      case SlotState::kValid:
        w = std::snprintf(buf + used, n - used, "%s%s: generation %llu, rig %s%s", sep, kSlotNames[i],
                          static_cast<unsigned long long>(r.info.generation), r.info.rig_id.data(),
                          i == snap.active ? " (active)" : "");
        break;
      case SlotState::kInvalid:
        w = std::snprintf(buf + used, n - used, "%s%s: %s", sep, kSlotNames[i], ToString(r.blob_status));
        break;
      case SlotState::kUnreadable:
        w = std::snprintf(buf + used, n - used, "%s%s: unreadable: %s", sep, kSlotNames[i], std::strerror(r.error));
        break;
      case SlotState::kMissing:
      case SlotState::kTooLarge:
      case SlotState::kNotRegular:
        w = std::snprintf(buf + used, n - used, "%s%s: %s", sep, kSlotNames[i], ToString(r.state));
        break;
    }
    if (w < 0) return;
    used += static_cast<std::size_t>(w);
    if (used >= n) return;  // truncated, still NUL-terminated by snprintf
  }
}

ParamStore::ParamStore(StoreIo* io) : io_(io != nullptr ? io : DefaultStoreIo()) {}

StoreStatus ParamStore::Count(StoreStatus s) {
  ++counters_.by_status[static_cast<std::size_t>(s)];
  return s;
}

StoreStatus ParamStore::SetDirectory(const char* dir) {
  dir_[0] = '\0';
  if (dir == nullptr || dir[0] == '\0') return Count(StoreStatus::kBadPath);
  const std::size_t len = strnlen(dir, dir_.size());
  if (len >= dir_.size()) return Count(StoreStatus::kBadPath);
  std::memcpy(dir_.data(), dir, len + 1);
  return StoreStatus::kOk;
}

bool ParamStore::MakePath(PathBuffer* out, int slot, const char* suffix) const {
  const int w = std::snprintf(out->data(), out->size(), "%s/%s%s", dir_.data(), kSlotNames[slot], suffix);
  return w > 0 && static_cast<std::size_t>(w) < out->size();
}

// slot-X.bin.PID.tmp: unique per process, so even a writer that ignores the lock cannot
// truncate or rename another's temp file.
bool ParamStore::MakeTempPath(PathBuffer* out, int slot) const {
  const int w = std::snprintf(out->data(), out->size(), "%s/%s.%ld%s", dir_.data(), kSlotNames[slot],
                              static_cast<long>(::getpid()), kTempSuffix);  // NOLINT(runtime/int)
  return w > 0 && static_cast<std::size_t>(w) < out->size();
}

// The writers' lock: flock on the store directory itself (no lock file to create or leave).
// Polled every millisecond rather than blocking, so the wait is bounded (kBusy after
// lock_timeout_ms_); the kernel drops the lock when its holder dies.
StoreStatus ParamStore::Lock(int* fd, StoreError* err) {
  *fd = io_->Open(dir_.data(), O_RDONLY | O_DIRECTORY | O_CLOEXEC, 0);
  if (*fd < 0) {
    const bool missing = errno == ENOENT || errno == ENOTDIR;
    SetError(err, StoreStep::kOpenDirectory);
    return missing ? StoreStatus::kNotFound : StoreStatus::kIoError;
  }
  for (int waited = 0; waited <= lock_timeout_ms_; ++waited) {
    if (io_->Flock(*fd, LOCK_EX | LOCK_NB) == 0) return StoreStatus::kOk;
    if (errno != EWOULDBLOCK && errno != EINTR) break;
    ++counters_.lock_waits;
    const timespec one_ms{0, 1'000'000};
    ::nanosleep(&one_ms, nullptr);
  }
  const bool busy = errno == EWOULDBLOCK || errno == EINTR;
  if (busy) errno = EWOULDBLOCK;
  SetError(err, StoreStep::kLock);
  const int saved = errno;
  io_->Close(*fd);
  errno = saved;
  *fd = -1;
  return busy ? StoreStatus::kBusy : StoreStatus::kIoError;
}

void ParamStore::Unlock(int fd) {
  if (fd >= 0) io_->Close(fd);  // closing the descriptor releases the flock
}

// Whether path is (still) the file id names.
bool ParamStore::IsFile(const PathBuffer& path, const FileId& id) {
  struct stat st {};
  const int fd = OpenRegularForRead(io_, path.data(), nullptr, &st);
  if (fd < 0) return false;
  io_->Close(fd);
  return st.st_dev == id.dev && st.st_ino == id.ino;
}

std::span<const std::uint8_t> ParamStore::slot_bytes(int slot) const {
  if (slot < 0 || slot >= kNumSlots) return {};
  const auto i = static_cast<std::size_t>(slot);
  return {slot_bytes_[i].data(), slot_size_[i]};
}

StoreStatus ParamStore::CreateDirectory(StoreError* err) {
  if (dir_[0] == '\0') return Count(StoreStatus::kBadPath);
  if (io_->Mkdir(dir_.data(), kDirMode) != 0) {
    if (errno == EEXIST) return StoreStatus::kOk;
    SetError(err, StoreStep::kMkdir);
    return Count(errno == ENOENT ? StoreStatus::kNotFound : StoreStatus::kIoError);
  }
  // Make the new directory entry durable: fsync the parent ("." for a relative single name).
  PathBuffer parent{};
  std::memcpy(parent.data(), dir_.data(), dir_.size());
  char* slash = std::strrchr(parent.data(), '/');
  if (slash == nullptr) {
    std::snprintf(parent.data(), parent.size(), ".");
  } else if (slash == parent.data()) {
    slash[1] = '\0';  // "/name": the parent is "/"
  } else {
    *slash = '\0';
  }
  return FsyncDirectory(parent.data(), err);
}

StoreStatus ParamStore::FsyncDirectory(const char* path, StoreError* err) {
  const int fd = io_->Open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC, 0);
  if (fd < 0) {
    SetError(err, StoreStep::kOpenDirectory);
    return StoreStatus::kIoError;
  }
  if (io_->Fsync(fd) != 0) {
    SetError(err, StoreStep::kFsyncDirectory);
    const int saved = errno;
    io_->Close(fd);
    errno = saved;
    return StoreStatus::kIoError;
  }
  io_->Close(fd);  // a close error after a successful fsync loses nothing
  return StoreStatus::kOk;
}

void ParamStore::ReadSlot(int slot, const char* expected_rig_id, SlotReport* r) {
  *r = SlotReport{};
  const auto i = static_cast<std::size_t>(slot);
  slot_size_[i] = 0;
  PathBuffer path{};
  if (!MakePath(&path, slot, "")) {
    r->state = SlotState::kUnreadable;
    r->error = ENAMETOOLONG;
    return;
  }
  bool not_regular = false;
  const int fd = OpenRegularForRead(io_, path.data(), &not_regular);
  if (fd < 0) {
    if (not_regular) {  // a FIFO would block the read, a device never end it: skip, say so
      r->state = SlotState::kNotRegular;
      ++counters_.not_regular_slots;
      return;
    }
    if (errno == ENOENT) return;  // kMissing
    r->state = SlotState::kUnreadable;
    r->error = errno;
    ++counters_.unreadable_slots;
    return;
  }
  const ssize_t got = ReadAll(io_, fd, slot_bytes_[i].data(), slot_bytes_[i].size());
  const int read_errno = errno;
  io_->Close(fd);
  if (got < 0) {
    r->state = SlotState::kUnreadable;
    r->error = read_errno;
    ++counters_.unreadable_slots;
    return;
  }
  slot_size_[i] = static_cast<std::size_t>(got);
  r->bytes = slot_size_[i];
  if (r->bytes > limits::kMaxBlobBytes) {
    r->state = SlotState::kTooLarge;
    r->blob_status = BlobStatus::kTooLarge;
    ++counters_.invalid_slots[static_cast<std::size_t>(BlobStatus::kTooLarge)];
    return;
  }
  const std::span<const std::uint8_t> bytes(slot_bytes_[i].data(), r->bytes);
  r->header_valid = DecodeBlobHeader(bytes, &r->info) == BlobStatus::kOk;
  r->blob_status = DecodeParamBlob(bytes, expected_rig_id, &scratch_, &r->info);
  if (r->blob_status != BlobStatus::kOk) {
    r->state = SlotState::kInvalid;
    ++counters_.invalid_slots[static_cast<std::size_t>(r->blob_status)];
    return;
  }
  r->state = SlotState::kValid;
  r->num_cameras = scratch_.num_cameras;
  r->num_beacons = scratch_.num_beacons;
}

StoreStatus ParamStore::Scan(const char* expected_rig_id, StoreSnapshot* snap) {
  *snap = StoreSnapshot{};
  scan_error_ = StoreError{};
  ++counters_.scans;
  if (dir_[0] == '\0') return Count(StoreStatus::kBadPath);
  const int dfd = io_->Open(dir_.data(), O_RDONLY | O_DIRECTORY | O_CLOEXEC, 0);
  if (dfd < 0) {
    const bool missing = errno == ENOENT || errno == ENOTDIR;
    SetError(&scan_error_, StoreStep::kOpenDirectory);
    return Count(missing ? StoreStatus::kNotFound : StoreStatus::kIoError);
  }
  io_->Close(dfd);
  for (int i = 0; i < kNumSlots; ++i) ReadSlot(i, expected_rig_id, &snap->slots[static_cast<std::size_t>(i)]);
  snap->active = PickActive(*snap);
  return Count(snap->active >= 0 ? StoreStatus::kOk : StoreStatus::kNoValidBlob);
}

StoreStatus ParamStore::Load(const char* expected_rig_id, Rig* rig, BlobInfo* info, StoreSnapshot* snap) {
  StoreSnapshot local;
  StoreSnapshot* s = snap != nullptr ? snap : &local;
  const StoreStatus st = Scan(expected_rig_id, s);
  if (st != StoreStatus::kOk) return st;
  // Decode again from the bytes already read: the same bytes Scan judged, no second read.
  // It cannot fail (Scan decoded them); the decoder touches *rig only on kOk.
  const BlobStatus b = DecodeParamBlob(slot_bytes(s->active), expected_rig_id, rig, info);
  return b == BlobStatus::kOk ? StoreStatus::kOk : Count(StoreStatus::kNoValidBlob);
}

bool ParamStore::WriteTemp(const PathBuffer& tmp, std::span<const std::uint8_t> blob, FileId* id, StoreError* err) {
  const int fd = io_->Open(tmp.data(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, kFileMode);
  if (fd < 0) {
    SetError(err, StoreStep::kOpenTemp);
    return false;
  }
  StoreStep failed = StoreStep::kNone;
  struct stat st {};
  if (io_->Fstat(fd, &st) != 0) {  // the inode this install writes: its undo removes only that
    failed = StoreStep::kOpenTemp;
  } else if (!WriteAll(io_, fd, blob)) {
    failed = StoreStep::kWriteTemp;
  } else if (io_->Fsync(fd) != 0) {
    failed = StoreStep::kFsyncTemp;
  }
  if (failed != StoreStep::kNone) {
    SetError(err, failed);
    io_->Close(fd);
    return false;
  }
  id->dev = st.st_dev;
  id->ino = st.st_ino;
  if (io_->Close(fd) != 0) {  // e.g. a deferred write error on a network file system
    SetError(err, StoreStep::kCloseTemp);
    return false;
  }
  return true;
}

bool ParamStore::ReadBackMatches(int slot, std::span<const std::uint8_t> blob, StoreError* err) {
  SlotReport r;
  ReadSlot(slot, nullptr, &r);
  if (r.state == SlotState::kUnreadable || r.state == SlotState::kMissing) {
    if (err != nullptr) {
      err->step = StoreStep::kReadBack;
      err->error = r.state == SlotState::kMissing ? ENOENT : r.error;
    }
    return false;
  }
  const auto bytes = slot_bytes(slot);
  return r.state == SlotState::kValid && bytes.size() == blob.size() &&
         std::memcmp(bytes.data(), blob.data(), blob.size()) == 0;
}

// After a failure past the rename: remove the new slot so the old blob stays the newest valid
// one, but only while it is still the file this install wrote (never another writer's slot).
// Best effort; if this fails too the slot holds the complete new blob (it was fsynced before
// the rename), which is also a valid outcome.
void ParamStore::UndoInstall(int slot, const FileId& written) {
  PathBuffer path{};
  if (!MakePath(&path, slot, "") || !IsFile(path, written) || io_->Unlink(path.data()) != 0 ||
      FsyncDirectory(dir_.data(), nullptr) != StoreStatus::kOk) {
    ++counters_.cleanup_failures;
  }
}

StoreStatus ParamStore::Install(std::span<const std::uint8_t> blob, const InstallOptions& options,
                                InstallReport* report) {
  InstallReport local;
  InstallReport* rep = report != nullptr ? report : &local;
  *rep = InstallReport{};
  if (dir_[0] == '\0') return Count(StoreStatus::kBadPath);
  if (blob.size() > limits::kMaxBlobBytes) {
    rep->blob_status = BlobStatus::kTooLarge;
    Scan(nullptr, &rep->after);  // report what stays active
    return Count(StoreStatus::kBlobTooLarge);
  }
  rep->blob_status = DecodeParamBlob(blob, nullptr, &scratch_, &rep->new_info);
  if (rep->blob_status != BlobStatus::kOk) {
    Scan(nullptr, &rep->after);
    return Count(StoreStatus::kCorruptBlob);
  }
  // A blob the navigator would refuse at its next start never becomes the active one (the
  // store would then hold nothing navd can fly on until a rollback).
  rep->new_beacons = scratch_.num_beacons;
  if (scratch_.num_beacons < limits::kMinNavBeacons) {
    Scan(nullptr, &rep->after);
    return Count(StoreStatus::kTooFewBeacons);
  }
  // From the scan that judges the store to the last rename: one writer at a time.
  int lock_fd = -1;
  const StoreStatus locked = Lock(&lock_fd, &rep->io);
  if (locked != StoreStatus::kOk) {
    if (locked != StoreStatus::kNotFound) Scan(nullptr, &rep->after);
    return Count(locked);
  }
  const StoreStatus s = LockedInstall(blob, options, rep);
  Unlock(lock_fd);
  return s;
}

StoreStatus ParamStore::LockedInstall(std::span<const std::uint8_t> blob, const InstallOptions& options,
                                      InstallReport* rep) {
  StoreSnapshot before;
  const StoreStatus scanned = Scan(nullptr, &before);
  rep->after = before;
  if (scanned == StoreStatus::kNotFound || scanned == StoreStatus::kIoError || scanned == StoreStatus::kBadPath) {
    rep->io = scan_error_;
    return scanned;  // Scan counted it
  }
  // Never judge a store we cannot read: an unreadable slot might be the active one.
  for (int i = 0; i < kNumSlots; ++i) {
    const SlotReport& r = before.slots[static_cast<std::size_t>(i)];
    if (r.state == SlotState::kUnreadable) {
      rep->io = StoreError{StoreStep::kReadSlot, r.error};
      return Count(StoreStatus::kIoError);
    }
  }
  bool older_or_equal = false;
  if (before.active >= 0) {
    rep->had_active = true;
    rep->old_slot = before.active;
    rep->old_info = before.slots[static_cast<std::size_t>(before.active)].info;
    older_or_equal = rep->new_info.generation <= rep->old_info.generation;
    if (!options.allow_rig_change &&
        std::strncmp(rep->new_info.rig_id.data(), rep->old_info.rig_id.data(), rep->new_info.rig_id.size()) != 0) {
      return Count(StoreStatus::kRigIdMismatch);
    }
    if (older_or_equal && !options.force) return Count(StoreStatus::kStaleGeneration);
  }

  const int target = before.active < 0 ? 0 : 1 - before.active;
  rep->slot = target;
  PathBuffer tmp{}, slot_path{};
  if (!MakeTempPath(&tmp, target) || !MakePath(&slot_path, target, "")) return Count(StoreStatus::kBadPath);

  // 1. Temp file: write, fsync, close. A failure here leaves both slots as they were.
  FileId written;
  if (!WriteTemp(tmp, blob, &written, &rep->io)) {
    if (io_->Unlink(tmp.data()) != 0 && errno != ENOENT) ++counters_.cleanup_failures;
    Scan(nullptr, &rep->after);
    return Count(StoreStatus::kIoError);
  }
  // 2. Atomic replace of the inactive slot, then make the new name durable.
  if (io_->Rename(tmp.data(), slot_path.data()) != 0) {
    SetError(&rep->io, StoreStep::kRename);
    if (io_->Unlink(tmp.data()) != 0 && errno != ENOENT) ++counters_.cleanup_failures;
    Scan(nullptr, &rep->after);
    return Count(StoreStatus::kIoError);
  }
  if (FsyncDirectory(dir_.data(), &rep->io) != StoreStatus::kOk) {
    UndoInstall(target, written);
    Scan(nullptr, &rep->after);
    return Count(StoreStatus::kIoError);
  }
  // 3. Read back and verify: same bytes, full decode.
  if (!ReadBackMatches(target, blob, &rep->io)) {
    UndoInstall(target, written);
    Scan(nullptr, &rep->after);
    return Count(rep->io.step == StoreStep::kReadBack ? StoreStatus::kIoError : StoreStatus::kVerifyFailed);
  }
  // 4. Forced older/equal generation: set the newer old slot aside so newest-wins picks ours.
  if (older_or_equal) {
    PathBuffer old_path{}, aside{};
    if (!MakePath(&old_path, before.active, "") || !MakePath(&aside, before.active, kAsideSuffix)) {
      return Count(StoreStatus::kBadPath);
    }
    if (io_->Rename(old_path.data(), aside.data()) != 0) {
      SetError(&rep->io, StoreStep::kSetAside);
      UndoInstall(target, written);
      Scan(nullptr, &rep->after);
      return Count(StoreStatus::kIoError);
    }
    if (FsyncDirectory(dir_.data(), &rep->io) != StoreStatus::kOk) {
      // Put the old slot back (then the old blob is active again) and drop ours.
      if (io_->Rename(aside.data(), old_path.data()) != 0) ++counters_.cleanup_failures;
      UndoInstall(target, written);
      Scan(nullptr, &rep->after);
      return Count(StoreStatus::kIoError);
    }
  }
  // Done: the new blob is durable, verified and the newest valid one. The scan below only
  // reports the store as it now reads (an I/O error in it changes nothing on disk).
  Scan(nullptr, &rep->after);
  ++counters_.installs;
  return Count(StoreStatus::kOk);
}

StoreStatus ParamStore::Rollback(RollbackReport* report) {
  RollbackReport local;
  RollbackReport* rep = report != nullptr ? report : &local;
  *rep = RollbackReport{};
  if (dir_[0] == '\0') return Count(StoreStatus::kBadPath);
  int lock_fd = -1;
  const StoreStatus locked = Lock(&lock_fd, &rep->io);
  if (locked != StoreStatus::kOk) {
    if (locked != StoreStatus::kNotFound) Scan(nullptr, &rep->after);
    return Count(locked);
  }
  const StoreStatus s = LockedRollback(rep);
  Unlock(lock_fd);
  return s;
}

StoreStatus ParamStore::LockedRollback(RollbackReport* rep) {
  const StoreStatus scanned = Scan(nullptr, &rep->before);
  rep->after = rep->before;
  if (scanned != StoreStatus::kOk) {
    rep->io = scan_error_;
    return scanned;
  }
  for (int i = 0; i < kNumSlots; ++i) {
    const SlotReport& r = rep->before.slots[static_cast<std::size_t>(i)];
    if (r.state == SlotState::kUnreadable) {
      rep->io = StoreError{StoreStep::kReadSlot, r.error};
      return Count(StoreStatus::kIoError);
    }
  }
  const int from = rep->before.active;
  const int to = 1 - from;
  rep->from_slot = from;
  rep->to_slot = to;
  if (rep->before.slots[static_cast<std::size_t>(to)].state != SlotState::kValid) {
    return Count(StoreStatus::kNoRollbackTarget);
  }
  PathBuffer path{}, aside{};
  if (!MakePath(&path, from, "") || !MakePath(&aside, from, kAsideSuffix)) return Count(StoreStatus::kBadPath);
  if (io_->Rename(path.data(), aside.data()) != 0) {
    SetError(&rep->io, StoreStep::kSetAside);
    Scan(nullptr, &rep->after);
    return Count(StoreStatus::kIoError);
  }
  if (FsyncDirectory(dir_.data(), &rep->io) != StoreStatus::kOk) {
    if (io_->Rename(aside.data(), path.data()) != 0) ++counters_.cleanup_failures;
    Scan(nullptr, &rep->after);
    return Count(StoreStatus::kIoError);
  }
  Scan(nullptr, &rep->after);  // report only, as after an install
  ++counters_.rollbacks;
  return Count(StoreStatus::kOk);
}

}  // namespace mfns::fw
