// The thin seam between the camera trigger and the GPIO character device: one output line,
// plus the monotonic clock the pulse width is timed with. LibgpiodLineIo calls libgpiod 1.6
// (Debian 12); tests substitute FakeGpioLineIo (fake_gpio_line_io.h).
//
// Error convention: 0 on success, else a positive errno value.
#pragma once

#include <cstdint>

struct gpiod_chip;
struct gpiod_line;

namespace mfns::fw {

class GpioLineIo {
 public:
  virtual ~GpioLineIo() = default;
  // Opens a GPIO chip by name ("gpiochip0"), number ("0"), path ("/dev/gpiochip0") or label.
  virtual int OpenChip(const char* chip) = 0;
  // Claims line `offset` of the open chip as an output driven to `initial` (0/1, logical:
  // with active_low, logical 1 drives the pin low).
  virtual int RequestOutput(unsigned offset, const char* consumer, bool active_low,
                            int initial) = 0;
  virtual int SetValue(int value) = 0;
  // Gives the line back and closes the chip; harmless when nothing is open.
  virtual void Release() = 0;
  // CLOCK_MONOTONIC now, ns; and a sleep until an absolute CLOCK_MONOTONIC time.
  virtual std::int64_t NowNs() = 0;
  virtual int SleepUntilNs(std::int64_t t_ns) = 0;
};

// The real thing: gpiod_chip_open_lookup, gpiod_chip_get_line, gpiod_line_request_output_flags,
// gpiod_line_set_value, gpiod_line_release, gpiod_chip_close; clock_gettime and
// clock_nanosleep(TIMER_ABSTIME) on CLOCK_MONOTONIC (EINTR resumes, bounded).
class LibgpiodLineIo final : public GpioLineIo {
 public:
  ~LibgpiodLineIo() override;
  int OpenChip(const char* chip) override;
  int RequestOutput(unsigned offset, const char* consumer, bool active_low, int initial) override;
  int SetValue(int value) override;
  void Release() override;
  std::int64_t NowNs() override;
  int SleepUntilNs(std::int64_t t_ns) override;

 private:
  gpiod_chip* chip_ = nullptr;
  gpiod_line* line_ = nullptr;
};

}  // namespace mfns::fw
