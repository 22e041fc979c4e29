// Fuzz support: makes a byte string pass the parameter blob's length and CRC checks (header
// offsets from common/blob/README.md), the way an attacker with a CRC calculator would write
// it, so that a fuzzer reaches the decoder's sections instead of stopping at the CRCs.
#pragma once

#include <cstdint>
#include <span>

#include "common/blob/param_blob.h"

namespace mfns::fuzz {

inline void PutLe(std::uint8_t* p, std::uint32_t v, int n) {
  for (int i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

inline void RepairBlob(std::span<std::uint8_t> b) {
  if (b.size() < kBlobHeaderBytes) return;
  const auto payload = b.subspan(kBlobHeaderBytes);
  PutLe(&b[14], static_cast<std::uint32_t>(payload.size() & 0xFFFF), 2);
  PutLe(&b[56], Crc32(payload), 4);
  PutLe(&b[60], Crc32(b.first(60)), 4);
}

}  // namespace mfns::fuzz
