// Test support: an in-memory V4L2 capture driver behind the V4l2Io seam, so the real capture
// code (v4l2_source.cc) runs and is tested on machines without cameras.
//
// It implements what V4l2Source uses: open/close, VIDIOC_QUERYCAP, S_FMT/G_FMT (GREY, Y16),
// REQBUFS/QUERYBUF (MMAP), mmap/munmap of buffers backed by memory this object owns,
// QBUF/DQBUF (FIFO, non-blocking), STREAMON/OFF and poll. It checks the caller's side of the
// protocol (queueing a queued buffer, DQBUF while not streaming, a wrong mmap offset/length,
// S_FMT with buffers allocated, ...) and counts each violation in protocol_errors, so a test
// can require zero. Each device is scripted before or during a test:
//   frames       the frames the sensor produces (sequence numbers with gaps, error flag, clock
//                flags, short bytesused); none left = the camera stops delivering (poll times out)
//   poll_script  outcomes of the next poll calls (timeout, EINTR, POLLERR, failure)
//   failures     an ioctl that fails with an errno a number of times (EINTR, EIO, ...)
//   adjust_*     the driver changes the negotiated size or format
//   grant_buffers, capabilities, stride_padding
// Not flight code: it allocates while scripted (never inside poll/DQBUF/QBUF).
#pragma once

#include <linux/videodev2.h>

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "firmware/drivers/v4l2/v4l2_io.h"

namespace mfns::fw {

// One frame the fake sensor produces.
struct FakeV4l2Frame {
  std::uint32_t sequence = 0;
  std::uint64_t t_ns = 0;  // CLOCK_MONOTONIC-like time; the driver reports it at 1 us resolution
  // Buffer flags: timestamp clock and source, plus V4L2_BUF_FLAG_ERROR to flag a bad frame.
  std::uint32_t flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  std::int64_t bytesused = -1;  // -1: the full negotiated image (sizeimage)
  std::uint8_t seed = 0;        // pixel pattern, see FakePixel
};

// The value the fake writes at pixel (x, y) of a frame with this seed (mono16: 16 bits used).
std::uint16_t FakePixel(std::uint8_t seed, int x, int y, bool mono16);

// Scripted outcome of one poll call.
enum class FakePoll : unsigned char {
  kTimeout,  // returns 0
  kEintr,    // returns -1, errno EINTR
  kPollErr,  // returns 1 with revents = POLLERR
  kFail,     // returns -1, errno ENOMEM
};

struct FakeIoctlFailure {
  unsigned long request = 0;  // NOLINT(runtime/int) e.g. VIDIOC_DQBUF
  int error = 0;              // errno, e.g. EIO, EINTR
  int count = 1;              // how many calls fail
};

class FakeV4l2Device {
 public:
  // Behaviour.
  std::string path;
  std::uint32_t capabilities =
      V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_DEVICE_CAPS;
  std::uint32_t device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
  std::uint32_t adjust_width = 0;        // nonzero: the driver picks this width instead
  std::uint32_t adjust_height = 0;       // nonzero: the driver picks this height instead
  std::uint32_t adjust_pixelformat = 0;  // nonzero: the driver picks this fourcc instead
  std::uint32_t stride_padding = 0;      // bytes per row beyond width * bytes per pixel
  int grant_buffers = -1;                // REQBUFS grants this many (-1: what was asked)
  std::deque<FakeV4l2Frame> frames;
  std::deque<FakePoll> poll_script;
  std::vector<FakeIoctlFailure> failures;

  // State, for tests to inspect.
  struct Buffer {
    std::vector<std::uint8_t> memory;  // what mmap hands out
    bool queued = false;
    bool mapped = false;
  };
  bool is_open = false;
  int open_flags = 0;
  bool streaming = false;
  v4l2_pix_format format{};
  std::vector<Buffer> buffers;
  std::vector<unsigned> queue;  // queued buffer indices, FIFO (capacity reserved: no heap)
  int opens = 0;
  int closes = 0;
  int qbufs = 0;
  int dqbufs = 0;
  int streamons = 0;
  int streamoffs = 0;
  int protocol_errors = 0;
  bool log_ioctls = true;                // off for no-allocation tests
  std::vector<unsigned long> ioctl_log;  // NOLINT(runtime/int) every request, in order

  int queued_count() const { return static_cast<int>(queue.size()); }
  int mapped_count() const;
};

class FakeV4l2Io final : public V4l2Io {
 public:
  // Adds a device node at `path`; the reference stays valid for the fake's life.
  FakeV4l2Device& AddDevice(const std::string& path);
  FakeV4l2Device* Find(const std::string& path);

  int Open(const char* path, int flags) override;
  int Close(int fd) override;
  int Ioctl(int fd, unsigned long request, void* arg) override;  // NOLINT(runtime/int)
  void* Mmap(std::size_t length, int prot, int flags, int fd, off_t offset) override;
  int Munmap(void* addr, std::size_t length) override;
  int Poll(pollfd* fds, nfds_t nfds, int timeout_ms) override;

  static constexpr int kFirstFd = 100;
  static constexpr std::uint32_t kOffsetStep = 0x100000;  // buffer i's mmap offset: i * step

 private:
  FakeV4l2Device* ByFd(int fd);
  int Fail(int error);
  int Violation(FakeV4l2Device* d, int error);
  int SetFormat(FakeV4l2Device* d, v4l2_format* f);
  int RequestBuffers(FakeV4l2Device* d, v4l2_requestbuffers* r);
  int QueryBuffer(FakeV4l2Device* d, v4l2_buffer* b);
  int QueueBuffer(FakeV4l2Device* d, v4l2_buffer* b);
  int DequeueBuffer(FakeV4l2Device* d, v4l2_buffer* b);

  std::vector<std::unique_ptr<FakeV4l2Device>> devices_;
};

}  // namespace mfns::fw
