// A set of beacon indices [0, limits::kMaxBeacons): fixed-size bit set, no heap, no exceptions.
//
// Beacon masks were one 64-bit word while the map held at most 64 beacons; this type keeps
// their operations (|=, &, ~, popcount, iterate) for any kMaxBeacons. Indices outside the range
// are ignored by Set and read as absent by Has (callers check indices where they come from
// outside; this is a container, not a validator).
#pragma once

#include <array>
#include <bit>
#include <cstdint>

#include "common/limits.h"

namespace mfns {

class BeaconSet {
 public:
  static constexpr int kWords = (limits::kMaxBeacons + 63) / 64;

  constexpr BeaconSet() = default;

  // The set {0, ..., n - 1} (n clamped to [0, kMaxBeacons]).
  static constexpr BeaconSet FirstN(int n) {
    BeaconSet s;
    for (int w = 0; w < kWords; ++w) {
      const int lo = 64 * w;
      if (n >= lo + 64) s.w_[static_cast<std::size_t>(w)] = ~std::uint64_t{0};
      else if (n > lo) s.w_[static_cast<std::size_t>(w)] = (std::uint64_t{1} << (n - lo)) - 1;
    }
    return s;
  }

  constexpr void Set(int m) {
    if (m >= 0 && m < limits::kMaxBeacons)
      w_[static_cast<std::size_t>(m >> 6)] |= std::uint64_t{1} << (m & 63);
  }
  constexpr void Clear(int m) {
    if (m >= 0 && m < limits::kMaxBeacons)
      w_[static_cast<std::size_t>(m >> 6)] &= ~(std::uint64_t{1} << (m & 63));
  }
  constexpr bool Has(int m) const {
    return m >= 0 && m < limits::kMaxBeacons && (w_[static_cast<std::size_t>(m >> 6)] >> (m & 63) & 1U) != 0;
  }
  constexpr void Reset() { w_.fill(0); }
  constexpr bool Empty() const {
    for (std::uint64_t x : w_)
      if (x != 0) return false;
    return true;
  }
  constexpr int Count() const {
    int n = 0;
    for (std::uint64_t x : w_) n += std::popcount(x);
    return n;
  }
  // The smallest member >= from, or -1.
  constexpr int Next(int from) const {
    if (from < 0) from = 0;
    for (int w = from >> 6; w < kWords; ++w) {
      std::uint64_t x = w_[static_cast<std::size_t>(w)];
      if (w == from >> 6) x &= ~std::uint64_t{0} << (from & 63);
      if (x != 0) return 64 * w + std::countr_zero(x);
    }
    return -1;
  }
  constexpr int First() const { return Next(0); }

  constexpr BeaconSet& operator|=(const BeaconSet& o) {
    for (int w = 0; w < kWords; ++w) w_[static_cast<std::size_t>(w)] |= o.w_[static_cast<std::size_t>(w)];
    return *this;
  }
  constexpr BeaconSet& operator&=(const BeaconSet& o) {
    for (int w = 0; w < kWords; ++w) w_[static_cast<std::size_t>(w)] &= o.w_[static_cast<std::size_t>(w)];
    return *this;
  }
  // Members of this set not in o.
  constexpr BeaconSet Minus(const BeaconSet& o) const {
    BeaconSet r = *this;
    for (int w = 0; w < kWords; ++w) r.w_[static_cast<std::size_t>(w)] &= ~o.w_[static_cast<std::size_t>(w)];
    return r;
  }
  friend constexpr BeaconSet operator&(BeaconSet a, const BeaconSet& b) { return a &= b; }
  friend constexpr BeaconSet operator|(BeaconSet a, const BeaconSet& b) { return a |= b; }
  friend constexpr bool operator==(const BeaconSet& a, const BeaconSet& b) = default;

  // Visits members in increasing order: for (int m = s.First(); m >= 0; m = s.Next(m + 1)).
  constexpr std::uint64_t Word(int w) const { return w_[static_cast<std::size_t>(w)]; }

 private:
  std::array<std::uint64_t, kWords> w_{};
};

}  // namespace mfns
