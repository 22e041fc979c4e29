// The real V4L2 capture code driven through FakeV4l2Io: each scripted driver behaviour must
// give the documented status and counter, and the fake must see no protocol violation.
#include "firmware/drivers/v4l2/v4l2_source.h"

#include <fcntl.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>

#include "common/rig/paper_rig.h"
#include "firmware/drivers/v4l2/fake_v4l2_io.h"
#include "firmware/lib/testing/alloc_counter.h"
#include "firmware/lib/testing/print_status.h"

namespace mfns::fw {
namespace {

constexpr int kW = 64;
constexpr int kH = 48;

V4l2SourceConfig Config(int n, PixelFormat format = PixelFormat::kMono8) {
  static const char* const kPaths[] = {"/dev/video0", "/dev/video1", "/dev/video2",
                                       "/dev/video3"};
  V4l2SourceConfig c;
  c.num_cameras = n;
  for (int k = 0; k < n; ++k) {
    c.cameras[static_cast<unsigned>(k)] = {kPaths[k], kW, kH, format, limits::kMinCaptureBuffers};
  }
  return c;
}

FakeV4l2Frame Frame(std::uint32_t seq, std::uint64_t t_ns = 0, std::uint8_t seed = 0) {
  FakeV4l2Frame f;
  f.sequence = seq;
  f.t_ns = t_ns;
  f.seed = seed;
  return f;
}

class V4l2SourceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    for (const char* p : {"/dev/video0", "/dev/video1", "/dev/video2"}) devs_.push_back(&io_.AddDevice(p));
  }
  void TearDown() override {
    for (const FakeV4l2Device* d : devs_) EXPECT_EQ(d->protocol_errors, 0) << d->path;
  }
  FakeV4l2Device& dev(int k) { return *devs_[static_cast<std::size_t>(k)]; }

  FakeV4l2Io io_;
  std::vector<FakeV4l2Device*> devs_;
};

TEST_F(V4l2SourceTest, StartNegotiatesGreyMapsAndQueuesEveryBufferAndStreams) {
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  const FakeV4l2Device& d = dev(0);
  EXPECT_TRUE(d.is_open);
  EXPECT_NE(d.open_flags & O_NONBLOCK, 0);
  EXPECT_EQ(d.format.pixelformat, static_cast<std::uint32_t>(V4L2_PIX_FMT_GREY));
  EXPECT_EQ(d.format.width, static_cast<std::uint32_t>(kW));
  EXPECT_EQ(d.format.height, static_cast<std::uint32_t>(kH));
  ASSERT_EQ(d.buffers.size(), static_cast<std::size_t>(limits::kMinCaptureBuffers));
  EXPECT_EQ(d.mapped_count(), limits::kMinCaptureBuffers);
  EXPECT_EQ(d.queued_count(), limits::kMinCaptureBuffers);
  EXPECT_TRUE(d.streaming);
  EXPECT_EQ(src.num_buffers(0), limits::kMinCaptureBuffers);
  EXPECT_EQ(src.camera_status(0), SourceStatus::kOk);
  // The order of the V4L2 handshake.
  const std::vector<unsigned long> expected_head = {VIDIOC_QUERYCAP, VIDIOC_S_FMT, VIDIOC_G_FMT,
                                                    VIDIOC_REQBUFS, VIDIOC_QUERYBUF};
  ASSERT_GE(d.ioctl_log.size(), expected_head.size());
  EXPECT_TRUE(std::equal(expected_head.begin(), expected_head.end(), d.ioctl_log.begin()));
  EXPECT_EQ(d.ioctl_log.back(), static_cast<unsigned long>(VIDIOC_STREAMON));
}

TEST_F(V4l2SourceTest, AsksForY16WhenMono16IsConfigured) {
  V4l2Source src(&io_, Config(1, PixelFormat::kMono16));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  EXPECT_EQ(dev(0).format.pixelformat, static_cast<std::uint32_t>(V4L2_PIX_FMT_Y16));
}

TEST_F(V4l2SourceTest, HonoursTheRequestedBufferCount) {
  V4l2SourceConfig c = Config(1);
  c.cameras[0].num_buffers = limits::kMaxCaptureBuffers;
  V4l2Source src(&io_, c);
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  EXPECT_EQ(dev(0).mapped_count(), limits::kMaxCaptureBuffers);
}

