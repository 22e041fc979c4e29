// mfns-paramctl: in-process (RunParamctl) for every command and refusal, and the built binary
// as a subprocess (stdin, exit codes; through qemu under the aarch64 preset).
#include "firmware/app/paramctl/paramctl.h"

#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <spawn.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "common/blob/param_blob.h"
#include "firmware/lib/testing/returns_without_blocking.h"
#include "firmware/modules/params/reload_signal.h"
#include "firmware/modules/params/testing/fork_child.h"
#include "firmware/modules/params/testing/test_blobs.h"

extern char** environ;  // NOLINT

namespace mfns::fw {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using ::testing::StartsWith;
using testing::MakeBlob;
using testing::ReadBytes;
using testing::TempDir;
using testing::WriteBytes;
namespace fs = std::filesystem;

struct Result {
  int code = -1;
  std::string out, err;
};

std::string Slurp(std::FILE* f) {
  std::fflush(f);
  std::rewind(f);
  std::string s;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) s.append(buf, n);
  std::fclose(f);
  return s;
}

// Runs RunParamctl in this process; stdin_bytes feed "install -".
Result Paramctl(std::vector<std::string> args, const std::vector<std::uint8_t>& stdin_bytes = {}) {
  args.insert(args.begin(), "mfns-paramctl");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::FILE* in = std::tmpfile();
  if (!stdin_bytes.empty()) std::fwrite(stdin_bytes.data(), 1, stdin_bytes.size(), in);
  std::fflush(in);
  std::rewind(in);
  std::FILE* out = std::tmpfile();
  std::FILE* err = std::tmpfile();
  Result r;
  r.code = RunParamctl(static_cast<int>(args.size()), argv.data(), fileno(in), out, err);
  std::fclose(in);
  r.out = Slurp(out);
  r.err = Slurp(err);
  return r;
}

int Lines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

// "key: value" from show's output ("" if absent).
std::string Field(const std::string& out, const std::string& key) {
  std::istringstream in(out);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key + ": ", 0) == 0) return line.substr(key.size() + 2);
  }
  return "";
}

class ParamctlTest : public ::testing::Test {
 protected:
  std::string Blob(std::uint64_t gen, const char* rig = kPaperRigId, int beacons = -1) {
    const std::string path = dir_ / ("g" + std::to_string(gen) + "-" + rig + std::to_string(beacons) + ".bin");
    WriteBytes(path, MakeBlob(gen, rig, beacons));
    return path;
  }
  Result Install(const std::string& blob, std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"install", "--store", store_, "--no-signal"};
    args.insert(args.end(), extra.begin(), extra.end());
    args.push_back(blob);
    return Paramctl(args);
  }
  std::string ActiveGeneration() { return Field(Paramctl({"show", "--store", store_}).out, "generation"); }

  TempDir dir_;
  std::string store_ = dir_ / "params";
};

TEST_F(ParamctlTest, HelpAndUsageErrors) {
  Result r = Paramctl({"--help"});
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("install BLOB|-"));
  for (const auto& args : std::vector<std::vector<std::string>>{
           {}, {"frobnicate"}, {"install", "--store", store_}, {"show", "--bogus"}, {"show", "extra"}}) {
    r = Paramctl(args);
    EXPECT_EQ(r.code, 1) << ::testing::PrintToString(args);
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_THAT(r.err, StartsWith("mfns-paramctl: "));
  }
}

// Issue 14 (host_cli_fuzz): an argument holding a newline was echoed as given, a two-line
// error; its control characters are escaped now.
TEST_F(ParamctlTest, ArgumentsHoldingANewlineGiveOneLineErrors) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"sh\now"}, "mfns-paramctl: unknown command 'sh\\now' (install, show, verify, rollback; --help)\n"},
      {{"show", "ex\ntra"}, "mfns-paramctl: unexpected argument: ex\\ntra\n"},
      {{"show", "--bo\x01gus"}, "mfns-paramctl: unknown option or missing value: --bo\\x01gus\n"},
  };
  for (const auto& [args, err] : cases) {
    const Result r = Paramctl(args);
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err, err);
  }
}

