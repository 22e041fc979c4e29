// The parameter store on a real directory: slots, newest-wins, refusals, forced installs,
// rollback, read-back verification, bounded I/O loops, and the statuses' names.
#include "firmware/modules/params/param_store.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fcntl.h>
#include <unistd.h>
#include <sys/stat.h>

#include <atomic>
#include <memory>
#include <thread>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>

#include "firmware/lib/testing/alloc_counter.h"
#include "firmware/lib/testing/returns_without_blocking.h"
#include "firmware/modules/params/testing/fault_store_io.h"
#include "firmware/modules/params/testing/test_blobs.h"

namespace mfns::fw {
namespace {

using testing::FaultStoreIo;
using testing::MakeBlob;
using testing::ReadBytes;
using testing::TempDir;
using testing::WriteBytes;
namespace fs = std::filesystem;

std::set<std::string> Entries(const std::string& dir) {
  std::set<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.insert(e.path().filename().string());
  return out;
}

StoreStatus InstallBlob(ParamStore* store, const std::vector<std::uint8_t>& blob, InstallOptions opt = {},
                        InstallReport* rep = nullptr) {
  return store->Install(blob, opt, rep);
}

TEST(ParamStoreNames, EveryStatusStateAndStepHasADistinctName) {
  std::set<std::string> names;
  for (int i = 0; i < kNumStoreStatuses; ++i) names.insert(ToString(static_cast<StoreStatus>(i)));
  EXPECT_EQ(names.size(), static_cast<std::size_t>(kNumStoreStatuses));
  names.clear();
  for (int i = 0; i <= static_cast<int>(SlotState::kUnreadable); ++i) names.insert(ToString(static_cast<SlotState>(i)));
  EXPECT_EQ(names.size(), 5u);
  names.clear();
  for (int i = 0; i <= static_cast<int>(StoreStep::kSetAside); ++i) names.insert(ToString(static_cast<StoreStep>(i)));
  EXPECT_EQ(names.size(), static_cast<std::size_t>(StoreStep::kSetAside) + 1);
  EXPECT_STREQ(SlotFileName(0), "slot-a.bin");
  EXPECT_STREQ(SlotFileName(1), "slot-b.bin");
  EXPECT_EQ(SlotFileName(2), nullptr);
}

TEST(ParamStore, EmptyStoreHasNoValidBlobAndSaysWhyPerSlot) {
  TempDir dir;
  ParamStore store;
  ASSERT_EQ(store.SetDirectory(dir.path().c_str()), StoreStatus::kOk);
  StoreSnapshot snap;
  EXPECT_EQ(store.Scan(nullptr, &snap), StoreStatus::kNoValidBlob);
  EXPECT_EQ(snap.active, -1);
  EXPECT_EQ(snap.slots[0].state, SlotState::kMissing);
  EXPECT_EQ(snap.slots[1].state, SlotState::kMissing);
  char why[256];
  DescribeSnapshot(snap, why, sizeof why);
  EXPECT_STREQ(why, "slot-a.bin: missing; slot-b.bin: missing");
  Rig rig;
  rig.num_cameras = 77;
  EXPECT_EQ(store.Load(nullptr, &rig, nullptr, nullptr), StoreStatus::kNoValidBlob);
  EXPECT_EQ(rig.num_cameras, 77);  // untouched
}

TEST(ParamStore, MissingDirectoryOrBadPathIsTyped) {
  TempDir dir;
  ParamStore store;
  ASSERT_EQ(store.SetDirectory((dir / "nope").c_str()), StoreStatus::kOk);
  StoreSnapshot snap;
  EXPECT_EQ(store.Scan(nullptr, &snap), StoreStatus::kNotFound);
  EXPECT_EQ(store.scan_error().step, StoreStep::kOpenDirectory);
  EXPECT_EQ(store.scan_error().error, ENOENT);
  InstallReport rep;
  EXPECT_EQ(InstallBlob(&store, MakeBlob(1), {}, &rep), StoreStatus::kNotFound);
  EXPECT_EQ(rep.io.error, ENOENT);
  EXPECT_EQ(store.SetDirectory(""), StoreStatus::kBadPath);
  EXPECT_EQ(store.SetDirectory(std::string(limits::kMaxPathChars + 1, 'x').c_str()), StoreStatus::kBadPath);
  EXPECT_EQ(store.Scan(nullptr, &snap), StoreStatus::kBadPath);
}

TEST(ParamStore, CreateDirectoryMakesTheStoreOnceAndNeedsTheParent) {
  TempDir dir;
  ParamStore store;
  ASSERT_EQ(store.SetDirectory((dir / "params").c_str()), StoreStatus::kOk);
  StoreError err;
  EXPECT_EQ(store.CreateDirectory(&err), StoreStatus::kOk);
  EXPECT_TRUE(fs::is_directory(dir / "params"));
  EXPECT_EQ(store.CreateDirectory(&err), StoreStatus::kOk);  // already there
  EXPECT_EQ(InstallBlob(&store, MakeBlob(1)), StoreStatus::kOk);
  ASSERT_EQ(store.SetDirectory((dir / "a/b").c_str()), StoreStatus::kOk);
  EXPECT_EQ(store.CreateDirectory(&err), StoreStatus::kNotFound);
  EXPECT_EQ(err.step, StoreStep::kMkdir);
}

TEST(ParamStore, InstallsAlternateSlotsAndTheNewestIsActive) {
  TempDir dir;
  ParamStore store;
  ASSERT_EQ(store.SetDirectory(dir.path().c_str()), StoreStatus::kOk);
  const auto g1 = MakeBlob(1), g2 = MakeBlob(2, kPaperRigId, 9), g3 = MakeBlob(3, kPaperRigId, 8);
  InstallReport rep;
  ASSERT_EQ(InstallBlob(&store, g1, {}, &rep), StoreStatus::kOk);
  EXPECT_EQ(rep.slot, 0);
  EXPECT_FALSE(rep.had_active);
  EXPECT_EQ(ReadBytes(dir / "slot-a.bin"), g1);  // the bytes on disk, read independently
  ASSERT_EQ(InstallBlob(&store, g2, {}, &rep), StoreStatus::kOk);
  EXPECT_EQ(rep.slot, 1);
  EXPECT_TRUE(rep.had_active);
  EXPECT_EQ(rep.old_info.generation, 1u);
  EXPECT_EQ(rep.after.active, 1);
  EXPECT_EQ(ReadBytes(dir / "slot-b.bin"), g2);
  EXPECT_EQ(ReadBytes(dir / "slot-a.bin"), g1);  // the old slot is kept for rollback
  ASSERT_EQ(InstallBlob(&store, g3, {}, &rep), StoreStatus::kOk);
  EXPECT_EQ(rep.slot, 0);  // overwrites the older slot, never the active one
  EXPECT_EQ(ReadBytes(dir / "slot-a.bin"), g3);
  EXPECT_EQ(ReadBytes(dir / "slot-b.bin"), g2);
  EXPECT_EQ(Entries(dir.path()), (std::set<std::string>{"slot-a.bin", "slot-b.bin"}));  // no temp left

  // A fresh store object (as after a reboot) opens to the newest, with its contents.
  ParamStore reopened;
  reopened.SetDirectory(dir.path().c_str());
  Rig rig;
  BlobInfo info;
  StoreSnapshot snap;
  ASSERT_EQ(reopened.Load(nullptr, &rig, &info, &snap), StoreStatus::kOk);
  EXPECT_EQ(info.generation, 3u);
  EXPECT_EQ(rig.num_beacons, 8);
  EXPECT_EQ(snap.active, 0);
  EXPECT_EQ(snap.slots[1].info.generation, 2u);
  EXPECT_EQ(snap.slots[0].num_cameras, PaperRig().num_cameras);
  EXPECT_EQ(snap.slots[0].bytes, g3.size());
  EXPECT_EQ(store.counters().installs, 3u);
}

TEST(ParamStore, RefusesACorruptBlobAndKeepsTheOldOneActive) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  const auto good = MakeBlob(5);
  ASSERT_EQ(InstallBlob(&store, good), StoreStatus::kOk);
  auto flipped = MakeBlob(6);
  flipped[flipped.size() / 2] ^= 0x10;
  auto truncated = MakeBlob(6);
  truncated.resize(truncated.size() - 1);
  const std::vector<std::uint8_t> empty;
  const std::vector<std::uint8_t> too_large(limits::kMaxBlobBytes + 1, 0);
  InstallReport rep;
  EXPECT_EQ(InstallBlob(&store, flipped, {}, &rep), StoreStatus::kCorruptBlob);
  EXPECT_EQ(rep.blob_status, BlobStatus::kPayloadCrcMismatch);
  EXPECT_EQ(InstallBlob(&store, truncated, {}, &rep), StoreStatus::kCorruptBlob);
  EXPECT_EQ(rep.blob_status, BlobStatus::kTruncated);
  EXPECT_EQ(InstallBlob(&store, empty, {}, &rep), StoreStatus::kCorruptBlob);
  EXPECT_EQ(InstallBlob(&store, too_large, {}, &rep), StoreStatus::kBlobTooLarge);
  EXPECT_EQ(InstallBlob(&store, flipped, InstallOptions{true, true}), StoreStatus::kCorruptBlob);  // force: still no
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>{"slot-a.bin"});
  EXPECT_EQ(ReadBytes(dir / "slot-a.bin"), good);
  EXPECT_EQ(store.counters().by_status[static_cast<int>(StoreStatus::kCorruptBlob)], 4u);
}

