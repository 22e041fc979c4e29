#include "firmware/drivers/v4l2/fake_v4l2_io.h"

#include <fcntl.h>
#include <sys/mman.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace mfns::fw {

std::uint16_t FakePixel(std::uint8_t seed, int x, int y, bool mono16) {
  const unsigned v = static_cast<unsigned>(x) * 3U + static_cast<unsigned>(y) * 7U + seed;
  return mono16 ? static_cast<std::uint16_t>((v * 257U + 11U) & 0xFFFFU)
                : static_cast<std::uint16_t>(v & 0xFFU);
}

int FakeV4l2Device::mapped_count() const {
  return static_cast<int>(std::count_if(buffers.begin(), buffers.end(),
                                        [](const Buffer& b) { return b.mapped; }));
}

FakeV4l2Device& FakeV4l2Io::AddDevice(const std::string& path) {
  devices_.push_back(std::make_unique<FakeV4l2Device>());
  devices_.back()->path = path;
  return *devices_.back();
}

FakeV4l2Device* FakeV4l2Io::Find(const std::string& path) {
  for (auto& d : devices_) {
    if (d->path == path) return d.get();
  }
  return nullptr;
}

FakeV4l2Device* FakeV4l2Io::ByFd(int fd) {
  const int i = fd - kFirstFd;
  if (i < 0 || i >= static_cast<int>(devices_.size())) return nullptr;
  FakeV4l2Device* d = devices_[static_cast<std::size_t>(i)].get();
  return d->is_open ? d : nullptr;
}

int FakeV4l2Io::Fail(int error) {
  errno = error;
  return -1;
}

int FakeV4l2Io::Violation(FakeV4l2Device* d, int error) {
  ++d->protocol_errors;
  return Fail(error);
}

int FakeV4l2Io::Open(const char* path, int flags) {
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    FakeV4l2Device& d = *devices_[i];
    if (d.path != path) continue;
    if (d.is_open) return Fail(EBUSY);  // one user at a time, as capture drivers often allow
    d.is_open = true;
    d.open_flags = flags;
    ++d.opens;
    return kFirstFd + static_cast<int>(i);
  }
  return Fail(ENOENT);
}

int FakeV4l2Io::Close(int fd) {
  FakeV4l2Device* d = ByFd(fd);
  if (d == nullptr) return Fail(EBADF);
  // The last close stops streaming and frees the buffers (vb2_queue_release), unless a
  // mapping still holds them.
  d->is_open = false;
  d->streaming = false;
  d->queue.clear();
  for (auto& b : d->buffers) b.queued = false;
  if (d->mapped_count() == 0) d->buffers.clear();
  ++d->closes;
  return 0;
}

int FakeV4l2Io::SetFormat(FakeV4l2Device* d, v4l2_format* f) {
  if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return Violation(d, EINVAL);
  if (!d->buffers.empty()) return Violation(d, EBUSY);  // format is locked once buffers exist
  v4l2_pix_format& p = f->fmt.pix;
  if (d->adjust_width != 0) p.width = d->adjust_width;
  if (d->adjust_height != 0) p.height = d->adjust_height;
  if (d->adjust_pixelformat != 0) p.pixelformat = d->adjust_pixelformat;
  if (p.pixelformat != V4L2_PIX_FMT_GREY && p.pixelformat != V4L2_PIX_FMT_Y16) {
    p.pixelformat = V4L2_PIX_FMT_GREY;  // what drivers do: fall back to a supported format
  }
  const std::uint32_t bpp = p.pixelformat == V4L2_PIX_FMT_Y16 ? 2U : 1U;
  p.field = V4L2_FIELD_NONE;
  p.bytesperline = p.width * bpp + d->stride_padding;
  p.sizeimage = p.bytesperline * p.height;
  d->format = p;
  return 0;
}

int FakeV4l2Io::RequestBuffers(FakeV4l2Device* d, v4l2_requestbuffers* r) {
  if (r->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || r->memory != V4L2_MEMORY_MMAP) {
    return Violation(d, EINVAL);
  }
  if (d->streaming) return Violation(d, EBUSY);
  for (const auto& b : d->buffers) {
    if (b.mapped) return Violation(d, EBUSY);  // buffers still mapped cannot be freed
  }
  d->buffers.clear();
  d->queue.clear();
  if (r->count == 0) return 0;
  const std::uint32_t n = d->grant_buffers >= 0 ? static_cast<std::uint32_t>(d->grant_buffers)
                                                : r->count;
  d->buffers.resize(n);
  d->queue.reserve(n);
  for (auto& b : d->buffers) b.memory.assign(d->format.sizeimage, 0);
  r->count = n;
  return 0;
}