TEST_F(V4l2SourceTest, DeliversPixelsTimestampAndSequenceThenRequeuesOnRelease) {
  dev(0).stride_padding = 16;  // rows longer than the image: the view must use the stride
  FakeV4l2Frame f = Frame(42, 1234567891234ULL, 9);
  f.flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  dev(0).frames.push_back(f);
  f = Frame(43, 1234600000000ULL, 10);
  f.flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
  dev(0).frames.push_back(f);
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);

  FrameView v;
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  EXPECT_EQ(v.width, kW);
  EXPECT_EQ(v.height, kH);
  EXPECT_EQ(v.stride_bytes, kW + 16);
  EXPECT_EQ(v.format, PixelFormat::kMono8);
  EXPECT_EQ(v.camera, 0);
  EXPECT_EQ(v.sequence, 42U);
  EXPECT_EQ(v.t_capture_ns, 1234567891000ULL);  // the driver's microsecond timeval, in ns
  EXPECT_EQ(v.t_source, TimestampSource::kStartOfExposure);
  int wrong = 0;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) wrong += v.At(x, y) != FakePixel(9, x, y, false);
  }
  EXPECT_EQ(wrong, 0);
  EXPECT_EQ(dev(0).queued_count(), limits::kMinCaptureBuffers - 1);  // lent to us
  src.Release(0);
  EXPECT_EQ(dev(0).queued_count(), limits::kMinCaptureBuffers);
  src.Release(0);  // nothing held: no second QBUF (the fake would flag it)

  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  EXPECT_EQ(v.t_source, TimestampSource::kEndOfFrame);
  EXPECT_EQ(v.At(5, 7), FakePixel(10, 5, 7, false));
  src.Release(0);
  EXPECT_EQ(src.counters(0).frames, 2U);
  EXPECT_EQ(src.counters(0).drops, 0U);
}

TEST_F(V4l2SourceTest, Y16FramesReadAsLittleEndianMono16) {
  dev(0).frames.push_back(Frame(0, 1000, 77));
  V4l2Source src(&io_, Config(1, PixelFormat::kMono16));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  EXPECT_EQ(v.format, PixelFormat::kMono16);
  EXPECT_EQ(v.stride_bytes, 2 * kW);
  int wrong = 0;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) wrong += v.At(x, y) != FakePixel(77, x, y, true);
  }
  EXPECT_EQ(wrong, 0);
  src.Release(0);
}

TEST_F(V4l2SourceTest, SequenceGapsCountAsDrops) {
  for (std::uint32_t s : {10U, 11U, 14U, 15U, 20U}) dev(0).frames.push_back(Frame(s));
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  for (int i = 0; i < 5; ++i) {
    FrameView v;
    ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
    src.Release(0);
  }
  EXPECT_EQ(src.counters(0).drops, 2U + 4U);
  EXPECT_EQ(src.counters(0).frames, 5U);
}

TEST_F(V4l2SourceTest, ErrorFlaggedBufferIsRequeuedCountedAndDropped) {
  dev(0).frames.push_back(Frame(0));
  FakeV4l2Frame bad = Frame(1);
  bad.flags |= V4L2_BUF_FLAG_ERROR;
  dev(0).frames.push_back(bad);
  dev(0).frames.push_back(Frame(2));
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  src.Release(0);
  FrameView untouched;
  EXPECT_EQ(src.Acquire(0, 100, &untouched), SourceStatus::kDropped);
  EXPECT_EQ(untouched.data, nullptr);
  EXPECT_EQ(dev(0).queued_count(), limits::kMinCaptureBuffers);  // given straight back
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);  // no Release owed for the bad one
  EXPECT_EQ(v.sequence, 2U);
  src.Release(0);
  EXPECT_EQ(src.counters(0).error_buffers, 1U);
  EXPECT_EQ(src.counters(0).drops, 0U);  // the flagged frame is not counted twice
  EXPECT_EQ(src.counters(0).frames, 2U);
}

TEST_F(V4l2SourceTest, PollTimeoutIsATimeout) {
  dev(0).poll_script.push_back(FakePoll::kTimeout);
  dev(0).frames.push_back(Frame(0));
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kTimeout);
  EXPECT_EQ(src.counters(0).timeouts, 1U);
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);  // the frame arrives afterwards
  src.Release(0);
}

