// MAVLink 2 out of the flyer (issue 17; DESIGN.md "Pose output": "MAVLink ODOMETRY is the
// ecosystem's way to feed a flight controller"): the two messages an autopilot needs from an
// external navigation source, HEARTBEAT (#0) and ODOMETRY (#331), written by hand (no MAVLink
// library is packaged in Debian). No heap, no exceptions, fixed-size buffers.
//
// Packet (MAVLink 2, unsigned), offsets in bytes:
//   0 STX 0xFD   1 payload length (after truncation)   2 incompat_flags = 0   3 compat_flags = 0
//   4 sequence (per output, wraps at 256)   5 system id   6 component id   7..9 message id (u24 LE)
//   10 payload (fields little-endian, in MAVLink's wire order: sorted by type size, extensions
//      last in definition order), trailing zero bytes removed but never the first byte
//   10 + len: u16 checksum, X.25 (CRC-16/MCRF4XX) of bytes 1 .. 9 + len, then of CRC_EXTRA.
// CRC_EXTRA and the payload layouts are those of the published definitions (common.xml,
// minimal.xml; checked against mavlink-mappings 1.0.21-20250824-1, the generated code
// node-mavlink uses): HEARTBEAT 50, ODOMETRY 91.
//
//   HEARTBEAT payload (9 bytes): 0 u32 custom_mode  4 u8 type  5 u8 autopilot  6 u8 base_mode
//     7 u8 system_status  8 u8 mavlink_version (3)
//   ODOMETRY payload (233 bytes): 0 u64 time_usec  8 f32 x  12 f32 y  16 f32 z  20 f32[4] q
//     (w, x, y, z)  36 f32 vx  40 vy  44 vz  48 rollspeed  52 pitchspeed  56 yawspeed
//     60 f32[21] pose_covariance  144 f32[21] velocity_covariance  228 u8 frame_id
//     229 u8 child_frame_id  230 u8 reset_counter  231 u8 estimator_type  232 i8 quality
//     (230..232: MAVLink 2 extensions)
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware/modules/publish/pose_message.h"