// A blob that decodes but maps fewer beacons than the navigator needs would leave the store
// with nothing mfns-navd can start on: refused like a corrupt one, force or not.
TEST(ParamStore, RefusesABlobWithTooFewBeaconsToNavigate) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  const auto good = MakeBlob(5);
  ASSERT_EQ(InstallBlob(&store, good), StoreStatus::kOk);
  for (int beacons = 0; beacons < limits::kMinNavBeacons; ++beacons) {
    InstallReport rep;
    EXPECT_EQ(InstallBlob(&store, MakeBlob(6, kPaperRigId, beacons), InstallOptions{true, true}, &rep),
              StoreStatus::kTooFewBeacons)
        << beacons;
    EXPECT_EQ(rep.blob_status, BlobStatus::kOk);
    EXPECT_EQ(rep.new_beacons, beacons);
    EXPECT_EQ(testing::ActiveGeneration(rep.after), 5u);
  }
  EXPECT_EQ(InstallBlob(&store, MakeBlob(6, kPaperRigId, limits::kMinNavBeacons)), StoreStatus::kOk);
  EXPECT_EQ(Entries(dir.path()), (std::set<std::string>{"slot-a.bin", "slot-b.bin"}));
  EXPECT_EQ(ReadBytes(dir / "slot-a.bin"), good);
  EXPECT_EQ(store.counters().by_status[static_cast<int>(StoreStatus::kTooFewBeacons)],
            static_cast<std::uint64_t>(limits::kMinNavBeacons));
}