TEST_F(V4l2SourceTest, EintrIsRetriedWithinTheBound) {
  dev(0).frames.push_back(Frame(0));
  dev(0).poll_script = {FakePoll::kEintr, FakePoll::kEintr};
  dev(0).failures.push_back({VIDIOC_DQBUF, EINTR, 1});
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  src.Release(0);
  EXPECT_EQ(src.counters(0).eintr_retries, 3U);
  EXPECT_EQ(src.counters(0).driver_errors, 0U);
}

TEST_F(V4l2SourceTest, EndlessEintrGivesUpWithAnError) {
  dev(0).frames.push_back(Frame(0));
  dev(0).poll_script.assign(limits::kMaxEintrRetries + 1, FakePoll::kEintr);
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kError);
  EXPECT_EQ(src.counters(0).eintr_retries, static_cast<std::uint64_t>(limits::kMaxEintrRetries));
  EXPECT_EQ(src.counters(0).driver_errors, 1U);
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);  // the next call works again
  src.Release(0);
}

TEST_F(V4l2SourceTest, DqbufEioIsADriverError) {
  dev(0).frames.push_back(Frame(0));
  dev(0).failures.push_back({VIDIOC_DQBUF, EIO, 1});
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kError);
  EXPECT_EQ(src.counters(0).driver_errors, 1U);
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  src.Release(0);
}

TEST_F(V4l2SourceTest, PollErrorsAreDriverErrors) {
  dev(0).poll_script = {FakePoll::kPollErr, FakePoll::kFail};
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kError);
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kError);
  EXPECT_EQ(src.counters(0).driver_errors, 2U);
}

TEST_F(V4l2SourceTest, DqbufEagainAfterPollIsATimeout) {
  dev(0).frames.push_back(Frame(0));
  dev(0).failures.push_back({VIDIOC_DQBUF, EAGAIN, 1});
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kTimeout);
  EXPECT_EQ(src.counters(0).timeouts, 1U);
  EXPECT_EQ(src.counters(0).driver_errors, 0U);
}

TEST_F(V4l2SourceTest, NonMonotonicClockIsCountedAndDropped) {
  FakeV4l2Frame f = Frame(0, 5000);
  f.flags = V4L2_BUF_FLAG_TIMESTAMP_COPY;
  dev(0).frames.push_back(f);
  f.sequence = 1;
  f.flags = V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN;
  dev(0).frames.push_back(f);
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kDropped);
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kDropped);
  EXPECT_EQ(src.counters(0).unknown_clock, 2U);
  EXPECT_EQ(src.counters(0).frames, 0U);
  EXPECT_EQ(dev(0).queued_count(), limits::kMinCaptureBuffers);
}

TEST_F(V4l2SourceTest, ShortBufferIsCountedAndDropped) {
  FakeV4l2Frame f = Frame(0);
  f.bytesused = kW * kH - 1;
  dev(0).frames.push_back(f);
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kDropped);
  EXPECT_EQ(src.counters(0).short_buffers, 1U);
}

TEST_F(V4l2SourceTest, CameraThatStopsDeliveringTimesOutWhileOthersGoOn) {
  dev(0).frames = {Frame(0), Frame(1), Frame(2)};
  dev(1).frames = {Frame(0)};  // then silence
  V4l2Source src(&io_, Config(2));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  int ok0 = 0;
  int timeouts1 = 0;
  for (int set = 0; set < 3; ++set) {
    FrameView v;
    if (src.Acquire(0, 100, &v) == SourceStatus::kOk) ++ok0;
    src.Release(0);
    const SourceStatus s1 = src.Acquire(1, 100, &v);
    if (s1 == SourceStatus::kTimeout) ++timeouts1;
    src.Release(1);
  }
  EXPECT_EQ(ok0, 3);
  EXPECT_EQ(timeouts1, 2);
  EXPECT_EQ(src.counters(1).timeouts, 2U);
  EXPECT_EQ(src.counters(0).timeouts, 0U);
}

