// mfns-flash over real ssh: an OpenSSH server started by the test on 127.0.0.1 (a free port,
// host and user keys made with ssh-keygen in a temp dir, its own sshd_config), the system ssh
// client, and the built mfns-paramctl as the remote paramctl. Skipped, with the reason, only
// when sshd cannot start here. Every wait is bounded; sshd is killed at the end.
#include <fcntl.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "firmware/modules/params/testing/test_blobs.h"
#include "host/flash/flash.h"
#include "host/flash/process.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using fw::testing::MakeBlob;
using fw::testing::ReadBytes;
using fw::testing::TempDir;
using fw::testing::WriteBytes;
namespace fs = std::filesystem;

constexpr char kSshd[] = "/usr/sbin/sshd";

int FreePort() {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof a;
  ::bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a);
  ::getsockname(s, reinterpret_cast<sockaddr*>(&a), &len);
  ::close(s);
  return ntohs(a.sin_port);
}

bool Accepts(int port) {
  const int s = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = ::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  ::close(s);
  return ok;
}

std::string Tail(const std::string& path) {
  std::ifstream f(path);
  std::string all((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return all.size() > 800 ? all.substr(all.size() - 800) : all;
}

// One sshd for the whole suite (keys and start-up cost once).
class SshServer {
 public:
  // Empty when running; otherwise why sshd could not start.
  std::string Start() {
    if (::access(kSshd, X_OK) != 0) return std::string(kSshd) + " not installed (openssh-server)";
    if (::access("/usr/bin/ssh", X_OK) != 0 || ::access("/usr/bin/ssh-keygen", X_OK) != 0) {
      return "OpenSSH client or ssh-keygen not installed";
    }
    // The privilege separation directory sshd insists on.
    if (::access("/run/sshd", F_OK) != 0 && ::mkdir("/run/sshd", 0755) != 0) {
      return "cannot create /run/sshd (privilege separation directory): " + std::string(std::strerror(errno));
    }
    const passwd* pw = ::getpwuid(::geteuid());
    if (pw == nullptr) return "no passwd entry for this user";
    user_ = pw->pw_name;
    for (const char* key : {"host_ed25519", "user_ed25519"}) {
      const ProcessResult k =
          RunProcess({"ssh-keygen", "-q", "-t", "ed25519", "-N", "", "-f", dir_ / key}, {}, 30);
      if (k.exit_code != 0) return "ssh-keygen failed: " + k.err;
    }
    fs::copy_file(dir_ / "user_ed25519.pub", dir_ / "authorized_keys");
    ::chmod((dir_ / "authorized_keys").c_str(), 0600);
    for (int attempt = 0; attempt < 3; ++attempt) {
      port_ = FreePort();
      std::ofstream cfg(dir_ / "sshd_config");
      cfg << "Port " << port_ << "\nListenAddress 127.0.0.1\n"
          << "HostKey " << (dir_ / "host_ed25519") << "\n"
          << "PidFile " << (dir_ / "sshd.pid") << "\n"
          << "AuthorizedKeysFile " << (dir_ / "authorized_keys") << "\n"
          << "PubkeyAuthentication yes\nPasswordAuthentication no\nKbdInteractiveAuthentication no\n"
          << "UsePAM no\nStrictModes no\nPermitRootLogin prohibit-password\n"
          << "AllowUsers " << user_ << "\nLogLevel VERBOSE\n";
      cfg.close();
      pid_ = ::fork();
      if (pid_ == 0) {
        const int log = ::open((dir_ / "sshd.log").c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
        ::dup2(log, 1);
        ::dup2(log, 2);
        const std::string cfg_path = dir_ / "sshd_config";
        ::execl(kSshd, kSshd, "-D", "-e", "-f", cfg_path.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
      }
      // Up to 10 s for the port to accept, while sshd is alive.
      for (int i = 0; i < 200; ++i) {
        int status = 0;
        if (::waitpid(pid_, &status, WNOHANG) == pid_) {
          pid_ = -1;
          break;
        }
        if (Accepts(port_)) return "";
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      Stop();
    }
    return "sshd did not start: " + Tail(dir_ / "sshd.log");
  }

  void Stop() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGTERM);
    for (int i = 0; i < 100; ++i) {  // up to 5 s, then SIGKILL
      if (::waitpid(pid_, nullptr, WNOHANG) == pid_) {
        pid_ = -1;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }

  ~SshServer() { Stop(); }

  // Client options that make the test independent of ~/.ssh.
  FlashOptions Options() const {
    FlashOptions o;
    o.identity_file = dir_ / "user_ed25519";
    o.ssh_config = "/dev/null";
    o.ssh_options = {"StrictHostKeyChecking=no", "UserKnownHostsFile=/dev/null", "LogLevel=ERROR"};
    o.remote_paramctl = MFNS_PARAMCTL_PATH;
    o.connect_timeout_s = 10;
    o.timeout_s = 60;
    o.signal_navd = false;
    return o;
  }
  std::string Url(const std::string& store) const {
    return "ssh://" + user_ + "@127.0.0.1:" + std::to_string(port_) + store;
  }
  std::string log() const { return Tail(dir_ / "sshd.log"); }

 private:
  TempDir dir_;
  std::string user_;
  int port_ = 0;
  pid_t pid_ = -1;
};

class FlashOverSsh : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    server_ = new SshServer;
    skip_reason_ = new std::string(server_->Start());
  }
  static void TearDownTestSuite() {
    delete server_;
    delete skip_reason_;
    server_ = nullptr;
    skip_reason_ = nullptr;
  }
  void SetUp() override {
    if (!skip_reason_->empty()) {
      std::printf("skipping: %s\n", skip_reason_->c_str());
      GTEST_SKIP() << *skip_reason_;
    }
  }
  std::string Error(const std::vector<std::uint8_t>& blob, const FlashTarget& t, const FlashOptions& o) {
    try {
      Flash(blob, t, o);
    } catch (const UserError& e) {
      return e.what();
    }
    return "";
  }

  static SshServer* server_;
  static std::string* skip_reason_;
  TempDir work_;
  std::string store_ = work_ / "params";
};
SshServer* FlashOverSsh::server_ = nullptr;
std::string* FlashOverSsh::skip_reason_ = nullptr;

TEST_F(FlashOverSsh, InstallsConfirmsAndRelaysRefusals) {
  const FlashTarget t = ParseTarget(server_->Url(store_));
  const FlashOptions o = server_->Options();
  FlashResult r = Flash(MakeBlob(5), t, o);
  EXPECT_EQ(r.active_generation, 5u);
  EXPECT_EQ(r.active_rig_id, kPaperRigId);
  EXPECT_THAT(r.install_output, StartsWith("installed generation 5"));
  EXPECT_EQ(ReadBytes(store_ + "/slot-a.bin"), MakeBlob(5)) << server_->log();

  r = Flash(MakeBlob(6, kPaperRigId, 5), t, o);
  EXPECT_EQ(r.active_generation, 6u);
  EXPECT_EQ(ReadBytes(store_ + "/slot-b.bin"), MakeBlob(6, kPaperRigId, 5));

  // Refused by the flyer, with paramctl's reason; the store is unchanged.
  EXPECT_THAT(Error(MakeBlob(4), t, o),
              HasSubstr("refused: generation 4 is not newer than the active generation 6 (--force"));
  EXPECT_THAT(Error(MakeBlob(7, "other-rig"), t, o),
              HasSubstr("refused: blob is for rig 'other-rig' but the active blob is for rig 'mfns-paper-2017'"));
  EXPECT_EQ(ReadBytes(store_ + "/slot-a.bin"), MakeBlob(5));
  EXPECT_EQ(ReadBytes(store_ + "/slot-b.bin"), MakeBlob(6, kPaperRigId, 5));

  FlashOptions forced = o;
  forced.force = true;
  EXPECT_EQ(Flash(MakeBlob(4), t, forced).active_generation, 4u);
}

TEST_F(FlashOverSsh, AMissingParamctlIsExit127AndAClearError) {
  FlashOptions o = server_->Options();
  o.remote_paramctl = "/nonexistent/mfns-paramctl";
  EXPECT_EQ(Error(MakeBlob(1), ParseTarget(server_->Url(store_)), o),
            "'/nonexistent/mfns-paramctl' not found on 127.0.0.1 (install the mfns package there, or give its path "
            "with --remote-paramctl)");
  EXPECT_FALSE(fs::exists(store_));
}

TEST_F(FlashOverSsh, AWrongKeyIsAnAuthenticationErrorNotAHang) {
  FlashOptions o = server_->Options();
  const std::string other = work_ / "other_key";
  ASSERT_EQ(RunProcess({"ssh-keygen", "-q", "-t", "ed25519", "-N", "", "-f", other}, {}, 30).exit_code, 0);
  o.identity_file = other;
  const std::string e = Error(MakeBlob(1), ParseTarget(server_->Url(store_)), o);
  EXPECT_THAT(e, StartsWith("cannot reach 127.0.0.1:"));
  EXPECT_THAT(e, HasSubstr("Permission denied"));
}

TEST_F(FlashOverSsh, TheMfnsFlashBinaryExitsZeroOrOneWithOneLine) {
  const std::string blob = work_ / "cal.bin";
  WriteBytes(blob, MakeBlob(9));
  const FlashOptions o = server_->Options();
  std::vector<std::string> argv = {MFNS_FLASH_PATH, blob, server_->Url(store_), "-i", o.identity_file, "-F",
                                   "/dev/null", "--remote-paramctl", o.remote_paramctl, "--no-signal"};
  for (const auto& opt : o.ssh_options) {
    argv.push_back("-o");
    argv.push_back(opt);
  }
  ProcessResult p = RunProcess(argv, {}, 120);
  ASSERT_EQ(p.exit_code, 0) << p.err;
  EXPECT_THAT(p.out, HasSubstr("generation 9 (rig mfns-paper-2017) is active"));
  p = RunProcess(argv, {}, 120);  // the same generation again: refused
  EXPECT_EQ(p.exit_code, 1);
  EXPECT_EQ(std::count(p.err.begin(), p.err.end(), '\n'), 1) << p.err;
  EXPECT_THAT(p.err, StartsWith("mfns-flash: "));
  EXPECT_THAT(p.err, HasSubstr("refused: generation 9 is not newer than the active generation 9"));
}

}  // namespace
}  // namespace mfns::host
