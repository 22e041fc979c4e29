// Parameter blob v1: encoder and heap-free decoder. The byte layout is in README.md; the
// constants below are its single source in code. Every multi-byte value is written and read
// one byte at a time (little-endian), so the result does not depend on the CPU's byte order
// or alignment rules, and no struct is ever copied as raw memory.
#include "common/blob/param_blob.h"

#include "common/wire/byte_io.h"

#include <algorithm>
#include <bit>
#include <climits>
#include <cmath>
#include <cstring>

namespace mfns {
namespace {

// ---- Layout (README.md, "Byte layout") ----
constexpr std::array<std::uint8_t, 8> kMagic = {'M', 'F', 'N', 'S', 'P', 'R', 'M', '1'};

// Header field offsets. The fields fill the 64 bytes exactly, no padding.
constexpr std::size_t kOffVersion = 8;        // u16
constexpr std::size_t kOffHeaderSize = 10;    // u16
constexpr std::size_t kOffFlags = 12;         // u16
constexpr std::size_t kOffPayloadBytes = 14;  // u16
constexpr std::size_t kOffRigId = 16;         // 32 bytes
constexpr std::size_t kRigIdBytes = limits::kMaxRigIdChars + 1;
constexpr std::size_t kOffGeneration = 48;    // u64
constexpr std::size_t kOffPayloadCrc = 56;    // u32
constexpr std::size_t kOffHeaderCrc = 60;     // u32, CRC of bytes [0, 60)
static_assert(kOffRigId + kRigIdBytes == kOffGeneration, "rig id field is 32 bytes");
static_assert(kOffHeaderCrc + 4 == kBlobHeaderBytes, "the header CRC is the header's last field");

constexpr std::uint16_t kFlagHasSigma = 1u << 0;
constexpr std::uint16_t kKnownFlags = kFlagHasSigma;

// Payload sections.
constexpr std::size_t kSectionHeaderBytes = 8;  // u16 type, u16 version, u32 body length
constexpr std::uint16_t kSectionVersion = 1;
enum SectionType : std::uint16_t {
  kCameras = 1, kExtrinsics = 2, kBeacons = 3, kSigma = 4, kFacing = 5, kBeaconSigmas = 6
};
constexpr std::size_t kNumSectionSlots = 7;  // indexed by SectionType

constexpr std::size_t kCountBytes = 4;        // u32 count at the start of every known body
constexpr std::size_t kNameBytes = limits::kMaxCameraNameChars + 1;
constexpr std::size_t kCameraRecordBytes = kNameBytes + 4 + 4 + 10 * 8;  // name, w, h, 5+5 f64
constexpr std::size_t kExtrinsicRecordBytes = 12 * 8;                   // C_k_b 9, r_b_bk 3
constexpr std::size_t kBeaconRecordBytes = 3 * 8;                        // x, y, z
constexpr std::size_t kBeaconFixedBytes = 8;                             // beacon_sigma
constexpr std::size_t kSigmaRecordBytes = 16 * 8;  // intrinsics 5, kc 5, euler 3, r_b_bk 3
constexpr std::size_t kFacingRecordBytes = 4 * 8;  // normal x, y, z, half-angle
constexpr std::size_t kBeaconSigmaRecordBytes = 8;  // 1-sigma (m)

constexpr std::size_t SectionBytes(std::size_t fixed, std::size_t count, std::size_t record) {
  return kSectionHeaderBytes + kCountBytes + fixed + count * record;
}

constexpr std::size_t PayloadBytes(std::size_t cameras, std::size_t beacons, bool sigma, bool facing,
                                   bool beacon_sigmas) {
  return SectionBytes(0, cameras, kCameraRecordBytes) +
         SectionBytes(0, cameras, kExtrinsicRecordBytes) +
         SectionBytes(kBeaconFixedBytes, beacons, kBeaconRecordBytes) +
         (sigma ? SectionBytes(0, cameras, kSigmaRecordBytes) : 0) +
         (facing ? SectionBytes(0, beacons, kFacingRecordBytes) : 0) +
         (beacon_sigmas ? SectionBytes(0, beacons, kBeaconSigmaRecordBytes) : 0);
}

constexpr std::size_t kLargestBlobBytes =
    kBlobHeaderBytes + PayloadBytes(limits::kMaxCameras, limits::kMaxBeacons, true, true, true);
static_assert(kLargestBlobBytes <= limits::kMaxBlobBytes,
              "the largest rig (kMaxCameras with sigma, kMaxBeacons with facing and sigmas) must fit kMaxBlobBytes");
static_assert(limits::kMaxBlobBytes - kBlobHeaderBytes <= 0xFFFF,
              "the payload length field is a u16: a larger kMaxBlobBytes needs another format version");
// The sizes README.md states: 1424 + 64 B bytes for 4 cameras with sigma and B beacons with
// facing and per-beacon sigmas, i.e. 17808 bytes at kMaxBeacons = 256.
static_assert(limits::kMaxCameras != 4 || kLargestBlobBytes == 1424 + 64 * std::size_t{limits::kMaxBeacons},
              "common/blob/README.md states the largest blob's size: update it");
static_assert(limits::kMaxCameras != 4 || limits::kMaxBeacons != 256 || kLargestBlobBytes == 17808,
              "common/blob/README.md states the largest blob's size: update it");

// Every section is at least a section header, so a payload holds at most this many: the
// section walk's loop bound.
constexpr std::size_t kMaxSections = limits::kMaxBlobBytes / kSectionHeaderBytes;

// ---- Little-endian byte access: common/wire/byte_io.h ----
using wire::ByteReader;
using wire::ByteWriter;
using wire::LoadLe;

// Same rule as ValidateRig's: non-empty printable ASCII without spaces, NUL-terminated within
// the field, and (so the encoding is canonical) all zeros after the NUL.
bool IsGoodRigIdField(std::span<const std::uint8_t> f) {
  std::size_t len = 0;
  while (len < f.size() && f[len] != 0) {
    if (f[len] < 0x21 || f[len] > 0x7e) return false;
    ++len;
  }
  if (len == 0 || len == f.size()) return false;
  return std::all_of(f.begin() + static_cast<std::ptrdiff_t>(len), f.end(),
                     [](std::uint8_t b) { return b == 0; });
}

// ---- Header ----

struct Header {
  BlobInfo info;
  std::uint16_t flags = 0;
  std::array<char, kRigIdBytes> rig_id{};
};

// The header checks in the documented order. *valid turns true once the header itself is
// sound (magic, version, CRC, fields), i.e. when *h may be reported to the caller.
BlobStatus ParseHeader(std::span<const std::uint8_t> in, Header* h, bool* valid) {
  *valid = false;
  if (in.size() < kBlobHeaderBytes) return BlobStatus::kTruncated;
  const std::span<const std::uint8_t> b = in.first(kBlobHeaderBytes);
  if (!std::equal(kMagic.begin(), kMagic.end(), b.begin())) return BlobStatus::kBadMagic;
  const auto version = static_cast<std::uint16_t>(LoadLe(b, kOffVersion, 2));
  if (version < kOldestBlobFormatVersion || version > kBlobFormatVersion) return BlobStatus::kUnsupportedVersion;
  if (Crc32(b.first(kOffHeaderCrc)) != LoadLe(b, kOffHeaderCrc, 4))
    return BlobStatus::kHeaderCrcMismatch;

  const auto header_size = LoadLe(b, kOffHeaderSize, 2);
  h->flags = static_cast<std::uint16_t>(LoadLe(b, kOffFlags, 2));
  const std::span<const std::uint8_t> rig_id = b.subspan(kOffRigId, kRigIdBytes);
  if (header_size != kBlobHeaderBytes || (h->flags & ~kKnownFlags) != 0 || !IsGoodRigIdField(rig_id))
    return BlobStatus::kBadHeader;

  for (std::size_t i = 0; i < kRigIdBytes; ++i) h->rig_id[i] = static_cast<char>(rig_id[i]);
  h->info.format_version = version;
  h->info.generation = LoadLe(b, kOffGeneration, 8);
  static_assert(sizeof(h->info.rig_id) == kRigIdBytes);
  h->info.rig_id = h->rig_id;
  h->info.payload_bytes = static_cast<std::uint32_t>(LoadLe(b, kOffPayloadBytes, 2));
  h->info.payload_crc32 = static_cast<std::uint32_t>(LoadLe(b, kOffPayloadCrc, 4));
  *valid = true;
  if (kBlobHeaderBytes + h->info.payload_bytes > limits::kMaxBlobBytes) return BlobStatus::kTooLarge;
  return BlobStatus::kOk;
}

// ---- Payload ----

struct Section {
  bool present = false;
  std::span<const std::uint8_t> body;
};
using SectionTable = std::array<Section, kNumSectionSlots>;

bool IsKnownSection(std::uint16_t type) { return type >= kCameras && type <= kBeaconSigmas; }

// Walks the section headers: every length must stay inside the payload; unknown types are
// skipped (forward compatibility); a known type appears at most once, in version 1.
BlobStatus FindSections(std::span<const std::uint8_t> payload, std::uint16_t blob_version, SectionTable* table) {
  std::size_t pos = 0;
  for (std::size_t i = 0; i < kMaxSections && pos < payload.size(); ++i) {
    if (payload.size() - pos < kSectionHeaderBytes) return BlobStatus::kBadSection;
    const auto type = static_cast<std::uint16_t>(LoadLe(payload, pos, 2));
    const auto version = static_cast<std::uint16_t>(LoadLe(payload, pos + 2, 2));
    const std::uint64_t length = LoadLe(payload, pos + 4, 4);
    pos += kSectionHeaderBytes;
    if (length > payload.size() - pos) return BlobStatus::kBadSection;
    const auto body = payload.subspan(pos, static_cast<std::size_t>(length));
    pos += static_cast<std::size_t>(length);
    // (BEACON_SIGMAS is a version-2 section: in a version-1 blob it is unknown, as it was to
    // version-1 decoders.)
    if (!IsKnownSection(type) || (type == kBeaconSigmas && blob_version < 2)) continue;
    Section& s = (*table)[type];
    if (s.present) return BlobStatus::kDuplicateSection;
    if (version != kSectionVersion) return BlobStatus::kBadSection;
    s = {true, body};
  }
  return pos == payload.size() ? BlobStatus::kOk : BlobStatus::kBadSection;
}

// Reads a section's count and checks it against its limit before anything else, then that
// the body length is exactly what that count implies.
BlobStatus CheckCount(std::span<const std::uint8_t> body, std::uint32_t max_count,
                      BlobStatus too_many, std::size_t fixed, std::size_t record,
                      std::uint32_t* count) {
  if (body.size() < kCountBytes) return BlobStatus::kBadSection;
  *count = static_cast<std::uint32_t>(LoadLe(body, 0, 4));
  if (*count > max_count) return too_many;
  if (body.size() != kCountBytes + fixed + *count * record) return BlobStatus::kBadSection;
  return BlobStatus::kOk;
}

struct Counts {
  std::uint32_t cameras = 0, extrinsics = 0, beacons = 0, sigma = 0, facing = 0, beacon_sigmas = 0;
};

BlobStatus CheckCounts(const SectionTable& t, bool has_sigma, bool has_facing, Counts* n) {
  constexpr auto kMaxCam = static_cast<std::uint32_t>(limits::kMaxCameras);
  constexpr auto kMaxBea = static_cast<std::uint32_t>(limits::kMaxBeacons);
  constexpr BlobStatus kCam = BlobStatus::kTooManyCameras;
  BlobStatus s = CheckCount(t[kCameras].body, kMaxCam, kCam, 0, kCameraRecordBytes, &n->cameras);
  if (s == BlobStatus::kOk)
    s = CheckCount(t[kExtrinsics].body, kMaxCam, kCam, 0, kExtrinsicRecordBytes, &n->extrinsics);
  if (s == BlobStatus::kOk)
    s = CheckCount(t[kBeacons].body, kMaxBea, BlobStatus::kTooManyBeacons, kBeaconFixedBytes,
                   kBeaconRecordBytes, &n->beacons);
  if (s == BlobStatus::kOk && has_sigma)
    s = CheckCount(t[kSigma].body, kMaxCam, kCam, 0, kSigmaRecordBytes, &n->sigma);
  if (s == BlobStatus::kOk && has_facing)
    s = CheckCount(t[kFacing].body, kMaxBea, BlobStatus::kTooManyBeacons, 0, kFacingRecordBytes,
                   &n->facing);
  const bool has_beacon_sigmas = t[kBeaconSigmas].present;
  if (s == BlobStatus::kOk && has_beacon_sigmas)
    s = CheckCount(t[kBeaconSigmas].body, kMaxBea, BlobStatus::kTooManyBeacons, 0, kBeaconSigmaRecordBytes,
                   &n->beacon_sigmas);
  if (s != BlobStatus::kOk) return s;
  if (n->extrinsics != n->cameras || (has_sigma && n->sigma != n->cameras) ||
      (has_facing && n->facing != n->beacons) || (has_beacon_sigmas && n->beacon_sigmas != n->beacons))
    return BlobStatus::kCountMismatch;
  return BlobStatus::kOk;
}

// Image sizes are u32 in the blob; anything above INT_MAX cannot pass ValidateRig anyway.
int ToInt(std::uint32_t v) { return v > INT_MAX ? INT_MAX : static_cast<int>(v); }

void ReadArray(ByteReader& r, std::array<double, 5>* a) {
  for (double& v : *a) v = r.F64();
}

void ReadVector(ByteReader& r, Eigen::Vector3d* v) {
  for (int i = 0; i < 3; ++i) (*v)(i) = r.F64();
}

// Reads every record (counts and lengths already checked) into *rig, then the values.
BlobStatus ReadRecords(const SectionTable& t, bool has_sigma, bool has_facing, const Counts& n,
                       Rig* rig) {
  ByteReader cam(t[kCameras].body.subspan(kCountBytes));
  ByteReader ext(t[kExtrinsics].body.subspan(kCountBytes));
  ByteReader bea(t[kBeacons].body.subspan(kCountBytes));
  ByteReader sig(has_sigma ? t[kSigma].body.subspan(kCountBytes) : std::span<const std::uint8_t>());
  ByteReader fac(has_facing ? t[kFacing].body.subspan(kCountBytes) : std::span<const std::uint8_t>());
  const bool has_beacon_sigmas = t[kBeaconSigmas].present;
  ByteReader bsg(has_beacon_sigmas ? t[kBeaconSigmas].body.subspan(kCountBytes) : std::span<const std::uint8_t>());
  bool names_ok = true;
  rig->num_cameras = static_cast<int>(n.cameras);
  for (std::size_t i = 0; i < n.cameras; ++i) {
    RigCamera& c = rig->cameras[i];
    names_ok = cam.Text(&c.name) && names_ok;
    CameraIntrinsics& k = c.intrinsics;
    k.width = ToInt(cam.U32());
    k.height = ToInt(cam.U32());
    k.alpha_x = cam.F64();
    k.alpha_y = cam.F64();
    k.skew = cam.F64();
    k.u0 = cam.F64();
    k.v0 = cam.F64();
    ReadArray(cam, &k.kc);
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) c.C_k_b(row, col) = ext.F64();
    ReadVector(ext, &c.r_b_bk);
    if (has_sigma) {
      RigCameraSigma& s = rig->sigma[i];
      ReadArray(sig, &s.intrinsics);
      ReadArray(sig, &s.distortion);
      ReadVector(sig, &s.euler);
      ReadVector(sig, &s.r_b_bk);
    }
  }
  rig->has_sigma = has_sigma;
  rig->beacon_sigma = bea.F64();
  rig->num_beacons = static_cast<int>(n.beacons);
  for (std::size_t i = 0; i < n.beacons; ++i) ReadVector(bea, &rig->beacons_w[i]);
  rig->has_facing = has_facing;
  for (std::size_t i = 0; has_facing && i < n.beacons; ++i) {  // n.facing == n.beacons
    ReadVector(fac, &rig->beacon_normal_w[i]);
    rig->beacon_half_angle[i] = fac.F64();
  }
  rig->has_beacon_sigmas = has_beacon_sigmas;
  for (std::size_t i = 0; has_beacon_sigmas && i < n.beacons; ++i) rig->beacon_sigmas[i] = bsg.F64();