TEST_F(ParamctlTest, InstallCreatesTheStoreAndShowPrintsTheActiveBlob) {
  const std::string blob = Blob(5);
  Result r = Install(blob);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "installed generation 5 (rig mfns-paper-2017, " + std::to_string(MakeBlob(5).size()) +
                       " bytes) in slot-a.bin\n");
  EXPECT_EQ(ReadBytes(store_ + "/slot-a.bin"), ReadBytes(blob));

  r = Paramctl({"show", "--store", store_});
  ASSERT_EQ(r.code, 0) << r.err;
  // Checked against the blob decoded here and its CRC computed here.
  const auto bytes = MakeBlob(5);
  Rig rig;
  BlobInfo info;
  ASSERT_EQ(DecodeParamBlob(bytes, nullptr, &rig, &info), BlobStatus::kOk);
  char crc[16];
  std::snprintf(crc, sizeof crc, "0x%08x", Crc32(std::span<const std::uint8_t>(bytes).subspan(kBlobHeaderBytes)));
  EXPECT_EQ(Field(r.out, "active"), "slot-a.bin");
  EXPECT_EQ(Field(r.out, "generation"), "5");
  EXPECT_EQ(Field(r.out, "rig_id"), kPaperRigId);
  EXPECT_EQ(Field(r.out, "bytes"), std::to_string(bytes.size()));
  EXPECT_EQ(Field(r.out, "payload_crc32"), crc);
  EXPECT_THAT(Field(r.out, "cameras"), StartsWith(std::to_string(rig.num_cameras) + " (x 1280x1024"));
  EXPECT_EQ(Field(r.out, "beacons"), std::to_string(rig.num_beacons));
  EXPECT_EQ(Field(r.out, "other"), "slot-b.bin missing");

  ASSERT_EQ(Install(Blob(6, kPaperRigId, 7)).code, 0);
  r = Paramctl({"show", "--store", store_});
  EXPECT_EQ(Field(r.out, "active"), "slot-b.bin");
  EXPECT_EQ(Field(r.out, "beacons"), "7");
  EXPECT_THAT(Field(r.out, "other"), StartsWith("slot-a.bin valid generation 5 rig mfns-paper-2017"));
}

TEST_F(ParamctlTest, RefusalsAreOneLineWithTheReasonAndLeaveTheOldBlobActive) {
  ASSERT_EQ(Install(Blob(5)).code, 0);
  const auto before = ReadBytes(store_ + "/slot-a.bin");
  auto corrupt = MakeBlob(9);
  corrupt[corrupt.size() - 3] ^= 0x40;
  const std::string corrupt_path = dir_ / "corrupt.bin";
  WriteBytes(corrupt_path, corrupt);
  const std::string garbage = dir_ / "garbage.bin";
  WriteBytes(garbage, {'h', 'e', 'l', 'l', 'o'});
  struct Case {
    std::string blob;
    std::string reason;
  };
  const std::vector<Case> cases = {
      {corrupt_path, "refused: corrupt blob: payload CRC32 mismatch"},
      {garbage, "refused: corrupt blob: blob shorter than its header"},
      {Blob(9, "other-rig"), "refused: blob is for rig 'other-rig' but the active blob is for rig 'mfns-paper-2017'"},
      {Blob(4), "refused: generation 4 is not newer than the active generation 5 (--force"},
      {Blob(5, kPaperRigId, 3), "refused: generation 5 is not newer than the active generation 5"},
      {Blob(9, kPaperRigId, 2), "refused: the blob maps 2 beacons, mfns-navd needs at least 3"},
      {Blob(9, kPaperRigId, 0), "refused: the blob maps 0 beacons, mfns-navd needs at least 3"},
      {dir_ / "missing.bin", "cannot read blob"},
  };
  for (const Case& c : cases) {
    const Result r = Install(c.blob);
    EXPECT_EQ(r.code, 1) << c.blob;
    EXPECT_EQ(Lines(r.err), 1) << r.err;
    EXPECT_THAT(r.err, StartsWith("mfns-paramctl: " + c.reason)) << r.err;
    if (c.reason.rfind("refused", 0) == 0) {
      EXPECT_THAT(r.err, HasSubstr("generation 5 (slot-a.bin) still active"));
    }
    EXPECT_EQ(r.out, "");
    EXPECT_EQ(ReadBytes(store_ + "/slot-a.bin"), before);
    EXPECT_FALSE(fs::exists(store_ + "/slot-b.bin"));
    EXPECT_EQ(ActiveGeneration(), "5");
  }
  // Over the size limit, from stdin.
  const Result big = Paramctl({"install", "--store", store_, "--no-signal", "-"},
                         std::vector<std::uint8_t>(limits::kMaxBlobBytes + 10, 0x55));
  EXPECT_EQ(big.code, 1);
  EXPECT_THAT(big.err, StartsWith("mfns-paramctl: refused: blob larger than " + std::to_string(limits::kMaxBlobBytes) + " bytes"));
}