TEST_F(V4l2SourceTest, HoldingFramesOfSeveralCamerasAtOnce) {
  dev(0).frames = {Frame(0, 10, 1), Frame(1, 20, 2)};
  dev(1).frames = {Frame(0, 10, 3)};
  V4l2Source src(&io_, Config(2));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView a, b, c;
  ASSERT_EQ(src.Acquire(0, 100, &a), SourceStatus::kOk);
  ASSERT_EQ(src.Acquire(1, 100, &b), SourceStatus::kOk);
  EXPECT_EQ(src.Acquire(0, 100, &c), SourceStatus::kBusy);
  EXPECT_EQ(a.camera, 0);
  EXPECT_EQ(b.camera, 1);
  EXPECT_EQ(a.At(3, 3), FakePixel(1, 3, 3, false));
  EXPECT_EQ(b.At(3, 3), FakePixel(3, 3, 3, false));
  src.Release(0);
  src.Release(1);
}

TEST_F(V4l2SourceTest, DriverChangingTheSizeIsRefused) {
  dev(0).adjust_width = kW / 2;
  V4l2Source src(&io_, Config(1));
  EXPECT_EQ(src.Start(), SourceStatus::kFormatRefused);
  EXPECT_EQ(src.camera_status(0), SourceStatus::kFormatRefused);
  EXPECT_FALSE(dev(0).is_open);
  EXPECT_EQ(dev(0).mapped_count(), 0);
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kNotStarted);
}

TEST_F(V4l2SourceTest, DriverChangingTheHeightOrFormatIsRefused) {
  dev(0).adjust_height = kH + 2;
  dev(1).adjust_pixelformat = V4L2_PIX_FMT_YUYV;  // falls back to GREY: asked Y16, got GREY
  V4l2SourceConfig c = Config(2, PixelFormat::kMono16);
  V4l2Source src(&io_, c);
  EXPECT_EQ(src.Start(), SourceStatus::kFormatRefused);
  EXPECT_EQ(src.camera_status(0), SourceStatus::kFormatRefused);
  EXPECT_EQ(src.camera_status(1), SourceStatus::kFormatRefused);
}

TEST_F(V4l2SourceTest, OneBrokenCameraAtStartLeavesTheOthersStreaming) {
  dev(1).device_caps = V4L2_CAP_VIDEO_CAPTURE;  // no streaming I/O
  dev(0).frames = {Frame(0)};
  dev(2).frames = {Frame(0)};
  V4l2Source src(&io_, Config(3));
  EXPECT_EQ(src.Start(), SourceStatus::kNotCapture);
  EXPECT_EQ(src.camera_status(0), SourceStatus::kOk);
  EXPECT_EQ(src.camera_status(1), SourceStatus::kNotCapture);
  EXPECT_EQ(src.camera_status(2), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(1, 100, &v), SourceStatus::kNotStarted);
  EXPECT_EQ(src.Acquire(2, 100, &v), SourceStatus::kOk);
  src.Release(2);
}

TEST_F(V4l2SourceTest, NotACaptureDeviceIsRefused) {
  dev(0).device_caps = V4L2_CAP_STREAMING;  // e.g. an output node
  V4l2Source src(&io_, Config(1));
  EXPECT_EQ(src.Start(), SourceStatus::kNotCapture);
  EXPECT_FALSE(dev(0).is_open);
}

TEST_F(V4l2SourceTest, CapabilitiesFieldIsUsedWithoutDeviceCaps) {
  dev(0).capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;  // old driver
  dev(0).device_caps = 0;
  V4l2Source src(&io_, Config(1));
  EXPECT_EQ(src.Start(), SourceStatus::kOk);
}

TEST_F(V4l2SourceTest, TooFewOrTooManyBuffersAreRefused) {
  dev(0).grant_buffers = limits::kMinCaptureBuffers - 1;
  dev(1).grant_buffers = limits::kMaxCaptureBuffers + 1;
  V4l2Source src(&io_, Config(2));
  EXPECT_EQ(src.Start(), SourceStatus::kNoBuffers);
  EXPECT_EQ(src.camera_status(0), SourceStatus::kNoBuffers);
  EXPECT_EQ(src.camera_status(1), SourceStatus::kNoBuffers);
  EXPECT_FALSE(dev(0).is_open);
  EXPECT_FALSE(dev(1).is_open);
}

