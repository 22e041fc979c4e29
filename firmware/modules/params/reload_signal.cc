#include "firmware/modules/params/reload_signal.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <signal.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "common/limits.h"

namespace mfns::fw {
namespace {

// Reads at most cap - 1 bytes of a small file into buf (NUL-terminated). -1 with errno on error.
int ReadSmallFile(const char* path, char* buf, std::size_t cap) {
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  std::size_t got = 0;
  for (int i = 0; i < limits::kMaxEintrRetries + static_cast<int>(cap) && got + 1 < cap; ++i) {
    const ssize_t r = ::read(fd, buf + got, cap - 1 - got);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    got += static_cast<std::size_t>(r);
  }
  ::close(fd);
  buf[got] = '\0';
  return static_cast<int>(got);
}

// Parses "1234\n" (optional trailing whitespace) into a positive pid; 0 if malformed.
int ParsePid(const char* s) {
  long long v = 0;  // NOLINT(runtime/int)
  int digits = 0;
  const char* p = s;
  for (; *p >= '0' && *p <= '9' && digits < 10; ++p, ++digits) v = v * 10 + (*p - '0');
  for (; *p == '\n' || *p == ' ' || *p == '\r' || *p == '\t'; ++p) {}
  if (digits == 0 || *p != '\0' || v <= 0 || v > 0x7fffffff) return 0;
  return static_cast<int>(v);
}

}  // namespace

const char* ToString(SignalStatus s) {
  switch (s) {
    case SignalStatus::kSignalled: return "signalled";
    case SignalStatus::kNoPidFile: return "no pid file (navd not running)";
    case SignalStatus::kBadPidFile: return "pid file unreadable or malformed";
    case SignalStatus::kNotRunning: return "no process with that pid (stale pid file)";
    case SignalStatus::kNotNavd: return "pid belongs to another program; not signalled";
    case SignalStatus::kKillFailed: return "kill failed";
  }
  return "unknown signal status";
}

SignalStatus SignalReload(const char* pid_file, const char* process_name, int* pid_out) {
  if (pid_out != nullptr) *pid_out = 0;
  std::array<char, 32> text{};
  if (ReadSmallFile(pid_file, text.data(), text.size()) < 0) {
    return errno == ENOENT ? SignalStatus::kNoPidFile : SignalStatus::kBadPidFile;
  }
  const int pid = ParsePid(text.data());
  if (pid == 0) return SignalStatus::kBadPidFile;
  if (pid_out != nullptr) *pid_out = pid;
  std::array<char, 64> comm_path{};
  std::snprintf(comm_path.data(), comm_path.size(), "/proc/%d/comm", pid);
  std::array<char, 64> comm{};
  if (ReadSmallFile(comm_path.data(), comm.data(), comm.size()) < 0) {
    return errno == ENOENT ? SignalStatus::kNotRunning : SignalStatus::kKillFailed;
  }
  char* nl = std::strchr(comm.data(), '\n');
  if (nl != nullptr) *nl = '\0';
  // The kernel keeps 15 characters of the name (TASK_COMM_LEN 16).
  if (std::strncmp(comm.data(), process_name, 15) != 0) return SignalStatus::kNotNavd;
  if (::kill(pid, SIGHUP) != 0) return errno == ESRCH ? SignalStatus::kNotRunning : SignalStatus::kKillFailed;
  return SignalStatus::kSignalled;
}

bool WritePidFile(const char* path) {
  // A pid file names a regular file: renaming one over a device or FIFO (--pid-file /dev/null)
  // would replace the node itself.
  struct stat st {};
  if (path != nullptr && ::stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
    errno = EINVAL;
    return false;
  }
  std::array<char, limits::kMaxPathChars + 8> tmp{};
  const int w = std::snprintf(tmp.data(), tmp.size(), "%s.tmp", path);
  if (w < 0 || static_cast<std::size_t>(w) >= tmp.size()) {
    errno = ENAMETOOLONG;
    return false;
  }
  std::array<char, 24> text{};
  const int n = std::snprintf(text.data(), text.size(), "%d\n", static_cast<int>(::getpid()));
  const int fd = ::open(tmp.data(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return false;
  const bool ok = ::write(fd, text.data(), static_cast<std::size_t>(n)) == n && ::fsync(fd) == 0;
  const int saved = errno;
  if (::close(fd) != 0 || !ok) {
    ::unlink(tmp.data());
    errno = ok ? errno : saved;
    return false;
  }
  if (std::rename(tmp.data(), path) != 0) {
    const int e = errno;
    ::unlink(tmp.data());
    errno = e;
    return false;
  }
  return true;
}

bool RemovePidFile(const char* path) {
  std::array<char, 32> text{};
  if (ReadSmallFile(path, text.data(), text.size()) < 0) return false;
  if (ParsePid(text.data()) != static_cast<int>(::getpid())) return false;
  return ::unlink(path) == 0;
}

}  // namespace mfns::fw
