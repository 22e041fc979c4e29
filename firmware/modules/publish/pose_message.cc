#include "firmware/modules/publish/pose_message.h"

#include <algorithm>
#include <cmath>

#include "common/blob/param_blob.h"
#include "common/wire/byte_io.h"

namespace mfns::fw {
namespace {

constexpr std::array<std::uint8_t, 4> kMagic = {'M', 'F', 'N', 'P'};
constexpr std::uint8_t kTypePose = 1, kTypeHealth = 2, kTypeBlobs = 3, kTypeBeaconHealth = 4;
constexpr std::size_t kCameraHealthBytes = 28, kCameraHealthV1Bytes = 20;
static_assert(48 + 3 * 8 + 4 * 8 + 3 * 4 + 4 + 21 * 4 + 4 == kPoseMessageBytes, "pose layout");
static_assert(56 + limits::kMaxCameras * kCameraHealthBytes + 3 * 4 + 4 == kHealthMessageBytes, "health layout");
static_assert(56 + limits::kMaxCameras * kCameraHealthV1Bytes + 4 == kHealthMessageV1Bytes, "health v1 layout");
static_assert(limits::kMaxCameras == 4, "the wire formats carry exactly 4 camera slots");

void Header(wire::ByteWriter& w, std::uint8_t version, std::uint8_t type, std::size_t size) {
  w.Bytes(kMagic);
  w.U8(version);
  w.U8(type);
  w.U16(static_cast<std::uint16_t>(size));
}

void Seal(std::span<std::uint8_t> out) {
  const std::size_t n = out.size() - 4;
  const std::uint32_t crc = Crc32(out.first(n));
  wire::ByteWriter w(out.subspan(n));
  w.U32(crc);
}

MessageStatus Check(std::span<const std::uint8_t> in, std::uint8_t version, std::uint8_t type, std::size_t size) {
  if (in.size() < 8) return MessageStatus::kTruncated;
  for (std::size_t i = 0; i < 4; ++i)
    if (in[i] != kMagic[i]) return MessageStatus::kBadMagic;
  if (in[5] != type) return MessageStatus::kBadType;
  if (in[4] != version) return MessageStatus::kBadVersion;
  if (wire::LoadLe(in, 6, 2) != size) return MessageStatus::kBadSize;
  if (in.size() < size) return MessageStatus::kTruncated;
  if (in.size() > size) return MessageStatus::kBadSize;
  if (Crc32(in.first(size - 4)) != wire::LoadLe(in, size - 4, 4)) return MessageStatus::kBadCrc;
  return MessageStatus::kOk;
}

}  // namespace

const char* ToString(NavStatus s) {
  switch (s) {
    case NavStatus::kFix: return "fix";
    case NavStatus::kDegraded: return "degraded";
    case NavStatus::kLost: return "lost";
  }
  return "unknown";
}

const char* ToString(NavReason r) {
  switch (r) {
    case NavReason::kNone: return "none";
    case NavReason::kFewBeacons: return "few beacons";
    case NavReason::kLargeResidual: return "large residual";
    case NavReason::kLargeCovariance: return "large covariance";
    case NavReason::kCameraDown: return "camera down";
    case NavReason::kTooFewBeacons: return "too few beacons";
    case NavReason::kAmbiguous: return "ambiguous identification";
    case NavReason::kSolveFailed: return "solve failed";
    case NavReason::kNoFrames: return "no frames";
    case NavReason::kAcquiring: return "acquiring";
    case NavReason::kNoHypothesis: return "no hypothesis";
    case NavReason::kClockFault: return "clock fault";
    case NavReason::kUnverified: return "unverified";
    case NavReason::kRepeatedView: return "map repeats this view";
    case NavReason::kCount: break;
  }
  return "unknown";
}

const char* ToString(MessageStatus s) {
  switch (s) {
    case MessageStatus::kOk: return "ok";
    case MessageStatus::kTruncated: return "truncated";
    case MessageStatus::kBadMagic: return "bad magic";
    case MessageStatus::kBadVersion: return "unsupported version";
    case MessageStatus::kBadType: return "wrong message type";
    case MessageStatus::kBadSize: return "wrong size";
    case MessageStatus::kBadCrc: return "CRC mismatch";
    case MessageStatus::kBadField: return "a field out of range";
  }
  return "unknown";
}

void EncodePose(const PoseRecord& r, std::span<std::uint8_t, kPoseMessageBytes> out) {
  wire::ByteWriter w(out);
  Header(w, kPoseMessageVersion, kTypePose, kPoseMessageBytes);
  w.U32(r.sequence);
  w.U32(r.frame_set);
  w.U64(r.t_capture_ns);
  w.U64(r.t_publish_ns);
  w.U64(r.param_generation);
  w.U8(static_cast<std::uint8_t>(r.status));
  w.U8(static_cast<std::uint8_t>(r.reason));
  w.U8(r.num_cameras);
  w.U8(r.num_beacons);
  for (std::uint8_t n : r.beacons_per_camera) w.U8(n);
  for (int i = 0; i < 3; ++i) w.F64(r.r_w_wb[i]);
  w.F64(r.q_w_b.w());
  w.F64(r.q_w_b.x());
  w.F64(r.q_w_b.y());
  w.F64(r.q_w_b.z());
  for (int i = 0; i < 3; ++i) w.F32(r.euler_deg[i]);
  w.F32(r.residual_rms_px);
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) w.F32(static_cast<float>(r.covariance(i, j)));
  Seal(out);
}

