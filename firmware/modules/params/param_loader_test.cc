// What navd uses: ParamLoader (store directory or blob file, expected rig id, reasons),
// StoreWatcher (inotify and the stat fallback) and the pid-file SIGHUP path.
#include "firmware/modules/params/param_loader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <poll.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>

#include "firmware/lib/testing/alloc_counter.h"
#include "firmware/lib/testing/returns_without_blocking.h"
#include "firmware/modules/params/reload_signal.h"
#include "firmware/modules/params/store_watcher.h"
#include "firmware/modules/params/testing/fork_child.h"
#include "firmware/modules/params/testing/test_blobs.h"

namespace mfns::fw {
namespace {

using ::testing::HasSubstr;
using testing::MakeBlob;
using testing::TempDir;
using testing::WriteBytes;
namespace fs = std::filesystem;

std::string Why(const ParamLoader& loader) {
  char buf[512];
  loader.Describe(buf, sizeof buf);
  return buf;
}

TEST(ParamLoader, OpensTheNewestValidSlotOfAStoreAndSaysWhyWhenNone) {
  TempDir dir;
  ParamLoader loader;
  Rig rig;
  BlobInfo info;
  EXPECT_EQ(loader.Open(dir.path().c_str(), nullptr, &rig, &info), StoreStatus::kNoValidBlob);
  EXPECT_EQ(Why(loader), "store " + dir.path() + ": slot-a.bin: missing; slot-b.bin: missing");
  auto bad = MakeBlob(7);
  bad[70] ^= 0xff;
  WriteBytes(dir / "slot-a.bin", bad);
  EXPECT_EQ(loader.Open(dir.path().c_str(), nullptr, &rig, &info), StoreStatus::kNoValidBlob);
  EXPECT_THAT(Why(loader), HasSubstr("slot-a.bin: payload CRC32 mismatch (payload corrupted); slot-b.bin: missing"));
  WriteBytes(dir / "slot-b.bin", MakeBlob(6, kPaperRigId, 4));
  ASSERT_EQ(loader.Open(dir.path().c_str(), nullptr, &rig, &info), StoreStatus::kOk);
  EXPECT_TRUE(loader.is_store());
  EXPECT_EQ(loader.active_slot(), 1);
  EXPECT_EQ(info.generation, 6u);
  EXPECT_EQ(rig.num_beacons, 4);
  EXPECT_THAT(Why(loader), HasSubstr("slot-b.bin: generation 6, rig mfns-paper-2017 (active)"));
}

TEST(ParamLoader, AnExpectedRigIdRefusesBlobsForOtherRigs) {
  TempDir dir;
  WriteBytes(dir / "slot-a.bin", MakeBlob(3, "spare-rig"));
  ParamLoader loader;
  Rig rig;
  BlobInfo info;
  EXPECT_EQ(loader.Open(dir.path().c_str(), kPaperRigId, &rig, &info), StoreStatus::kNoValidBlob);
  EXPECT_THAT(Why(loader), HasSubstr("slot-a.bin: blob is for another rig id"));
  EXPECT_EQ(loader.Open(dir.path().c_str(), "spare-rig", &rig, &info), StoreStatus::kOk);
  // A too-long expected id matches nothing (not a truncated prefix).
  EXPECT_EQ(loader.Open(dir.path().c_str(), "spare-rig-with-a-name-far-longer-than-31", &rig, &info),
            StoreStatus::kNoValidBlob);
}

// Issue 14 defect 9: navd hot-loaded a valid blob of another rig id with a higher generation.
// Pinned to the rig it started with, a reload keeps the current slot and says why the newer
// one is not taken; a newer but corrupt slot is named too.
TEST(ParamLoader, APinnedRigIdKeepsReloadsOnThatRig) {
  TempDir dir;
  WriteBytes(dir / "slot-a.bin", MakeBlob(3));
  ParamLoader loader;
  Rig rig;
  BlobInfo info;
  ASSERT_EQ(loader.Open(dir.path().c_str(), nullptr, &rig, &info), StoreStatus::kOk);
  loader.ExpectRigId(info.rig_id.data());
  WriteBytes(dir / "slot-b.bin", MakeBlob(9, "another-flyer"));
  BlobInfo next;
  ASSERT_EQ(loader.Reload(&rig, &next), StoreStatus::kOk);
  EXPECT_EQ(next.generation, 3u);
  EXPECT_EQ(loader.active_slot(), 0);
  EXPECT_THAT(Why(loader), HasSubstr("slot-b.bin: blob is for another rig id"));
  auto corrupt = MakeBlob(10);
  corrupt[70] ^= 0xff;
  WriteBytes(dir / "slot-b.bin", corrupt);
  ASSERT_EQ(loader.Reload(&rig, &next), StoreStatus::kOk);
  EXPECT_EQ(next.generation, 3u);
  EXPECT_THAT(Why(loader), HasSubstr("slot-b.bin: payload CRC32 mismatch"));
  WriteBytes(dir / "slot-b.bin", MakeBlob(11));
  ASSERT_EQ(loader.Reload(&rig, &next), StoreStatus::kOk);
  EXPECT_EQ(next.generation, 11u);
  loader.ExpectRigId(nullptr);  // unpinned: any rig again
  WriteBytes(dir / "slot-a.bin", MakeBlob(12, "another-flyer"));
  ASSERT_EQ(loader.Reload(&rig, &next), StoreStatus::kOk);
  EXPECT_EQ(next.generation, 12u);
}

TEST(ParamLoader, APlainBlobFileIsAcceptedWithItsOwnReasons) {
  TempDir dir;
  const std::string file = dir / "calibration.bin";
  ParamLoader loader;
  Rig rig;
  BlobInfo info;
  EXPECT_EQ(loader.Open(file.c_str(), nullptr, &rig, &info), StoreStatus::kNotFound);
  EXPECT_THAT(Why(loader), HasSubstr("No such file or directory"));
  WriteBytes(file, std::vector<std::uint8_t>(10, 0));
  EXPECT_EQ(loader.Open(file.c_str(), nullptr, &rig, &info), StoreStatus::kNoValidBlob);
  EXPECT_EQ(Why(loader), file + ": blob shorter than its header or than header + payload length");
  WriteBytes(file, MakeBlob(12));
  ASSERT_EQ(loader.Open(file.c_str(), nullptr, &rig, &info), StoreStatus::kOk);
  EXPECT_FALSE(loader.is_store());
  EXPECT_EQ(loader.active_slot(), -1);
  EXPECT_EQ(info.generation, 12u);
  EXPECT_EQ(rig.num_cameras, PaperRig().num_cameras);
  EXPECT_EQ(loader.Open("", nullptr, &rig, &info), StoreStatus::kBadPath);
}

void ExpectReloadSeesInstalls(bool force_stat) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  ASSERT_EQ(store.Install(MakeBlob(1), {}, nullptr), StoreStatus::kOk);
  ParamLoader loader;
  Rig rig;
  BlobInfo info;
  ASSERT_EQ(loader.Open(dir.path().c_str(), nullptr, &rig, &info, force_stat), StoreStatus::kOk);
  EXPECT_EQ(loader.watcher().mode(), force_stat ? StoreWatcher::Mode::kStat : StoreWatcher::Mode::kInotify);
  EXPECT_FALSE(loader.Changed());
  // Unrelated files in the directory are not a change.
  WriteBytes(dir / "notes.txt", {1, 2, 3});
  WriteBytes(dir / "slot-a.bin.tmp", {1, 2, 3});
  EXPECT_FALSE(loader.Changed());

