// Parameter blob v1 (DESIGN.md, "Contracts"): the calibration as the flyer stores and loads it.
//
// Little-endian, versioned, fixed maximum size (limits::kMaxBlobBytes) so the firmware decodes
// it with no heap. The byte layout is specified in common/blob/README.md; in short:
//   header (64 bytes): magic "MFNSPRM1", u16 format version, u16 header size, u16 flags,
//     u16 payload length, rig id (32 bytes, NUL-padded), u64 generation, u32 payload CRC32,
//     u32 header CRC32 (the fields fill the 64 bytes exactly; README.md says why u16)
//   payload: sections, each {u16 type, u16 version, u32 length, bytes}: cameras (intrinsics and
//     image size), extrinsics (C_k_b, r_b_bk), beacons (map and its 1-sigma), sigma (optional),
//     beacon facing (optional: normal and beam half-angle per beacon; Rig::has_facing), beacon
//     sigmas (optional, version 2: one 1-sigma per beacon; Rig::has_beacon_sigmas).
// The decoder never trusts a length or a count: every failure is a typed BlobStatus.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "common/rig/rig.h"

namespace mfns {

// Version 2 adds the optional BEACON_SIGMAS section (per-beacon 1-sigma, Rig::has_beacon_sigmas);
// the encoder writes version 1 for a rig without them (older flyers keep loading those) and 2
// with them (an older decoder refuses it: kUnsupportedVersion, rather than drop the sigmas).
// The decoder reads both.
inline constexpr std::uint16_t kBlobFormatVersion = 2;
inline constexpr std::uint16_t kOldestBlobFormatVersion = 1;
inline constexpr std::size_t kBlobHeaderBytes = 64;

enum class BlobStatus : unsigned char {
  kOk = 0,
  kTruncated,           // fewer bytes than the header or than header + payload length
  kTrailingBytes,       // more bytes than header + payload length
  kBadMagic,
  kUnsupportedVersion,  // format version newer (or older) than this decoder understands
  kHeaderCrcMismatch,
  kBadHeader,           // header size, flags or rig id field malformed
  kTooLarge,            // header + payload length above limits::kMaxBlobBytes
  kPayloadCrcMismatch,
  kBadSection,          // a section length overruns the payload or disagrees with its contents
  kMissingSection,      // cameras, extrinsics or beacons absent
  kDuplicateSection,
  kTooManyCameras,      // count above limits::kMaxCameras
  kTooManyBeacons,      // count above limits::kMaxBeacons
  kCountMismatch,       // sections disagree on the number of cameras or of beacons
  kNonFiniteValue,      // NaN or Inf in any number
  kInvalidValue,        // decoded rig fails ValidateRig (e.g. C_k_b not a rotation)
  kRigIdMismatch,       // blob for another rig than the one expected
  kBufferTooSmall,      // encoder: output span smaller than the encoded blob
};
const char* ToString(BlobStatus s);

// Number of BlobStatus values, to size a counter per failure mode (array indexed by status).
inline constexpr int kNumBlobStatuses = static_cast<int>(BlobStatus::kBufferTooSmall) + 1;

// What the header says, available once the header is valid.
struct BlobInfo {
  std::uint16_t format_version = 0;
  std::uint64_t generation = 0;
  std::array<char, limits::kMaxRigIdChars + 1> rig_id{};
  std::uint32_t payload_bytes = 0;
  std::uint32_t payload_crc32 = 0;
};

// Encodes rig (validated with ValidateRig first: an invalid rig gives kInvalidValue, too many
// cameras/beacons their own status, a NaN/Inf kNonFiniteValue) into out. *written (optional)
// is the blob's size on kOk; nothing is written to out unless it is large enough.
BlobStatus EncodeParamBlob(const Rig& rig, std::uint64_t generation, std::span<std::uint8_t> out,
                           std::size_t* written);

// Decodes a whole blob. expected_rig_id: nullptr accepts any rig id; otherwise a different id
// gives kRigIdMismatch. *info is filled as soon as the header is valid (also on later errors);
// *rig only on kOk. rig and info may be nullptr (check only). No heap, no exceptions, bounded
// loops; in may be any bytes at all.
BlobStatus DecodeParamBlob(std::span<const std::uint8_t> in, const char* expected_rig_id, Rig* rig,
                           BlobInfo* info);

// Reads and checks only the header (magic, version, header CRC, header fields, payload length
// against limits::kMaxBlobBytes); in may hold just the header. *info (optional) as above.
BlobStatus DecodeBlobHeader(std::span<const std::uint8_t> in, BlobInfo* info);

// CRC-32/ISO-HDLC (zlib's crc32, polynomial 0xEDB88320 reflected), of data continuing crc.
std::uint32_t Crc32(std::span<const std::uint8_t> data, std::uint32_t crc = 0);

}  // namespace mfns