void EncodeHealth(const HealthRecord& r, std::span<std::uint8_t, kHealthMessageBytes> out) {
  wire::ByteWriter w(out);
  Header(w, kHealthMessageVersion, kTypeHealth, kHealthMessageBytes);
  w.U32(r.sequence);
  w.U32(r.frame_sets);
  w.U64(r.t_ns);
  w.U64(r.param_generation);
  w.U32(r.fixes);
  w.U32(r.degraded);
  w.U32(r.lost);
  w.U32(r.deadline_slips);
  w.U32(r.worst_frame_set_us);
  w.U8(r.num_cameras);
  for (int i = 0; i < 3; ++i) w.U8(0);
  for (const CameraHealth& c : r.cameras) {
    w.U8(c.state);
    w.U8(0);
    w.U16(c.blobs_last);
    w.U32(c.frames);
    w.U32(c.drops);
    w.U32(c.timeouts);
    w.U32(c.errors);
    w.U32(c.bad_frames);
    w.U32(c.detect_errors);
  }
  w.U32(r.clock_faults);
  w.U32(r.log_errors);
  w.U32(r.trigger_errors);
  Seal(out);
}

MessageStatus DecodePose(std::span<const std::uint8_t> in, PoseRecord* r) {
  const MessageStatus s = Check(in, kPoseMessageVersion, kTypePose, kPoseMessageBytes);
  if (s != MessageStatus::kOk) return s;
  wire::ByteReader rd(in.subspan(8));
  r->sequence = rd.U32();
  r->frame_set = rd.U32();
  r->t_capture_ns = rd.U64();
  r->t_publish_ns = rd.U64();
  r->param_generation = rd.U64();
  r->status = static_cast<NavStatus>(rd.U8());
  r->reason = static_cast<NavReason>(rd.U8());
  r->num_cameras = rd.U8();
  r->num_beacons = rd.U8();
  for (std::uint8_t& n : r->beacons_per_camera) n = rd.U8();
  for (int i = 0; i < 3; ++i) r->r_w_wb[i] = rd.F64();
  const double qw = rd.F64(), qx = rd.F64(), qy = rd.F64(), qz = rd.F64();
  r->q_w_b = Eigen::Quaterniond(qw, qx, qy, qz);
  for (int i = 0; i < 3; ++i) r->euler_deg[i] = rd.F32();
  r->residual_rms_px = rd.F32();
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) r->covariance(i, j) = r->covariance(j, i) = static_cast<double>(rd.F32());
  return MessageStatus::kOk;
}