namespace mfns::fw {
namespace mavlink {

inline constexpr std::uint8_t kStx = 0xFD;
inline constexpr std::size_t kHeaderBytes = 10;
inline constexpr std::size_t kChecksumBytes = 2;
inline constexpr std::uint32_t kHeartbeatId = 0;
inline constexpr std::uint32_t kOdometryId = 331;
inline constexpr std::uint8_t kHeartbeatCrcExtra = 50;
inline constexpr std::uint8_t kOdometryCrcExtra = 91;
inline constexpr std::size_t kHeartbeatPayloadBytes = 9;
inline constexpr std::size_t kOdometryPayloadBytes = 233;
inline constexpr std::size_t kMaxPacketBytes = kHeaderBytes + kOdometryPayloadBytes + kChecksumBytes;

// Enum values of common.xml / minimal.xml used here.
inline constexpr std::uint8_t kFrameBodyFrd = 12;             // MAV_FRAME_BODY_FRD
inline constexpr std::uint8_t kFrameLocalFrd = 20;            // MAV_FRAME_LOCAL_FRD
inline constexpr std::uint8_t kEstimatorVision = 2;           // MAV_ESTIMATOR_TYPE_VISION
inline constexpr std::uint8_t kTypeOnboardController = 18;    // MAV_TYPE_ONBOARD_CONTROLLER
inline constexpr std::uint8_t kAutopilotInvalid = 8;          // MAV_AUTOPILOT_INVALID: not an autopilot
inline constexpr std::uint8_t kStateActive = 4;               // MAV_STATE_ACTIVE
inline constexpr std::uint8_t kStateCritical = 5;             // MAV_STATE_CRITICAL
inline constexpr std::uint8_t kProtocolVersion = 3;           // HEARTBEAT.mavlink_version
inline constexpr std::uint8_t kCompVisualInertialOdometry = 197;  // MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY

struct Header {
  std::uint8_t sequence = 0;
  std::uint8_t system_id = 1;
  std::uint8_t component_id = kCompVisualInertialOdometry;
};

struct Heartbeat {
  std::uint32_t custom_mode = 0;
  std::uint8_t type = kTypeOnboardController;
  std::uint8_t autopilot = kAutopilotInvalid;
  std::uint8_t base_mode = 0;
  std::uint8_t system_status = kStateActive;
  std::uint8_t mavlink_version = kProtocolVersion;
};

// The ODOMETRY fields as MAVLink defines them (units m, rad, m/s, rad/s, us; % for quality).
struct Odometry {
  std::uint64_t time_usec = 0;
  std::array<float, 3> position{};          // x, y, z in frame_id
  std::array<float, 4> q{1, 0, 0, 0};       // w, x, y, z: child (body) -> frame_id
  std::array<float, 3> velocity{};          // vx, vy, vz
  std::array<float, 3> angular_velocity{};  // rollspeed, pitchspeed, yawspeed
  std::array<float, 21> pose_covariance{};  // upper-right triangle, row by row
  std::array<float, 21> velocity_covariance{};
  std::uint8_t frame_id = kFrameLocalFrd;
  std::uint8_t child_frame_id = kFrameBodyFrd;
  std::uint8_t reset_counter = 0;
  std::uint8_t estimator_type = kEstimatorVision;
  std::int8_t quality = 0;  // -1 failed, 0 unknown, 1 worst .. 100 best
};

// MAVLink's checksum step (crc_accumulate of the reference C library, X.25 / CRC-16/MCRF4XX:
// reflected polynomial 0x1021, initial 0xFFFF, no final xor) over bytes, continuing from crc.
std::uint16_t Crc16(std::span<const std::uint8_t> bytes, std::uint16_t crc = 0xFFFF);

// Each writes one complete packet to the front of out and returns its length in bytes
// (kHeaderBytes + truncated payload + kChecksumBytes).
std::size_t EncodeHeartbeat(const Heartbeat& m, const Header& h, std::span<std::uint8_t, kMaxPacketBytes> out);
std::size_t EncodeOdometry(const Odometry& m, const Header& h, std::span<std::uint8_t, kMaxPacketBytes> out);

}  // namespace mavlink

// How the station world frame w and the body frame b are handed to MAVLink, whose frames are
// FRD (docs/navd.md "MAVLink"). Indexed by --mavlink-frame.
enum class MavlinkAxes : unsigned char {
  kFrd = 0,  // w and b are already x forward, y right, z down (the station convention, e.g. the
             // ISS analysis frame: x forward, y starboard, z nadir): sent as they are
  kFlu,      // w and b are x forward, y left, z up: both turned half a turn about x (y, z negated)
  kCount
};
const char* ToString(MavlinkAxes a);  // "frd", "flu"

struct MavlinkConfig {
  std::uint8_t system_id = 1;
  std::uint8_t component_id = mavlink::kCompVisualInertialOdometry;
  MavlinkAxes axes = MavlinkAxes::kFrd;
};

// The ODOMETRY of a pose record with a pose (status fix or degraded): time_usec = t_capture_ns
// / 1000; position r_w_wb and q of C_w_b (w >= 0) in MAV_FRAME_LOCAL_FRD / MAV_FRAME_BODY_FRD
// after the axes mapping; pose_covariance the record's covariance of [dr_w; dtheta_b] turned
// to [dr; dtheta about the local frame's axes] (dtheta_w = C_w_b dtheta_b), m^2 and rad^2;
// velocities and their covariance NaN (not estimated); quality 100 for a fix, 50 degraded.
mavlink::Odometry OdometryOf(const PoseRecord& r, MavlinkAxes axes, std::uint8_t reset_counter);

// One MAVLink output's state: sequence, reset counter, heartbeat schedule. Per frame set, Next
// gives the packets to send for its pose record:
//   - a HEARTBEAT at the first record and then at whole seconds of sample time after it (the
//     first frame set at or after each; t_capture_ns: on the board the driver's clock, in a
//     replay the recording's, so that a replay faster than real time still shows 1 Hz per
//     second of data); a record without a sample time (no camera delivered) uses t_publish_ns
//     (CLOCK_MONOTONIC), 1 s after the last heartbeat, so a flyer whose cameras all stopped
//     still says it is alive. system_status ACTIVE with a pose, CRITICAL when lost.
//   - an ODOMETRY unless the record is lost (lost: nothing, the autopilot times the source out).
//     reset_counter counts the poses that follow a lost stretch (a re-acquired track may jump).
class MavlinkStream {
 public:
  MavlinkStream() = default;
  explicit MavlinkStream(const MavlinkConfig& config) : config_(config) {}

  int Next(const PoseRecord& r);  // number of packets, 0..2
  std::span<const std::uint8_t> packet(int i) const {
    return std::span<const std::uint8_t>(packets_[static_cast<std::size_t>(i)]).first(sizes_[static_cast<std::size_t>(i)]);
  }
  std::uint8_t reset_counter() const { return reset_counter_; }

 private:
  static constexpr std::uint64_t kHeartbeatNs = 1'000'000'000;
  bool HeartbeatDue(const PoseRecord& r);
  void ScheduleHeartbeat(const PoseRecord& r);
  mavlink::Header NextHeader() { return {sequence_++, config_.system_id, config_.component_id}; }

  MavlinkConfig config_;
  std::uint8_t sequence_ = 0;
  std::uint8_t reset_counter_ = 0;
  bool had_pose_ = false, lost_since_pose_ = false;
  bool heartbeat_sent_ = false;
  std::uint64_t next_heartbeat_sample_ns_ = 0;  // 0: none on the sample clock yet
  std::uint64_t last_heartbeat_monotonic_ns_ = 0;
  std::array<std::array<std::uint8_t, mavlink::kMaxPacketBytes>, 2> packets_{};
  std::array<std::size_t, 2> sizes_{};
};

}  // namespace mfns::fw
