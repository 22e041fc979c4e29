#include "host/core/image.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

namespace mfns::host {
namespace {

constexpr long kMaxDimension = 65535;
constexpr long kMaxPixels = 1L << 28;

bool IsPgmSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

// A cursor over the header that skips whitespace and '#' comments between fields.
class HeaderReader {
 public:
  explicit HeaderReader(const std::string& bytes) : bytes_(bytes) {}

  // Reads a decimal field of at most 9 digits; throws PgmError naming `what` otherwise.
  long ReadNumber(const char* what) {
    SkipSpaceAndComments();
    long value = 0;
    std::size_t digits = 0;
    while (pos_ < bytes_.size() && bytes_[pos_] >= '0' && bytes_[pos_] <= '9') {
      if (++digits > 9) throw PgmError(std::string("PGM: ") + what + " has too many digits");
      value = value * 10 + (bytes_[pos_] - '0');
      ++pos_;
    }
    if (digits == 0) throw PgmError(std::string("PGM: missing or non-numeric ") + what);
    return value;
  }

  // After maxval the spec requires exactly one whitespace character, then the raster.
  void ReadSingleSpace() {
    if (pos_ >= bytes_.size() || !IsPgmSpace(bytes_[pos_]))
      throw PgmError("PGM: no whitespace after maxval");
    ++pos_;
  }

  std::size_t pos() const { return pos_; }

 private:
  void SkipSpaceAndComments() {
    while (pos_ < bytes_.size()) {
      if (IsPgmSpace(bytes_[pos_])) {
        ++pos_;
      } else if (bytes_[pos_] == '#') {
        while (pos_ < bytes_.size() && bytes_[pos_] != '\n' && bytes_[pos_] != '\r') ++pos_;
      } else {
        break;
      }
    }
  }

