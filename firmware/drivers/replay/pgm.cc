#include "firmware/drivers/replay/pgm.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>

#include "common/limits.h"

namespace mfns::fw {
namespace {

bool IsSpace(std::uint8_t c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

// Skips whitespace and comments from *i. kOk, or kTruncated when the bytes run out.
PgmStatus SkipSeparators(const std::uint8_t* b, std::size_t n, std::size_t* i) {
  while (*i < n) {
    if (IsSpace(b[*i])) {
      ++*i;
    } else if (b[*i] == '#') {
      while (*i < n && b[*i] != '\n' && b[*i] != '\r') ++*i;
    } else {
      return PgmStatus::kOk;
    }
  }
  return PgmStatus::kTruncated;
}

// Reads a decimal token at *i; values above `cap` saturate at cap + 1 (no overflow, still
// rejected by the caller's bound). The token must be followed by a separator.
PgmStatus ReadNumber(const std::uint8_t* b, std::size_t n, std::size_t* i, int cap, int* value) {
  PgmStatus s = SkipSeparators(b, n, i);
  if (s != PgmStatus::kOk) return s;
  if (b[*i] < '0' || b[*i] > '9') return PgmStatus::kBadHeader;
  long long v = 0;  // NOLINT(runtime/int)
  while (*i < n && b[*i] >= '0' && b[*i] <= '9') {
    v = v * 10 + (b[*i] - '0');
    if (v > cap) v = static_cast<long long>(cap) + 1;  // NOLINT(runtime/int)
    ++*i;
  }
  if (*i == n) return PgmStatus::kTruncated;
  if (!IsSpace(b[*i]) && b[*i] != '#') return PgmStatus::kBadHeader;
  *value = static_cast<int>(v);
  return PgmStatus::kOk;
}

// pread of exactly n bytes at offset; bounded retries on EINTR and short reads.
PgmStatus ReadExact(int fd, std::uint8_t* buf, std::size_t n, off_t offset) {
  std::size_t done = 0;
  int interrupts = 0;
  // Each pass moves forward by at least one byte or counts an interrupt, and a regular file
  // returns all it can in one call, so few passes are needed; the bound only guards a
  // misbehaving filesystem.
  for (int pass = 0; pass < 1024 && done < n; ++pass) {
    const ssize_t r = ::pread(fd, buf + done, n - done, offset + static_cast<off_t>(done));
    if (r < 0) {
      if (errno == EINTR && ++interrupts <= limits::kMaxEintrRetries) continue;
      return PgmStatus::kReadFailed;
    }
    if (r == 0) return PgmStatus::kTruncated;  // the file shrank under us
    done += static_cast<std::size_t>(r);
  }
  return done == n ? PgmStatus::kOk : PgmStatus::kReadFailed;
}

// Owns a read-only descriptor; errno is left as open(2) set it.
class Fd {
 public:
  // O_NONBLOCK: a FIFO named like a frame must not hang the open (fstat then refuses it).
  explicit Fd(const char* path) : fd_(::open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC)) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

// Opens path, reads and parses its header, checks the file holds the raster.
PgmStatus OpenAndParse(const Fd& fd, PgmHeader* header) {
  if (fd.get() < 0) return errno == ENOENT ? PgmStatus::kNotFound : PgmStatus::kReadFailed;
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0) return PgmStatus::kReadFailed;
  if (!S_ISREG(st.st_mode)) return PgmStatus::kNotRegular;
  const std::size_t file_bytes = static_cast<std::size_t>(st.st_size);
  std::array<std::uint8_t, limits::kMaxPgmHeaderBytes> head{};
  const std::size_t n = file_bytes < head.size() ? file_bytes : head.size();
  PgmStatus s = ReadExact(fd.get(), head.data(), n, 0);
  if (s != PgmStatus::kOk) return s;
  s = ParsePgmHeader(head.data(), n, header);
  // Out of bytes within the first kMaxPgmHeaderBytes of a longer file: the header is too long.
  if (s == PgmStatus::kTruncated && n < file_bytes) return PgmStatus::kBadHeader;
  if (s != PgmStatus::kOk) return s;
  if (file_bytes - header->header_bytes < header->raster_bytes) return PgmStatus::kTruncated;
  return PgmStatus::kOk;
}

}  // namespace

const char* ToString(PgmStatus s) {
  switch (s) {
    case PgmStatus::kOk: return "ok";
    case PgmStatus::kNotFound: return "not found";
    case PgmStatus::kReadFailed: return "read failed";
    case PgmStatus::kBadMagic: return "not a binary PGM (P5)";
    case PgmStatus::kBadHeader: return "malformed header";
    case PgmStatus::kBadSize: return "width or height out of bounds";
    case PgmStatus::kBadMaxval: return "maxval not 255 or 65535";
    case PgmStatus::kTruncated: return "truncated";
    case PgmStatus::kTooLarge: return "image larger than the buffer";
    case PgmStatus::kNotRegular: return "not a regular file";
  }
  return "unknown";
}

PgmStatus ParsePgmHeader(const std::uint8_t* b, std::size_t n, PgmHeader* header) {
  if (n < 2) return PgmStatus::kTruncated;
  if (b[0] != 'P' || b[1] != '5') return PgmStatus::kBadMagic;
  std::size_t i = 2;
  if (i == n) return PgmStatus::kTruncated;
  if (!IsSpace(b[i]) && b[i] != '#') return PgmStatus::kBadMagic;  // e.g. "P55"
  int width = 0;
  int height = 0;
  int maxval = 0;
  PgmStatus s = ReadNumber(b, n, &i, limits::kMaxImageWidth, &width);
  if (s != PgmStatus::kOk) return s;
  s = ReadNumber(b, n, &i, limits::kMaxImageHeight, &height);
  if (s != PgmStatus::kOk) return s;
  // The maxval token: bad digits are a bad maxval, not a generic header error.
  s = ReadNumber(b, n, &i, 65535, &maxval);
  if (s == PgmStatus::kBadHeader) return PgmStatus::kBadMaxval;
  if (s != PgmStatus::kOk) return s;
  if (!IsSpace(b[i])) return PgmStatus::kBadHeader;  // a comment right after maxval
  ++i;  // the single whitespace byte before the raster
  if (width < 1 || width > limits::kMaxImageWidth || height < 1 ||
      height > limits::kMaxImageHeight) {
    return PgmStatus::kBadSize;
  }
  if (maxval != 255 && maxval != 65535) return PgmStatus::kBadMaxval;
  header->width = width;
  header->height = height;
  header->maxval = maxval;
  header->format = maxval == 255 ? PixelFormat::kMono8 : PixelFormat::kMono16;
  header->header_bytes = i;
  header->raster_bytes = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) *
                         static_cast<std::size_t>(BytesPerPixel(header->format));
  return PgmStatus::kOk;
}

PgmStatus ReadPgmHeader(const char* path, PgmHeader* header) {
  const Fd fd(path);
  return OpenAndParse(fd, header);
}

PgmStatus ReadPgm(const char* path, std::uint8_t* buf, std::size_t capacity, PgmHeader* header) {
  const Fd fd(path);
  PgmStatus s = OpenAndParse(fd, header);
  if (s != PgmStatus::kOk) return s;
  if (header->raster_bytes > capacity) return PgmStatus::kTooLarge;
  s = ReadExact(fd.get(), buf, header->raster_bytes, static_cast<off_t>(header->header_bytes));
  if (s != PgmStatus::kOk) return s;
  if (header->format == PixelFormat::kMono16) {
    // Big-endian on disk, little-endian in FrameView: swap every pair (on any host).
    for (std::size_t j = 0; j + 1 < header->raster_bytes; j += 2) {
      const std::uint8_t hi = buf[j];
      buf[j] = buf[j + 1];
      buf[j + 1] = hi;
    }
  }
  return PgmStatus::kOk;
}

}  // namespace mfns::fw