  if (!cam.ok() || !ext.ok() || !bea.ok() || !sig.ok() || !fac.ok() || !bsg.ok()) return BlobStatus::kBadSection;
  if (!cam.finite() || !ext.finite() || !bea.finite() || !sig.finite() || !fac.finite() || !bsg.finite())
    return BlobStatus::kNonFiniteValue;
  if (!names_ok || ValidateRig(*rig) != RigStatus::kOk) return BlobStatus::kInvalidValue;
  return BlobStatus::kOk;
}

BlobStatus DecodePayload(std::span<const std::uint8_t> payload, std::uint16_t blob_version, bool has_sigma, Rig* rig) {
  SectionTable table{};
  BlobStatus s = FindSections(payload, blob_version, &table);
  if (s != BlobStatus::kOk) return s;
  if (!table[kCameras].present || !table[kExtrinsics].present || !table[kBeacons].present ||
      (has_sigma && !table[kSigma].present))
    return BlobStatus::kMissingSection;
  if (!has_sigma && table[kSigma].present) return BlobStatus::kBadSection;  // flag says none
  const bool has_facing = table[kFacing].present;  // optional, no flag: older decoders skip it
  Counts counts;
  s = CheckCounts(table, has_sigma, has_facing, &counts);
  if (s != BlobStatus::kOk) return s;
  return ReadRecords(table, has_sigma, has_facing, counts, rig);
}

// ---- Encoder ----

BlobStatus FromRigStatus(RigStatus s) {
  switch (s) {
    case RigStatus::kOk: return BlobStatus::kOk;
    case RigStatus::kTooManyCameras: return BlobStatus::kTooManyCameras;
    case RigStatus::kTooManyBeacons: return BlobStatus::kTooManyBeacons;
    case RigStatus::kNonFinite: return BlobStatus::kNonFiniteValue;
    default: return BlobStatus::kInvalidValue;
  }
}

void WriteSectionHeader(ByteWriter& w, SectionType type, std::size_t section_bytes) {
  w.U16(type);
  w.U16(kSectionVersion);
  w.U32(static_cast<std::uint32_t>(section_bytes - kSectionHeaderBytes));
}

void WriteVector(ByteWriter& w, const Eigen::Vector3d& v) {
  for (int i = 0; i < 3; ++i) w.F64(v(i));
}

void WriteArray(ByteWriter& w, const std::array<double, 5>& a) {
  for (const double v : a) w.F64(v);
}

void WritePayload(const Rig& rig, ByteWriter& w) {
  const auto n_cam = static_cast<std::size_t>(rig.num_cameras);
  const auto n_bea = static_cast<std::size_t>(rig.num_beacons);

  WriteSectionHeader(w, kCameras, SectionBytes(0, n_cam, kCameraRecordBytes));
  w.U32(static_cast<std::uint32_t>(n_cam));
  for (std::size_t i = 0; i < n_cam; ++i) {
    const RigCamera& c = rig.cameras[i];
    const CameraIntrinsics& k = c.intrinsics;
    w.Text(c.name);
    w.U32(static_cast<std::uint32_t>(k.width));
    w.U32(static_cast<std::uint32_t>(k.height));
    for (const double v : {k.alpha_x, k.alpha_y, k.skew, k.u0, k.v0}) w.F64(v);
    WriteArray(w, k.kc);
  }

  WriteSectionHeader(w, kExtrinsics, SectionBytes(0, n_cam, kExtrinsicRecordBytes));
  w.U32(static_cast<std::uint32_t>(n_cam));
  for (std::size_t i = 0; i < n_cam; ++i) {
    const RigCamera& c = rig.cameras[i];
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) w.F64(c.C_k_b(row, col));  // row-major
    WriteVector(w, c.r_b_bk);
  }

