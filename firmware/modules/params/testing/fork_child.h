// Test support: starting a child process that runs test code, and killing it hard.
//
// glibc's fork() never returns in the child of a dynamically linked aarch64 program under
// qemu-user 7.2 (Debian 12's qemu-aarch64; the child spins), while the raw clone system call
// works. So on aarch64 the child is made with clone(SIGCHLD) directly: the child skips
// glibc's at-fork handlers, which is fine for these single-threaded tests whose children only
// do file I/O and simple libc calls and end with _exit (or a SIGKILL). To run another program
// use posix_spawn (it works under qemu too).
#pragma once

#include <signal.h>
#include <sys/syscall.h>
#include <sys/types.h>
#include <unistd.h>

namespace mfns::fw::testing {

inline pid_t ForkChild() {
#if defined(__aarch64__)
  return static_cast<pid_t>(::syscall(SYS_clone, SIGCHLD, 0, 0, 0, 0));
#else
  return ::fork();
#endif
}

// SIGKILL to this process by system calls only (glibc's raise uses thread data that a raw
// clone child shares with its parent's image).
inline void KillSelf() { ::syscall(SYS_kill, static_cast<long>(::syscall(SYS_getpid)), SIGKILL); }  // NOLINT

}  // namespace mfns::fw::testing
