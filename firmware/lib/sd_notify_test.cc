#include "firmware/lib/sd_notify.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <string>

#include "firmware/lib/testing/alloc_counter.h"

namespace mfns::fw {
namespace {

// The systemd side: a datagram socket bound to a temp path (or an abstract name) that
// receives what the notifier sends.
class FakeSystemd {
 public:
  explicit FakeSystemd(bool abstract) {
    fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un sa{};
    sa.sun_family = AF_UNIX;
    socklen_t len = 0;
    if (abstract) {
      name_ = "@mfns-sd-notify-test-" + std::to_string(getpid());
      std::memcpy(sa.sun_path, name_.data(), name_.size());
      sa.sun_path[0] = '\0';
      len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + name_.size());
    } else {
      char dir[] = "/tmp/mfns-sd-XXXXXX";
      dir_ = mkdtemp(dir);
      name_ = dir_ + "/notify";
      std::memcpy(sa.sun_path, name_.c_str(), name_.size() + 1);
      len = static_cast<socklen_t>(sizeof(sa));
    }
    bound_ = bind(fd_, reinterpret_cast<sockaddr*>(&sa), len) == 0;
    setenv("NOTIFY_SOCKET", name_.c_str(), 1);
  }
  ~FakeSystemd() {
    close(fd_);
    if (!dir_.empty()) {
      unlink(name_.c_str());
      rmdir(dir_.c_str());
    }
    unsetenv("NOTIFY_SOCKET");
    unsetenv("WATCHDOG_USEC");
    unsetenv("WATCHDOG_PID");
  }
  bool bound() const { return bound_; }
  // The next datagram, or "" when none is waiting.
  std::string Receive() {
    char buf[512];
    const ssize_t n = recv(fd_, buf, sizeof(buf), MSG_DONTWAIT);
    return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
  }
  void Unbind() {
    close(fd_);
    fd_ = -1;
    if (!dir_.empty()) unlink(name_.c_str());
  }