  WriteSectionHeader(w, kBeacons, SectionBytes(kBeaconFixedBytes, n_bea, kBeaconRecordBytes));
  w.U32(static_cast<std::uint32_t>(n_bea));
  w.F64(rig.beacon_sigma);
  for (std::size_t i = 0; i < n_bea; ++i) WriteVector(w, rig.beacons_w[i]);

  if (rig.has_sigma) {
    WriteSectionHeader(w, kSigma, SectionBytes(0, n_cam, kSigmaRecordBytes));
    w.U32(static_cast<std::uint32_t>(n_cam));
    for (std::size_t i = 0; i < n_cam; ++i) {
      const RigCameraSigma& s = rig.sigma[i];
      WriteArray(w, s.intrinsics);
      WriteArray(w, s.distortion);
      WriteVector(w, s.euler);
      WriteVector(w, s.r_b_bk);
    }
  }

  if (rig.has_facing) {
    WriteSectionHeader(w, kFacing, SectionBytes(0, n_bea, kFacingRecordBytes));
    w.U32(static_cast<std::uint32_t>(n_bea));
    for (std::size_t i = 0; i < n_bea; ++i) {
      WriteVector(w, rig.beacon_normal_w[i]);
      w.F64(rig.beacon_half_angle[i]);
    }
  }