TEST(ParamStore, RefusesAnotherRigIdUnlessAllowed) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  ASSERT_EQ(InstallBlob(&store, MakeBlob(5)), StoreStatus::kOk);
  const auto other = MakeBlob(6, "other-rig");
  InstallReport rep;
  EXPECT_EQ(InstallBlob(&store, other, {}, &rep), StoreStatus::kRigIdMismatch);
  EXPECT_STREQ(rep.old_info.rig_id.data(), kPaperRigId);
  EXPECT_STREQ(rep.new_info.rig_id.data(), "other-rig");
  EXPECT_EQ(InstallBlob(&store, other, InstallOptions{true, false}), StoreStatus::kRigIdMismatch);
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>{"slot-a.bin"});
  EXPECT_EQ(InstallBlob(&store, other, InstallOptions{false, true}, &rep), StoreStatus::kOk);
  EXPECT_STREQ(rep.after.slots[static_cast<std::size_t>(rep.after.active)].info.rig_id.data(), "other-rig");
}

TEST(ParamStore, RefusesAnOlderOrEqualGenerationUnlessForcedAndAForcedOneBecomesActive) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  const auto g1 = MakeBlob(1), g2 = MakeBlob(2), g3 = MakeBlob(3);
  ASSERT_EQ(InstallBlob(&store, g1), StoreStatus::kOk);
  ASSERT_EQ(InstallBlob(&store, g3), StoreStatus::kOk);  // A=1, B=3
  EXPECT_EQ(InstallBlob(&store, g2), StoreStatus::kStaleGeneration);
  EXPECT_EQ(InstallBlob(&store, MakeBlob(3, kPaperRigId, 7)), StoreStatus::kStaleGeneration);  // equal
  EXPECT_EQ(ReadBytes(dir / "slot-a.bin"), g1);
  InstallReport rep;
  ASSERT_EQ(InstallBlob(&store, g2, InstallOptions{true, false}, &rep), StoreStatus::kOk);
  EXPECT_EQ(rep.slot, 0);
  EXPECT_EQ(rep.after.active, 0);
  EXPECT_EQ(testing::ActiveGeneration(rep.after), 2u);
  // The newer slot was set aside so that newest-wins picks the forced blob from now on.
  EXPECT_EQ(Entries(dir.path()), (std::set<std::string>{"slot-a.bin", "slot-b.bin.rolled-back"}));
  EXPECT_EQ(ReadBytes(dir / "slot-b.bin.rolled-back"), g3);
  StoreSnapshot snap;
  EXPECT_EQ(store.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(testing::ActiveGeneration(snap), 2u);
}

