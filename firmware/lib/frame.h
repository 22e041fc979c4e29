// A camera frame as the firmware sees it: a view on pixels owned by a frame source (a V4L2
// MMAP buffer, a replay buffer reserved at start, a test image). No ownership, no heap.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "common/limits.h"

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

// The blind cell (limits::kBlindCellsX x kBlindCellsY, row-major) of image point (u, v) px in a
// width x height image: the image [-0.5, width - 0.5] x [-0.5, height - 0.5] cut into equal
// parts (a pixel belongs to the cell of its centre), points beyond it in the nearest cell. The detector marks cells by pixel, the matcher
// looks predictions up by point: one function, so that both cut the image alike.
inline int BlindCellOf(double u_px, double v_px, int width, int height) {
  const auto index = [](double t, int size, int cells) {
    const double c = std::floor((t + 0.5) * cells / std::max(size, 1));
    return c >= cells - 1.0 ? cells - 1 : c >= 0.0 ? static_cast<int>(c) : 0;  // (NaN: cell 0)
  };
  return index(v_px, height, limits::kBlindCellsY) * limits::kBlindCellsX + index(u_px, width, limits::kBlindCellsX);
}

}  // namespace mfns::fw
