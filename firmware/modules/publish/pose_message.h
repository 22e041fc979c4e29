// The navigation output datagram (DESIGN.md, "Pose output"): one fixed-size little-endian
// message per frame set, versioned, CRC-protected, sent over UDP. Also the health message.
// Wire layout (offsets in bytes; all little-endian; f64/f32 IEEE 754):
//
//   PoseMessage v1 (type 1, 208 bytes)
//   0   char[4] magic "MFNP"          4   u8 version = 1     5 u8 type = 1     6 u16 size = 208
//   8   u32 sequence (per message)    12  u32 frame_set (frame index of the source)
//   16  u64 t_capture_ns  (sample time: CLOCK_MONOTONIC of the driver timestamp, earliest camera)
//   24  u64 t_publish_ns  (CLOCK_MONOTONIC when sent; latency = t_publish - t_capture)
//   32  u64 param_generation (blob in use)
//   40  u8 status (0 fix, 1 degraded, 2 lost)   41 u8 reason (NavReason)
//   42  u8 num_cameras                          43 u8 num_beacons (used in the solve)
//   44  u8[4] beacons per camera
//   48  f64[3] r_w_wb (m, body origin in world)
//   72  f64[4] q_w_b (w, x, y, z; rotation body -> world)
//   104 f32[3] roll, pitch, yaw of C_b_w (deg, the paper's 2-1-3 set; for people)
//   116 f32 residual RMS (px)
//   120 f32[21] covariance, upper triangle row by row, of [dr_w (m); dtheta_b (rad)]
//               (common/rig/rig.h PoseDelta)
//   204 u32 CRC-32 (zlib) of bytes 0..203
//
//   HealthMessage v2 (type 2, 184 bytes)
//   0   magic, version = 2, type = 2, u16 size = 184 (as above)
//   8   u32 sequence   12 u32 frame_sets   16 u64 t_ns   24 u64 param_generation
//   32  u32 fixes   36 u32 degraded   40 u32 lost   44 u32 deadline_slips
//   48  u32 worst_frame_set_us   52 u8 num_cameras   53 u8[3] zero
//   56  4 x 28 bytes per camera: u8 state, u8 zero, u16 blobs_last, u32 frames, u32 drops,
//       u32 timeouts, u32 errors, u32 bad_frames, u32 detect_errors
//   168 u32 clock_faults   172 u32 log_errors   176 u32 trigger_errors
//   180 u32 CRC-32 of bytes 0..179
//   (HealthMessage v1, 140 bytes: the same up to byte 56, then 4 x 20 bytes per camera without
//   bad_frames and detect_errors, and the CRC at 136; still decoded, the new fields zero.)
//   All counters count since start and saturate at 2^32 - 1.
//
//   BlobsMessage v1 (type 3, 32 + 12 n bytes, n <= limits::kMaxBlobsInMessage; for viewers:
//   mfns-view draws each camera's blobs and what they were matched to)
//   0   magic, version = 1, type = 3, u16 size (as above)
//   8   u32 sequence   12 u32 frame_set (as the pose message's)   16 u64 t_capture_ns
//   24  u16 n   26 u8 num_cameras   27 u8 flags (bit 0: the frame set had more blobs than n)
//   28  n x 12 bytes: u8 camera, u8 zero, i16 beacon (index into the map; -1: not matched),
//       f32 u_px, f32 v_px (distorted image centroid)
//   28 + 12 n  u32 CRC-32 of the bytes before it
//   The matched blobs come first, then the others, in the frame set's blob order.
//
//   BeaconHealthMessage v1 (type 4, 32 + 32 n bytes, n <= limits::kBeaconHealthPerMessage; one
//   page of the map's beacons, sent after each health message, the pages in turn; issue 16)
//   0   magic, version = 1, type = 4, u16 size (as above)
//   8   u32 sequence   12 u32 frame_sets   16 u64 t_ns (as the health message's)
//   24  u16 map_beacons   26 u16 flagged (beacons not ok, whole map)   28 u16 first   30 u16 n
//   32  n x 32 bytes, beacons first .. first + n - 1: u16 beacon, u8 state (BeaconState: 0 ok,
//       1 inconsistent, 2 missing), u8 judged (0/1), u32 in_view, u32 seen, u32 used,
//       u32 rejected, f32 mean residual (px), f32 RMS residual (px), f32 the map sigma its
//       residuals suggest (mm; 0 unless inconsistent)
//   32 + 32 n  u32 CRC-32 of the bytes before it
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <span>

