// Camera trigger: one GPIO output line pulsed once per frame set so that every camera (in
// external-trigger mode) exposes at the same instant. libgpiod 1.6 behind the GpioLineIo seam.
//
//   GpioTrigger trigger(&io, config);
//   trigger.Start();            // open chip, claim line as output, drive it inactive (0)
//   trigger.Fire();             // per frame set: 1, sleep until t_high + pulse_width, 0
//   trigger.Stop();             // drive 0, release line, close chip
//
// Without a configured line (config.enabled == false) every call is a no-op returning
// kDisabled: the cameras free-run, or another device triggers them. Fire blocks for the pulse
// width (<= limits::kMaxTriggerPulseNs). Not thread-safe.
#pragma once

#include <cstdint>

#include "firmware/drivers/gpio/gpio_line_io.h"

namespace mfns::fw {

enum class TriggerStatus : unsigned char {
  kOk = 0,
  kDisabled,       // no line configured: nothing done
  kNotStarted,     // Fire before a successful Start, or after Stop
  kBadConfig,      // no chip name, or pulse width outside (0, kMaxTriggerPulseNs]
  kOpenFailed,     // the GPIO chip could not be opened
  kRequestFailed,  // the line could not be claimed as an output (busy, bad offset)
  kSetFailed,      // driving the line failed; the pulse may be missing or stuck
};
const char* ToString(TriggerStatus s);

struct TriggerConfig {
  bool enabled = false;
  const char* chip = nullptr;     // "gpiochip0", "0", "/dev/gpiochip0" or a label; borrowed
  unsigned line_offset = 0;       // line number on the chip
  std::int64_t pulse_width_ns = 100000;  // time high (logical 1), ns
  bool active_low = false;        // the cameras trigger on a low pulse
  const char* consumer = "mfns-navd";    // shown by gpioinfo; borrowed
};

struct TriggerCounters {
  std::uint64_t pulses = 0;          // complete pulses (1 then 0 both set)
  std::uint64_t open_errors = 0;
  std::uint64_t request_errors = 0;
  std::uint64_t set_errors = 0;      // failed sets (each counted)
  std::uint64_t sleep_errors = 0;    // the pulse-width wait failed (pulse ended early)
};

class GpioTrigger {
 public:
  // io is borrowed and must outlive the trigger; it may be null when config.enabled is false.
  GpioTrigger(GpioLineIo* io, const TriggerConfig& config);
  ~GpioTrigger();
  GpioTrigger(const GpioTrigger&) = delete;
  GpioTrigger& operator=(const GpioTrigger&) = delete;

  TriggerStatus Start();  // restarts when started
  // One pulse. kOk, kDisabled, kNotStarted or kSetFailed (the line is left at 0 if possible).
  TriggerStatus Fire();
  void Stop();

  bool enabled() const { return config_.enabled; }
  const TriggerCounters& counters() const { return counters_; }

 private:
  GpioLineIo* io_;
  TriggerConfig config_;
  bool started_ = false;
  TriggerCounters counters_{};
};

}  // namespace mfns::fw
