// A camera frame as the firmware sees it: a view on pixels owned by a frame source (a V4L2
// MMAP buffer, a replay buffer reserved at start, a test image). No ownership, no heap.
#pragma once

#include <cstddef>
#include <cstdint>

namespace mfns::fw {

enum class PixelFormat : std::uint8_t { kMono8 = 0, kMono16 = 1 };

inline constexpr int BytesPerPixel(PixelFormat f) { return f == PixelFormat::kMono16 ? 2 : 1; }

// Which instant of the exposure t_capture_ns marks (V4L2_BUF_FLAG_TSTAMP_SRC_*): the end of the
// frame (V4L2's default, after readout) or the start of exposure. Replayed and simulated frames
// carry the truth time of the frame set (kTruth).
enum class TimestampSource : std::uint8_t { kEndOfFrame = 0, kStartOfExposure = 1, kTruth = 2 };

struct FrameView {
  const std::uint8_t* data = nullptr;  // first byte of row 0; owned by the source
  int width = 0;                        // px
  int height = 0;                       // px
  int stride_bytes = 0;                 // bytes from one row to the next (>= width * bpp)
  PixelFormat format = PixelFormat::kMono8;
  std::uint64_t t_capture_ns = 0;  // sample time: CLOCK_MONOTONIC ns, from the driver
  std::uint32_t sequence = 0;       // driver frame counter (gaps are drops)
  TimestampSource t_source = TimestampSource::kEndOfFrame;  // what t_capture_ns marks
  int camera = -1;                  // index into the rig's cameras

  // Pixel value at (x, y); mono16 is native little-endian as V4L2 Y16 delivers it.
  std::uint16_t At(int x, int y) const {
    const std::uint8_t* row = data + static_cast<std::ptrdiff_t>(y) * stride_bytes;
    if (format == PixelFormat::kMono8) return row[x];
    return static_cast<std::uint16_t>(row[2 * x] | (row[2 * x + 1] << 8));
  }
};

}  // namespace mfns::fw
