// systemd service notification (the sd_notify(3) datagram protocol) without libsystemd, so
// that mfns-navd can run as a Type=notify unit with a watchdog: "READY=1" once navigation has
// started, "WATCHDOG=1" while frame sets keep being processed, "STOPPING=1" on the way out.
//
// Contract
// - Open() reads $NOTIFY_SOCKET and $WATCHDOG_USEC / $WATCHDOG_PID once, at start (it is the
//   only call that reads the environment). Outside systemd (no NOTIFY_SOCKET) the notifier is
//   disabled and every later call is a no-op returning kDisabled: the daemon runs the same.
// - After Open() nothing allocates; each call is one non-blocking sendto() of a short text.
// - Watchdog(now_ns) sends at most once per half the watchdog period (systemd's advice), so
//   the loop can call it every frame set. No watchdog configured: kDisabled.
// - A failed send is counted (counters().send_failed) and returned; it never stops navigation.
// - Not thread-safe: the navigation thread owns it.
#pragma once

#include <cstdint>

namespace mfns::fw {

enum class NotifyStatus : unsigned char {
  kOk,
  kDisabled,       // not under systemd (no NOTIFY_SOCKET), or no watchdog for Watchdog()
  kNotDue,         // Watchdog(): the last keep-alive is recent enough
  kBadSocketPath,  // NOTIFY_SOCKET is not an absolute path or @abstract name, or too long
  kSocketFailed,   // socket() failed
  kSendFailed,     // sendto() failed (systemd gone, socket full)
  kBadMessage,     // Status(): text too long or with a newline
};
const char* ToString(NotifyStatus s);

struct NotifyCounters {
  std::uint64_t sent = 0;
  std::uint64_t send_failed = 0;
};

class SdNotifier {
 public:
  SdNotifier() = default;
  ~SdNotifier();
  SdNotifier(const SdNotifier&) = delete;
  SdNotifier& operator=(const SdNotifier&) = delete;

  // Reads the environment and opens the socket. kOk or kDisabled are both fine to go on with.
  NotifyStatus Open();
  bool enabled() const { return fd_ >= 0; }
  // Half of WATCHDOG_USEC in ns: how often Watchdog() sends; 0 when no watchdog is configured.
  std::uint64_t watchdog_interval_ns() const { return watchdog_interval_ns_; }

  NotifyStatus Ready();
  NotifyStatus Stopping();
  // now_ns: any monotonic clock in ns (the loop's CLOCK_MONOTONIC time).
  NotifyStatus Watchdog(std::uint64_t now_ns);
  // "STATUS=<text>": one line shown by systemctl status; at most 200 characters.
  NotifyStatus Status(const char* text);

  const NotifyCounters& counters() const { return counters_; }

 private:
  NotifyStatus Send(const char* message, unsigned long length);

  int fd_ = -1;
  // sockaddr_un bytes and the address length actually used (abstract names are not
  // NUL-terminated, so the length matters).
  alignas(8) unsigned char address_[112] = {};
  unsigned int address_length_ = 0;
  std::uint64_t watchdog_interval_ns_ = 0;
  std::uint64_t last_watchdog_ns_ = 0;
  bool watchdog_sent_ = false;
  NotifyCounters counters_;
};

}  // namespace mfns::fw
