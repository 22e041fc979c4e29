// mfns-flash without an ssh server: target parsing, quoting (checked by /bin/sh itself), the
// ssh command line, local stores, error mapping through a stand-in ssh program, an unreachable
// port with the real ssh client, and the process runner's limits.
#include "host/flash/flash.h"
#include "host/flash/flash_cli.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <functional>
#include <iterator>
#include <fstream>
#include <string>
#include <vector>

#include "firmware/modules/params/testing/test_blobs.h"
#include "host/flash/process.h"
#include "host/util/cli_parse.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
using fw::testing::MakeBlob;
using fw::testing::ReadBytes;
using fw::testing::TempDir;
namespace fs = std::filesystem;

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const UserError& e) {
    return e.what();
  }
  return "";
}

TEST(ParseTarget, DirectoriesAndSshUrls) {
  FlashTarget t = ParseTarget("/var/lib/mfns/params");
  EXPECT_EQ(t.kind, FlashTarget::Kind::kLocal);
  EXPECT_EQ(t.dir, "/var/lib/mfns/params");
  t = ParseTarget("relative/dir");
  EXPECT_EQ(t.dir, "relative/dir");
  t = ParseTarget("ssh://flyer/var/lib/mfns/params");
  EXPECT_EQ(t.kind, FlashTarget::Kind::kSsh);
  EXPECT_EQ(t.host, "flyer");
  EXPECT_EQ(t.user, "");
  EXPECT_EQ(t.port, 22);
  EXPECT_EQ(t.dir, "/var/lib/mfns/params");
  t = ParseTarget("ssh://root@10.0.0.7:2222/tmp/p");
  EXPECT_EQ(t.user, "root");
  EXPECT_EQ(t.host, "10.0.0.7");
  EXPECT_EQ(t.port, 2222);
  EXPECT_EQ(t.dir, "/tmp/p");
  EXPECT_EQ(t.Display(), "root@10.0.0.7:2222:/tmp/p");
  t = ParseTarget("ssh://pi@[fe80::1%eth0]:22/p");
  EXPECT_EQ(t.host, "fe80::1%eth0");
  EXPECT_EQ(t.user, "pi");
  for (const char* bad : {"", "ssh://flyer", "ssh://flyer/", "ssh:///dir", "ssh://-oProxyCommand=x/dir",
                          "ssh://host:0/d", "ssh://host:70000/d", "ssh://host:/d", "ssh://host:x/d",
                          "ssh://@host/d", "ssh://[::1/d", "http://host/d", "ssh://ho st/d"}) {
    EXPECT_NE(ErrorOf([&] { ParseTarget(bad); }), "") << bad;
  }
}

// The reference for quoting is the shell itself: sh -c 'printf "%s\n" WORDS' prints each word.
// Issue 14 (host_cli_fuzz): the command line is parsed (the target included) without reading
// or flashing anything, and an argument holding a newline no longer makes a two-line error.
TEST(FlashCommandLine, ParsesTheTargetAndErrorsStayOneLine) {
  const auto parse = [](const std::vector<std::string>& words) { return ParseWords(ParseFlashCommandLine, words); };
  const FlashCommandLine cl =
      parse({"mfns-flash", "no-such.bin", "ssh://pi@flyer:2200/p", "--no-signal", "-o", "A=b", "--timeout", "9"});
  EXPECT_EQ(cl.blob_path, "no-such.bin");
  EXPECT_EQ(cl.target.Display(), "pi@flyer:2200:/p");
  EXPECT_FALSE(cl.options.signal_navd);
  EXPECT_EQ(cl.options.ssh_options, std::vector<std::string>{"A=b"});
  EXPECT_EQ(cl.options.timeout_s, 9);
  EXPECT_EQ(ErrorOf([&] { parse({"mfns-flash", "b.bin", "ssh://fly\ner/p"}); }),
            "TARGET ssh://fly\\ner/p: bad or missing host name");
  try {
    parse({"mfns-flash", "b.bin", "dir", "--timeout", "6\n0"});
    ADD_FAILURE() << "accepted";
  } catch (const CLI::ParseError& e) {
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("6\\n0"), std::string::npos) << e.what();
  }
}