TEST_F(ParamctlTest, ForceAndAllowRigChangeOverrideTheirRefusalOnly) {
  ASSERT_EQ(Install(Blob(5)).code, 0);
  ASSERT_EQ(Install(Blob(7)).code, 0);
  Result r = Install(Blob(6), {"--force"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(ActiveGeneration(), "6");
  EXPECT_EQ(Install(Blob(8, "new-rig"), {"--force"}).code, 1);
  r = Install(Blob(8, "new-rig"), {"--allow-rig-change"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(Field(Paramctl({"show", "--store", store_}).out, "rig_id"), "new-rig");
}

TEST_F(ParamctlTest, InstallFromStdin) {
  const auto blob = MakeBlob(11);
  const Result r = Paramctl({"install", "-", "--store", store_, "--no-signal"}, blob);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(ReadBytes(store_ + "/slot-a.bin"), blob);
  const Result empty = Paramctl({"install", "--store", store_, "--no-signal", "-"}, {});
  EXPECT_EQ(empty.code, 1);
  EXPECT_THAT(empty.err, HasSubstr("refused: corrupt blob"));
}

TEST_F(ParamctlTest, RollbackSelectsTheOtherValidSlotOrRefusesWithTheReason) {
  Result r = Paramctl({"rollback", "--store", store_, "--no-signal"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, StartsWith("mfns-paramctl: rollback failed: no such store directory"));
  ASSERT_EQ(Install(Blob(5)).code, 0);
  r = Paramctl({"rollback", "--store", store_, "--no-signal"});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "mfns-paramctl: refused: no other valid slot to roll back to: slot-a.bin: generation 5, rig "
                   "mfns-paper-2017 (active); slot-b.bin: missing\n");
  ASSERT_EQ(Install(Blob(6)).code, 0);
  r = Paramctl({"rollback", "--store", store_, "--no-signal"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "rolled back to generation 5 in slot-a.bin (generation 6 set aside as slot-b.bin.rolled-back)\n");
  EXPECT_EQ(ActiveGeneration(), "5");
}

TEST_F(ParamctlTest, VerifyFailsWhenNothingIsValidOrTheNewestInstallIsCorrupt) {
  fs::create_directory(store_);
  Result r = Paramctl({"verify", "--store", store_});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(Lines(r.err), 1);
  ASSERT_EQ(Install(Blob(5)).code, 0);
  ASSERT_EQ(Install(Blob(6)).code, 0);
  r = Paramctl({"verify", "--store", store_});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("ok: generation 6 active in slot-b.bin"));
  r = Paramctl({"verify", "--store", store_, "--rig-id", "other-rig"});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, HasSubstr("no valid blob for rig other-rig"));
  // Corrupt the newest slot's payload: the store falls back to 5, verify says so and fails.
  auto bytes = ReadBytes(store_ + "/slot-b.bin");
  bytes[bytes.size() - 1] ^= 1;
  WriteBytes(store_ + "/slot-b.bin", bytes);
  EXPECT_EQ(ActiveGeneration(), "5");
  r = Paramctl({"verify", "--store", store_});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(r.err, "mfns-paramctl: verify: slot-b.bin holds generation 6 but is corrupt (payload CRC32 mismatch "
                   "(payload corrupted)); generation 5 is active\n");
  // An older corrupt slot is reported but is not a failure.
  WriteBytes(store_ + "/slot-b.bin", MakeBlob(7));
  WriteBytes(store_ + "/slot-a.bin", {1, 2, 3});
  r = Paramctl({"verify", "--store", store_});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("slot: slot-a.bin invalid"));
}

TEST_F(ParamctlTest, ShowWithoutAValidBlobSaysWhyAndFails) {
  Result r = Paramctl({"show", "--store", store_});
  EXPECT_EQ(r.code, 1);
  EXPECT_THAT(r.err, StartsWith("mfns-paramctl: cannot open store"));
  fs::create_directory(store_);
  WriteBytes(store_ + "/slot-b.bin", {0, 1});
  r = Paramctl({"show", "--store", store_});
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(Field(r.out, "active"), "none");
  EXPECT_EQ(r.err, "mfns-paramctl: no valid blob in " + store_ +
                       ": slot-a.bin: missing; slot-b.bin: blob shorter than its header or than header + payload length\n");
}

// A stand-in for mfns-navd: named mfns-navd, writes its pid file, reports each SIGHUP on a pipe.
class FakeNavd {
 public:
  explicit FakeNavd(const std::string& pid_file) {
    int fds[2];
    if (::pipe(fds) != 0) return;
    pid_ = testing::ForkChild();
    if (pid_ == 0) {
      ::close(fds[0]);
      ::prctl(PR_SET_NAME, "mfns-navd", 0, 0, 0);
      sigset_t set;
      sigemptyset(&set);
      sigaddset(&set, SIGHUP);
      sigaddset(&set, SIGTERM);
      sigprocmask(SIG_BLOCK, &set, nullptr);
      if (!WritePidFile(pid_file.c_str())) ::_exit(2);
      for (int i = 0; i < 20; ++i) {
        timespec t{20, 0};
        siginfo_t si;
        if (sigtimedwait(&set, &si, &t) != SIGHUP) break;
        const char c = 'H';
        if (::write(fds[1], &c, 1) != 1) break;
      }
      ::_exit(0);
    }
    ::close(fds[1]);
    read_fd_ = fds[0];
    for (int i = 0; i < 500 && !fs::exists(pid_file); ++i) ::usleep(10000);
  }
  ~FakeNavd() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
    if (read_fd_ >= 0) ::close(read_fd_);
  }
  // True when a SIGHUP arrived within 10 s.
  bool GotSighup() {
    pollfd p{read_fd_, POLLIN, 0};
    char c = 0;
    return ::poll(&p, 1, 10000) == 1 && ::read(read_fd_, &c, 1) == 1 && c == 'H';
  }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int read_fd_ = -1;
};

TEST_F(ParamctlTest, InstallAndRollbackTellARunningNavdToReload) {
  const std::string pid_file = dir_ / "navd.pid";
  Result r = Paramctl({"install", "--store", store_, "--pid-file", pid_file, Blob(1)});
  ASSERT_EQ(r.code, 0);
  EXPECT_THAT(r.out, HasSubstr("reload: no " + pid_file + " (mfns-navd not running"));
  FakeNavd navd(pid_file);
  ASSERT_GT(navd.pid(), 0);
  r = Paramctl({"install", "--store", store_, "--pid-file", pid_file, Blob(2)});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("reload: signalled mfns-navd (pid " + std::to_string(navd.pid()) + ")"));
  EXPECT_TRUE(navd.GotSighup());
  r = Paramctl({"rollback", "--store", store_, "--pid-file", pid_file});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(navd.GotSighup());
  // A refused install signals nobody.
  r = Paramctl({"install", "--store", store_, "--pid-file", pid_file, Blob(1)});
  EXPECT_EQ(r.code, 1);
  // A pid file naming another program: warned, not signalled, the install still succeeds.
  const std::string other = dir_ / "other.pid";
  WriteBytes(other, {'1', '\n'});  // pid 1 is never mfns-navd
  r = Paramctl({"install", "--store", store_, "--pid-file", other, Blob(3)});
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("warning: did not signal mfns-navd"));
}

