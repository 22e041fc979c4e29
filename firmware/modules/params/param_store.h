// The parameter store on the flyer (DESIGN.md, "Contracts: Parameter store"): a directory with
// two slots, slot-a.bin and slot-b.bin, each holding one parameter blob (common/blob).
//
// Rules (README.md in this folder has the power-cut argument in full):
//  - Active slot = the valid slot with the newest generation (ties: slot a). "Valid" means the
//    whole blob decodes (CRCs, sections, ValidateRig) and, when the caller names one, carries
//    the expected rig id. The same rule picks the blob at start and on every reload.
//  - Every writer (Install, Rollback; any process: mfns-paramctl, mfns-flash) holds an exclusive
//    flock on the store directory from its first scan to its last rename, so concurrent writers
//    take turns: each one judges the store as the one before it left it, and a failed install's
//    undo can only remove the slot this install wrote (it also checks the inode). Readers
//    (Scan, Load, navd) take no lock: every change they can see is one atomic rename.
//  - Install writes the new blob to the other slot: slot-X.bin.PID.tmp, write, fsync, close,
//    rename to slot-X.bin, fsync of the directory, then reads slot-X.bin back and checks it
//    (same bytes, full decode). The active slot is never written, so a power cut at any point
//    leaves the old blob or the new one active, never nothing and never a mix.
//  - Install refuses (old blob still active, nothing written): a blob that does not decode, a
//    rig id other than the active blob's (unless allow_rig_change), a generation <= the active
//    one (unless force).
//  - A forced install of an older or equal generation, and a rollback, make the wanted slot the
//    newest valid one by renaming the other slot aside to slot-Y.bin.rolled-back (one atomic
//    rename, then fsync of the directory): newest-wins needs no selection file.
//
// No heap and no exceptions: the store holds two slot buffers of limits::kMaxBlobBytes + 1
// bytes and one scratch Rig (about 40 KB in all); every loop is bounded. Every syscall goes
// through StoreIo (store_io.h). One ParamStore per thread; any number of ParamStores and
// processes on one directory (the lock). A slot that is not a regular file (a FIFO, a device)
// is never opened blocking nor read: it is reported kNotRegular and skipped.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "common/blob/param_blob.h"
#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/modules/params/store_io.h"

namespace mfns::fw {

inline constexpr int kNumSlots = 2;

// "slot-a.bin" / "slot-b.bin" for slot 0 / 1; nullptr otherwise.
const char* SlotFileName(int slot);

enum class StoreStatus : unsigned char {
  kOk = 0,
  kBadPath,           // empty, or longer than limits::kMaxPathChars
  kNotFound,          // the store directory (or the --params file) does not exist
  kNoValidBlob,       // no slot (or the --params file) holds a valid blob: StoreSnapshot says why
  kIoError,           // a syscall failed: StoreError names the step and errno
  kBlobTooLarge,      // install: more than limits::kMaxBlobBytes
  kCorruptBlob,       // install: the new blob does not decode (blob_status says why)
  kRigIdMismatch,     // install: rig id other than the active blob's
  kStaleGeneration,   // install: generation <= the active blob's
  kVerifyFailed,      // install: the slot read back differs or does not decode
  kNoRollbackTarget,  // rollback: the other slot holds no valid blob
  kBusy,              // install/rollback: another writer held the store lock past the timeout
  kTooFewBeacons,     // install: the blob decodes but maps fewer than limits::kMinNavBeacons
                      // beacons (mfns-navd would refuse it at its next start)
  kCount,
};
const char* ToString(StoreStatus s);
inline constexpr int kNumStoreStatuses = static_cast<int>(StoreStatus::kCount);

enum class SlotState : unsigned char {
  kMissing = 0,  // no such file
  kValid,
  kInvalid,      // present but does not decode: blob_status says why
  kTooLarge,     // more than limits::kMaxBlobBytes
  kUnreadable,   // open or read failed: error holds errno
  kNotRegular,   // not a regular file (a FIFO, a device, a directory): skipped, never read
};
const char* ToString(SlotState s);

// The syscall step an I/O failure happened in (for one-line reasons).
enum class StoreStep : unsigned char {
  kNone = 0,
  kMkdir,
  kOpenDirectory,
  kReadSlot,
  kOpenTemp,
  kWriteTemp,
  kFsyncTemp,
  kCloseTemp,
  kRename,
  kFsyncDirectory,
  kReadBack,
  kSetAside,  // renaming a slot to slot-?.bin.rolled-back
  kLock,      // flock of the store directory
};
const char* ToString(StoreStep s);

struct StoreError {
  StoreStep step = StoreStep::kNone;
  int error = 0;  // errno of the failed call (0 when none)
};

struct SlotReport {
  SlotState state = SlotState::kMissing;
  BlobStatus blob_status = BlobStatus::kOk;  // kInvalid: why
  BlobInfo info;           // valid once the header decoded (kValid, and kInvalid past the header)
  bool header_valid = false;
  std::size_t bytes = 0;   // file size read (kValid, kInvalid)
  int error = 0;           // kUnreadable: errno
  int num_cameras = 0;     // kValid only
  int num_beacons = 0;     // kValid only
};

struct StoreSnapshot {
  std::array<SlotReport, kNumSlots> slots{};
  int active = -1;  // newest valid slot; -1 when none
};

struct InstallOptions {
  bool force = false;             // accept a generation <= the active one (it becomes active)
  bool allow_rig_change = false;  // accept a rig id other than the active blob's
};

struct InstallReport {
  BlobStatus blob_status = BlobStatus::kOk;  // the new blob's decode status (kCorruptBlob: why)
  BlobInfo new_info;      // the new blob's header, when it decoded that far
  int new_beacons = 0;    // beacons the new blob maps, when it decoded
  bool had_active = false;
  BlobInfo old_info;      // the blob active before the install (had_active)
  int old_slot = -1;
  int slot = -1;          // the slot written (-1 when refused before writing)
  StoreError io;          // kIoError: where and why
  StoreSnapshot after;    // the store as scanned after the call, also after a failure
};

struct RollbackReport {
  int from_slot = -1;     // the slot set aside
  int to_slot = -1;       // the slot active afterwards
  StoreError io;
  StoreSnapshot before;
  StoreSnapshot after;
};

struct StoreCounters {
  std::uint64_t scans = 0;
  std::uint64_t installs = 0;    // successful
  std::uint64_t rollbacks = 0;   // successful
  std::array<std::uint64_t, kNumStoreStatuses> by_status{};      // results of every call
  std::array<std::uint64_t, kNumBlobStatuses> invalid_slots{};   // per BlobStatus seen on scans
  std::uint64_t unreadable_slots = 0;
  std::uint64_t not_regular_slots = 0;  // slots skipped on scans: not a regular file
  std::uint64_t lock_waits = 0;         // lock attempts that found another writer holding it
  std::uint64_t cleanup_failures = 0;  // undo after a failure itself failed (store still safe)
};

// Whether two headers name the same blob (rig id, generation, payload CRC and length).
bool SameBlob(const BlobInfo& a, const BlobInfo& b);

class ParamStore {
 public:
  explicit ParamStore(StoreIo* io = DefaultStoreIo());
  ParamStore(const ParamStore&) = delete;
  ParamStore& operator=(const ParamStore&) = delete;