MessageStatus DecodeHealth(std::span<const std::uint8_t> in, HealthRecord* r) {
  const bool v1 = in.size() >= 5 && in[4] == 1;
  const MessageStatus s = v1 ? Check(in, 1, kTypeHealth, kHealthMessageV1Bytes)
                             : Check(in, kHealthMessageVersion, kTypeHealth, kHealthMessageBytes);
  if (s != MessageStatus::kOk) return s;
  *r = HealthRecord{};
  wire::ByteReader rd(in.subspan(8));
  r->sequence = rd.U32();
  r->frame_sets = rd.U32();
  r->t_ns = rd.U64();
  r->param_generation = rd.U64();
  r->fixes = rd.U32();
  r->degraded = rd.U32();
  r->lost = rd.U32();
  r->deadline_slips = rd.U32();
  r->worst_frame_set_us = rd.U32();
  r->num_cameras = rd.U8();
  for (int i = 0; i < 3; ++i) rd.U8();
  for (CameraHealth& c : r->cameras) {
    c.state = rd.U8();
    rd.U8();
    c.blobs_last = rd.U16();
    c.frames = rd.U32();
    c.drops = rd.U32();
    c.timeouts = rd.U32();
    c.errors = rd.U32();
    if (v1) continue;
    c.bad_frames = rd.U32();
    c.detect_errors = rd.U32();
  }
  if (!v1) {
    r->clock_faults = rd.U32();
    r->log_errors = rd.U32();
    r->trigger_errors = rd.U32();
  }
  return MessageStatus::kOk;
}

}  // namespace mfns::fw

