// libFuzzer target for the parameter blob decoder (common/blob): whatever the bytes, decoding
// gives a typed status, never a crash, an out-of-bounds access (ASan) or undefined behaviour
// (UBSan); a blob that decodes kOk is a valid rig that re-encodes and decodes to itself.
//
// First input byte selects a mode so the fuzzer also gets past the CRCs: even = the rest is
// the blob as is; odd = the rest with its payload length and both CRCs repaired first (the
// way an attacker with a CRC calculator would write it).
//   CC=clang CXX=clang++ cmake --preset host -B build/fuzz -DMFNS_BUILD_FUZZERS=ON
//   cmake --build build/fuzz --target param_blob_fuzz && build/fuzz/bin/param_blob_fuzz -max_total_time=60
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "common/blob/param_blob.h"
#include "tests/fuzz/blob_repair.h"


extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static std::array<std::uint8_t, 2 * mfns::limits::kMaxBlobBytes> input;
  const std::size_t n = size - 1 < input.size() ? size - 1 : input.size();
  std::memcpy(input.data(), data + 1, n);
  const std::span<std::uint8_t> blob(input.data(), n);
  if ((data[0] & 1u) != 0) mfns::fuzz::RepairBlob(blob);

  mfns::Rig rig;
  mfns::BlobInfo info;
  const mfns::BlobStatus s = mfns::DecodeParamBlob(blob, nullptr, &rig, &info);
  if (mfns::ToString(s) == nullptr) __builtin_trap();
  if (s != mfns::BlobStatus::kOk) return 0;

  static std::array<std::uint8_t, mfns::limits::kMaxBlobBytes> again;
  std::size_t written = 0;
  if (mfns::EncodeParamBlob(rig, info.generation, again, &written) != mfns::BlobStatus::kOk) __builtin_trap();
  mfns::Rig rig2;
  if (mfns::DecodeParamBlob(std::span<const std::uint8_t>(again.data(), written), rig.rig_id.data(), &rig2,
                            nullptr) != mfns::BlobStatus::kOk)
    __builtin_trap();
  return 0;
}
