#include "firmware/drivers/gpio/gpio_trigger.h"

#include "common/limits.h"

namespace mfns::fw {

const char* ToString(TriggerStatus s) {
  switch (s) {
    case TriggerStatus::kOk: return "ok";
    case TriggerStatus::kDisabled: return "disabled";
    case TriggerStatus::kNotStarted: return "not started";
    case TriggerStatus::kBadConfig: return "bad configuration";
    case TriggerStatus::kOpenFailed: return "gpio chip open failed";
    case TriggerStatus::kRequestFailed: return "gpio line request failed";
    case TriggerStatus::kSetFailed: return "gpio line set failed";
  }
  return "unknown";
}

GpioTrigger::GpioTrigger(GpioLineIo* io, const TriggerConfig& config)
    : io_(io), config_(config) {}

GpioTrigger::~GpioTrigger() { Stop(); }

TriggerStatus GpioTrigger::Start() {
  if (!config_.enabled) return TriggerStatus::kDisabled;
  Stop();
  if (io_ == nullptr || config_.chip == nullptr || config_.chip[0] == '\0' ||
      config_.pulse_width_ns <= 0 || config_.pulse_width_ns > limits::kMaxTriggerPulseNs) {
    return TriggerStatus::kBadConfig;
  }
  if (io_->OpenChip(config_.chip) != 0) {
    ++counters_.open_errors;
    io_->Release();
    return TriggerStatus::kOpenFailed;
  }
  const char* consumer = config_.consumer != nullptr ? config_.consumer : "mfns-navd";
  if (io_->RequestOutput(config_.line_offset, consumer, config_.active_low, 0) != 0) {
    ++counters_.request_errors;
    io_->Release();
    return TriggerStatus::kRequestFailed;
  }
  started_ = true;
  return TriggerStatus::kOk;
}

TriggerStatus GpioTrigger::Fire() {
  if (!config_.enabled) return TriggerStatus::kDisabled;
  if (!started_) return TriggerStatus::kNotStarted;
  if (io_->SetValue(1) != 0) {
    ++counters_.set_errors;
    // The line's state is unknown: try to leave it inactive so no camera sees a stuck trigger.
    if (io_->SetValue(0) != 0) ++counters_.set_errors;
    return TriggerStatus::kSetFailed;
  }
  // Timed from the moment the edge was set, to an absolute deadline: EINTR cannot stretch it.
  const std::int64_t deadline = io_->NowNs() + config_.pulse_width_ns;
  if (io_->SleepUntilNs(deadline) != 0) ++counters_.sleep_errors;
  if (io_->SetValue(0) != 0) {
    ++counters_.set_errors;
    return TriggerStatus::kSetFailed;
  }
  ++counters_.pulses;
  return TriggerStatus::kOk;
}

void GpioTrigger::Stop() {
  if (!started_) return;
  if (io_->SetValue(0) != 0) ++counters_.set_errors;
  io_->Release();
  started_ = false;
}

}  // namespace mfns::fw