namespace mfns::fw {

std::size_t EncodeBlobs(const BlobsRecord& r, std::span<std::uint8_t, kMaxBlobsMessageBytes> out) {
  const int n = std::clamp(r.num_blobs, 0, limits::kMaxBlobsInMessage);
  const std::size_t size = kBlobsMessageHeaderBytes + kBlobsMessageEntryBytes * static_cast<std::size_t>(n) + 4;
  const std::span<std::uint8_t> msg = std::span<std::uint8_t>(out).first(size);
  wire::ByteWriter w(msg);
  Header(w, kBlobsMessageVersion, kTypeBlobs, size);
  w.U32(r.sequence);
  w.U32(r.frame_set);
  w.U64(r.t_capture_ns);
  w.U16(static_cast<std::uint16_t>(n));
  w.U8(r.num_cameras);
  w.U8(r.truncated ? 1 : 0);
  for (int i = 0; i < n; ++i) {
    const BlobEntry& b = r.blobs[static_cast<std::size_t>(i)];
    w.U8(b.camera);
    w.U8(0);
    w.U16(static_cast<std::uint16_t>(b.beacon));
    w.F32(b.u_px);
    w.F32(b.v_px);
  }
  Seal(msg);
  return size;
}

MessageStatus DecodeBlobs(std::span<const std::uint8_t> in, BlobsRecord* r) {
  // The size follows from the count: read it (when there is one) before the header check.
  const std::size_t n = in.size() >= kBlobsMessageHeaderBytes ? wire::LoadLe(in, 24, 2) : 0;
  if (n > static_cast<std::size_t>(limits::kMaxBlobsInMessage)) return MessageStatus::kBadSize;
  const MessageStatus s =
      Check(in, kBlobsMessageVersion, kTypeBlobs, kBlobsMessageHeaderBytes + kBlobsMessageEntryBytes * n + 4);
  if (s != MessageStatus::kOk) return s;
  BlobsRecord out;
  wire::ByteReader rd(in.subspan(8));
  out.sequence = rd.U32();
  out.frame_set = rd.U32();
  out.t_capture_ns = rd.U64();
  out.num_blobs = rd.U16();
  out.num_cameras = rd.U8();
  const std::uint8_t flags = rd.U8();
  out.truncated = (flags & 1U) != 0;
  if (out.num_cameras > limits::kMaxCameras || (flags & ~1U) != 0) return MessageStatus::kBadField;
  for (int i = 0; i < out.num_blobs; ++i) {
    BlobEntry& b = out.blobs[static_cast<std::size_t>(i)];
    b.camera = rd.U8();
    rd.U8();
    b.beacon = static_cast<std::int16_t>(rd.U16());
    b.u_px = rd.F32();
    b.v_px = rd.F32();
    if (b.camera >= out.num_cameras || b.beacon < -1 || !std::isfinite(b.u_px) || !std::isfinite(b.v_px))
      return MessageStatus::kBadField;
  }
  *r = out;
  return MessageStatus::kOk;
}

std::size_t EncodeBeaconHealth(const BeaconHealthRecord& r, std::span<std::uint8_t, kMaxBeaconHealthMessageBytes> out) {
  const int n = std::clamp(r.num_entries, 0, limits::kBeaconHealthPerMessage);
  const std::size_t size = kBeaconHealthHeaderBytes + kBeaconHealthEntryBytes * static_cast<std::size_t>(n) + 4;
  const std::span<std::uint8_t> msg = std::span<std::uint8_t>(out).first(size);
  wire::ByteWriter w(msg);
  Header(w, kBeaconHealthMessageVersion, kTypeBeaconHealth, size);
  w.U32(r.sequence);
  w.U32(r.frame_sets);
  w.U64(r.t_ns);
  w.U16(r.map_beacons);
  w.U16(r.flagged);
  w.U16(r.first);
  w.U16(static_cast<std::uint16_t>(n));
  for (int i = 0; i < n; ++i) {
    const BeaconHealthEntry& e = r.entries[static_cast<std::size_t>(i)];
    w.U16(e.beacon);
    w.U8(e.state);
    w.U8(e.judged ? 1 : 0);
    for (const std::uint32_t c : {e.in_view, e.seen, e.used, e.rejected}) w.U32(c);
    for (const float f : {e.mean_residual_px, e.rms_residual_px, e.suggested_sigma_mm}) w.F32(f);
  }
  Seal(msg);
  return size;
}

namespace {

// A decoded entry that cannot come from an encoder of BeaconHealth's counters.
bool BadEntry(const BeaconHealthEntry& e, std::uint32_t want_beacon, std::uint8_t judged) {
  const bool finite = std::isfinite(e.mean_residual_px) && std::isfinite(e.rms_residual_px) &&
                      std::isfinite(e.suggested_sigma_mm);
  return e.beacon != want_beacon || e.state >= static_cast<std::uint8_t>(3) || judged > 1 || e.seen > e.in_view ||
         static_cast<std::uint64_t>(e.used) + e.rejected != e.seen || !finite || e.mean_residual_px < 0.0f ||
         e.rms_residual_px < 0.0f || e.suggested_sigma_mm < 0.0f;
}

}  // namespace

MessageStatus DecodeBeaconHealth(std::span<const std::uint8_t> in, BeaconHealthRecord* r) {
  // The size follows from the count: read it (when there is one) before the header check.
  const std::size_t n = in.size() >= kBeaconHealthHeaderBytes ? wire::LoadLe(in, 30, 2) : 0;
  if (n > static_cast<std::size_t>(limits::kBeaconHealthPerMessage)) return MessageStatus::kBadSize;
  const MessageStatus s = Check(in, kBeaconHealthMessageVersion, kTypeBeaconHealth,
                                kBeaconHealthHeaderBytes + kBeaconHealthEntryBytes * n + 4);
  if (s != MessageStatus::kOk) return s;
  BeaconHealthRecord out;
  wire::ByteReader rd(in.subspan(8));
  out.sequence = rd.U32();
  out.frame_sets = rd.U32();
  out.t_ns = rd.U64();
  out.map_beacons = rd.U16();
  out.flagged = rd.U16();
  out.first = rd.U16();
  out.num_entries = rd.U16();
  if (out.map_beacons > limits::kMaxBeacons || out.flagged > out.map_beacons ||
      static_cast<std::size_t>(out.first) + n > out.map_beacons)
    return MessageStatus::kBadField;
  for (int i = 0; i < out.num_entries; ++i) {
    BeaconHealthEntry& e = out.entries[static_cast<std::size_t>(i)];
    e.beacon = rd.U16();
    e.state = rd.U8();
    const std::uint8_t judged = rd.U8();
    e.judged = judged == 1;
    e.in_view = rd.U32();
    e.seen = rd.U32();
    e.used = rd.U32();
    e.rejected = rd.U32();
    e.mean_residual_px = rd.F32();
    e.rms_residual_px = rd.F32();
    e.suggested_sigma_mm = rd.F32();
    if (BadEntry(e, static_cast<std::uint32_t>(out.first) + static_cast<std::uint32_t>(i), judged))
      return MessageStatus::kBadField;
  }
  *r = out;
  return MessageStatus::kOk;
}

}  // namespace mfns::fw