#include "common/limits.h"

namespace mfns::fw {

enum class NavStatus : std::uint8_t { kFix = 0, kDegraded = 1, kLost = 2 };
const char* ToString(NavStatus s);  // "fix", "degraded", "lost" (the poses CSV words)

// Why the status is not a plain fix (kNone for a good fix).
enum class NavReason : std::uint8_t {
  kNone = 0,
  kFewBeacons,        // a fix on fewer beacons than wanted for redundancy (degraded)
  kLargeResidual,     // residual RMS above its bound (degraded)
  kLargeCovariance,   // position or attitude sigma above its bound (degraded)
  kCameraDown,        // a camera set aside (degraded)
  kTooFewBeacons,     // fewer than 3 identified beacons (lost)
  kAmbiguous,         // identification could not decide (lost)
  kSolveFailed,       // the solver gave no pose (lost)
  kNoFrames,          // no camera delivered a frame (lost)
  kAcquiring,         // several poses explain the blobs; following them over frames (lost)
  kNoHypothesis,      // no pose explains the blobs, or the hypothesis budget ran out (lost)
  kClockFault,        // the frame set's timestamp was not after the previous one: the pose is
                      // stamped with the previous time plus one frame period (degraded)
  kUnverified,        // a track that has stood on exactly three beacons since it began (degraded)
  kRepeatedView,      // the map repeats the beacons of the poses found: a copy elsewhere explains
                      // the blobs as well (lost; a regular grid, docs/navd.md)
  kCount
};
const char* ToString(NavReason r);

inline constexpr std::size_t kPoseMessageBytes = 208;
inline constexpr std::size_t kHealthMessageBytes = 184;
inline constexpr std::size_t kHealthMessageV1Bytes = 140;
inline constexpr std::size_t kBlobsMessageHeaderBytes = 28;
inline constexpr std::size_t kBlobsMessageEntryBytes = 12;
inline constexpr std::size_t kMaxBlobsMessageBytes =
    kBlobsMessageHeaderBytes + kBlobsMessageEntryBytes * limits::kMaxBlobsInMessage + 4;
inline constexpr std::uint8_t kBlobsMessageVersion = 1;
inline constexpr std::size_t kBeaconHealthHeaderBytes = 32;
inline constexpr std::size_t kBeaconHealthEntryBytes = 32;
inline constexpr std::size_t kMaxBeaconHealthMessageBytes =
    kBeaconHealthHeaderBytes + kBeaconHealthEntryBytes * limits::kBeaconHealthPerMessage + 4;
inline constexpr std::uint8_t kBeaconHealthMessageVersion = 1;
inline constexpr std::uint8_t kPoseMessageVersion = 1;
inline constexpr std::uint8_t kHealthMessageVersion = 2;

// One frame set's output. When status is kLost there is no pose: r_w_wb, q_w_b, euler_deg and
// covariance are NaN (set by the producer, NavLoop::Publish) and residual_rms_px is 0.
struct PoseRecord {
  std::uint32_t sequence = 0;
  std::uint32_t frame_set = 0;
  std::uint64_t t_capture_ns = 0;
  std::uint64_t t_publish_ns = 0;
  std::uint64_t param_generation = 0;
  NavStatus status = NavStatus::kLost;
  NavReason reason = NavReason::kNoFrames;
  std::uint8_t num_cameras = 0;
  std::uint8_t num_beacons = 0;
  std::array<std::uint8_t, limits::kMaxCameras> beacons_per_camera{};
  Eigen::Vector3d r_w_wb = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_w_b = Eigen::Quaterniond::Identity();
  Eigen::Vector3f euler_deg = Eigen::Vector3f::Zero();
  float residual_rms_px = 0.0f;
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
};

struct CameraHealth {
  std::uint8_t state = 0;  // 0 ok, 1 set aside (retrying), 2 failed at start
  std::uint32_t frames = 0;         // frames delivered
  std::uint32_t drops = 0;          // frames lost: gaps in the driver's sequence, missing files
  std::uint32_t timeouts = 0;       // no frame within the timeout
  std::uint32_t errors = 0;         // failed driver calls
  std::uint32_t bad_frames = 0;     // frames delivered but unusable: error-flagged, short,
                                    // unreadable, unstamped or blank (every pixel alike)
  std::uint32_t detect_errors = 0;  // frames whose blob detection failed (no blob list)
  std::uint16_t blobs_last = 0;
};

struct HealthRecord {
  std::uint32_t sequence = 0;
  std::uint32_t frame_sets = 0;
  std::uint64_t t_ns = 0;
  std::uint64_t param_generation = 0;
  std::uint32_t fixes = 0, degraded = 0, lost = 0;
  std::uint32_t deadline_slips = 0;
  std::uint32_t worst_frame_set_us = 0;
  std::uint8_t num_cameras = 0;
  std::array<CameraHealth, limits::kMaxCameras> cameras{};
  std::uint32_t clock_faults = 0;    // frame sets not later than the previous one (kClockFault), and
                                     // stamps that jumped ahead with no frame lost (NavLoop stamp_jumps)
  std::uint32_t log_errors = 0;      // pose log rows that failed to write
  std::uint32_t trigger_errors = 0;  // trigger pulses that failed
};

// One blob of a frame set as the blobs message carries it.
struct BlobEntry {
  std::uint8_t camera = 0;
  std::int16_t beacon = -1;  // -1: matched to no beacon
  float u_px = 0.0f, v_px = 0.0f;
};

// One frame set's blobs and their identities (BlobsMessage).
struct BlobsRecord {
  std::uint32_t sequence = 0;
  std::uint32_t frame_set = 0;
  std::uint64_t t_capture_ns = 0;
  std::uint8_t num_cameras = 0;
  bool truncated = false;  // the frame set had more blobs than the message carries
  int num_blobs = 0;       // 0..limits::kMaxBlobsInMessage
  std::array<BlobEntry, limits::kMaxBlobsInMessage> blobs{};
};

// One beacon's health as the beacon-health message carries it (firmware/modules/health).
struct BeaconHealthEntry {
  std::uint16_t beacon = 0;
  std::uint8_t state = 0;  // BeaconState
  bool judged = false;
  std::uint32_t in_view = 0, seen = 0, used = 0, rejected = 0;
  float mean_residual_px = 0.0f, rms_residual_px = 0.0f, suggested_sigma_mm = 0.0f;
};

// One page of the map's beacons (BeaconHealthMessage).
struct BeaconHealthRecord {
  std::uint32_t sequence = 0;
  std::uint32_t frame_sets = 0;
  std::uint64_t t_ns = 0;
  std::uint16_t map_beacons = 0;
  std::uint16_t flagged = 0;
  std::uint16_t first = 0;
  int num_entries = 0;  // 0..limits::kBeaconHealthPerMessage
  std::array<BeaconHealthEntry, limits::kBeaconHealthPerMessage> entries{};
};

enum class MessageStatus : unsigned char {
  kOk = 0, kTruncated, kBadMagic, kBadVersion, kBadType, kBadSize, kBadCrc,
  kBadField,  // a field out of its range (a blob's camera, beacon or centroid)
};
const char* ToString(MessageStatus s);

// Encoders write exactly the message size into out (which must be at least that long).
void EncodePose(const PoseRecord& r, std::span<std::uint8_t, kPoseMessageBytes> out);
void EncodeHealth(const HealthRecord& r, std::span<std::uint8_t, kHealthMessageBytes> out);

// Writes the blobs message of r (num_blobs clamped to 0..kMaxBlobsInMessage) into out;
// returns its size.
std::size_t EncodeBlobs(const BlobsRecord& r, std::span<std::uint8_t, kMaxBlobsMessageBytes> out);
// Writes the beacon-health message of r (num_entries clamped to 0..kBeaconHealthPerMessage)
// into out; returns its size.
std::size_t EncodeBeaconHealth(const BeaconHealthRecord& r, std::span<std::uint8_t, kMaxBeaconHealthMessageBytes> out);
// Decoders for receivers and tests: check magic, version, type, size and CRC. DecodeHealth
// also takes a v1 message (the fields v1 lacks are zero).
MessageStatus DecodePose(std::span<const std::uint8_t> in, PoseRecord* r);
MessageStatus DecodeHealth(std::span<const std::uint8_t> in, HealthRecord* r);
// Also checks every blob: camera < num_cameras <= kMaxCameras, beacon >= -1, finite centroid
// (else kBadField).
MessageStatus DecodeBlobs(std::span<const std::uint8_t> in, BlobsRecord* r);
// Also checks every entry: its beacon is first + its index, < map_beacons <= kMaxBeacons, state
// < 3, judged 0/1, seen <= in_view, used + rejected == seen, finite non-negative residuals and
// sigma; flagged <= map_beacons (else kBadField).
MessageStatus DecodeBeaconHealth(std::span<const std::uint8_t> in, BeaconHealthRecord* r);

}  // namespace mfns::fw