int FakeV4l2Io::QueryBuffer(FakeV4l2Device* d, v4l2_buffer* b) {
  if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || b->memory != V4L2_MEMORY_MMAP ||
      b->index >= d->buffers.size()) {
    return Violation(d, EINVAL);
  }
  b->length = static_cast<std::uint32_t>(d->buffers[b->index].memory.size());
  b->m.offset = b->index * kOffsetStep;
  b->flags = d->buffers[b->index].queued ? V4L2_BUF_FLAG_QUEUED : 0U;
  return 0;
}

int FakeV4l2Io::QueueBuffer(FakeV4l2Device* d, v4l2_buffer* b) {
  if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || b->memory != V4L2_MEMORY_MMAP ||
      b->index >= d->buffers.size() || d->buffers[b->index].queued) {
    return Violation(d, EINVAL);
  }
  d->buffers[b->index].queued = true;
  d->queue.push_back(b->index);
  ++d->qbufs;
  return 0;
}

int FakeV4l2Io::DequeueBuffer(FakeV4l2Device* d, v4l2_buffer* b) {
  if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || b->memory != V4L2_MEMORY_MMAP ||
      !d->streaming) {
    return Violation(d, EINVAL);
  }
  if (d->queue.empty() || d->frames.empty()) {
    // A blocking DQBUF here would hang the caller forever: the caller must open non-blocking.
    if ((d->open_flags & O_NONBLOCK) == 0) ++d->protocol_errors;
    return Fail(EAGAIN);
  }
  const FakeV4l2Frame f = d->frames.front();
  d->frames.pop_front();
  const unsigned index = d->queue.front();
  d->queue.erase(d->queue.begin());
  FakeV4l2Device::Buffer& buf = d->buffers[index];
  buf.queued = false;

  // Pixels, then a 0xEE marker in the row padding so a stride mistake shows up as bad data.
  const bool mono16 = d->format.pixelformat == V4L2_PIX_FMT_Y16;
  std::fill(buf.memory.begin(), buf.memory.end(), std::uint8_t{0xEE});
  for (std::uint32_t y = 0; y < d->format.height; ++y) {
    std::uint8_t* row = buf.memory.data() + static_cast<std::size_t>(y) * d->format.bytesperline;
    for (std::uint32_t x = 0; x < d->format.width; ++x) {
      const std::uint16_t v = FakePixel(f.seed, static_cast<int>(x), static_cast<int>(y), mono16);
      if (mono16) {
        row[2 * x] = static_cast<std::uint8_t>(v & 0xFF);  // Y16 is little-endian
        row[2 * x + 1] = static_cast<std::uint8_t>(v >> 8);
      } else {
        row[x] = static_cast<std::uint8_t>(v);
      }
    }
  }

  b->index = index;
  b->sequence = f.sequence;
  b->flags = f.flags;
  b->field = V4L2_FIELD_NONE;
  b->timestamp.tv_sec = static_cast<decltype(b->timestamp.tv_sec)>(f.t_ns / 1000000000ULL);
  b->timestamp.tv_usec =
      static_cast<decltype(b->timestamp.tv_usec)>((f.t_ns % 1000000000ULL) / 1000ULL);
  b->bytesused = f.bytesused < 0 ? d->format.sizeimage : static_cast<std::uint32_t>(f.bytesused);
  b->length = static_cast<std::uint32_t>(buf.memory.size());
  b->m.offset = index * kOffsetStep;
  ++d->dqbufs;
  return 0;
}

