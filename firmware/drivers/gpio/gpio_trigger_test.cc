// The trigger's pulse sequence and failure handling through FakeGpioLineIo, and the real
// libgpiod layer on a chip that does not exist (no GPIO hardware needed).
#include "firmware/drivers/gpio/gpio_trigger.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <ostream>
#include <set>
#include <string>

#include "common/limits.h"
#include "firmware/drivers/gpio/fake_gpio_line_io.h"
#include "firmware/lib/testing/alloc_counter.h"

namespace mfns::fw {

void PrintTo(TriggerStatus s, std::ostream* os) { *os << ToString(s); }

namespace {

using Op = FakeGpioLineIo::Op;

TriggerConfig Enabled(std::int64_t width_ns = 250000) {
  TriggerConfig c;
  c.enabled = true;
  c.chip = "gpiochip2";
  c.line_offset = 17;
  c.pulse_width_ns = width_ns;
  return c;
}

TEST(TriggerStatus, EveryValueHasADistinctName) {
  std::set<std::string> names;
  const int last = static_cast<int>(TriggerStatus::kSetFailed);
  for (int i = 0; i <= last; ++i) names.insert(ToString(static_cast<TriggerStatus>(i)));
  EXPECT_EQ(names.size(), static_cast<std::size_t>(last + 1));
  EXPECT_EQ(names.count("unknown"), 0U);
}

TEST(GpioTrigger, StartClaimsTheLineAsAnInactiveOutput) {
  FakeGpioLineIo io;
  TriggerConfig c = Enabled();
  c.active_low = true;
  GpioTrigger t(&io, c);
  ASSERT_EQ(t.Start(), TriggerStatus::kOk);
  EXPECT_EQ(io.chip, "gpiochip2");
  ASSERT_GE(io.calls.size(), 2U);
  EXPECT_EQ(io.calls[1].op, Op::kRequest);
  EXPECT_EQ(io.calls[1].value, 17);
  EXPECT_EQ(io.initial_value, 0);
  EXPECT_TRUE(io.active_low);
  EXPECT_EQ(io.consumer, "mfns-navd");
  EXPECT_TRUE(io.SetValues().empty());  // no edge at start
}

TEST(GpioTrigger, FireIsHighForThePulseWidthThenLow) {
  FakeGpioLineIo io;
  const std::int64_t width = 250000;
  GpioTrigger t(&io, Enabled(width));
  ASSERT_EQ(t.Start(), TriggerStatus::kOk);
  io.calls.clear();
  const std::int64_t t0 = io.now_ns;
  ASSERT_EQ(t.Fire(), TriggerStatus::kOk);
  ASSERT_EQ(io.calls.size(), 3U);
  EXPECT_EQ(io.calls[0].op, Op::kSet);
  EXPECT_EQ(io.calls[0].value, 1);
  EXPECT_EQ(io.calls[1].op, Op::kSleepUntil);
  EXPECT_EQ(io.calls[1].value, t0 + width);  // deadline measured from the rising edge
  EXPECT_EQ(io.calls[2].op, Op::kSet);
  EXPECT_EQ(io.calls[2].value, 0);
  EXPECT_EQ(io.calls[2].t_ns - io.calls[0].t_ns, width);  // time high, on the fake clock
  EXPECT_EQ(io.value, 0);

  ASSERT_EQ(t.Fire(), TriggerStatus::kOk);
  EXPECT_EQ(io.SetValues(), (std::vector<std::int64_t>{1, 0, 1, 0}));
  EXPECT_EQ(t.counters().pulses, 2U);
}

TEST(GpioTrigger, DisabledDoesNothing) {
  TriggerConfig c;  // enabled = false
  GpioTrigger t(nullptr, c);
  EXPECT_FALSE(t.enabled());
  EXPECT_EQ(t.Start(), TriggerStatus::kDisabled);
  EXPECT_EQ(t.Fire(), TriggerStatus::kDisabled);
  t.Stop();
  FakeGpioLineIo io;
  GpioTrigger with_io(&io, c);
  EXPECT_EQ(with_io.Start(), TriggerStatus::kDisabled);
  EXPECT_EQ(with_io.Fire(), TriggerStatus::kDisabled);
  EXPECT_TRUE(io.calls.empty());
  EXPECT_EQ(with_io.counters().pulses, 0U);
}

TEST(GpioTrigger, OpenFailureIsTypedAndCounted) {
  FakeGpioLineIo io;
  io.open_error = ENOENT;
  GpioTrigger t(&io, Enabled());
  EXPECT_EQ(t.Start(), TriggerStatus::kOpenFailed);
  EXPECT_EQ(t.counters().open_errors, 1U);
  EXPECT_EQ(t.Fire(), TriggerStatus::kNotStarted);
  EXPECT_TRUE(io.SetValues().empty());
}

TEST(GpioTrigger, RequestFailureReleasesTheChip) {
  FakeGpioLineIo io;
  io.request_error = EBUSY;  // another consumer holds the line
  GpioTrigger t(&io, Enabled());
  EXPECT_EQ(t.Start(), TriggerStatus::kRequestFailed);
  EXPECT_EQ(t.counters().request_errors, 1U);
  EXPECT_FALSE(io.chip_open);
  EXPECT_EQ(t.Fire(), TriggerStatus::kNotStarted);
}

TEST(GpioTrigger, FailedRisingEdgeIsReportedAndTheLineDrivenLow) {
  FakeGpioLineIo io;
  GpioTrigger t(&io, Enabled());
  ASSERT_EQ(t.Start(), TriggerStatus::kOk);
  io.set_error = EIO;  // every set fails
  EXPECT_EQ(t.Fire(), TriggerStatus::kSetFailed);
  EXPECT_EQ(io.SetValues(), (std::vector<std::int64_t>{1, 0}));  // no sleep, a try at 0
  EXPECT_EQ(t.counters().set_errors, 2U);
  EXPECT_EQ(t.counters().pulses, 0U);
  io.set_error = 0;
  EXPECT_EQ(t.Fire(), TriggerStatus::kOk);  // recovers
  EXPECT_EQ(t.counters().pulses, 1U);
}

TEST(GpioTrigger, FailedFallingEdgeIsReported) {
  FakeGpioLineIo io;
  GpioTrigger t(&io, Enabled());
  ASSERT_EQ(t.Start(), TriggerStatus::kOk);
  io.set_error = EIO;
  io.sets_before_failure = 1;  // 1 works, 0 fails
  EXPECT_EQ(t.Fire(), TriggerStatus::kSetFailed);
  EXPECT_EQ(t.counters().set_errors, 1U);
  EXPECT_EQ(t.counters().pulses, 0U);
  EXPECT_EQ(io.value, 1);  // stuck high, and reported as such
}

TEST(GpioTrigger, FailedSleepIsCountedButThePulseEnds) {
  FakeGpioLineIo io;
  GpioTrigger t(&io, Enabled());
  ASSERT_EQ(t.Start(), TriggerStatus::kOk);
  io.sleep_error = EINVAL;
  EXPECT_EQ(t.Fire(), TriggerStatus::kOk);
  EXPECT_EQ(t.counters().sleep_errors, 1U);
  EXPECT_EQ(io.value, 0);
}

TEST(GpioTrigger, BadConfigIsRefused) {
  FakeGpioLineIo io;
  TriggerConfig c = Enabled(0);
  EXPECT_EQ(GpioTrigger(&io, c).Start(), TriggerStatus::kBadConfig);
  c = Enabled(limits::kMaxTriggerPulseNs + 1);
  EXPECT_EQ(GpioTrigger(&io, c).Start(), TriggerStatus::kBadConfig);
  c = Enabled();
  c.chip = "";
  EXPECT_EQ(GpioTrigger(&io, c).Start(), TriggerStatus::kBadConfig);
  c.chip = nullptr;
  EXPECT_EQ(GpioTrigger(&io, c).Start(), TriggerStatus::kBadConfig);
  EXPECT_EQ(GpioTrigger(nullptr, Enabled()).Start(), TriggerStatus::kBadConfig);
  EXPECT_TRUE(io.calls.empty());
}

TEST(GpioTrigger, StopDrivesLowAndReleasesAndDestructorStops) {
  FakeGpioLineIo io;
  {
    GpioTrigger t(&io, Enabled());
    ASSERT_EQ(t.Start(), TriggerStatus::kOk);
    t.Stop();
    EXPECT_FALSE(io.line_requested);
    EXPECT_EQ(io.value, 0);
    EXPECT_EQ(t.Fire(), TriggerStatus::kNotStarted);
    ASSERT_EQ(t.Start(), TriggerStatus::kOk);
  }
  EXPECT_FALSE(io.chip_open);  // the destructor let go
}

TEST(GpioTrigger, NoHeapWhileFiring) {
  FakeGpioLineIo io;
  io.calls.reserve(40000);
  GpioTrigger t(&io, Enabled());
  ASSERT_EQ(t.Start(), TriggerStatus::kOk);
  int ok = 0;
  const std::uint64_t before = testing::AllocationCount();
  for (int i = 0; i < 10000; ++i) ok += t.Fire() == TriggerStatus::kOk;
  EXPECT_EQ(testing::AllocationCount(), before);
  EXPECT_EQ(ok, 10000);
}

// The real libgpiod layer: a chip that does not exist fails cleanly.
TEST(LibgpiodLineIo, MissingChipIsOpenFailed) {
  LibgpiodLineIo io;
  TriggerConfig c = Enabled();
  c.chip = "mfns-no-such-gpiochip";
  GpioTrigger t(&io, c);
  EXPECT_EQ(t.Start(), TriggerStatus::kOpenFailed);
  EXPECT_EQ(t.counters().open_errors, 1U);
  EXPECT_EQ(t.Fire(), TriggerStatus::kNotStarted);
}

TEST(LibgpiodLineIo, LineCallsWithoutAChipFail) {
  LibgpiodLineIo io;
  EXPECT_NE(io.RequestOutput(0, "test", false, 0), 0);
  EXPECT_NE(io.SetValue(1), 0);
  io.Release();  // harmless
}

TEST(LibgpiodLineIo, SleepUntilWaitsForTheMonotonicDeadline) {
  LibgpiodLineIo io;
  const std::int64_t t0 = io.NowNs();
  ASSERT_EQ(io.SleepUntilNs(t0 + 2000000), 0);  // 2 ms
  EXPECT_GE(io.NowNs(), t0 + 2000000);           // never early (a lower bound, not a timing test)
  EXPECT_EQ(io.SleepUntilNs(t0), 0);             // a past deadline returns at once
}

}  // namespace
}  // namespace mfns::fw
