// V4L2 capture: one single-planar video capture device per rig camera (e.g. /dev/video0..2),
// GREY (mono8) or Y16 (mono16) at the rig camera's size, MMAP streaming, poll + DQBUF/QBUF.
// FrameSource's contract applies (firmware/lib/frame_source.h); every syscall goes through a
// V4l2Io (v4l2_io.h), so tests run this code against FakeV4l2Io.
//
// Start, per camera: open(O_RDWR | O_NONBLOCK), VIDIOC_QUERYCAP (video capture + streaming),
// VIDIOC_S_FMT then VIDIOC_G_FMT (refused with kFormatRefused if the driver changes the width,
// height or pixel format, picks an interlaced field, or reports a row stride or image size too
// small), VIDIOC_REQBUFS (MMAP, the driver must grant limits::kMinCaptureBuffers..
// kMaxCaptureBuffers), VIDIOC_QUERYBUF + mmap of each, VIDIOC_QBUF of all, VIDIOC_STREAMON.
//
// Acquire(k, timeout_ms): poll(POLLIN, timeout_ms), then VIDIOC_DQBUF.
//   - timeout -> kTimeout (counters.timeouts);
//   - poll/DQBUF failure (incl. EIO, POLLERR) -> kError (counters.driver_errors); the camera
//     keeps its state, the loop may Reset(k);
//   - EINTR is retried up to limits::kMaxEintrRetries times (counters.eintr_retries), then kError;
//   - gaps in v4l2_buffer.sequence count lost frames (counters.drops), error-flagged buffers
//     included so one lost frame is never counted twice;
//   - V4L2_BUF_FLAG_ERROR -> buffer re-queued, kDropped (counters.error_buffers);
//   - clock not V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC -> re-queued, kDropped
//     (counters.unknown_clock): a frame that cannot be placed on CLOCK_MONOTONIC cannot be fused;
//   - bytesused below the image (stride * (height - 1) + width * bytes per pixel) -> re-queued,
//     kDropped (counters.short_buffers);
//   - otherwise kOk: FrameView on the mmapped buffer, t_capture_ns = the buffer's timeval in ns,
//     t_source = start of exposure or end of frame from V4L2_BUF_FLAG_TSTAMP_SRC_*.
// Release(k): VIDIOC_QBUF (failure counted in driver_errors; the camera streams on with one
// buffer fewer). Stop: VIDIOC_STREAMOFF, munmap, close.
#pragma once

#include <array>
#include <cstddef>

#include "common/limits.h"
#include "common/rig/rig.h"
#include "firmware/drivers/v4l2/v4l2_io.h"
#include "firmware/lib/frame_source.h"

namespace mfns::fw {

struct V4l2CameraConfig {
  const char* device_path = nullptr;  // e.g. "/dev/video0"; borrowed, must outlive the source
  int width = 0;                      // px, the rig camera's image size
  int height = 0;                     // px
  PixelFormat format = PixelFormat::kMono8;       // kMono8 -> GREY, kMono16 -> Y16
  int num_buffers = limits::kMinCaptureBuffers;  // requested, in [kMin, kMaxCaptureBuffers]
};

struct V4l2SourceConfig {
  int num_cameras = 0;  // [1, limits::kMaxCameras]; camera k is the rig's camera k
  std::array<V4l2CameraConfig, limits::kMaxCameras> cameras{};
};

// Sizes from the rig's cameras, one device path per camera (borrowed).
V4l2SourceConfig V4l2ConfigFromRig(const Rig& rig,
                                   const std::array<const char*, limits::kMaxCameras>& paths,
                                   PixelFormat format = PixelFormat::kMono8);

class V4l2Source final : public FrameSource {
 public:
  // io is borrowed and must outlive the source.
  V4l2Source(V4l2Io* io, const V4l2SourceConfig& config);
  ~V4l2Source() override;

  // Tries every camera. kOk when all stream; otherwise the first failing camera's status, and
  // the cameras that did start keep streaming (the source counts as started): camera_status(k)
  // tells which failed; the caller may go on without them, Reset(k) later, or Stop().
  SourceStatus Start() override;
  SourceStatus Acquire(int camera, int timeout_ms, FrameView* out) override;
  void Release(int camera) override;
  // Closes and reopens camera k (the others stream on); returns its start status.
  SourceStatus Reset(int camera) override;
  void Stop() override;

  // kOk while camera k streams; its start failure otherwise; kNotStarted before Start.
  SourceStatus camera_status(int camera) const;
  // Buffers mapped for camera k (0 when not streaming).
  int num_buffers(int camera) const;

 private:
  struct Camera {
    int fd = -1;
    bool streaming = false;
    int num_mapped = 0;  // buffers [0, num_mapped) are mapped
    std::array<void*, limits::kMaxCaptureBuffers> mem{};
    std::array<std::size_t, limits::kMaxCaptureBuffers> length{};
    int stride_bytes = 0;
    std::size_t min_bytes = 0;  // bytes a complete frame fills
    int held = -1;              // index of the buffer lent to the caller, -1 when none
    SourceStatus status = SourceStatus::kNotStarted;
    SequenceTracker sequence;
  };

  SourceStatus StartCamera(int k);
  SourceStatus SetUpCamera(int k);
  SourceStatus NegotiateFormat(int k);
  SourceStatus MapBuffers(int k);
  void StopCamera(int k);
  SourceStatus Wait(int k, int timeout_ms);
  void Requeue(int k, unsigned index);
  // ioctl with bounded EINTR retries (counted for camera k).
  int Xioctl(int k, unsigned long request, void* arg);  // NOLINT(runtime/int)

  V4l2Io* io_;
  V4l2SourceConfig config_;
  bool started_ = false;
  std::array<Camera, limits::kMaxCameras> cams_{};
};

}  // namespace mfns::fw