// --- the built binary --------------------------------------------------------------------------

std::vector<std::string> Split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == sep) {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

// Runs the mfns-paramctl binary (through the cross emulator when there is one) with stdin,
// at most 60 s. Returns exit code, stdout, stderr. MFNS_PARAMCTL_BINARY, when set, is run
// instead, as it is: on the emulated ARM64 board (scripts/test-board.sh) this test runs
// natively, where neither the build tree nor qemu-aarch64 exists.
Result RunBinary(const std::vector<std::string>& args, const std::vector<std::uint8_t>& stdin_bytes) {
  std::vector<std::string> cmd;
  const char* binary = std::getenv("MFNS_PARAMCTL_BINARY");
  if (binary != nullptr && binary[0] != '\0') {
    cmd.push_back(binary);
  } else {
    cmd = Split(MFNS_TEST_EMULATOR, '|');
    cmd.push_back(MFNS_PARAMCTL_PATH);
  }
  cmd.insert(cmd.end(), args.begin(), args.end());
  int in[2], out[2], err[2];
  Result r;
  if (::pipe(in) != 0 || ::pipe(out) != 0 || ::pipe(err) != 0) return r;
  // posix_spawn, not fork: glibc's fork hangs under qemu-user (testing/fork_child.h).
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, in[0], 0);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_adddup2(&actions, err[1], 2);
  for (int fd : {in[0], in[1], out[0], out[1], err[0], err[1]}) posix_spawn_file_actions_addclose(&actions, fd);
  std::vector<char*> argv;
  for (auto& a : cmd) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  EXPECT_EQ(spawned, 0) << argv[0];
  if (spawned != 0) {
    for (int fd : {in[0], in[1], out[0], out[1], err[0], err[1]}) ::close(fd);
    return r;
  }
  ::close(in[0]);
  ::close(out[1]);
  ::close(err[1]);
  if (!stdin_bytes.empty()) {
    EXPECT_EQ(::write(in[1], stdin_bytes.data(), stdin_bytes.size()), static_cast<ssize_t>(stdin_bytes.size()));
  }
  ::close(in[1]);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  pollfd fds[2] = {{out[0], POLLIN, 0}, {err[0], POLLIN, 0}};
  int open_fds = 2;
  while (open_fds > 0 && std::chrono::steady_clock::now() < deadline) {
    if (::poll(fds, 2, 1000) <= 0) continue;
    for (int i = 0; i < 2; ++i) {
      if (fds[i].fd < 0 || fds[i].revents == 0) continue;
      char buf[4096];
      const ssize_t n = ::read(fds[i].fd, buf, sizeof buf);
      if (n <= 0) {
        ::close(fds[i].fd);
        fds[i].fd = -1;
        --open_fds;
      } else {
        (i == 0 ? r.out : r.err).append(buf, static_cast<std::size_t>(n));
      }
    }
  }
  if (open_fds > 0) ::kill(pid, SIGKILL);
  for (auto& f : fds) {
    if (f.fd >= 0) ::close(f.fd);
  }
  int wstatus = 0;
  ::waitpid(pid, &wstatus, 0);
  r.code = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : -1;
  return r;
}