  if (rig.has_beacon_sigmas) {
    WriteSectionHeader(w, kBeaconSigmas, SectionBytes(0, n_bea, kBeaconSigmaRecordBytes));
    w.U32(static_cast<std::uint32_t>(n_bea));
    for (std::size_t i = 0; i < n_bea; ++i) w.F64(rig.beacon_sigmas[i]);
  }
}

}  // namespace

const char* ToString(BlobStatus s) {
  switch (s) {
    case BlobStatus::kOk: return "ok";
    case BlobStatus::kTruncated: return "blob shorter than its header or than header + payload length";
    case BlobStatus::kTrailingBytes: return "bytes after the end of the payload";
    case BlobStatus::kBadMagic: return "not a parameter blob (magic is not MFNSPRM1)";
    case BlobStatus::kUnsupportedVersion: return "blob format version not supported by this decoder";
    case BlobStatus::kHeaderCrcMismatch: return "header CRC32 mismatch (header corrupted)";
    case BlobStatus::kBadHeader: return "header size, flags or rig id field malformed";
    case BlobStatus::kTooLarge: return "blob larger than limits::kMaxBlobBytes";
    case BlobStatus::kPayloadCrcMismatch: return "payload CRC32 mismatch (payload corrupted)";
    case BlobStatus::kBadSection: return "section length or version inconsistent with the payload";
    case BlobStatus::kMissingSection:
      return "required section (cameras, extrinsics, beacons, sigma) missing";
    case BlobStatus::kDuplicateSection: return "a section appears more than once";
    case BlobStatus::kTooManyCameras: return "more cameras than limits::kMaxCameras";
    case BlobStatus::kTooManyBeacons: return "more beacons than limits::kMaxBeacons";
    case BlobStatus::kCountMismatch: return "sections disagree on the number of cameras or beacons";
    case BlobStatus::kNonFiniteValue: return "NaN or infinite value";
    case BlobStatus::kInvalidValue:
      return "rig fails validation (e.g. C_k_b not a rotation, a value outside its sensible range, two beacons at one position)";
    case BlobStatus::kRigIdMismatch: return "blob is for another rig id";
    case BlobStatus::kBufferTooSmall: return "output buffer smaller than the encoded blob";
  }
  return "unknown blob status";
}