  const std::string& bytes_;
  std::size_t pos_ = 2;  // after the magic
};

// A temporary name beside `path` that no other writer in this process or another uses.
std::string TempNameFor(const std::string& path) {
  static std::atomic<unsigned> counter{0};
  return path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

}  // namespace

bool IsMonoImage(const cv::Mat& image) {
  return !image.empty() && image.dims == 2 && (image.type() == CV_8UC1 || image.type() == CV_16UC1);
}

std::string EncodePgm(const cv::Mat& image) {
  if (!IsMonoImage(image)) throw PgmError("PGM: image must be a non-empty CV_8UC1 or CV_16UC1");
  const bool wide = image.type() == CV_16UC1;
  std::string out = "P5\n" + std::to_string(image.cols) + " " + std::to_string(image.rows) + "\n" +
                    (wide ? "65535" : "255") + "\n";
  const std::size_t header = out.size();
  const std::size_t row_bytes = static_cast<std::size_t>(image.cols) * (wide ? 2 : 1);
  out.resize(header + row_bytes * static_cast<std::size_t>(image.rows));
  char* dst = out.data() + header;
  for (int v = 0; v < image.rows; ++v) {
    if (wide) {
      const std::uint16_t* row = image.ptr<std::uint16_t>(v);
      for (int u = 0; u < image.cols; ++u) {
        *dst++ = static_cast<char>(row[u] >> 8);  // big-endian, per the PGM spec
        *dst++ = static_cast<char>(row[u] & 0xFF);
      }
    } else {
      const unsigned char* row = image.ptr<unsigned char>(v);
      std::copy(row, row + image.cols, dst);
      dst += image.cols;
    }
  }
  return out;
}

void WritePgm(const std::string& path, const cv::Mat& image) {
  const std::string bytes = EncodePgm(image);
  const std::string temp = TempNameFor(path);
  std::FILE* f = std::fopen(temp.c_str(), "wb");
  if (f == nullptr) throw PgmError("PGM: cannot create " + temp);
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  const bool closed = std::fclose(f) == 0;
  std::error_code ec;
  if (!written || !closed) {
    std::filesystem::remove(temp, ec);
    throw PgmError("PGM: cannot write " + temp);
  }
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw PgmError("PGM: cannot rename " + temp + " to " + path + ": " + ec.message());
  }
}

cv::Mat DecodePgm(const std::string& bytes) {
  if (bytes.size() < 2 || bytes[0] != 'P' || bytes[1] != '5')
    throw PgmError("PGM: not a binary PGM (magic P5 expected)");
  HeaderReader header(bytes);
  const long width = header.ReadNumber("width");
  const long height = header.ReadNumber("height");
  const long maxval = header.ReadNumber("maxval");
  if (width < 1 || width > kMaxDimension || height < 1 || height > kMaxDimension ||
      width * height > kMaxPixels)
    throw PgmError("PGM: unsupported size " + std::to_string(width) + "x" + std::to_string(height));
  if (maxval < 1 || maxval > 65535) throw PgmError("PGM: maxval must be 1..65535");
  header.ReadSingleSpace();

  const bool wide = maxval > 255;
  const std::size_t sample_bytes = wide ? 2 : 1;
  const std::size_t raster = static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * sample_bytes;
  const std::size_t available = bytes.size() - header.pos();
  if (available < raster) throw PgmError("PGM: truncated raster");
  if (available > raster) throw PgmError("PGM: trailing bytes after the raster");

  cv::Mat image(static_cast<int>(height), static_cast<int>(width), wide ? CV_16UC1 : CV_8UC1);
  // OpenCV's vectorized copies instead of a loop over samples (a calibration decodes ~1.3 Mpx
  // per image; the per-sample loop cost ~16 instructions a pixel): the raster viewed in place
  // (read only), 16-bit samples byte-swapped from big-endian by swapping the two channels of
  // an 8-bit 2-channel view of the image, and maxval checked only when below the type's maximum.
  static_assert(std::endian::native == std::endian::little);
  auto* src = reinterpret_cast<unsigned char*>(const_cast<char*>(bytes.data() + header.pos()));
  const cv::Mat samples(image.rows, image.cols, wide ? CV_8UC2 : CV_8UC1, src);
  if (wide) {
    cv::Mat swapped(image.rows, image.cols, CV_8UC2, image.data);
    const int from_to[] = {0, 1, 1, 0};
    cv::mixChannels(&samples, 1, &swapped, 1, from_to, 2);
  } else {
    samples.copyTo(image);
  }
  if (maxval < (wide ? 65535 : 255)) {
    double hi = 0.0;
    cv::minMaxLoc(image, nullptr, &hi);
    if (hi > static_cast<double>(maxval)) throw PgmError("PGM: sample above maxval");
  }
  return image;
}

cv::Mat ReadPgm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw PgmError("PGM: cannot open " + path);
  // One read into a buffer of the file's size (a stream copy and its str() cost two more
  // copies of every image); a file whose size cannot be told (a pipe) is read as a stream.
  std::string bytes;
  std::error_code ec;
  const bool regular = std::filesystem::is_regular_file(path, ec);
  const std::streamoff size = regular ? static_cast<std::streamoff>(in.seekg(0, std::ios::end).tellg()) : -1;
  // The largest valid file: 16-bit samples at kMaxPixels and a header of comments.
  if (size > static_cast<std::streamoff>(2 * kMaxPixels + (1L << 20)))
    throw PgmError("PGM: file too large (" + path + ")");
  if (size >= 0 && in) {
    in.seekg(0, std::ios::beg);
    bytes.resize(static_cast<std::size_t>(size));
    in.read(bytes.data(), size);
    if (in.gcount() != size) throw PgmError("PGM: cannot read " + path);
  } else {
    in.clear();
    std::ostringstream buffer;
    buffer << in.rdbuf();
    if (in.bad()) throw PgmError("PGM: cannot read " + path);
    bytes = buffer.str();
  }
  try {
    return DecodePgm(bytes);
  } catch (const PgmError& e) {
    throw PgmError(std::string(e.what()) + " (" + path + ")");
  }
}

}  // namespace mfns::host
