// Little-endian byte access for wire formats (parameter blob, navigation messages): every
// multi-byte value is written and read one byte at a time, so the result does not depend on
// the CPU's byte order or alignment, and no struct is ever copied as raw memory. No heap.
#pragma once

#include <array>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

namespace mfns::wire {

// Value of n bytes at b[off, off + n); the caller has checked the bounds.
inline std::uint64_t LoadLe(std::span<const std::uint8_t> b, std::size_t off, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i)
    v |= static_cast<std::uint64_t>(b[off + static_cast<std::size_t>(i)]) << (8 * i);
  return v;
}

// Sequential writer into a span already checked to be large enough; a write past the end is
// dropped and remembered (can't happen: sizes are computed from the same constants).
class ByteWriter {
 public:
  explicit ByteWriter(std::span<std::uint8_t> out) : out_(out) {}

  void U8(std::uint8_t v) { Le(v, 1); }
  void U16(std::uint16_t v) { Le(v, 2); }
  void U32(std::uint32_t v) { Le(v, 4); }
  void U64(std::uint64_t v) { Le(v, 8); }
  void F32(float v) { Le(std::bit_cast<std::uint32_t>(v), 4); }
  void F64(double v) { Le(std::bit_cast<std::uint64_t>(v), 8); }
  void Bytes(std::span<const std::uint8_t> b) {
    for (const std::uint8_t x : b) Byte(x);
  }
  // A NUL-terminated string in a fixed field of n bytes: its characters, then zeros.
  template <std::size_t N>
  void Text(const std::array<char, N>& s) {
    bool ended = false;
    for (std::size_t i = 0; i < N; ++i) {
      ended = ended || s[i] == '\0' || i + 1 == N;
      Byte(ended ? 0 : static_cast<std::uint8_t>(s[i]));
    }
  }
  bool ok() const { return ok_; }

 private:
  void Le(std::uint64_t v, int n) {
    for (int i = 0; i < n; ++i) Byte(static_cast<std::uint8_t>(v >> (8 * i)));
  }
  void Byte(std::uint8_t b) {
    if (pos_ < out_.size()) {
      out_[pos_++] = b;
    } else {
      ok_ = false;
    }
  }
  std::span<std::uint8_t> out_;
  std::size_t pos_ = 0;
  bool ok_ = true;
};

// Sequential reader; a read past the end returns 0 and clears ok() (can't happen after the
// section lengths were checked, kept so that no input can make it read out of bounds).
// Remembers whether every f64 read was finite.
class ByteReader {
 public:
  explicit ByteReader(std::span<const std::uint8_t> in) : in_(in) {}

  std::uint8_t U8() { return static_cast<std::uint8_t>(Le(1)); }
  std::uint16_t U16() { return static_cast<std::uint16_t>(Le(2)); }
  std::uint32_t U32() { return static_cast<std::uint32_t>(Le(4)); }
  std::uint64_t U64() { return Le(8); }
  float F32() {
    const float v = std::bit_cast<float>(static_cast<std::uint32_t>(Le(4)));
    finite_ = finite_ && std::isfinite(v);
    return v;
  }
  double F64() {
    const double v = std::bit_cast<double>(Le(8));
    finite_ = finite_ && std::isfinite(v);
    return v;
  }
  // A fixed text field: true when it is NUL-terminated and zero after the first NUL (the only
  // encoding the encoder produces, so a decoded rig re-encodes to the same bytes).
  template <std::size_t N>
  bool Text(std::array<char, N>* s) {
    bool ended = false;
    bool canonical = true;
    for (std::size_t i = 0; i < N; ++i) {
      const auto c = static_cast<char>(Le(1));
      (*s)[i] = c;
      if (ended && c != '\0') canonical = false;
      ended = ended || c == '\0';
    }
    return canonical && ended;
  }
  bool ok() const { return ok_; }
  bool finite() const { return finite_; }

 private:
  std::uint64_t Le(int n) {
    const auto un = static_cast<std::size_t>(n);
    if (in_.size() - pos_ < un) {
      ok_ = false;
      pos_ = in_.size();
      return 0;
    }
    const std::uint64_t v = LoadLe(in_, pos_, n);
    pos_ += un;
    return v;
  }
  std::span<const std::uint8_t> in_;
  std::size_t pos_ = 0;
  bool ok_ = true;
  bool finite_ = true;
};

}  // namespace mfns::wire
