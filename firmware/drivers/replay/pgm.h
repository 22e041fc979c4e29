// Binary PGM (P5) reading without heap and without trusting the header: the magic, width,
// height and maxval tokens may be separated by any whitespace and '#' comments (to end of
// line); exactly one whitespace byte ends the header. Accepted: 1 <= width <= kMaxImageWidth,
// 1 <= height <= kMaxImageHeight, maxval 255 (mono8) or 65535 (mono16, big-endian on disk per
// the PGM spec, converted to FrameView's little-endian). Other maxvals are valid PGM but not a
// camera format here: kBadMaxval. Bytes after the raster are ignored (netpbm allows more
// images in one file).
#pragma once

#include <cstddef>
#include <cstdint>

#include "firmware/lib/frame.h"

namespace mfns::fw {

enum class PgmStatus : unsigned char {
  kOk = 0,
  kNotFound,    // no such file
  kReadFailed,  // cannot open (other than missing), or read error
  kBadMagic,    // not "P5" (e.g. ASCII "P2", or not a PGM at all)
  kBadHeader,   // missing or malformed token, no whitespace after a token, header too long
  kBadSize,     // width or height outside [1, kMaxImageWidth/Height]
  kBadMaxval,   // maxval other than 255 or 65535
  kTruncated,   // the file ends before the header or the raster does
  kTooLarge,    // the raster does not fit the caller's buffer
  kNotRegular,  // a FIFO, device or directory: refused without blocking or reading
};
const char* ToString(PgmStatus s);

struct PgmHeader {
  int width = 0;   // px
  int height = 0;  // px
  int maxval = 0;
  PixelFormat format = PixelFormat::kMono8;
  std::size_t header_bytes = 0;   // offset of the raster in the file
  std::size_t raster_bytes = 0;   // width * height * bytes per pixel
};

// Parses the header at the start of bytes[0, n). kTruncated when the bytes end inside it.
PgmStatus ParsePgmHeader(const std::uint8_t* bytes, std::size_t n, PgmHeader* header);

// Reads only the header of the file at path (at most limits::kMaxPgmHeaderBytes) and checks
// that the file holds the whole raster.
PgmStatus ReadPgmHeader(const char* path, PgmHeader* header);

// Reads the file at path: header into *header, raster into buf[0, header->raster_bytes), rows
// packed (stride = width * bytes per pixel), mono16 little-endian. kTooLarge when the raster
// exceeds capacity. On failure *header and buf may hold partial data.
PgmStatus ReadPgm(const char* path, std::uint8_t* buf, std::size_t capacity, PgmHeader* header);

}  // namespace mfns::fw
