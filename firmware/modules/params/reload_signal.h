// Telling a running mfns-navd to reload its parameters now: a pid file and SIGHUP.
//
// navd's side (the contract mfns-paramctl relies on):
//   - at start, WritePidFile(path) (default kDefaultNavdPidFile; written to a temp name and
//     renamed, so a reader never sees a half-written pid), RemovePidFile at a clean exit;
//   - a SIGHUP handler that only sets a volatile sig_atomic_t flag (async-signal-safe);
//   - between frame sets: if the flag is set (clear it) or ParamLoader::Changed(), call
//     ParamLoader::Reload; on kOk with a different blob (SameBlob false) switch to it and log
//     the generation; otherwise keep the current calibration and log why. Never reload inside
//     a frame set. The inotify watch alone is enough; SIGHUP only makes the reload immediate.
// paramctl's side: SignalReload reads the pid file and sends SIGHUP, but only to a process
// whose /proc/PID/comm is the expected name, so a stale pid file never signals a stranger
// (SIGHUP's default action would terminate it).
#pragma once

namespace mfns::fw {

inline constexpr char kDefaultNavdPidFile[] = "/run/mfns-navd.pid";
inline constexpr char kNavdProcessName[] = "mfns-navd";

enum class SignalStatus : unsigned char {
  kSignalled = 0,
  kNoPidFile,    // no such file: navd not running (it loads the newest blob when it starts)
  kBadPidFile,   // unreadable, or not a positive decimal pid
  kNotRunning,   // no process with that pid (stale pid file)
  kNotNavd,      // the pid belongs to a process with another name: not signalled
  kKillFailed,   // kill(2) failed otherwise (e.g. EPERM)
};
const char* ToString(SignalStatus s);

// Sends SIGHUP to the process named in pid_file if its /proc/PID/comm equals process_name.
// *pid (optional) receives the pid read (0 if none).
SignalStatus SignalReload(const char* pid_file, const char* process_name, int* pid);

// Writes getpid() to path atomically (path.tmp, fsync, rename). False with errno on failure
// (EINVAL: path exists and is not a regular file, e.g. /dev/null, which it leaves alone).
bool WritePidFile(const char* path);

// Removes path if it names this process. False when it did not.
bool RemovePidFile(const char* path);

}  // namespace mfns::fw