TEST(ParamStore, RollbackSelectsTheOtherValidSlotAndNewestWinsStillHolds) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  RollbackReport rb;
  EXPECT_EQ(store.Rollback(&rb), StoreStatus::kNoValidBlob);
  const auto g1 = MakeBlob(1), g2 = MakeBlob(2);
  ASSERT_EQ(InstallBlob(&store, g1), StoreStatus::kOk);
  EXPECT_EQ(store.Rollback(&rb), StoreStatus::kNoRollbackTarget);
  EXPECT_EQ(rb.to_slot, 1);
  ASSERT_EQ(InstallBlob(&store, g2), StoreStatus::kOk);
  ASSERT_EQ(store.Rollback(&rb), StoreStatus::kOk);
  EXPECT_EQ(rb.from_slot, 1);
  EXPECT_EQ(rb.to_slot, 0);
  EXPECT_EQ(testing::ActiveGeneration(rb.after), 1u);
  EXPECT_EQ(ReadBytes(dir / "slot-b.bin.rolled-back"), g2);
  // Reopened (reboot): still the rolled-back-to blob.
  ParamStore reopened;
  reopened.SetDirectory(dir.path().c_str());
  StoreSnapshot snap;
  ASSERT_EQ(reopened.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(testing::ActiveGeneration(snap), 1u);
  // Nothing left to roll back to.
  EXPECT_EQ(store.Rollback(&rb), StoreStatus::kNoRollbackTarget);
  // The next install takes the empty slot; the one after that overwrites the oldest.
  InstallReport rep;
  ASSERT_EQ(InstallBlob(&store, MakeBlob(3), {}, &rep), StoreStatus::kOk);
  EXPECT_EQ(rep.slot, 1);
  ASSERT_EQ(store.Rollback(&rb), StoreStatus::kOk);
  EXPECT_EQ(testing::ActiveGeneration(rb.after), 1u);
  EXPECT_EQ(ReadBytes(dir / "slot-b.bin.rolled-back"), MakeBlob(3));  // replaced the older aside copy
  EXPECT_EQ(store.counters().rollbacks, 2u);
}

