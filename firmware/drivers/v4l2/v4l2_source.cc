#include "firmware/drivers/v4l2/v4l2_source.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstdint>
#include <cstring>

namespace mfns::fw {
namespace {

std::uint32_t FourCc(PixelFormat f) {
  return f == PixelFormat::kMono16 ? V4L2_PIX_FMT_Y16 : V4L2_PIX_FMT_GREY;
}

bool ValidCameraConfig(const V4l2CameraConfig& c) {
  if (c.device_path == nullptr || c.device_path[0] == '\0') return false;
  if (std::strlen(c.device_path) > static_cast<std::size_t>(limits::kMaxPathChars)) return false;
  return c.width > 0 && c.width <= limits::kMaxImageWidth && c.height > 0 &&
         c.height <= limits::kMaxImageHeight && c.num_buffers >= limits::kMinCaptureBuffers &&
         c.num_buffers <= limits::kMaxCaptureBuffers;
}

v4l2_buffer MmapBuffer(unsigned index) {
  v4l2_buffer b;
  std::memset(&b, 0, sizeof(b));
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  b.index = index;
  return b;
}

}  // namespace

V4l2SourceConfig V4l2ConfigFromRig(const Rig& rig,
                                   const std::array<const char*, limits::kMaxCameras>& paths,
                                   PixelFormat format) {
  V4l2SourceConfig c;
  c.num_cameras = rig.num_cameras;
  for (int k = 0; k < limits::kMaxCameras && k < rig.num_cameras; ++k) {
    V4l2CameraConfig& cam = c.cameras[static_cast<unsigned>(k)];
    cam.device_path = paths[static_cast<unsigned>(k)];
    cam.width = rig.cameras[static_cast<unsigned>(k)].intrinsics.width;
    cam.height = rig.cameras[static_cast<unsigned>(k)].intrinsics.height;
    cam.format = format;
  }
  return c;
}

V4l2Source::V4l2Source(V4l2Io* io, const V4l2SourceConfig& config)
    : FrameSource(config.num_cameras), io_(io), config_(config) {}

V4l2Source::~V4l2Source() { Stop(); }

int V4l2Source::Xioctl(int k, unsigned long request, void* arg) {  // NOLINT(runtime/int)
  int r = -1;
  for (int attempt = 0; attempt <= limits::kMaxEintrRetries; ++attempt) {
    r = io_->Ioctl(cams_[static_cast<unsigned>(k)].fd, request, arg);
    if (r >= 0 || errno != EINTR) return r;
    if (attempt < limits::kMaxEintrRetries) ++mutable_counters(k).eintr_retries;
  }
  return r;  // still EINTR after the bound
}

SourceStatus V4l2Source::Start() {
  Stop();
  ResetCounters();
  if (io_ == nullptr || config_.num_cameras < 1 || config_.num_cameras > limits::kMaxCameras) {
    return SourceStatus::kBadConfig;
  }
  started_ = true;
  SourceStatus first_failure = SourceStatus::kOk;
  for (int k = 0; k < num_cameras(); ++k) {
    const SourceStatus s = StartCamera(k);
    if (s != SourceStatus::kOk && first_failure == SourceStatus::kOk) first_failure = s;
  }
  return first_failure;
}

SourceStatus V4l2Source::StartCamera(int k) {
  Camera& cam = cams_[static_cast<unsigned>(k)];
  cam.status = SetUpCamera(k);
  if (cam.status != SourceStatus::kOk) StopCamera(k);  // undo what was done; keeps the status
  return cam.status;
}

SourceStatus V4l2Source::SetUpCamera(int k) {
  Camera& cam = cams_[static_cast<unsigned>(k)];
  const V4l2CameraConfig& cfg = config_.cameras[static_cast<unsigned>(k)];
  if (!ValidCameraConfig(cfg)) return SourceStatus::kBadConfig;
  cam.sequence.Reset();
  cam.held = -1;

  // Non-blocking: DQBUF never sleeps; poll() is the only wait and it has the timeout.
  for (int attempt = 0; attempt <= limits::kMaxEintrRetries; ++attempt) {
    cam.fd = io_->Open(cfg.device_path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (cam.fd >= 0 || errno != EINTR) break;
  }
  if (cam.fd < 0) return SourceStatus::kOpenFailed;

  v4l2_capability cap;
  std::memset(&cap, 0, sizeof(cap));
  if (Xioctl(k, VIDIOC_QUERYCAP, &cap) < 0) return SourceStatus::kNotCapture;
  // device_caps describes this node; capabilities the whole physical device.
  const std::uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? cap.device_caps : cap.capabilities;
  if ((caps & V4L2_CAP_VIDEO_CAPTURE) == 0 || (caps & V4L2_CAP_STREAMING) == 0) {
    return SourceStatus::kNotCapture;
  }

  SourceStatus s = NegotiateFormat(k);
  if (s != SourceStatus::kOk) return s;
  s = MapBuffers(k);
  if (s != SourceStatus::kOk) return s;

  for (int i = 0; i < cam.num_mapped; ++i) {
    v4l2_buffer b = MmapBuffer(static_cast<unsigned>(i));
    if (Xioctl(k, VIDIOC_QBUF, &b) < 0) return SourceStatus::kStreamFailed;
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (Xioctl(k, VIDIOC_STREAMON, &type) < 0) return SourceStatus::kStreamFailed;
  cam.streaming = true;
  return SourceStatus::kOk;
}

SourceStatus V4l2Source::NegotiateFormat(int k) {
  Camera& cam = cams_[static_cast<unsigned>(k)];
  const V4l2CameraConfig& cfg = config_.cameras[static_cast<unsigned>(k)];
  const std::uint32_t fourcc = FourCc(cfg.format);
  const int bpp = BytesPerPixel(cfg.format);

  v4l2_format fmt;
  std::memset(&fmt, 0, sizeof(fmt));
  fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  fmt.fmt.pix.width = static_cast<std::uint32_t>(cfg.width);
  fmt.fmt.pix.height = static_cast<std::uint32_t>(cfg.height);
  fmt.fmt.pix.pixelformat = fourcc;
  fmt.fmt.pix.field = V4L2_FIELD_NONE;
  if (Xioctl(k, VIDIOC_S_FMT, &fmt) < 0) return SourceStatus::kFormatRefused;
  // S_FMT answers with what the driver chose; G_FMT confirms what it will actually stream.
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      std::memset(&fmt, 0, sizeof(fmt));
      fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      if (Xioctl(k, VIDIOC_G_FMT, &fmt) < 0) return SourceStatus::kFormatRefused;
    }
    const v4l2_pix_format& p = fmt.fmt.pix;
    if (p.width != static_cast<std::uint32_t>(cfg.width) ||
        p.height != static_cast<std::uint32_t>(cfg.height) || p.pixelformat != fourcc ||
        (p.field != V4L2_FIELD_NONE && p.field != V4L2_FIELD_ANY)) {
      return SourceStatus::kFormatRefused;
    }
  }
  const v4l2_pix_format& p = fmt.fmt.pix;
  const std::size_t row_bytes = static_cast<std::size_t>(cfg.width) * static_cast<std::size_t>(bpp);
  const std::size_t stride = p.bytesperline == 0 ? row_bytes : p.bytesperline;
  // A stride above the largest image row is nonsense and would overflow int below.
  if (stride < row_bytes || stride > static_cast<std::size_t>(limits::kMaxImageWidth) * 2U) {
    return SourceStatus::kFormatRefused;
  }
  cam.stride_bytes = static_cast<int>(stride);
  cam.min_bytes = stride * static_cast<std::size_t>(cfg.height - 1) + row_bytes;
  if (p.sizeimage != 0 && p.sizeimage < cam.min_bytes) return SourceStatus::kFormatRefused;
  return SourceStatus::kOk;
}

SourceStatus V4l2Source::MapBuffers(int k) {
  Camera& cam = cams_[static_cast<unsigned>(k)];
  const V4l2CameraConfig& cfg = config_.cameras[static_cast<unsigned>(k)];
  v4l2_requestbuffers req;
  std::memset(&req, 0, sizeof(req));
  req.count = static_cast<std::uint32_t>(cfg.num_buffers);
  req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  req.memory = V4L2_MEMORY_MMAP;
  if (Xioctl(k, VIDIOC_REQBUFS, &req) < 0) return SourceStatus::kNoBuffers;
  // Fewer than the minimum starves the driver at frame rate; more than the maximum would not
  // fit the fixed tables (closing the device frees what the driver allocated).
  if (req.count < static_cast<std::uint32_t>(limits::kMinCaptureBuffers) ||
      req.count > static_cast<std::uint32_t>(limits::kMaxCaptureBuffers)) {
    return SourceStatus::kNoBuffers;
  }
  for (unsigned i = 0; i < req.count; ++i) {
    v4l2_buffer b = MmapBuffer(i);
    if (Xioctl(k, VIDIOC_QUERYBUF, &b) < 0 || b.length < cam.min_bytes) {
      return SourceStatus::kNoBuffers;
    }
    void* mem = io_->Mmap(b.length, PROT_READ | PROT_WRITE, MAP_SHARED, cam.fd,
                          static_cast<off_t>(b.m.offset));
    if (mem == MAP_FAILED) return SourceStatus::kNoBuffers;
    cam.mem[i] = mem;
    cam.length[i] = b.length;
    cam.num_mapped = static_cast<int>(i) + 1;
  }
  return SourceStatus::kOk;
}

void V4l2Source::StopCamera(int k) {
  Camera& cam = cams_[static_cast<unsigned>(k)];
  if (cam.streaming) {
    int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (Xioctl(k, VIDIOC_STREAMOFF, &type) < 0) ++mutable_counters(k).driver_errors;
    cam.streaming = false;
  }
  for (int i = 0; i < cam.num_mapped; ++i) {
    io_->Munmap(cam.mem[static_cast<unsigned>(i)], cam.length[static_cast<unsigned>(i)]);
    cam.mem[static_cast<unsigned>(i)] = nullptr;
    cam.length[static_cast<unsigned>(i)] = 0;
  }
  cam.num_mapped = 0;
  if (cam.fd >= 0) {
    io_->Close(cam.fd);  // also frees the driver's buffers
    cam.fd = -1;
  }
  cam.held = -1;
}

void V4l2Source::Stop() {
  if (io_ != nullptr) {
    for (int k = 0; k < num_cameras(); ++k) {
      StopCamera(k);
      cams_[static_cast<unsigned>(k)].status = SourceStatus::kNotStarted;
    }
  }
  started_ = false;
}

SourceStatus V4l2Source::Reset(int camera) {
  if (!started_) return SourceStatus::kNotStarted;
  if (!ValidCamera(camera)) return SourceStatus::kBadCamera;
  StopCamera(camera);
  return StartCamera(camera);
}

SourceStatus V4l2Source::camera_status(int camera) const {
  return ValidCamera(camera) ? cams_[static_cast<unsigned>(camera)].status
                             : SourceStatus::kBadCamera;
}

int V4l2Source::num_buffers(int camera) const {
  return ValidCamera(camera) ? cams_[static_cast<unsigned>(camera)].num_mapped : 0;
}

SourceStatus V4l2Source::Wait(int k, int timeout_ms) {
  SourceCounters& c = mutable_counters(k);
  pollfd p{};
  p.fd = cams_[static_cast<unsigned>(k)].fd;
  p.events = POLLIN;
  int r = -1;
  for (int attempt = 0; attempt <= limits::kMaxEintrRetries; ++attempt) {
    p.revents = 0;
    r = io_->Poll(&p, 1, timeout_ms);
    if (r >= 0 || errno != EINTR) break;
    if (attempt < limits::kMaxEintrRetries) ++c.eintr_retries;
  }
  if (r == 0) {
    ++c.timeouts;
    return SourceStatus::kTimeout;
  }
  // POLLERR without POLLIN: not streaming or no buffer queued (V4L2), or the device went away.
  if (r < 0 || (p.revents & POLLIN) == 0) {
    ++c.driver_errors;
    return SourceStatus::kError;
  }
  return SourceStatus::kOk;
}

void V4l2Source::Requeue(int k, unsigned index) {
  v4l2_buffer b = MmapBuffer(index);
  if (Xioctl(k, VIDIOC_QBUF, &b) < 0) ++mutable_counters(k).driver_errors;
}

SourceStatus V4l2Source::Acquire(int camera, int timeout_ms, FrameView* out) {
  if (!started_) return SourceStatus::kNotStarted;
  if (!ValidCamera(camera)) return SourceStatus::kBadCamera;
  Camera& cam = cams_[static_cast<unsigned>(camera)];
  if (!cam.streaming) return SourceStatus::kNotStarted;
  if (cam.held >= 0) return SourceStatus::kBusy;
  SourceCounters& c = mutable_counters(camera);

  const SourceStatus waited = Wait(camera, timeout_ms);
  if (waited != SourceStatus::kOk) return waited;

  v4l2_buffer b = MmapBuffer(0);
  if (Xioctl(camera, VIDIOC_DQBUF, &b) < 0) {
    if (errno == EAGAIN) {  // poll said ready, yet nothing was done: nothing this time
      ++c.timeouts;
      return SourceStatus::kTimeout;
    }
    ++c.driver_errors;  // EIO and friends: the driver failed; it may have lost a buffer
    return SourceStatus::kError;
  }
  if (b.index >= static_cast<std::uint32_t>(cam.num_mapped)) {
    ++c.driver_errors;  // cannot be: a buffer we never mapped
    return SourceStatus::kError;
  }
  // Error-flagged frames still consumed a sequence number: observe first so a flagged frame is
  // counted once (error_buffers), not again as a gap.
  cam.sequence.Observe(b.sequence, &c);
  if ((b.flags & V4L2_BUF_FLAG_ERROR) != 0) {
    ++c.error_buffers;
    Requeue(camera, b.index);
    return SourceStatus::kDropped;
  }
  if ((b.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) != V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC) {
    ++c.unknown_clock;
    Requeue(camera, b.index);
    return SourceStatus::kDropped;
  }
  if (b.bytesused < cam.min_bytes) {
    ++c.short_buffers;
    Requeue(camera, b.index);
    return SourceStatus::kDropped;
  }

  const V4l2CameraConfig& cfg = config_.cameras[static_cast<unsigned>(camera)];
  out->data = static_cast<const std::uint8_t*>(cam.mem[b.index]);
  out->width = cfg.width;
  out->height = cfg.height;
  out->stride_bytes = cam.stride_bytes;
  out->format = cfg.format;
  out->t_capture_ns = static_cast<std::uint64_t>(b.timestamp.tv_sec) * 1000000000ULL +
                      static_cast<std::uint64_t>(b.timestamp.tv_usec) * 1000ULL;
  out->t_source = (b.flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE
                      ? TimestampSource::kStartOfExposure
                      : TimestampSource::kEndOfFrame;
  out->sequence = b.sequence;
  out->camera = camera;
  cam.held = static_cast<int>(b.index);
  ++c.frames;
  return SourceStatus::kOk;
}

void V4l2Source::Release(int camera) {
  if (!ValidCamera(camera)) return;
  Camera& cam = cams_[static_cast<unsigned>(camera)];
  if (cam.held < 0 || !cam.streaming) return;
  Requeue(camera, static_cast<unsigned>(cam.held));
  cam.held = -1;
}

}  // namespace mfns::fw