TEST_F(V4l2SourceTest, FailuresDuringSetUpUndoEverything) {
  struct Case {
    unsigned long request;  // NOLINT(runtime/int)
    SourceStatus expected;
  };
  const Case cases[] = {
      {VIDIOC_QUERYCAP, SourceStatus::kNotCapture}, {VIDIOC_S_FMT, SourceStatus::kFormatRefused},
      {VIDIOC_G_FMT, SourceStatus::kFormatRefused}, {VIDIOC_REQBUFS, SourceStatus::kNoBuffers},
      {VIDIOC_QUERYBUF, SourceStatus::kNoBuffers},  {VIDIOC_QBUF, SourceStatus::kStreamFailed},
      {VIDIOC_STREAMON, SourceStatus::kStreamFailed},
  };
  for (const Case& c : cases) {
    FakeV4l2Io io;
    FakeV4l2Device& d = io.AddDevice("/dev/video0");
    d.failures.push_back({c.request, EIO, 1});
    V4l2Source src(&io, Config(1));
    EXPECT_EQ(src.Start(), c.expected) << c.request;
    EXPECT_FALSE(d.is_open) << c.request;
    EXPECT_EQ(d.mapped_count(), 0) << c.request;
    EXPECT_EQ(d.protocol_errors, 0) << c.request;
  }
}

TEST_F(V4l2SourceTest, MissingDeviceAndBadConfigAreTyped) {
  V4l2SourceConfig c = Config(1);
  c.cameras[0].device_path = "/dev/video9";
  V4l2Source missing(&io_, c);
  EXPECT_EQ(missing.Start(), SourceStatus::kOpenFailed);

  V4l2SourceConfig bad = Config(1);
  bad.cameras[0].num_buffers = limits::kMinCaptureBuffers - 1;
  EXPECT_EQ(V4l2Source(&io_, bad).Start(), SourceStatus::kBadConfig);
  bad = Config(1);
  bad.cameras[0].width = limits::kMaxImageWidth + 1;
  EXPECT_EQ(V4l2Source(&io_, bad).Start(), SourceStatus::kBadConfig);
  bad = Config(1);
  bad.cameras[0].device_path = nullptr;
  EXPECT_EQ(V4l2Source(&io_, bad).Start(), SourceStatus::kBadConfig);
  EXPECT_EQ(V4l2Source(&io_, Config(0)).Start(), SourceStatus::kBadConfig);
  EXPECT_EQ(V4l2Source(nullptr, Config(1)).Start(), SourceStatus::kBadConfig);
}

TEST_F(V4l2SourceTest, MisuseIsTyped) {
  V4l2Source src(&io_, Config(1));
  FrameView v;
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kNotStarted);
  EXPECT_EQ(src.Reset(0), SourceStatus::kNotStarted);
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  EXPECT_EQ(src.Acquire(1, 100, &v), SourceStatus::kBadCamera);
  EXPECT_EQ(src.Acquire(-1, 100, &v), SourceStatus::kBadCamera);
  EXPECT_EQ(src.Reset(3), SourceStatus::kBadCamera);
  EXPECT_EQ(src.camera_status(3), SourceStatus::kBadCamera);
}

TEST_F(V4l2SourceTest, StopStreamsOffUnmapsAndCloses) {
  dev(0).frames = {Frame(0)};
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);  // held across Stop: still cleaned up
  src.Stop();
  EXPECT_EQ(dev(0).streamoffs, 1);
  EXPECT_EQ(dev(0).mapped_count(), 0);
  EXPECT_FALSE(dev(0).is_open);
  EXPECT_EQ(dev(0).closes, 1);
  src.Stop();  // twice: harmless
  EXPECT_EQ(dev(0).closes, 1);
  EXPECT_EQ(src.Acquire(0, 100, &v), SourceStatus::kNotStarted);
  // Restart works after Stop.
  dev(0).frames = {Frame(5)};
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  EXPECT_EQ(v.sequence, 5U);
  src.Release(0);
}

TEST_F(V4l2SourceTest, DestructorReleasesTheDevice) {
  {
    V4l2Source src(&io_, Config(1));
    ASSERT_EQ(src.Start(), SourceStatus::kOk);
  }
  EXPECT_FALSE(dev(0).is_open);
  EXPECT_EQ(dev(0).mapped_count(), 0);
}