 private:
  int fd_ = -1;
  std::string dir_, name_;
  bool bound_ = false;
};

TEST(SdNotifier, DisabledOutsideSystemdAndEveryCallIsANoOp) {
  unsetenv("NOTIFY_SOCKET");
  SdNotifier n;
  EXPECT_EQ(n.Open(), NotifyStatus::kDisabled);
  EXPECT_FALSE(n.enabled());
  EXPECT_EQ(n.Ready(), NotifyStatus::kDisabled);
  EXPECT_EQ(n.Watchdog(1), NotifyStatus::kDisabled);
  EXPECT_EQ(n.Status("x"), NotifyStatus::kDisabled);
  EXPECT_EQ(n.counters().sent, 0u);
}

TEST(SdNotifier, ReadyStatusAndStoppingReachAPathSocket) {
  FakeSystemd systemd(false);
  ASSERT_TRUE(systemd.bound());
  SdNotifier n;
  ASSERT_EQ(n.Open(), NotifyStatus::kOk);
  EXPECT_EQ(n.watchdog_interval_ns(), 0u);
  EXPECT_EQ(n.Ready(), NotifyStatus::kOk);
  EXPECT_EQ(systemd.Receive(), "READY=1");
  EXPECT_EQ(n.Status("fix, 3 beacons"), NotifyStatus::kOk);
  EXPECT_EQ(systemd.Receive(), "STATUS=fix, 3 beacons");
  EXPECT_EQ(n.Stopping(), NotifyStatus::kOk);
  EXPECT_EQ(systemd.Receive(), "STOPPING=1");
  EXPECT_EQ(n.counters().sent, 3u);
  // No watchdog configured: nothing is sent.
  EXPECT_EQ(n.Watchdog(5), NotifyStatus::kDisabled);
  EXPECT_EQ(systemd.Receive(), "");
}

TEST(SdNotifier, AbstractSocketNamesWork) {
  FakeSystemd systemd(true);
  ASSERT_TRUE(systemd.bound());
  SdNotifier n;
  ASSERT_EQ(n.Open(), NotifyStatus::kOk);
  EXPECT_EQ(n.Ready(), NotifyStatus::kOk);
  EXPECT_EQ(systemd.Receive(), "READY=1");
}

TEST(SdNotifier, WatchdogIsSentAtHalfThePeriodWithoutAllocating) {
  FakeSystemd systemd(false);
  setenv("WATCHDOG_USEC", "2000000", 1);  // 2 s: keep-alive every 1 s
  SdNotifier n;
  ASSERT_EQ(n.Open(), NotifyStatus::kOk);
  EXPECT_EQ(n.watchdog_interval_ns(), 1'000'000'000u);
  const std::uint64_t before = testing::AllocationCount();
  int sent = 0;
  for (std::uint64_t t = 0; t <= 10'000'000'000u; t += 10'000'000u) {  // 10 s at 100 Hz
    const NotifyStatus s = n.Watchdog(t);
    ASSERT_TRUE(s == NotifyStatus::kOk || s == NotifyStatus::kNotDue) << ToString(s);
    if (s == NotifyStatus::kOk) {
      ++sent;
      EXPECT_EQ(systemd.Receive(), "WATCHDOG=1");
    }
  }
  EXPECT_EQ(testing::AllocationCount(), before);
  EXPECT_EQ(sent, 11);  // t = 0, 1, ..., 10 s
  EXPECT_EQ(systemd.Receive(), "");
}

TEST(SdNotifier, WatchdogForAnotherPidIsNotOurs) {
  FakeSystemd systemd(false);
  setenv("WATCHDOG_USEC", "2000000", 1);
  setenv("WATCHDOG_PID", std::to_string(getpid() + 1).c_str(), 1);
  SdNotifier n;
  ASSERT_EQ(n.Open(), NotifyStatus::kOk);
  EXPECT_EQ(n.watchdog_interval_ns(), 0u);
  setenv("WATCHDOG_PID", std::to_string(getpid()).c_str(), 1);
  ASSERT_EQ(n.Open(), NotifyStatus::kOk);
  EXPECT_EQ(n.watchdog_interval_ns(), 1'000'000'000u);
  setenv("WATCHDOG_USEC", "12x", 1);  // junk: no watchdog rather than a wrong one
  ASSERT_EQ(n.Open(), NotifyStatus::kOk);
  EXPECT_EQ(n.watchdog_interval_ns(), 0u);
}

TEST(SdNotifier, BadInputAndAVanishedSystemdAreTypedAndCounted) {
  setenv("NOTIFY_SOCKET", "relative/path", 1);
  SdNotifier n;
  EXPECT_EQ(n.Open(), NotifyStatus::kBadSocketPath);
  EXPECT_FALSE(n.enabled());
  setenv("NOTIFY_SOCKET", ("/" + std::string(200, 'a')).c_str(), 1);
  EXPECT_EQ(n.Open(), NotifyStatus::kBadSocketPath);
  unsetenv("NOTIFY_SOCKET");

  FakeSystemd systemd(false);
  ASSERT_EQ(n.Open(), NotifyStatus::kOk);
  EXPECT_EQ(n.Status("two\nlines"), NotifyStatus::kBadMessage);
  EXPECT_EQ(n.Status(std::string(201, 'x').c_str()), NotifyStatus::kBadMessage);
  systemd.Unbind();
  EXPECT_EQ(n.Ready(), NotifyStatus::kSendFailed);
  EXPECT_EQ(n.counters().send_failed, 1u);
  EXPECT_EQ(n.counters().sent, 0u);
}

TEST(SdNotifier, EveryStatusHasADistinctName) {
  const NotifyStatus all[] = {NotifyStatus::kOk,           NotifyStatus::kDisabled,     NotifyStatus::kNotDue,
                              NotifyStatus::kBadSocketPath, NotifyStatus::kSocketFailed, NotifyStatus::kSendFailed,
                              NotifyStatus::kBadMessage};
  for (NotifyStatus a : all) {
    for (NotifyStatus b : all) {
      if (a != b) {
        EXPECT_STRNE(ToString(a), ToString(b));
      }
    }
  }
}

}  // namespace
}  // namespace mfns::fw
