// Test and benchmark helpers for the blob detector (not flight code: allocates freely).
//
// Spots are rendered by exact area integration of a 2-D Gaussian over each pixel (erf of the
// pixel edges), so the true centroid of a spot's signal is its centre (pixel centres at
// integer coordinates, DESIGN.md).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

#include "firmware/lib/frame.h"

namespace mfns::fw::testing {

// An axis-aligned Gaussian spot; flux is its integral over the plane (DN px).
struct Spot {
  double u = 0.0;  // px
  double v = 0.0;  // px
  double sigma_x = 1.5;
  double sigma_y = 1.5;
  double flux = 1000.0;
  double Peak() const { return flux / (2.0 * std::numbers::pi * sigma_x * sigma_y); }
};

// Fraction of a unit Gaussian centred at c (sigma s) over the pixel [i - 0.5, i + 0.5].
inline double PixelFraction(int i, double c, double s) {
  const double k = 1.0 / (std::sqrt(2.0) * s);
  return 0.5 * (std::erf((i + 0.5 - c) * k) - std::erf((i - 0.5 - c) * k));
}

// A real-valued image before quantisation.
struct SyntheticImage {
  int width = 0;
  int height = 0;
  std::vector<double> value;

  SyntheticImage(int w, int h)
      : width(w), height(h), value(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0.0) {}

  double& At(int x, int y) { return value[Index(x, y)]; }
  double At(int x, int y) const { return value[Index(x, y)]; }
  std::size_t Index(int x, int y) const {
    return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x);
  }

  // level + gx (x - x_c) + gy (y - y_c) with (x_c, y_c) the image centre.
  void AddBackground(double level, double gx = 0.0, double gy = 0.0) {
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x)
        At(x, y) += level + gx * (x - 0.5 * (width - 1)) + gy * (y - 0.5 * (height - 1));
  }

  void AddSpot(const Spot& s) {
    const int rx = static_cast<int>(std::ceil(8.0 * s.sigma_x)) + 1;
    const int ry = static_cast<int>(std::ceil(8.0 * s.sigma_y)) + 1;
    const int x0 = std::max(0, static_cast<int>(s.u) - rx), x1 = std::min(width - 1, static_cast<int>(s.u) + rx);
    const int y0 = std::max(0, static_cast<int>(s.v) - ry), y1 = std::min(height - 1, static_cast<int>(s.v) + ry);
    for (int y = y0; y <= y1; ++y) {
      const double fy = PixelFraction(y, s.v, s.sigma_y);
      for (int x = x0; x <= x1; ++x) At(x, y) += s.flux * fy * PixelFraction(x, s.u, s.sigma_x);
    }
  }

  // A flat rectangle [x0, x1] x [y0, y1] (inclusive) raised by `level`.
  void AddRect(int x0, int y0, int x1, int y1, double level) {
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) At(x, y) += level;
  }

  void AddNoise(double sigma, std::mt19937_64& rng) {
    std::normal_distribution<double> n(0.0, sigma);
    for (double& v : value) v += n(rng);
  }
};

// Pixels in a buffer with padding after each row and an optional offset of the first byte
// (to exercise unaligned mono16 rows).
struct FrameBuffer {
  std::vector<std::uint8_t> bytes;
  FrameView view;
};

inline FrameBuffer Quantize(const SyntheticImage& img, PixelFormat format, int pad_bytes = 0,
                            int offset_bytes = 0) {
  FrameBuffer fb;
  const int bpp = BytesPerPixel(format);
  const int stride = img.width * bpp + pad_bytes;
  fb.bytes.assign(
      static_cast<std::size_t>(stride) * static_cast<std::size_t>(img.height) + static_cast<std::size_t>(offset_bytes),
      0xA5);
  const double full = format == PixelFormat::kMono8 ? 255.0 : 65535.0;
  for (int y = 0; y < img.height; ++y) {
    std::uint8_t* row = fb.bytes.data() + offset_bytes + static_cast<std::ptrdiff_t>(y) * stride;
    for (int x = 0; x < img.width; ++x) {
      const double q = std::clamp(std::round(img.At(x, y)), 0.0, full);
      if (format == PixelFormat::kMono8) {
        row[x] = static_cast<std::uint8_t>(q);
      } else {
        const auto v = static_cast<std::uint16_t>(q);
        std::memcpy(row + 2 * x, &v, 2);  // native little-endian, as V4L2 Y16
      }
    }
  }
  fb.view.data = fb.bytes.data() + offset_bytes;
  fb.view.width = img.width;
  fb.view.height = img.height;
  fb.view.stride_bytes = stride;
  fb.view.format = format;
  return fb;
}

}  // namespace mfns::fw::testing