TEST(ParamStore, NewestValidGenerationWinsWhateverTheSlot) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  StoreSnapshot snap;
  WriteBytes(dir / "slot-a.bin", MakeBlob(9));
  WriteBytes(dir / "slot-b.bin", MakeBlob(4));
  ASSERT_EQ(store.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(snap.active, 0);
  WriteBytes(dir / "slot-b.bin", MakeBlob(10));
  ASSERT_EQ(store.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(snap.active, 1);
  // A newer but corrupt slot loses to an older valid one.
  auto bad = MakeBlob(11);
  bad.back() ^= 1;
  WriteBytes(dir / "slot-b.bin", bad);
  ASSERT_EQ(store.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(snap.active, 0);
  EXPECT_EQ(snap.slots[1].state, SlotState::kInvalid);
  EXPECT_TRUE(snap.slots[1].header_valid);
  EXPECT_EQ(snap.slots[1].info.generation, 11u);
  char why[256];
  DescribeSnapshot(snap, why, sizeof why);
  EXPECT_THAT(why, ::testing::HasSubstr("slot-a.bin: generation 9, rig mfns-paper-2017 (active)"));
  EXPECT_THAT(why, ::testing::HasSubstr("slot-b.bin: payload CRC32 mismatch"));
  // Equal generations: slot a (deterministic).
  WriteBytes(dir / "slot-b.bin", MakeBlob(9, kPaperRigId, 5));
  ASSERT_EQ(store.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(snap.active, 0);
  // Oversized and garbage slots are invalid with their reason.
  WriteBytes(dir / "slot-b.bin", std::vector<std::uint8_t>(limits::kMaxBlobBytes + 100, 0xAB));
  ASSERT_EQ(store.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(snap.slots[1].state, SlotState::kTooLarge);
  WriteBytes(dir / "slot-a.bin", std::vector<std::uint8_t>(100, 0));
  EXPECT_EQ(store.Scan(nullptr, &snap), StoreStatus::kNoValidBlob);
  EXPECT_EQ(snap.slots[0].blob_status, BlobStatus::kBadMagic);
  EXPECT_FALSE(snap.slots[0].header_valid);
}

TEST(ParamStore, AnExpectedRigIdMakesOtherRigsInvalid) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  WriteBytes(dir / "slot-a.bin", MakeBlob(3, kPaperRigId));
  WriteBytes(dir / "slot-b.bin", MakeBlob(8, "spare-rig"));
  StoreSnapshot snap;
  ASSERT_EQ(store.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(snap.active, 1);
  ASSERT_EQ(store.Scan(kPaperRigId, &snap), StoreStatus::kOk);
  EXPECT_EQ(snap.active, 0);
  EXPECT_EQ(snap.slots[1].blob_status, BlobStatus::kRigIdMismatch);
  EXPECT_EQ(store.Scan("third-rig", &snap), StoreStatus::kNoValidBlob);
}

// Corrupts the first byte read from one file: models storage that returns other bytes.
class FlipOnReadIo final : public StoreIo {
 public:
  explicit FlipOnReadIo(std::string name) : name_(std::move(name)) {}
  int Open(const char* path, int flags, mode_t mode) override {
    const int fd = real_.Open(path, flags, mode);
    const std::string p(path);
    if (fd >= 0 && armed_ && (flags & O_ACCMODE) == O_RDONLY && p.size() >= name_.size() &&
        p.compare(p.size() - name_.size(), name_.size(), name_) == 0) {
      flip_fd_ = fd;
    }
    return fd;
  }
  int Close(int fd) override {
    if (fd == flip_fd_) flip_fd_ = -1;
    return real_.Close(fd);
  }
  ssize_t Read(int fd, void* buf, std::size_t n) override {
    const ssize_t r = real_.Read(fd, buf, n);
    if (fd == flip_fd_ && r > 20) {
      static_cast<std::uint8_t*>(buf)[20] ^= 0x01;
      flip_fd_ = -1;
    }
    return r;
  }
  ssize_t Write(int fd, const void* buf, std::size_t n) override { return real_.Write(fd, buf, n); }
  int Fsync(int fd) override { return real_.Fsync(fd); }
  int Rename(const char* a, const char* b) override { return real_.Rename(a, b); }
  int Unlink(const char* p) override { return real_.Unlink(p); }
  int Mkdir(const char* p, mode_t m) override { return real_.Mkdir(p, m); }
  int Fstat(int fd, struct stat* st) override { return real_.Fstat(fd, st); }
  int Flock(int fd, int op) override { return real_.Flock(fd, op); }
  bool armed_ = false;

 private:
  LinuxStoreIo real_;
  std::string name_;
  int flip_fd_ = -1;
};

TEST(ParamStore, AReadBackThatDiffersIsUndoneAndTheOldBlobStaysActive) {
  TempDir dir;
  FlipOnReadIo io("slot-b.bin");
  ParamStore store(&io);
  store.SetDirectory(dir.path().c_str());
  ASSERT_EQ(InstallBlob(&store, MakeBlob(1)), StoreStatus::kOk);
  io.armed_ = true;
  InstallReport rep;
  EXPECT_EQ(InstallBlob(&store, MakeBlob(2), {}, &rep), StoreStatus::kVerifyFailed);
  EXPECT_EQ(rep.slot, 1);
  EXPECT_EQ(rep.after.active, 0);
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>{"slot-a.bin"});  // the bad slot was removed
  io.armed_ = false;
  EXPECT_EQ(InstallBlob(&store, MakeBlob(2)), StoreStatus::kOk);
}

TEST(ParamStore, ShortTransfersAndInterruptedCallsAreRetriedWithinBounds) {
  TempDir dir;
  LinuxStoreIo real;
  FaultStoreIo io(&real);
  io.ShortTransfers(7);
  ParamStore store(&io);
  store.SetDirectory(dir.path().c_str());
  const auto blob = MakeBlob(4);
  ASSERT_EQ(InstallBlob(&store, blob), StoreStatus::kOk);
  EXPECT_EQ(ReadBytes(dir / "slot-a.bin"), blob);
  Rig rig;
  EXPECT_EQ(store.Load(nullptr, &rig, nullptr, nullptr), StoreStatus::kOk);

  // EINTR on the first temp write: retried, the install succeeds.
  FaultStoreIo io2(&real);
  ParamStore store2(&io2);
  store2.SetDirectory(dir.path().c_str());
  // Find the index of the first temp write in a dry run, then interrupt exactly that call.
  {
    TempDir dry;
    FaultStoreIo probe(&real);
    ParamStore s(&probe);
    s.SetDirectory(dry.path().c_str());
    ASSERT_EQ(InstallBlob(&s, MakeBlob(1)), StoreStatus::kOk);
    ASSERT_EQ(InstallBlob(&s, MakeBlob(2)), StoreStatus::kOk);  // same shape as below: one slot present
    int first_write = -1;
    const int start = probe.calls();
    ASSERT_EQ(InstallBlob(&s, MakeBlob(3)), StoreStatus::kOk);
    for (int i = start; i < probe.calls(); ++i) {
      if (probe.log()[static_cast<std::size_t>(i)].rfind("write ", 0) == 0) {
        first_write = i - start;
        break;
      }
    }
    ASSERT_GE(first_write, 0);
    io2.FailAtCall(first_write, EINTR);
  }
  TempDir dir2;
  store2.SetDirectory(dir2.path().c_str());
  WriteBytes(dir2 / "slot-a.bin", MakeBlob(1));
  WriteBytes(dir2 / "slot-b.bin", MakeBlob(2));
  ASSERT_EQ(InstallBlob(&store2, MakeBlob(3)), StoreStatus::kOk);
  EXPECT_EQ(ReadBytes(dir2 / "slot-a.bin"), MakeBlob(3));
}

TEST(ParamStore, AnUnreadableSlotIsReportedUsedAroundAtOpenButBlocksInstall) {
  TempDir dir;
  WriteBytes(dir / "slot-a.bin", MakeBlob(1));
  WriteBytes(dir / "slot-b.bin", MakeBlob(2));
  LinuxStoreIo real;
  FaultStoreIo io(&real);
  // Calls of a scan: open dir, close dir, open a, read a..., so fail the first read of slot b.
  ParamStore probe_store(&io);
  probe_store.SetDirectory(dir.path().c_str());
  StoreSnapshot snap;
  ASSERT_EQ(probe_store.Scan(nullptr, &snap), StoreStatus::kOk);
  int read_b = -1;
  for (std::size_t i = 0; i < io.log().size(); ++i) {
    if (io.log()[i] == "read slot-b.bin") {
      read_b = static_cast<int>(i);
      break;
    }
  }
  ASSERT_GE(read_b, 0);
  FaultStoreIo io2(&real);
  io2.FailAtCall(read_b, EIO);
  ParamStore store(&io2);
  store.SetDirectory(dir.path().c_str());
  ASSERT_EQ(store.Scan(nullptr, &snap), StoreStatus::kOk);
  EXPECT_EQ(snap.slots[1].state, SlotState::kUnreadable);
  EXPECT_EQ(snap.slots[1].error, EIO);
  EXPECT_EQ(snap.active, 0);
  EXPECT_EQ(store.counters().unreadable_slots, 1u);

  FaultStoreIo io3(&real);
  io3.FailAtCall(read_b, EIO);
  ParamStore store3(&io3);
  store3.SetDirectory(dir.path().c_str());
  InstallReport rep;
  EXPECT_EQ(InstallBlob(&store3, MakeBlob(3), {}, &rep), StoreStatus::kIoError);
  EXPECT_EQ(rep.io.step, StoreStep::kReadSlot);
  EXPECT_EQ(ReadBytes(dir / "slot-a.bin"), MakeBlob(1));
  EXPECT_EQ(ReadBytes(dir / "slot-b.bin"), MakeBlob(2));
}

TEST(ParamStore, TheInstallProtocolIsTempWriteFsyncCloseRenameDirectoryFsyncReadBack) {
  TempDir dir;
  LinuxStoreIo real;
  FaultStoreIo io(&real);
  ParamStore store(&io);
  store.SetDirectory(dir.path().c_str());
  WriteBytes(dir / "slot-a.bin", MakeBlob(1));
  ASSERT_EQ(InstallBlob(&store, MakeBlob(2)), StoreStatus::kOk);
  const std::string base = fs::path(dir.path()).filename().string();
  std::vector<std::string> effects;  // the calls that change the disk, in order
  for (const auto& l : io.log()) {
    const bool tmp = l.find(".tmp") != std::string::npos;
    if (l.rfind("write", 0) == 0 || l.rfind("fsync", 0) == 0 || l.rfind("rename", 0) == 0 ||
        l.rfind("unlink", 0) == 0 || (tmp && (l.rfind("open", 0) == 0 || l.rfind("close", 0) == 0))) {
      effects.push_back(l.rfind("write", 0) == 0 ? "write" : l);
    }
  }
  const std::string tmp = "slot-b.bin." + std::to_string(::getpid()) + ".tmp";  // unique per process
  const std::vector<std::string> expected = {"open " + tmp,  "write",
                                             "fsync " + tmp, "close " + tmp,
                                             "rename " + tmp + " slot-b.bin", "fsync " + base};
  EXPECT_EQ(effects, expected);
  // And the read-back of slot b comes after the directory fsync.
  const auto& log = io.log();
  const auto fsync_dir = std::find(log.begin(), log.end(), "fsync " + base);
  ASSERT_NE(fsync_dir, log.end());
  EXPECT_NE(std::find(fsync_dir, log.end(), "read slot-b.bin"), log.end());
}

TEST(ParamStore, ScanLoadAndInstallAllocateNothing) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  const auto g1 = MakeBlob(1), g2 = MakeBlob(2);
  ASSERT_EQ(InstallBlob(&store, g1), StoreStatus::kOk);
  Rig rig;
  BlobInfo info;
  StoreSnapshot snap;
  InstallReport rep;
  RollbackReport rb;
  const std::uint64_t before = testing::AllocationCount();
  EXPECT_EQ(store.Install(g2, {}, &rep), StoreStatus::kOk);
  EXPECT_EQ(store.Load(nullptr, &rig, &info, &snap), StoreStatus::kOk);
  EXPECT_EQ(store.Rollback(&rb), StoreStatus::kOk);
  EXPECT_EQ(testing::AllocationCount(), before);
}

// Issue 14: a FIFO named like a slot hung every scan in open(2). It is skipped and reported;
// the other slot stays active; the scan returns at once.
TEST(ParamStore, AFifoNamedLikeASlotIsSkippedAndReportedWithoutBlocking) {
  TempDir dir;
  WriteBytes(dir / "slot-a.bin", MakeBlob(1));
  ASSERT_EQ(::mkfifo((dir / "slot-b.bin").c_str(), 0644), 0);
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  StoreSnapshot snap;
  StoreStatus s = StoreStatus::kBadPath;
  ASSERT_TRUE(testing::ReturnsWithoutBlocking([&] { s = store.Scan(nullptr, &snap); }, {dir / "slot-b.bin"}))
      << "Scan blocked on the FIFO";
  EXPECT_EQ(s, StoreStatus::kOk);
  EXPECT_EQ(snap.active, 0);
  char why[256];
  DescribeSnapshot(snap, why, sizeof why);
  EXPECT_THAT(why, ::testing::HasSubstr("slot-b.bin: not a regular file"));
}

// Issue 14: concurrent installs shared one temp name, and a failed install's undo deleted
// slots other writers had made: 49 concurrent mfns-flash runs left an empty store. Writers,
// each with its own store (its own descriptors, as separate processes have), install distinct
// generations at once while a reader scans: the store never reads empty, every install either
// succeeds or is refused as stale, the newest succeeded generation is active, and the other
// slot still holds the generation it replaced.
TEST(ParamStore, ConcurrentInstallsTakeTurnsAndNeverLoseTheOldGeneration) {
  constexpr int kWriters = 12;
  constexpr int kRounds = 8;
  std::vector<std::uint64_t> gens;  // 2 .. kWriters + 1, shuffled over the writers
  std::vector<std::vector<std::uint8_t>> blobs;
  for (int i = 0; i < kWriters; ++i) {
    gens.push_back(static_cast<std::uint64_t>(2 + (i * 7) % kWriters));
    blobs.push_back(MakeBlob(gens.back()));
  }
  const auto first = MakeBlob(1);
  int empty_scans = 0, bad_statuses = 0;
  for (int round = 0; round < kRounds; ++round) {
    TempDir dir(testing::FastTempBase());
    WriteBytes(dir / "slot-a.bin", first);
    std::atomic<int> ready{0};
    std::atomic<bool> writing{true};
    std::vector<StoreStatus> status(kWriters, StoreStatus::kBadPath);
    std::vector<std::thread> threads;
    for (int i = 0; i < kWriters; ++i) {
      threads.emplace_back([&, i] {
        auto store = std::make_unique<ParamStore>();
        store->SetDirectory(dir.path().c_str());
        ++ready;
        while (ready.load() < kWriters) std::this_thread::yield();
        status[static_cast<std::size_t>(i)] = store->Install(blobs[static_cast<std::size_t>(i)], {}, nullptr);
      });
    }
    std::thread reader([&] {
      auto store = std::make_unique<ParamStore>();
      store->SetDirectory(dir.path().c_str());
      StoreSnapshot snap;
      while (writing.load()) empty_scans += store->Scan(nullptr, &snap) != StoreStatus::kOk;
    });
    for (auto& t : threads) t.join();
    writing = false;
    reader.join();
    std::uint64_t newest_ok = 1;
    for (int i = 0; i < kWriters; ++i) {
      const StoreStatus s = status[static_cast<std::size_t>(i)];
      if (s == StoreStatus::kOk) newest_ok = std::max(newest_ok, gens[static_cast<std::size_t>(i)]);
      if (s != StoreStatus::kOk && s != StoreStatus::kStaleGeneration) {
        if (++bad_statuses <= 5) ADD_FAILURE() << "round " << round << ", writer " << i << ": " << ToString(s);
      }
    }
    ParamStore check;
    check.SetDirectory(dir.path().c_str());
    StoreSnapshot snap;
    ASSERT_EQ(check.Scan(nullptr, &snap), StoreStatus::kOk) << "round " << round << ": the store is empty";
    EXPECT_EQ(testing::ActiveGeneration(snap), newest_ok) << "round " << round;
    const SlotReport& other = snap.slots[static_cast<std::size_t>(1 - snap.active)];
    EXPECT_EQ(other.state, SlotState::kValid) << "round " << round << ": the old generation is gone";
    EXPECT_LT(other.info.generation, newest_ok) << "round " << round;
    for (const auto& e : Entries(dir.path())) EXPECT_EQ(e.find(".tmp"), std::string::npos) << e;
  }
  EXPECT_EQ(empty_scans, 0) << "scans that found no valid blob while the installs ran";
  EXPECT_EQ(bad_statuses, 0);
}

}  // namespace
}  // namespace mfns::fw