TEST_F(V4l2SourceTest, ResetReopensOneCameraAndTheOthersStreamOn) {
  dev(0).frames = {Frame(0), Frame(1)};
  dev(1).frames = {Frame(0)};
  dev(1).failures.push_back({VIDIOC_DQBUF, EIO, 1});
  V4l2Source src(&io_, Config(2));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  FrameView v;
  EXPECT_EQ(src.Acquire(1, 100, &v), SourceStatus::kError);
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);  // camera 0 holds a frame meanwhile
  EXPECT_EQ(src.Reset(1), SourceStatus::kOk);
  EXPECT_EQ(dev(1).opens, 2);
  EXPECT_EQ(dev(0).opens, 1);
  EXPECT_EQ(v.At(1, 1), FakePixel(0, 1, 1, false));  // camera 0's frame untouched
  src.Release(0);
  ASSERT_EQ(src.Acquire(1, 100, &v), SourceStatus::kOk);
  src.Release(1);
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  src.Release(0);
}

TEST_F(V4l2SourceTest, FailedRequeueIsCountedAndTheCameraStreamsOn) {
  dev(0).frames = {Frame(0), Frame(1)};
  V4l2Source src(&io_, Config(1));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  dev(0).failures.push_back({VIDIOC_QBUF, EIO, 1});
  FrameView v;
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  src.Release(0);
  EXPECT_EQ(src.counters(0).driver_errors, 1U);
  EXPECT_EQ(dev(0).queued_count(), limits::kMinCaptureBuffers - 1);
  ASSERT_EQ(src.Acquire(0, 100, &v), SourceStatus::kOk);
  src.Release(0);
}

TEST_F(V4l2SourceTest, NoHeapAfterStart) {
  constexpr int kFrames = 10000;
  for (int k = 0; k < 3; ++k) {
    dev(k).log_ioctls = false;
    for (int i = 0; i < kFrames; ++i) {
      FakeV4l2Frame f = Frame(static_cast<std::uint32_t>(i), 1000ULL * static_cast<unsigned>(i));
      if (i % 100 == 7) f.flags |= V4L2_BUF_FLAG_ERROR;
      dev(k).frames.push_back(f);
    }
  }
  V4l2Source src(&io_, Config(3));
  ASSERT_EQ(src.Start(), SourceStatus::kOk);
  int ok = 0;
  const std::uint64_t before = testing::AllocationCount();
  for (int i = 0; i < kFrames + 1; ++i) {
    for (int k = 0; k < 3; ++k) {
      FrameView v;
      if (src.Acquire(k, 10, &v) == SourceStatus::kOk) ++ok;
      src.Release(k);
    }
  }
  const std::uint64_t allocations = testing::AllocationCount() - before;
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(ok, 3 * (kFrames - kFrames / 100));
  EXPECT_EQ(src.counters(2).timeouts, 1U);
}

TEST(V4l2ConfigFromRig, TakesEachCamerasSize) {
  const Rig rig = PaperRig();
  const std::array<const char*, limits::kMaxCameras> paths = {"/dev/a", "/dev/b", "/dev/c",
                                                              nullptr};
  const V4l2SourceConfig c = V4l2ConfigFromRig(rig, paths, PixelFormat::kMono16);
  ASSERT_EQ(c.num_cameras, rig.num_cameras);
  for (int k = 0; k < rig.num_cameras; ++k) {
    const auto& cam = c.cameras[static_cast<unsigned>(k)];
    EXPECT_EQ(cam.width, rig.cameras[static_cast<unsigned>(k)].intrinsics.width);
    EXPECT_EQ(cam.height, rig.cameras[static_cast<unsigned>(k)].intrinsics.height);
    EXPECT_EQ(cam.device_path, paths[static_cast<unsigned>(k)]);
    EXPECT_EQ(cam.format, PixelFormat::kMono16);
  }
}

// The real syscall layer, with no camera: a missing node and a node that is not V4L2.
TEST(LinuxV4l2Io, MissingDeviceIsOpenFailed) {
  LinuxV4l2Io io;
  V4l2SourceConfig c = Config(1);
  c.cameras[0].device_path = "/nonexistent/mfns-video0";
  V4l2Source src(&io, c);
  EXPECT_EQ(src.Start(), SourceStatus::kOpenFailed);
}

TEST(LinuxV4l2Io, NonV4l2NodeIsNotCapture) {
  LinuxV4l2Io io;
  V4l2SourceConfig c = Config(1);
  c.cameras[0].device_path = "/dev/null";
  V4l2Source src(&io, c);
  EXPECT_EQ(src.Start(), SourceStatus::kNotCapture);
}

}  // namespace
}  // namespace mfns::fw