  ASSERT_EQ(store.Install(MakeBlob(2, kPaperRigId, 6), {}, nullptr), StoreStatus::kOk);
  EXPECT_TRUE(loader.Changed());
  EXPECT_FALSE(loader.Changed());  // reported once
  Rig next;
  BlobInfo next_info;
  ASSERT_EQ(loader.Reload(&next, &next_info), StoreStatus::kOk);
  EXPECT_EQ(next_info.generation, 2u);
  EXPECT_EQ(next.num_beacons, 6);
  EXPECT_FALSE(SameBlob(next_info, info));

  ASSERT_EQ(store.Rollback(nullptr), StoreStatus::kOk);
  EXPECT_TRUE(loader.Changed());
  ASSERT_EQ(loader.Reload(&next, &next_info), StoreStatus::kOk);
  EXPECT_EQ(next_info.generation, 1u);
  EXPECT_TRUE(SameBlob(next_info, info));

  // A reload that finds nothing valid leaves the caller's rig alone.
  fs::remove(dir / "slot-a.bin");
  EXPECT_TRUE(loader.Changed());
  next.num_cameras = 99;
  EXPECT_EQ(loader.Reload(&next, &next_info), StoreStatus::kNoValidBlob);
  EXPECT_EQ(next.num_cameras, 99);
}

TEST(ParamLoader, ChangedSeesInstallsAndRollbacksThroughInotify) { ExpectReloadSeesInstalls(false); }
TEST(ParamLoader, ChangedSeesInstallsAndRollbacksThroughStatFallback) { ExpectReloadSeesInstalls(true); }

TEST(ParamLoader, ChangedSeesABlobFileReplaced) {
  for (bool force_stat : {false, true}) {
    TempDir dir;
    const std::string file = dir / "cal.bin";
    WriteBytes(file, MakeBlob(1));
    ParamLoader loader;
    Rig rig;
    BlobInfo info;
    ASSERT_EQ(loader.Open(file.c_str(), nullptr, &rig, &info, force_stat), StoreStatus::kOk);
    EXPECT_FALSE(loader.Changed());
    WriteBytes(dir / "other.bin", MakeBlob(5));
    EXPECT_FALSE(loader.Changed());
    fs::rename(dir / "other.bin", file);
    EXPECT_TRUE(loader.Changed()) << force_stat;
    ASSERT_EQ(loader.Reload(&rig, &info), StoreStatus::kOk);
    EXPECT_EQ(info.generation, 5u);
  }
}

TEST(ParamLoader, ChangedAndReloadAllocateNothing) {
  TempDir dir;
  ParamStore store;
  store.SetDirectory(dir.path().c_str());
  ASSERT_EQ(store.Install(MakeBlob(1), {}, nullptr), StoreStatus::kOk);
  ParamLoader loader;
  Rig rig;
  BlobInfo info;
  ASSERT_EQ(loader.Open(dir.path().c_str(), nullptr, &rig, &info), StoreStatus::kOk);
  ASSERT_EQ(store.Install(MakeBlob(2), {}, nullptr), StoreStatus::kOk);
  const std::uint64_t before = testing::AllocationCount();
  int changes = 0;
  for (int i = 0; i < 1000; ++i) changes += loader.Changed() ? 1 : 0;
  EXPECT_EQ(loader.Reload(&rig, &info), StoreStatus::kOk);
  char why[256];
  loader.Describe(why, sizeof why);
  EXPECT_EQ(testing::AllocationCount(), before);
  EXPECT_EQ(changes, 1);
  EXPECT_EQ(info.generation, 2u);
}

TEST(StoreWatcher, RefusesBadArgumentsAndAMissingDirectory) {
  StoreWatcher w;
  const char* names[] = {"a", "b", "c"};
  EXPECT_EQ(w.Start("/tmp", names, 0), WatchStatus::kBadArgument);
  EXPECT_EQ(w.Start("/tmp", names, 3), WatchStatus::kBadArgument);
  const char* slash[] = {"x/y"};
  EXPECT_EQ(w.Start("/tmp", slash, 1), WatchStatus::kBadArgument);
  EXPECT_EQ(w.Start("/nonexistent-mfns-dir", names, 1), WatchStatus::kError);
  EXPECT_EQ(w.mode(), StoreWatcher::Mode::kOff);
  EXPECT_FALSE(w.Changed());
  EXPECT_NE(std::string(ToString(WatchStatus::kOk)), ToString(WatchStatus::kError));
}

TEST(StoreWatcher, AFullEventQueueCountsAsAChange) {
  TempDir dir;
  StoreWatcher w;
  const char* names[] = {"slot-a.bin"};
  ASSERT_EQ(w.Start(dir.path().c_str(), names, 1), WatchStatus::kOk);
  // Events for unrelated long names (about 18 per 4 KB read): 2 x 300 renames are more than
  // kMaxStoreEventReads reads' worth.
  const std::string a = dir / std::string(200, 'a'), b = dir / std::string(200, 'b');
  WriteBytes(a, {1});
  EXPECT_FALSE(w.Changed());
  for (int i = 0; i < 300; ++i) {
    fs::rename(a, b);
    fs::rename(b, a);
  }
  EXPECT_TRUE(w.Changed());
  EXPECT_GE(w.counters().overflows, 1u);
}

// --- SIGHUP through the pid file -------------------------------------------------------------

TEST(ReloadSignal, SignalsOnlyARunningProcessWithTheExpectedName) {
  TempDir dir;
  const std::string pid_file = dir / "navd.pid";
  int pid = -1;
  EXPECT_EQ(SignalReload(pid_file.c_str(), kNavdProcessName, &pid), SignalStatus::kNoPidFile);
  WriteBytes(pid_file, {'x', '\n'});
  EXPECT_EQ(SignalReload(pid_file.c_str(), kNavdProcessName, &pid), SignalStatus::kBadPidFile);
  fs::remove(pid_file);

  // A child named mfns-navd that counts SIGHUPs and reports them through a pipe.
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t child = testing::ForkChild();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::close(fds[0]);
    ::prctl(PR_SET_NAME, "mfns-navd", 0, 0, 0);
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGHUP);
    sigaddset(&set, SIGTERM);
    sigprocmask(SIG_BLOCK, &set, nullptr);
    if (!WritePidFile(pid_file.c_str())) ::_exit(2);
    for (int i = 0; i < 10; ++i) {
      int sig = 0;
      timespec t{20, 0};
      siginfo_t si;
      sig = sigtimedwait(&set, &si, &t);
      if (sig == SIGHUP) {
        const char c = 'H';
        if (::write(fds[1], &c, 1) != 1) break;
      } else {
        break;  // SIGTERM or timeout
      }
    }
    RemovePidFile(pid_file.c_str());
    ::_exit(0);
  }
  ::close(fds[1]);
  // Reads one byte from the child, waiting at most 10 s.
  const auto read_one = [&](char* c) {
    pollfd p{fds[0], POLLIN, 0};
    return ::poll(&p, 1, 10000) == 1 && ::read(fds[0], c, 1) == 1;
  };
  // Wait (bounded) for the child to write its pid file; the first success signals it.
  SignalStatus st = SignalStatus::kNoPidFile;
  for (int i = 0; i < 500 && st == SignalStatus::kNoPidFile; ++i) {
    st = SignalReload(pid_file.c_str(), kNavdProcessName, &pid);
    if (st == SignalStatus::kNoPidFile) ::usleep(10000);
  }
  EXPECT_EQ(st, SignalStatus::kSignalled);
  char c = 0;
  if (st == SignalStatus::kSignalled) {
    EXPECT_TRUE(read_one(&c));
    EXPECT_EQ(c, 'H');
    EXPECT_EQ(pid, child);
    EXPECT_EQ(SignalReload(pid_file.c_str(), kNavdProcessName, &pid), SignalStatus::kSignalled);
    EXPECT_TRUE(read_one(&c));
  }
  // Another expected name: not signalled.
  EXPECT_EQ(SignalReload(pid_file.c_str(), "some-other", &pid), SignalStatus::kNotNavd);
  ::kill(child, SIGTERM);
  int wstatus = 0;
  ASSERT_EQ(::waitpid(child, &wstatus, 0), child);
  EXPECT_TRUE(WIFEXITED(wstatus) && WEXITSTATUS(wstatus) == 0);
  EXPECT_EQ(::read(fds[0], &c, 1), 0);  // no further SIGHUP arrived
  ::close(fds[0]);
  EXPECT_FALSE(fs::exists(pid_file));  // removed by its owner

  // A stale pid file (the child is gone).
  FILE* f = std::fopen(pid_file.c_str(), "w");
  std::fprintf(f, "%d\n", static_cast<int>(child));
  std::fclose(f);
  EXPECT_EQ(SignalReload(pid_file.c_str(), kNavdProcessName, &pid), SignalStatus::kNotRunning);
  // RemovePidFile leaves another process's pid file alone.
  EXPECT_FALSE(RemovePidFile(pid_file.c_str()));
  EXPECT_TRUE(fs::exists(pid_file));
  std::set<std::string> names;
  for (int i = 0; i <= static_cast<int>(SignalStatus::kKillFailed); ++i) names.insert(ToString(static_cast<SignalStatus>(i)));
  EXPECT_EQ(names.size(), 6u);
}