int FakeV4l2Io::Ioctl(int fd, unsigned long request, void* arg) {  // NOLINT(runtime/int)
  FakeV4l2Device* d = ByFd(fd);
  if (d == nullptr) return Fail(EBADF);
  if (d->log_ioctls) d->ioctl_log.push_back(request);
  for (auto& failure : d->failures) {
    if (failure.request == request && failure.count > 0) {
      --failure.count;
      return Fail(failure.error);
    }
  }
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* cap = static_cast<v4l2_capability*>(arg);
      std::memset(cap, 0, sizeof(*cap));
      std::strncpy(reinterpret_cast<char*>(cap->driver), "mfns-fake", sizeof(cap->driver) - 1);
      cap->capabilities = d->capabilities;
      cap->device_caps = d->device_caps;
      return 0;
    }
    case VIDIOC_S_FMT:
      return SetFormat(d, static_cast<v4l2_format*>(arg));
    case VIDIOC_G_FMT: {
      auto* f = static_cast<v4l2_format*>(arg);
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return Violation(d, EINVAL);
      f->fmt.pix = d->format;
      return 0;
    }
    case VIDIOC_REQBUFS:
      return RequestBuffers(d, static_cast<v4l2_requestbuffers*>(arg));
    case VIDIOC_QUERYBUF:
      return QueryBuffer(d, static_cast<v4l2_buffer*>(arg));
    case VIDIOC_QBUF:
      return QueueBuffer(d, static_cast<v4l2_buffer*>(arg));
    case VIDIOC_DQBUF:
      return DequeueBuffer(d, static_cast<v4l2_buffer*>(arg));
    case VIDIOC_STREAMON:
    case VIDIOC_STREAMOFF: {
      if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_CAPTURE) return Violation(d, EINVAL);
      if (request == VIDIOC_STREAMON) {
        if (d->buffers.empty()) return Violation(d, EINVAL);
        d->streaming = true;
        ++d->streamons;
      } else {
        // STREAMOFF returns every buffer to user space (dequeued, not queued).
        d->streaming = false;
        d->queue.clear();
        for (auto& b : d->buffers) b.queued = false;
        ++d->streamoffs;
      }
      return 0;
    }
    default:
      return Fail(ENOTTY);
  }
}

void* FakeV4l2Io::Mmap(std::size_t length, int prot, int flags, int fd, off_t offset) {
  FakeV4l2Device* d = ByFd(fd);
  if (d == nullptr) {
    errno = EBADF;
    return MAP_FAILED;
  }
  const std::size_t index = static_cast<std::size_t>(offset) / kOffsetStep;
  if (offset < 0 || static_cast<std::size_t>(offset) % kOffsetStep != 0 ||
      index >= d->buffers.size() || length != d->buffers[index].memory.size() ||
      (prot & PROT_READ) == 0 || (flags & MAP_SHARED) == 0 || d->buffers[index].mapped) {
    ++d->protocol_errors;
    errno = EINVAL;
    return MAP_FAILED;
  }
  d->buffers[index].mapped = true;
  return d->buffers[index].memory.data();
}

int FakeV4l2Io::Munmap(void* addr, std::size_t length) {
  for (auto& d : devices_) {
    for (auto& b : d->buffers) {
      if (b.mapped && b.memory.data() == addr) {
        if (length != b.memory.size()) return Violation(d.get(), EINVAL);
        b.mapped = false;
        return 0;
      }
    }
  }
  return Fail(EINVAL);
}

int FakeV4l2Io::Poll(pollfd* fds, nfds_t nfds, int /*timeout_ms*/) {
  if (nfds != 1) return Fail(EINVAL);
  fds[0].revents = 0;
  FakeV4l2Device* d = ByFd(fds[0].fd);
  if (d == nullptr) {
    fds[0].revents = POLLNVAL;
    return 1;
  }
  if (!d->poll_script.empty()) {
    const FakePoll p = d->poll_script.front();
    d->poll_script.pop_front();
    switch (p) {
      case FakePoll::kTimeout: return 0;
      case FakePoll::kEintr: return Fail(EINTR);
      case FakePoll::kPollErr: fds[0].revents = POLLERR; return 1;
      case FakePoll::kFail: return Fail(ENOMEM);
    }
  }
  // vb2's rule: not streaming, or no buffer owned by the driver -> POLLERR.
  if (!d->streaming || d->queue.empty()) {
    fds[0].revents = POLLERR;
    return 1;
  }
  if (d->frames.empty()) return 0;  // the sensor delivers nothing: the wait times out
  fds[0].revents = static_cast<short>(fds[0].events & (POLLIN | POLLRDNORM));
  return 1;
}

}  // namespace mfns::fw
