// The flight software's one clock: CLOCK_MONOTONIC, in ns, and an absolute sleep on it (and the
// thread's CPU time, for measuring work).
// Driver timestamps (V4L2, DESIGN.md) are on this clock, so every time the firmware compares
// with them (publish time, deadlines, the trigger's pulse, a paced replay) reads it here.
#pragma once

#include <time.h>

#include <cerrno>
#include <cstdint>

#include "common/limits.h"

namespace mfns::fw {

inline std::uint64_t MonotonicNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

// CPU time the calling thread has used, in ns (CLOCK_THREAD_CPUTIME_ID): the cost of a piece of
// work on one core, unaffected by other processes sharing the machine (tests and tools that
// report it: mfns-sim navmatrix's Step times).
inline std::uint64_t ThreadCpuNs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ull + static_cast<std::uint64_t>(ts.tv_nsec);
}

// Sleeps until CLOCK_MONOTONIC reaches t_ns. The deadline is absolute, so a sleep resumed after
// a signal still ends on time; at most limits::kMaxEintrRetries resumptions (a signal storm
// cannot hold the caller). Returns 0, or clock_nanosleep's error (EINTR when retries ran out).
inline int SleepUntilMonotonicNs(std::uint64_t t_ns) {
  const timespec ts{static_cast<time_t>(t_ns / 1'000'000'000ull), static_cast<long>(t_ns % 1'000'000'000ull)};  // NOLINT(runtime/int)
  int r = EINTR;
  for (int attempt = 0; attempt <= limits::kMaxEintrRetries && r == EINTR; ++attempt)
    r = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
  return r;
}

}  // namespace mfns::fw