BlobStatus EncodeParamBlob(const Rig& rig, std::uint64_t generation, std::span<std::uint8_t> out,
                           std::size_t* written) {
  const BlobStatus valid = FromRigStatus(ValidateRig(rig));
  if (valid != BlobStatus::kOk) return valid;
  const std::size_t payload_bytes =
      PayloadBytes(static_cast<std::size_t>(rig.num_cameras),
                   static_cast<std::size_t>(rig.num_beacons), rig.has_sigma, rig.has_facing,
                   rig.has_beacon_sigmas);
  const std::size_t total = kBlobHeaderBytes + payload_bytes;
  if (out.size() < total) return BlobStatus::kBufferTooSmall;

  const std::span<std::uint8_t> blob = out.first(total);
  const std::span<std::uint8_t> payload = blob.subspan(kBlobHeaderBytes);
  ByteWriter p(payload);
  WritePayload(rig, p);

  ByteWriter h(blob.first(kBlobHeaderBytes));
  h.Bytes(kMagic);
  h.U16(rig.has_beacon_sigmas ? kBlobFormatVersion : kOldestBlobFormatVersion);
  h.U16(static_cast<std::uint16_t>(kBlobHeaderBytes));
  h.U16(rig.has_sigma ? kFlagHasSigma : 0);
  h.U16(static_cast<std::uint16_t>(payload_bytes));
  h.Text(rig.rig_id);
  h.U64(generation);
  h.U32(Crc32(payload));
  h.U32(Crc32(blob.first(kOffHeaderCrc)));
  if (!p.ok() || !h.ok()) return BlobStatus::kBufferTooSmall;  // can't happen: sized above
  if (written != nullptr) *written = total;
  return BlobStatus::kOk;
}