TEST(ShellQuote, TheShellSeesEachArgumentAsOneUnchangedWord) {
  const std::vector<std::string> words = {"plain", "with space", "it's", "'", "", "$HOME", "`id`", "a\"b",
                                          "semi;colon", "new\nline", "back\\slash", "*", "--store"};
  std::string script = "printf '%s\\0'";
  for (const auto& w : words) script += " " + ShellQuote(w);
  const ProcessResult p = RunProcess({"/bin/sh", "-c", script}, {}, 30);
  ASSERT_EQ(p.exit_code, 0) << p.err;
  std::vector<std::string> got;
  std::string cur;
  for (char c : p.out) {
    if (c == '\0') {
      got.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  EXPECT_EQ(got, words);
}

TEST(SshArgv, CarriesPortBatchModeTimeoutIdentityOptionsAndTheQuotedCommand) {
  FlashTarget t = ParseTarget("ssh://pi@flyer:2200/var/lib/mfns/params");
  FlashOptions o;
  o.identity_file = "/home/me/.ssh/flyer";
  o.ssh_options = {"StrictHostKeyChecking=no", "UserKnownHostsFile=/dev/null"};
  o.connect_timeout_s = 7;
  o.remote_paramctl = "sudo /usr/bin/mfns-paramctl";
  const std::string cmd = RemoteCommand(o, {"install", "--store", t.dir, "-"});
  EXPECT_EQ(cmd, "'sudo' '/usr/bin/mfns-paramctl' 'install' '--store' '/var/lib/mfns/params' '-'");
  const std::vector<std::string> expected = {"ssh", "-T", "-p", "2200", "-o", "BatchMode=yes", "-o",
                                             "ConnectTimeout=7", "-i", "/home/me/.ssh/flyer", "-o",
                                             "IdentitiesOnly=yes", "-o", "StrictHostKeyChecking=no", "-o",
                                             "UserKnownHostsFile=/dev/null", "pi@flyer", cmd};
  EXPECT_EQ(SshArgv(t, o, cmd), expected);
  EXPECT_EQ(ShowField("store: x\nactive: slot-a.bin\ngeneration: 12\n", "generation"), "12");
  EXPECT_EQ(ShowField("generation: 12\n", "rig_id"), "");
}

TEST(FlashLocal, InstallsInAStoreDirectoryAndRelaysRefusals) {
  TempDir dir;
  const std::string store = dir / "params";
  FlashOptions o;
  FlashResult r = Flash(MakeBlob(4), ParseTarget(store), o);
  EXPECT_EQ(r.active_generation, 4u);
  EXPECT_EQ(r.active_rig_id, kPaperRigId);
  EXPECT_EQ(ReadBytes(store + "/slot-a.bin"), MakeBlob(4));
  EXPECT_THAT(ErrorOf([&] { Flash(MakeBlob(3), ParseTarget(store), o); }),
              HasSubstr("refused: generation 3 is not newer than the active generation 4"));
  EXPECT_THAT(ErrorOf([&] { Flash(MakeBlob(9, "other-rig"), ParseTarget(store), o); }),
              HasSubstr("refused: blob is for rig 'other-rig'"));
  auto bad = MakeBlob(9);
  bad[10] ^= 1;
  EXPECT_THAT(ErrorOf([&] { Flash(bad, ParseTarget(store), o); }), StartsWith("invalid blob: "));
  o.force = true;
  r = Flash(MakeBlob(3), ParseTarget(store), o);
  EXPECT_EQ(r.active_generation, 3u);
  EXPECT_THAT(ErrorOf([&] { Flash(MakeBlob(10), ParseTarget(dir / "no/such/parent"), FlashOptions{}); }),
              HasSubstr("cannot create the store"));
}

// A stand-in for ssh: a shell script that records its arguments and stdin, then exits with a
// chosen code and message (what ssh does when the remote side fails that way).
std::string FakeSsh(const TempDir& dir, int code, const std::string& err_line, const std::string& out = "") {
  const std::string path = dir / ("fake-ssh-" + std::to_string(code));
  std::ofstream f(path);
  f << "#!/bin/sh\n"
    << "printf '%s\\n' \"$@\" > " << ShellQuote(dir / "args") << "\n"
    << "cat > " << ShellQuote(dir / "stdin") << "\n"
    << "printf '%s' " << ShellQuote(out) << "\n"
    << "printf '%s\\n' " << ShellQuote(err_line) << " >&2\n"
    << "exit " << code << "\n";
  f.close();
  fs::permissions(path, fs::perms::owner_all);
  return path;
}

TEST(FlashSsh, MapsSshAndRemoteFailuresToOneLineErrors) {
  TempDir dir;
  const FlashTarget t = ParseTarget("ssh://pi@flyer:2222/var/lib/mfns/params");
  FlashOptions o;
  o.ssh_program = FakeSsh(dir, 255, "ssh: connect to host flyer port 2222: No route to host");
  EXPECT_EQ(ErrorOf([&] { Flash(MakeBlob(2), t, o); }),
            "cannot reach flyer:2222: ssh: connect to host flyer port 2222: No route to host");
  // The blob went to ssh's stdin, and the command names the store.
  EXPECT_EQ(ReadBytes(dir / "stdin"), MakeBlob(2));
  std::ifstream args(dir / "args");
  std::string all((std::istreambuf_iterator<char>(args)), std::istreambuf_iterator<char>());
  EXPECT_THAT(all, HasSubstr("pi@flyer\n'mfns-paramctl' 'install' '--store' '/var/lib/mfns/params' '-'"));

  o.ssh_program = FakeSsh(dir, 127, "bash: line 1: mfns-paramctl: command not found");
  EXPECT_THAT(ErrorOf([&] { Flash(MakeBlob(2), t, o); }), StartsWith("'mfns-paramctl' not found on flyer"));
  o.ssh_program = FakeSsh(dir, 1, "mfns-paramctl: refused: generation 2 is not newer than the active generation 5");
  EXPECT_EQ(ErrorOf([&] { Flash(MakeBlob(2), t, o); }),
            "pi@flyer:2222:/var/lib/mfns/params: refused: generation 2 is not newer than the active generation 5");
  // Install "succeeds" but show reports another generation: not confirmed.
  o.ssh_program = FakeSsh(dir, 0, "", "generation: 1\nrig_id: mfns-paper-2017\n");
  EXPECT_THAT(ErrorOf([&] { Flash(MakeBlob(2), t, o); }), HasSubstr("installed, but show reports generation 1"));
  o.ssh_program = FakeSsh(dir, 0, "", "generation: 2\nrig_id: mfns-paper-2017\n");
  EXPECT_EQ(Flash(MakeBlob(2), t, o).active_generation, 2u);
  o.ssh_program = dir / "no-such-ssh";
  EXPECT_THAT(ErrorOf([&] { Flash(MakeBlob(2), t, o); }), StartsWith("cannot run "));
}

// A TCP port on 127.0.0.1 with nobody listening (bound then released).
int ClosedPort() {
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

TEST(FlashSsh, AnUnreachableHostIsAClearErrorFromTheRealSshClient) {
  if (::access("/usr/bin/ssh", X_OK) != 0) GTEST_SKIP() << "no OpenSSH client at /usr/bin/ssh";
  const int port = ClosedPort();
  FlashOptions o;
  o.ssh_config = "/dev/null";
  o.connect_timeout_s = 5;
  o.timeout_s = 30;
  const std::string e = ErrorOf([&] {
    Flash(MakeBlob(2), ParseTarget("ssh://127.0.0.1:" + std::to_string(port) + "/tmp/p"), o);
  });
  EXPECT_THAT(e, StartsWith("cannot reach 127.0.0.1:" + std::to_string(port) + ": "));
  EXPECT_THAT(e, HasSubstr("Connection refused"));
  EXPECT_EQ(e.find('\n'), std::string::npos);
}

TEST(RunProcess, CollectsOutputFeedsStdinAndKillsAtTheTimeLimit) {
  const std::vector<std::uint8_t> in(200000, 'x');  // more than a pipe buffer
  ProcessResult p = RunProcess({"/bin/sh", "-c", "wc -c; echo oops >&2; exit 3"}, in, 30);
  EXPECT_EQ(p.exit_code, 3);
  EXPECT_EQ(p.out, "200000\n");
  EXPECT_EQ(p.err, "oops\n");
  // A child that never reads its stdin and exits: no SIGPIPE for us.
  p = RunProcess({"/bin/sh", "-c", "exit 0"}, in, 30);
  EXPECT_EQ(p.exit_code, 0);
  p = RunProcess({"/bin/sleep", "60"}, {}, 1);
  EXPECT_TRUE(p.timed_out);
  EXPECT_EQ(p.signal, SIGKILL);
}

}  // namespace
}  // namespace mfns::host