TEST_F(ParamctlTest, TheBinaryInstallsFromStdinAndExitsWithTheDocumentedCodes) {
  Result r = RunBinary({"install", "--store", store_, "--no-signal", "-"}, MakeBlob(3));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, StartsWith("installed generation 3"));
  r = RunBinary({"install", "--store", store_, "--no-signal", "-"}, MakeBlob(2));
  EXPECT_EQ(r.code, 1);
  EXPECT_EQ(Lines(r.err), 1);
  EXPECT_THAT(r.err, StartsWith("mfns-paramctl: refused: generation 2 is not newer"));
  r = RunBinary({"show", "--store", store_}, {});
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(Field(r.out, "generation"), "3");
  r = RunBinary({"--help"}, {});
  EXPECT_EQ(r.code, 0);
  EXPECT_THAT(r.out, StartsWith("usage: mfns-paramctl"));
}

// Issue 14: a FIFO named like a slot hung show and verify; a FIFO given as the blob hung
// install. Each returns at once: show reports the slot and shows the active blob, verify fails
// naming it, install refuses the FIFO with one line naming it.
TEST_F(ParamctlTest, AFifoNamedLikeASlotOrGivenAsTheBlobNeverBlocks) {
  ASSERT_EQ(Install(Blob(1)).code, 0);
  const std::string fifo_slot = store_ + "/slot-b.bin";
  ASSERT_EQ(::mkfifo(fifo_slot.c_str(), 0644), 0);
  Result show, verify, install;
  ASSERT_TRUE(testing::ReturnsWithoutBlocking([&] { show = Paramctl({"show", "--store", store_}); }, {fifo_slot}))
      << "show blocked";
  EXPECT_EQ(show.code, 0) << show.err;
  EXPECT_EQ(Field(show.out, "generation"), "1");
  EXPECT_THAT(Field(show.out, "other"), HasSubstr("not a regular file"));
  ASSERT_TRUE(testing::ReturnsWithoutBlocking([&] { verify = Paramctl({"verify", "--store", store_}); }, {fifo_slot}))
      << "verify blocked";
  EXPECT_EQ(verify.code, 1);
  EXPECT_EQ(Lines(verify.err), 1) << verify.err;
  EXPECT_THAT(verify.err, HasSubstr("slot-b.bin is not a regular file"));

  const std::string fifo_blob = dir_ / "blob.fifo";
  ASSERT_EQ(::mkfifo(fifo_blob.c_str(), 0644), 0);
  ASSERT_TRUE(testing::ReturnsWithoutBlocking([&] { install = Install(fifo_blob); }, {fifo_blob}))
      << "install blocked";
  EXPECT_EQ(install.code, 1);
  EXPECT_EQ(Lines(install.err), 1) << install.err;
  EXPECT_THAT(install.err, HasSubstr(fifo_blob + ": not a regular file"));
  EXPECT_EQ(ActiveGeneration(), "1");
}

