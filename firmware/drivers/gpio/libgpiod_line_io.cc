#include <gpiod.h>
#include <time.h>

#include <cerrno>

#include "common/limits.h"
#include "firmware/drivers/gpio/gpio_line_io.h"

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

std::int64_t LibgpiodLineIo::NowNs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

int LibgpiodLineIo::SleepUntilNs(std::int64_t t_ns) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(t_ns / 1000000000LL);
  ts.tv_nsec = static_cast<long>(t_ns % 1000000000LL);  // NOLINT(runtime/int)
  int r = EINTR;
  // An absolute deadline makes a resumed sleep end on time; a signal storm cannot hold us.
  for (int attempt = 0; attempt <= limits::kMaxEintrRetries && r == EINTR; ++attempt) {
    r = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
  }
  return r;
}

}  // namespace mfns::fw
