#include <gpiod.h>

#include <cerrno>

#include "common/limits.h"
#include "firmware/drivers/gpio/gpio_line_io.h"
#include "firmware/lib/monotonic_clock.h"

namespace mfns::fw {
namespace {
int ErrnoOr(int fallback) { return errno != 0 ? errno : fallback; }
}  // namespace

LibgpiodLineIo::~LibgpiodLineIo() { Release(); }

int LibgpiodLineIo::OpenChip(const char* chip) {
  Release();
  errno = 0;
  chip_ = gpiod_chip_open_lookup(chip);
  return chip_ == nullptr ? ErrnoOr(ENODEV) : 0;
}

int LibgpiodLineIo::RequestOutput(unsigned offset, const char* consumer, bool active_low,
                                  int initial) {
  if (chip_ == nullptr) return EBADF;
  errno = 0;
  gpiod_line* line = gpiod_chip_get_line(chip_, offset);
  if (line == nullptr) return ErrnoOr(EINVAL);
  const int flags = active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
  if (gpiod_line_request_output_flags(line, consumer, flags, initial) < 0) return ErrnoOr(EIO);
  line_ = line;
  return 0;
}

int LibgpiodLineIo::SetValue(int value) {
  if (line_ == nullptr) return EBADF;
  errno = 0;
  return gpiod_line_set_value(line_, value) < 0 ? ErrnoOr(EIO) : 0;
}

void LibgpiodLineIo::Release() {
  if (line_ != nullptr) gpiod_line_release(line_);
  line_ = nullptr;
  if (chip_ != nullptr) gpiod_chip_close(chip_);
  chip_ = nullptr;
}

std::int64_t LibgpiodLineIo::NowNs() { return static_cast<std::int64_t>(MonotonicNs()); }

int LibgpiodLineIo::SleepUntilNs(std::int64_t t_ns) {
  return t_ns < 0 ? EINVAL : SleepUntilMonotonicNs(static_cast<std::uint64_t>(t_ns));  // (as clock_nanosleep)
}

}  // namespace mfns::fw