// Issue 14: mfns-paramctl processes installing into one store at once (the issue saw an empty
// store after 49 concurrent mfns-flash runs) take turns on the store's lock: each exits 0 or
// refuses a generation that is no longer newer, the newest is active, and verify finds both
// slots valid (the generation it replaced is kept).
TEST_F(ParamctlTest, ConcurrentInstallProcessesTakeTurnsOnTheStore) {
  ASSERT_EQ(Install(Blob(1)).code, 0);
  constexpr int kProcesses = 8;
  std::vector<std::string> blobs;
  for (int i = 0; i < kProcesses; ++i) blobs.push_back(Blob(static_cast<std::uint64_t>(2 + (i * 3) % kProcesses)));
  std::vector<Result> results(kProcesses);
  std::vector<std::thread> threads;
  for (int i = 0; i < kProcesses; ++i) {
    threads.emplace_back([&, i] {
      results[static_cast<std::size_t>(i)] =
          RunBinary({"install", "--store", store_, "--no-signal", blobs[static_cast<std::size_t>(i)]}, {});
    });
  }
  for (auto& t : threads) t.join();
  for (const Result& r : results) {
    if (r.code != 0) {
      EXPECT_EQ(r.code, 1);
      EXPECT_THAT(r.err, HasSubstr("is not newer than the active generation")) << r.err;
    }
  }
  EXPECT_EQ(ActiveGeneration(), std::to_string(1 + kProcesses));
  const Result verify = Paramctl({"verify", "--store", store_});
  EXPECT_EQ(verify.code, 0) << verify.err;
  EXPECT_EQ(Lines(verify.out), 3) << verify.out;  // both slots, then "ok: ..."
  EXPECT_THAT(verify.out, Not(HasSubstr("missing"))) << verify.out;
}

}  // namespace
}  // namespace mfns::fw
