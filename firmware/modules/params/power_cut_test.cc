// Power cuts and crashes during an install (and a rollback): at every call the store makes and
// at every byte offset of the blob write, the store must afterwards open to the old blob or the
// new one (never to nothing, never to a mix), to the new one once Install returned kOk, and a
// later install must still work.
//
// Three ways to interrupt:
//  - SimFs (in memory) with FaultStoreIo: the writer dies at call k (or after b bytes of the
//    temp file), then the machine loses power: un-fsynced directory entries and file data are
//    kept or dropped in every combination (SimFs::Crash). This is the POSIX worst case.
//  - The real file system with FaultStoreIo: the writer dies (process-kill semantics) at every
//    call and byte offset, or one call fails and the store undoes.
//  - A forked writer process SIGKILLed at chosen steps on the real file system.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <algorithm>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "firmware/modules/params/param_store.h"
#include "firmware/modules/params/testing/fault_store_io.h"
#include "firmware/modules/params/testing/fork_child.h"
#include "firmware/modules/params/testing/sim_fs.h"
#include "firmware/modules/params/testing/test_blobs.h"

namespace mfns::fw {
namespace {

using testing::FaultStoreIo;
using testing::MakeBlob;
using testing::SimFs;
using testing::TempDir;
using testing::WriteBytes;
using Blob = std::vector<std::uint8_t>;

constexpr char kSimDir[] = "/sim/params";

// One starting state and one operation on it.
struct Scenario {
  const char* name;
  std::vector<std::pair<std::string, Blob>> files;  // initial slot files (durable)
  std::uint64_t old_gen;                            // active before
  std::uint64_t new_gen;                            // active after success
  bool rollback = false;
  Blob blob;                                        // install: the new blob
  InstallOptions options;
};

std::vector<Scenario> Scenarios() {
  std::vector<Scenario> out;
  out.push_back({"first-install", {}, 0, 1, false, MakeBlob(1), {}});
  out.push_back({"one-slot", {{"slot-a.bin", MakeBlob(1)}}, 1, 2, false, MakeBlob(2), {}});
  out.push_back({"overwrite-older-slot",
                 {{"slot-a.bin", MakeBlob(1)}, {"slot-b.bin", MakeBlob(2, kPaperRigId, 9)}},
                 2, 3, false, MakeBlob(3, kPaperRigId, 8), {}});
  out.push_back({"forced-older",
                 {{"slot-a.bin", MakeBlob(1)}, {"slot-b.bin", MakeBlob(3)}},
                 3, 2, false, MakeBlob(2, kPaperRigId, 7), InstallOptions{true, false}});
  out.push_back({"rollback", {{"slot-a.bin", MakeBlob(1)}, {"slot-b.bin", MakeBlob(2)}}, 2, 1, true, {}, {}});
  return out;
}

// Runs the scenario's operation through io. Returns the status.
StoreStatus RunOperation(const Scenario& sc, StoreIo* io, const std::string& dir) {
  ParamStore store(io);
  store.SetDirectory(dir.c_str());
  if (sc.rollback) return store.Rollback(nullptr);
  return store.Install(sc.blob, sc.options, nullptr);
}

const Blob& LaterBlob() {
  static const Blob blob = MakeBlob(100);
  return blob;
}

// After the crash: the store opens to old or new (new when the operation reported kOk, and a
// first install may also leave nothing), the active slot decodes fully, and a later install
// of a newer generation succeeds and is what the store opens to. Returns "" or what is wrong.
std::string CheckAfterCrash(StoreIo* io, const std::string& dir, const Scenario& sc, bool reported_ok,
                            bool try_later_install) {
  ParamStore store(io);
  store.SetDirectory(dir.c_str());
  StoreSnapshot snap;
  const StoreStatus s = store.Scan(nullptr, &snap);  // decodes every slot in full
  const std::uint64_t gen = testing::ActiveGeneration(snap);
  char why[256];
  DescribeSnapshot(snap, why, sizeof why);
  if (s != StoreStatus::kOk && !(sc.old_gen == 0 && !reported_ok)) {
    return std::string("opens to nothing: ") + ToString(s) + " (" + why + ")";
  }
  if (s == StoreStatus::kOk && gen != sc.old_gen && gen != sc.new_gen) {
    return "opens to generation " + std::to_string(gen) + " (" + why + ")";
  }
  if (reported_ok && gen != sc.new_gen) return "reported kOk but opens to generation " + std::to_string(gen);
  if (!try_later_install) return "";
  InstallReport rep;
  const StoreStatus later = store.Install(LaterBlob(), {}, &rep);
  if (later != StoreStatus::kOk) return std::string("later install: ") + ToString(later);
  StoreSnapshot after;
  if (store.Scan(nullptr, &after) != StoreStatus::kOk || testing::ActiveGeneration(after) != 100) {
    return "later install not active";
  }
  return "";
}

SimFs MakeSim(const Scenario& sc) {
  SimFs sim(kSimDir);
  for (const auto& [name, bytes] : sc.files) sim.PutFile(name, bytes);
  return sim;
}

// Number of calls the operation makes when nothing goes wrong.
int CountCalls(const Scenario& sc) {
  SimFs sim = MakeSim(sc);
  FaultStoreIo io(&sim);
  EXPECT_EQ(RunOperation(sc, &io, kSimDir), StoreStatus::kOk) << sc.name;
  return io.calls();
}

// Every SimFs crash kind applied to a copy of the state the dead writer left. Slot files that
// two kinds leave alike are checked once (the store reads nothing else, and the check decodes
// blobs, which costs CRCs).
void CheckEveryCrashKind(const SimFs& left, const Scenario& sc, bool reported_ok, const std::string& where,
                         int* failures, bool try_later_install = true) {
  std::vector<std::map<std::string, Blob>> seen;
  for (SimFs::Crash crash : SimFs::kAllCrashes) {
    SimFs after = left;
    after.PowerCut(crash);
    auto contents = after.Contents();
    std::erase_if(contents, [](const auto& kv) { return kv.first.size() < 4 || kv.first.substr(kv.first.size() - 4) != ".bin"; });
    if (std::find(seen.begin(), seen.end(), contents) != seen.end()) continue;
    seen.push_back(std::move(contents));
    const std::string bad = CheckAfterCrash(&after, kSimDir, sc, reported_ok, try_later_install);
    if (!bad.empty() && ++*failures <= 10) {
      ADD_FAILURE() << sc.name << ", " << where << ", crash kind " << static_cast<int>(crash) << ": " << bad;
    }
  }
}

TEST(PowerCut, SimulatedPowerLossAtEveryCallLeavesOldOrNew) {
  for (const Scenario& sc : Scenarios()) {
    const int n = CountCalls(sc);
    ASSERT_GT(n, 8) << sc.name;
    int failures = 0;
    for (int k = 0; k <= n; ++k) {  // k == n: the writer finishes, then the power goes
      SimFs sim = MakeSim(sc);
      FaultStoreIo io(&sim);
      io.DieAtCall(k);
      const bool ok = RunOperation(sc, &io, kSimDir) == StoreStatus::kOk;
      // Dying in a close(2) of a read, or in the final report scan, may still end in kOk.
      if (k == n) {
        EXPECT_TRUE(ok) << sc.name;
      }
      CheckEveryCrashKind(sim, sc, ok, "die at call " + std::to_string(k) + " (" +
                                           (k < n ? io.log()[static_cast<std::size_t>(k)] : "after") + ")",
                          &failures);
    }
    EXPECT_EQ(failures, 0) << sc.name;
  }
}

TEST(PowerCut, SimulatedPowerLossAtEveryByteOfTheBlobWriteLeavesOldOrNew) {
  for (const Scenario& sc : Scenarios()) {
    if (sc.rollback) continue;
    int failures = 0;
    for (std::size_t b = 0; b <= sc.blob.size(); ++b) {
      // The later install is the same code whatever b was: try it on a sample of offsets.
      const bool later = b % 61 == 0 || b + 2 >= sc.blob.size();
      for (std::size_t chunk : {std::size_t{0}, std::size_t{97}}) {  // one write, or short writes
        // Short writes exercise the same write loop in every scenario: one scenario suffices.
        if (chunk != 0 && std::string(sc.name) != "overwrite-older-slot") continue;
        SimFs sim = MakeSim(sc);
        FaultStoreIo io(&sim);
        io.ShortTransfers(chunk);
        io.DieAfterTempBytes(b);
        const StoreStatus s = RunOperation(sc, &io, kSimDir);
        // Dying after all bytes went through happens only if a later call kills it; here the
        // budget is crossed only by a write that wanted more, so b == size completes.
        EXPECT_EQ(s == StoreStatus::kOk, b == sc.blob.size()) << sc.name << " byte " << b;
        CheckEveryCrashKind(sim, sc, s == StoreStatus::kOk, "die after byte " + std::to_string(b), &failures,
                            later);
      }
    }
    EXPECT_EQ(failures, 0) << sc.name;
  }
}

// The checks above must be able to fail: a store whose fsyncs do nothing loses an install it
// reported as done (the rename survives but the data does not, or the rename is lost).
class NoFsyncIo final : public StoreIo {
 public:
  NoFsyncIo(StoreIo* inner, bool files, bool dirs) : inner_(inner), files_(files), dirs_(dirs) {}
  int Open(const char* path, int flags, mode_t mode) override {
    const int fd = inner_->Open(path, flags, mode);
    if (fd >= 0 && (flags & O_DIRECTORY) != 0) dir_fd_ = fd;
    return fd;
  }
  int Close(int fd) override { return inner_->Close(fd); }
  ssize_t Read(int fd, void* b, std::size_t n) override { return inner_->Read(fd, b, n); }
  ssize_t Write(int fd, const void* b, std::size_t n) override { return inner_->Write(fd, b, n); }
  int Fsync(int fd) override {
    const bool is_dir = fd == dir_fd_;
    if ((is_dir && dirs_) || (!is_dir && files_)) return 0;
    return inner_->Fsync(fd);
  }
  int Rename(const char* a, const char* b) override { return inner_->Rename(a, b); }
  int Unlink(const char* p) override { return inner_->Unlink(p); }
  int Mkdir(const char* p, mode_t m) override { return inner_->Mkdir(p, m); }
  int Fstat(int fd, struct stat* st) override { return inner_->Fstat(fd, st); }
  int Flock(int fd, int op) override { return inner_->Flock(fd, op); }