BlobStatus DecodeBlobHeader(std::span<const std::uint8_t> in, BlobInfo* info) {
  Header h;
  bool valid = false;
  const BlobStatus s = ParseHeader(in, &h, &valid);
  if (valid && info != nullptr) *info = h.info;
  return s;
}

BlobStatus DecodeParamBlob(std::span<const std::uint8_t> in, const char* expected_rig_id, Rig* rig,
                           BlobInfo* info) {
  Header h;
  bool valid = false;
  BlobStatus s = ParseHeader(in, &h, &valid);
  if (valid && info != nullptr) *info = h.info;
  if (s != BlobStatus::kOk) return s;

  const std::size_t total = kBlobHeaderBytes + h.info.payload_bytes;
  if (in.size() < total) return BlobStatus::kTruncated;
  if (in.size() > total) return BlobStatus::kTrailingBytes;
  const std::span<const std::uint8_t> payload = in.subspan(kBlobHeaderBytes);
  if (Crc32(payload) != h.info.payload_crc32) return BlobStatus::kPayloadCrcMismatch;

  Rig decoded;  // *rig is written only on success
  decoded.rig_id = h.rig_id;
  s = DecodePayload(payload, h.info.format_version, (h.flags & kFlagHasSigma) != 0, &decoded);
  if (s != BlobStatus::kOk) return s;
  if (expected_rig_id != nullptr &&
      std::strncmp(expected_rig_id, decoded.rig_id.data(), decoded.rig_id.size()) != 0)
    return BlobStatus::kRigIdMismatch;
  if (rig != nullptr) *rig = decoded;
  return BlobStatus::kOk;
}

}  // namespace mfns
