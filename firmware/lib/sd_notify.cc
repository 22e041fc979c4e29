#include "firmware/lib/sd_notify.h"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstring>

namespace mfns::fw {

static_assert(sizeof(sockaddr_un) <= 112, "address_ must hold a sockaddr_un");

const char* ToString(NotifyStatus s) {
  switch (s) {
    case NotifyStatus::kOk: return "ok";
    case NotifyStatus::kDisabled: return "disabled";
    case NotifyStatus::kNotDue: return "not due";
    case NotifyStatus::kBadSocketPath: return "bad NOTIFY_SOCKET";
    case NotifyStatus::kSocketFailed: return "socket failed";
    case NotifyStatus::kSendFailed: return "send failed";
    case NotifyStatus::kBadMessage: return "bad message";
  }
  return "?";
}

SdNotifier::~SdNotifier() {
  if (fd_ >= 0) close(fd_);
}

namespace {

// Parses a decimal unsigned integer; false on anything else (empty, sign, junk, overflow).
bool ParseU64(const char* s, std::uint64_t* out) {
  if (s == nullptr || *s == '\0') return false;
  std::uint64_t v = 0;
  for (int i = 0; s[i] != '\0'; ++i) {
    if (i >= 20 || s[i] < '0' || s[i] > '9') return false;
    const std::uint64_t d = static_cast<std::uint64_t>(s[i] - '0');
    if (v > (UINT64_MAX - d) / 10) return false;
    v = v * 10 + d;
  }
  *out = v;
  return true;
}

}  // namespace

NotifyStatus SdNotifier::Open() {
  if (fd_ >= 0) {
    close(fd_);
    fd_ = -1;
  }
  watchdog_interval_ns_ = 0;
  watchdog_sent_ = false;
  const char* path = std::getenv("NOTIFY_SOCKET");
  if (path == nullptr || *path == '\0') return NotifyStatus::kDisabled;

  sockaddr_un sa{};
  sa.sun_family = AF_UNIX;
  const std::size_t n = std::strlen(path);
  // '@' names an abstract socket: a leading NUL, and the length says where the name ends.
  if ((path[0] != '/' && path[0] != '@') || n >= sizeof(sa.sun_path)) return NotifyStatus::kBadSocketPath;
  std::memcpy(sa.sun_path, path, n);
  if (path[0] == '@') sa.sun_path[0] = '\0';
  address_length_ = static_cast<unsigned int>(offsetof(sockaddr_un, sun_path) + n + (path[0] == '/' ? 1 : 0));
  std::memcpy(address_, &sa, sizeof(sa));

  fd_ = socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd_ < 0) return NotifyStatus::kSocketFailed;

  // The watchdog applies to this process only when WATCHDOG_PID (if set) names it.
  std::uint64_t usec = 0, pid = 0;
  const char* wpid = std::getenv("WATCHDOG_PID");
  const bool ours = wpid == nullptr || (ParseU64(wpid, &pid) && pid == static_cast<std::uint64_t>(getpid()));
  if (ours && ParseU64(std::getenv("WATCHDOG_USEC"), &usec) && usec > 0) watchdog_interval_ns_ = usec * 500;
  return NotifyStatus::kOk;
}

NotifyStatus SdNotifier::Send(const char* message, unsigned long length) {
  if (fd_ < 0) return NotifyStatus::kDisabled;
  ssize_t r = -1;
  for (int i = 0; i < 4; ++i) {  // bounded EINTR retries
    r = sendto(fd_, message, length, MSG_NOSIGNAL, reinterpret_cast<const sockaddr*>(address_), address_length_);
    if (r >= 0 || errno != EINTR) break;
  }
  if (r != static_cast<ssize_t>(length)) {
    ++counters_.send_failed;
    return NotifyStatus::kSendFailed;
  }
  ++counters_.sent;
  return NotifyStatus::kOk;
}

NotifyStatus SdNotifier::Ready() { return Send("READY=1", 7); }

NotifyStatus SdNotifier::Stopping() { return Send("STOPPING=1", 10); }

NotifyStatus SdNotifier::Watchdog(std::uint64_t now_ns) {
  if (fd_ < 0 || watchdog_interval_ns_ == 0) return NotifyStatus::kDisabled;
  if (watchdog_sent_ && now_ns >= last_watchdog_ns_ && now_ns - last_watchdog_ns_ < watchdog_interval_ns_)
    return NotifyStatus::kNotDue;
  const NotifyStatus s = Send("WATCHDOG=1", 10);
  if (s == NotifyStatus::kOk) {
    last_watchdog_ns_ = now_ns;
    watchdog_sent_ = true;
  }
  return s;
}

NotifyStatus SdNotifier::Status(const char* text) {
  if (fd_ < 0) return NotifyStatus::kDisabled;
  char buffer[8 + 200 + 1];
  std::memcpy(buffer, "STATUS=", 7);
  std::size_t n = 7;
  for (std::size_t i = 0; text != nullptr && text[i] != '\0'; ++i) {
    if (i >= 200 || text[i] == '\n') return NotifyStatus::kBadMessage;
    buffer[n++] = text[i];
  }
  return Send(buffer, n);
}

}  // namespace mfns::fw