 private:
  StoreIo* inner_;
  bool files_, dirs_;
  int dir_fd_ = -1;
};

TEST(PowerCut, TheCheckCatchesAStoreThatSkipsItsFsyncs) {
  const Scenario sc = Scenarios()[2];  // overwrite-older-slot
  for (const auto& [skip_files, skip_dirs] : {std::pair{true, false}, std::pair{false, true}}) {
    SimFs sim = MakeSim(sc);
    NoFsyncIo io(&sim, skip_files, skip_dirs);
    ASSERT_EQ(RunOperation(sc, &io, kSimDir), StoreStatus::kOk);
    int bad = 0;
    for (SimFs::Crash crash : SimFs::kAllCrashes) {
      SimFs after = sim;
      after.PowerCut(crash);
      if (!CheckAfterCrash(&after, kSimDir, sc, true, false).empty()) ++bad;
    }
    EXPECT_GT(bad, 0) << "skip file fsync " << skip_files << ", skip dir fsync " << skip_dirs;
  }
}

// --- the real file system -------------------------------------------------------------------

void SetUpDir(const TempDir& dir, const Scenario& sc) {
  for (const auto& [name, bytes] : sc.files) WriteBytes(dir / name, bytes);
}

TEST(PowerCut, KilledWriterOnTheRealFileSystemAtEveryCallAndByteLeavesOldOrNew) {
  LinuxStoreIo real;
  for (const Scenario& sc : Scenarios()) {
    int n = 0;
    {
      TempDir dir(testing::FastTempBase());
      SetUpDir(dir, sc);
      FaultStoreIo io(&real);
      ASSERT_EQ(RunOperation(sc, &io, dir.path()), StoreStatus::kOk);
      n = io.calls();
    }
    for (int k = 0; k <= n; ++k) {
      TempDir dir(testing::FastTempBase());
      SetUpDir(dir, sc);
      FaultStoreIo io(&real);
      io.DieAtCall(k);
      const bool ok = RunOperation(sc, &io, dir.path()) == StoreStatus::kOk;
      EXPECT_EQ(CheckAfterCrash(&real, dir.path(), sc, ok, true), "") << sc.name << " die at call " << k;
    }
    // Every byte on the real file system for the two scenarios that overwrite an existing slot
    // (the simulation above covers every scenario at every byte).
    if (std::string(sc.name) != "overwrite-older-slot" && std::string(sc.name) != "forced-older") continue;
    for (std::size_t b = 0; b <= sc.blob.size(); ++b) {
      TempDir dir(testing::FastTempBase());
      SetUpDir(dir, sc);
      FaultStoreIo io(&real);
      io.DieAfterTempBytes(b);
      const bool ok = RunOperation(sc, &io, dir.path()) == StoreStatus::kOk;
      const bool later = b % 61 == 0 || b + 2 >= sc.blob.size();  // as in the simulation
      EXPECT_EQ(CheckAfterCrash(&real, dir.path(), sc, ok, later), "") << sc.name << " die after byte " << b;
    }
  }
}

TEST(PowerCut, OneFailedCallAnywhereIsUndoneAndTheOldBlobStaysActive) {
  LinuxStoreIo real;
  for (const Scenario& sc : Scenarios()) {
    int n = 0;
    {
      TempDir dir(testing::FastTempBase());
      SetUpDir(dir, sc);
      FaultStoreIo io(&real);
      ASSERT_EQ(RunOperation(sc, &io, dir.path()), StoreStatus::kOk);
      n = io.calls();
    }
    for (int k = 0; k < n; ++k) {
      TempDir dir(testing::FastTempBase());
      SetUpDir(dir, sc);
      FaultStoreIo io(&real);
      io.FailAtCall(k, EIO);
      const StoreStatus s = RunOperation(sc, &io, dir.path());
      ParamStore check;
      check.SetDirectory(dir.path().c_str());
      StoreSnapshot snap;
      check.Scan(nullptr, &snap);
      const std::uint64_t gen = testing::ActiveGeneration(snap);
      const std::string where = std::string(sc.name) + " fail call " + std::to_string(k) + " (" +
                                io.log()[static_cast<std::size_t>(k)] + "): " + ToString(s);
      if (s == StoreStatus::kOk) {
        EXPECT_EQ(gen, sc.new_gen) << where;
      } else {
        EXPECT_EQ(gen, sc.old_gen) << where;
      }
      // Nothing but slots and set-aside slots is left behind.
      for (const auto& e : std::filesystem::directory_iterator(dir.path())) {
        EXPECT_EQ(e.path().extension().string() == ".tmp", false) << where << ": left " << e.path();
      }
    }
  }
}

// A child process runs the install and SIGKILLs itself right before call k of the dry run's
// log; the parent then opens the store.
TEST(PowerCut, WriterProcessKilledWithSigkillAtEachStepLeavesOldOrNew) {
  LinuxStoreIo real;
  const Scenario sc = Scenarios()[3];  // forced-older: has every step, including the set-aside
  std::vector<std::string> log;
  {
    TempDir dir(testing::FastTempBase());
    SetUpDir(dir, sc);
    FaultStoreIo io(&real);
    io.ShortTransfers(200);  // several write calls, so a kill can land between them
    ASSERT_EQ(RunOperation(sc, &io, dir.path()), StoreStatus::kOk);
    log = io.log();
  }
  // The steps: each write, the fsyncs, the close, the renames, and the calls right after them.
  std::vector<int> kill_at;
  for (std::size_t i = 0; i < log.size(); ++i) {
    const std::string& l = log[i];
    if (l.rfind("write", 0) == 0 || l.rfind("fsync", 0) == 0 || l.rfind("rename", 0) == 0 ||
        (l.rfind("close slot-a.bin.", 0) == 0 && l.size() > 4 && l.compare(l.size() - 4, 4, ".tmp") == 0)) {
      kill_at.push_back(static_cast<int>(i));      // before it
      kill_at.push_back(static_cast<int>(i) + 1);  // after it
    }
  }
  ASSERT_GE(kill_at.size(), 12u);
  int killed = 0;
  for (int k : kill_at) {
    TempDir dir(testing::FastTempBase());
    SetUpDir(dir, sc);
    const pid_t pid = testing::ForkChild();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      FaultStoreIo io(&real);
      io.ShortTransfers(200);
      io.before_call = [k](int call, const std::string&) {
        if (call == k) testing::KillSelf();
      };
      RunOperation(sc, &io, dir.path());
      ::_exit(0);
    }
    int wstatus = 0;
    ASSERT_EQ(::waitpid(pid, &wstatus, 0), pid);
    const bool was_killed = WIFSIGNALED(wstatus) && WTERMSIG(wstatus) == SIGKILL;
    if (k < static_cast<int>(log.size())) {
      EXPECT_TRUE(was_killed) << "call " << k << " " << log[static_cast<std::size_t>(k)];
    }
    killed += was_killed ? 1 : 0;
    EXPECT_EQ(CheckAfterCrash(&real, dir.path(), sc, !was_killed, true), "")
        << "killed before call " << k << (k < static_cast<int>(log.size()) ? " " + log[static_cast<std::size_t>(k)] : "");
  }
  EXPECT_GE(killed, 12);
}

}  // namespace
}  // namespace mfns::fw
