#include "firmware/lib/in_process_source.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "firmware/lib/testing/alloc_counter.h"
#include "firmware/lib/testing/print_status.h"

namespace mfns::fw {
namespace {

FrameView MakeFrame(const std::uint8_t* pixels, std::uint32_t seq, std::uint64_t t_ns) {
  FrameView f;
  f.data = pixels;
  f.width = 4;
  f.height = 2;
  f.stride_bytes = 4;
  f.t_capture_ns = t_ns;
  f.sequence = seq;
  return f;
}

TEST(InProcessSource, HandsOutPushedFramesInOrderPerCamera) {
  std::array<std::uint8_t, 8> a{1, 2, 3, 4, 5, 6, 7, 8};
  std::array<std::uint8_t, 8> b{9, 9, 9, 9, 9, 9, 9, 9};
  InProcessSource src(2);
  ASSERT_TRUE(src.Push(0, MakeFrame(a.data(), 0, 100)));
  ASSERT_TRUE(src.Push(0, MakeFrame(b.data(), 1, 200)));
  ASSERT_TRUE(src.Push(1, MakeFrame(b.data(), 0, 100)));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);

  FrameView v0, v1;
  ASSERT_EQ(src.Acquire(0, 10, &v0), SourceStatus::kOk);
  ASSERT_EQ(src.Acquire(1, 10, &v1), SourceStatus::kOk);  // two cameras held together
  EXPECT_EQ(v0.data, a.data());
  EXPECT_EQ(v0.At(3, 1), 8);
  EXPECT_EQ(v0.t_capture_ns, 100U);
  EXPECT_EQ(v0.camera, 0);
  EXPECT_EQ(v1.camera, 1);
  FrameView again;
  EXPECT_EQ(src.Acquire(0, 10, &again), SourceStatus::kBusy);
  src.Release(0);
  src.Release(1);
  ASSERT_EQ(src.Acquire(0, 10, &v0), SourceStatus::kOk);
  EXPECT_EQ(v0.data, b.data());
  EXPECT_EQ(v0.t_capture_ns, 200U);
  src.Release(0);
  EXPECT_EQ(src.counters(0).frames, 2U);
  EXPECT_EQ(src.counters(1).frames, 1U);
}

TEST(InProcessSource, EmptyQueueTimesOutThenEndsWhenClosed) {
  std::array<std::uint8_t, 8> a{};
  InProcessSource src(1);
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kTimeout);
  EXPECT_EQ(src.counters(0).timeouts, 1U);
  ASSERT_TRUE(src.Push(0, MakeFrame(a.data(), 0, 1)));
  src.Close();
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kOk);  // queued frames drain first
  src.Release(0);
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kEndOfStream);
}

TEST(InProcessSource, ScriptedOutcomesAreReturnedAndCounted) {
  std::array<std::uint8_t, 8> a{};
  InProcessSource src(1);
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  ASSERT_TRUE(src.Push(0, MakeFrame(a.data(), 7, 1)));
  ASSERT_TRUE(src.PushStatus(0, SourceStatus::kDropped));
  ASSERT_TRUE(src.PushStatus(0, SourceStatus::kError));
  ASSERT_TRUE(src.PushStatus(0, SourceStatus::kMissingFrame));
  ASSERT_TRUE(src.PushStatus(0, SourceStatus::kBadFrame));
  ASSERT_TRUE(src.Push(0, MakeFrame(a.data(), 10, 2)));  // 8 and 9 lost
  EXPECT_FALSE(src.PushStatus(0, SourceStatus::kOk));
  EXPECT_FALSE(src.PushStatus(0, SourceStatus::kEndOfStream));
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kOk);
  src.Release(0);
  v = FrameView{};
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kDropped);
  EXPECT_EQ(v.data, nullptr);  // nothing lent
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kError);
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kMissingFrame);
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kBadFrame);
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kOk);
  src.Release(0);
  const SourceCounters& c = src.counters(0);
  EXPECT_EQ(c.frames, 2U);
  EXPECT_EQ(c.error_buffers, 1U);
  EXPECT_EQ(c.driver_errors, 1U);
  EXPECT_EQ(c.missing_files, 1U);
  EXPECT_EQ(c.bad_files, 1U);
  EXPECT_EQ(c.drops, 2U);
}

TEST(InProcessSource, RefusesBadInputAndMisuse) {
  std::array<std::uint8_t, 8> a{};
  InProcessSource src(2);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kNotStarted);
  EXPECT_FALSE(src.Push(2, MakeFrame(a.data(), 0, 0)));   // camera out of range
  EXPECT_FALSE(src.Push(-1, MakeFrame(a.data(), 0, 0)));
  EXPECT_FALSE(src.Push(0, MakeFrame(nullptr, 0, 0)));    // no pixels
  FrameView narrow = MakeFrame(a.data(), 0, 0);
  narrow.format = PixelFormat::kMono16;  // stride 4 < 4 px * 2 bytes
  EXPECT_FALSE(src.Push(0, narrow));
  for (int i = 0; i < limits::kMaxCaptureBuffers; ++i) {
    EXPECT_TRUE(src.Push(0, MakeFrame(a.data(), static_cast<std::uint32_t>(i), 0)));
  }
  EXPECT_FALSE(src.Push(0, MakeFrame(a.data(), 99, 0)));  // queue full
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  EXPECT_EQ(src.Acquire(2, 10, &v), SourceStatus::kBadCamera);
  EXPECT_EQ(src.Reset(0), SourceStatus::kOk);  // drops the queued frames
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kTimeout);
  src.Release(1);  // holds nothing: no-op
  src.Stop();
  EXPECT_EQ(src.Acquire(0, 10, &v), SourceStatus::kNotStarted);
  EXPECT_EQ(src.counters(7).frames, 0U);
}

TEST(AllocationCounter, SeesOperatorNew) {
  const std::uint64_t before = testing::AllocationCount();
  std::vector<int> v(100, 1);
  volatile int* escape = v.data();  // keep the allocation observable
  EXPECT_EQ(escape[99], 1);
  EXPECT_GE(testing::AllocationCount(), before + 1);
}

TEST(InProcessSource, NoHeapAfterStart) {
  std::array<std::uint8_t, 8> a{};
  InProcessSource src(3);
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  int ok = 0;
  const std::uint64_t before = testing::AllocationCount();
  for (std::uint32_t n = 0; n < 10000; ++n) {
    for (int k = 0; k < 3; ++k) {
      src.Push(k, MakeFrame(a.data(), n, n));
      FrameView v;
      if (src.Acquire(k, 10, &v) == SourceStatus::kOk) ++ok;
      src.Release(k);
    }
  }
  EXPECT_EQ(testing::AllocationCount(), before);
  EXPECT_EQ(ok, 30000);
}

}  // namespace
}  // namespace mfns::fw