  // Sets the store directory (copied; kBadPath when empty or too long). No I/O.
  StoreStatus SetDirectory(const char* dir);
  const char* directory() const { return dir_.data(); }

  // Creates the store directory if it is missing (mkdir 0755, then fsync of its parent).
  StoreStatus CreateDirectory(StoreError* err);

  // Reads and checks both slots. expected_rig_id: nullptr accepts any rig id, otherwise a slot
  // with another id is invalid (kRigIdMismatch). kOk when a slot is valid; kNoValidBlob when
  // none is; kNotFound when the directory is missing. *snap is always filled.
  StoreStatus Scan(const char* expected_rig_id, StoreSnapshot* snap);

  // Scan, then decode the active slot into *rig and *info (both untouched unless kOk).
  StoreStatus Load(const char* expected_rig_id, Rig* rig, BlobInfo* info, StoreSnapshot* snap);

  // Installs blob (at most limits::kMaxBlobBytes; must not alias the store). kOk: the new blob
  // is durable and active. Refusals (kCorruptBlob, kRigIdMismatch, kStaleGeneration,
  // kBlobTooLarge) write nothing. A failed syscall or read-back (kIoError, kVerifyFailed) is
  // undone as far as possible, so the old blob stays active; report->after says what is.
  StoreStatus Install(std::span<const std::uint8_t> blob, const InstallOptions& options,
                      InstallReport* report);

  // How long Install and Rollback wait for another writer's lock before kBusy (polled every
  // millisecond: a bounded wait, and a writer killed mid-way frees the lock with its fd).
  void set_lock_timeout_ms(int ms) { lock_timeout_ms_ = ms < 0 ? 0 : ms; }

  // Makes the other valid slot active by renaming the active one aside to slot-?.bin.rolled-back.
  // kNoValidBlob when nothing is active, kNoRollbackTarget when the other slot is not valid.
  StoreStatus Rollback(RollbackReport* report);

  // The bytes of a slot as last read by Scan (valid until the next call).
  std::span<const std::uint8_t> slot_bytes(int slot) const;

  const StoreCounters& counters() const { return counters_; }
  // Why the last Scan could not open the directory (step kNone when it could).
  const StoreError& scan_error() const { return scan_error_; }

 private:
  using PathBuffer = std::array<char, limits::kMaxPathChars + 32>;
  struct FileId {
    dev_t dev = 0;
    ino_t ino = 0;
  };
  bool MakePath(PathBuffer* out, int slot, const char* suffix) const;
  bool MakeTempPath(PathBuffer* out, int slot) const;
  StoreStatus Lock(int* fd, StoreError* err);
  void Unlock(int fd);
  bool IsFile(const PathBuffer& path, const FileId& id);
  void ReadSlot(int slot, const char* expected_rig_id, SlotReport* r);
  StoreStatus FsyncDirectory(const char* path, StoreError* err);
  bool WriteTemp(const PathBuffer& tmp, std::span<const std::uint8_t> blob, FileId* id, StoreError* err);
  bool ReadBackMatches(int slot, std::span<const std::uint8_t> blob, StoreError* err);
  void UndoInstall(int slot, const FileId& written);
  StoreStatus LockedInstall(std::span<const std::uint8_t> blob, const InstallOptions& options, InstallReport* rep);
  StoreStatus LockedRollback(RollbackReport* rep);
  StoreStatus Count(StoreStatus s);

  StoreIo* io_;
  StoreError scan_error_;  // why the last Scan could not open the directory
  std::array<char, limits::kMaxPathChars + 1> dir_{};
  std::array<std::array<std::uint8_t, limits::kMaxBlobBytes + 1>, kNumSlots> slot_bytes_{};
  std::array<std::size_t, kNumSlots> slot_size_{};
  Rig scratch_;
  StoreCounters counters_;
  int lock_timeout_ms_ = 30000;
};

// Formats one line saying what each slot holds, e.g.
// "slot-a.bin: payload CRC mismatch; slot-b.bin: missing" (truncated to n, NUL-terminated).
void DescribeSnapshot(const StoreSnapshot& snap, char* buf, std::size_t n);

}  // namespace mfns::fw
