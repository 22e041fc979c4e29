// Test support: a GpioLineIo that records every call (with a fake monotonic clock) and can be
// told to fail opening, requesting, setting or sleeping. Header-only; not flight code.
#pragma once

#include <cerrno>
#include <cstdint>
#include <string>
#include <vector>

#include "firmware/drivers/gpio/gpio_line_io.h"

namespace mfns::fw {

class FakeGpioLineIo final : public GpioLineIo {
 public:
  enum class Op : unsigned char { kOpen, kRequest, kSet, kSleepUntil, kRelease };
  struct Call {
    Op op;
    std::int64_t value;  // kSet: the value; kSleepUntil: the deadline; kRequest: the offset
    std::int64_t t_ns;   // fake clock when called
  };

  // Scripting: errno to return (0 = succeed) and, for sets, after how many good sets to fail.
  int open_error = 0;
  int request_error = 0;
  int set_error = 0;
  int sets_before_failure = 0;  // with set_error: this many sets succeed first
  int sleep_error = 0;
  std::int64_t now_ns = 1000000000;  // the fake clock; SleepUntilNs advances it

  // Recorded.
  std::vector<Call> calls;
  std::string chip;
  std::string consumer;
  bool active_low = false;
  int initial_value = -1;
  int value = -1;  // the line's current logical value (-1: never driven)
  bool chip_open = false;
  bool line_requested = false;

  int OpenChip(const char* c) override {
    calls.push_back({Op::kOpen, 0, now_ns});
    chip = c;
    if (open_error != 0) return open_error;
    chip_open = true;
    return 0;
  }
  int RequestOutput(unsigned offset, const char* who, bool low, int initial) override {
    calls.push_back({Op::kRequest, offset, now_ns});
    if (!chip_open) return EBADF;
    if (request_error != 0) return request_error;
    consumer = who;
    active_low = low;
    initial_value = initial;
    value = initial;
    line_requested = true;
    return 0;
  }
  int SetValue(int v) override {
    calls.push_back({Op::kSet, v, now_ns});
    if (!line_requested) return EBADF;
    if (set_error != 0) {
      if (sets_before_failure <= 0) return set_error;
      --sets_before_failure;
    }
    value = v;
    return 0;
  }
  void Release() override {
    calls.push_back({Op::kRelease, 0, now_ns});
    chip_open = false;
    line_requested = false;
  }
  std::int64_t NowNs() override { return now_ns; }
  int SleepUntilNs(std::int64_t t_ns) override {
    calls.push_back({Op::kSleepUntil, t_ns, now_ns});
    if (sleep_error != 0) return sleep_error;
    if (t_ns > now_ns) now_ns = t_ns;
    return 0;
  }

  // The set calls only, in order, e.g. {1, 0, 1, 0}.
  std::vector<std::int64_t> SetValues() const {
    std::vector<std::int64_t> v;
    for (const Call& c : calls) {
      if (c.op == Op::kSet) v.push_back(c.value);
    }
    return v;
  }
};

}  // namespace mfns::fw