// Issue 14: a FIFO as --params, or named like a slot, hung navd's start and its reload
// mid-flight (frame processing stopped). Refused (the file) or skipped (a slot), at once.
// A pid file path that is not a regular file (--pid-file /dev/null) is refused with EINVAL and
// left as it was: the rename would have replaced the node itself.
TEST(ReloadSignal, APidFileThatIsNotARegularFileIsRefusedAndLeftAlone) {
  TempDir dir;
  const std::string fifo = dir / "navd.pid";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  errno = 0;
  EXPECT_FALSE(WritePidFile(fifo.c_str()));
  EXPECT_EQ(errno, EINVAL);
  struct stat st {};
  ASSERT_EQ(::stat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_FALSE(std::filesystem::exists(fifo + ".tmp"));
  const std::string file = dir / "ok.pid";
  EXPECT_TRUE(WritePidFile(file.c_str()));
  EXPECT_TRUE(RemovePidFile(file.c_str()));
}

TEST(ParamLoader, AFifoAsTheBlobFileOrASlotIsRefusedWithoutBlocking) {
  TempDir dir;
  const std::string fifo = dir / "cal.bin";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  ParamLoader loader;
  Rig rig;
  BlobInfo info;
  StoreStatus s = StoreStatus::kOk;
  ASSERT_TRUE(testing::ReturnsWithoutBlocking([&] { s = loader.Open(fifo.c_str(), nullptr, &rig, &info); }, {fifo}))
      << "Open blocked on a FIFO";
  EXPECT_NE(s, StoreStatus::kOk);
  EXPECT_THAT(Why(loader), HasSubstr(fifo + ": not a regular file"));

  // A store whose other slot becomes a FIFO while navd runs: the reload keeps slot a.
  TempDir store_dir;
  WriteBytes(store_dir / "slot-a.bin", MakeBlob(1));
  ASSERT_EQ(loader.Open(store_dir.path().c_str(), nullptr, &rig, &info), StoreStatus::kOk);
  ASSERT_EQ(::mkfifo((store_dir / "slot-b.bin").c_str(), 0644), 0);
  ASSERT_TRUE(testing::ReturnsWithoutBlocking([&] { s = loader.Reload(&rig, &info); }, {store_dir / "slot-b.bin"}))
      << "Reload blocked on a FIFO slot";
  EXPECT_EQ(s, StoreStatus::kOk);
  EXPECT_EQ(info.generation, 1u);
  EXPECT_THAT(Why(loader), HasSubstr("slot-b.bin: not a regular file"));
}

}  // namespace
}  // namespace mfns::fw
