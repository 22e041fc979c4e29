#include "firmware/modules/publish/mavlink.h"

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>

#include "common/wire/byte_io.h"

namespace mfns::fw {
namespace mavlink {
namespace {

static_assert(4 + 5 * 1 == kHeartbeatPayloadBytes, "HEARTBEAT payload layout");
static_assert(8 + 3 * 4 + 4 * 4 + 6 * 4 + 2 * 21 * 4 + 2 * 1 + 3 * 1 == kOdometryPayloadBytes, "ODOMETRY payload layout");
static_assert(kMaxPacketBytes == 245, "the largest packet is an untruncated ODOMETRY");
static_assert(kOdometryPayloadBytes <= 255, "a MAVLink payload length is one byte");

// Header, the payload already written at kHeaderBytes, truncation and checksum. MAVLink 2
// drops the payload's trailing zero bytes (the receiver zero-fills them) but keeps the first.
std::size_t Seal(std::uint32_t message_id, std::uint8_t crc_extra, std::size_t payload_bytes, const Header& h,
                 std::span<std::uint8_t, kMaxPacketBytes> out) {
  std::size_t len = payload_bytes;
  while (len > 1 && out[kHeaderBytes + len - 1] == 0) --len;
  out[0] = kStx;
  out[1] = static_cast<std::uint8_t>(len);
  out[2] = 0;  // incompat_flags: not signed
  out[3] = 0;  // compat_flags
  out[4] = h.sequence;
  out[5] = h.system_id;
  out[6] = h.component_id;
  out[7] = static_cast<std::uint8_t>(message_id);
  out[8] = static_cast<std::uint8_t>(message_id >> 8);
  out[9] = static_cast<std::uint8_t>(message_id >> 16);
  const std::span<const std::uint8_t> covered(out.data() + 1, kHeaderBytes - 1 + len);
  const std::array<std::uint8_t, 1> extra = {crc_extra};
  const std::uint16_t crc = Crc16(extra, Crc16(covered));
  out[kHeaderBytes + len] = static_cast<std::uint8_t>(crc);
  out[kHeaderBytes + len + 1] = static_cast<std::uint8_t>(crc >> 8);
  return kHeaderBytes + len + kChecksumBytes;
}

std::span<std::uint8_t> Payload(std::span<std::uint8_t, kMaxPacketBytes> out, std::size_t bytes) {
  return std::span<std::uint8_t>(out).subspan(kHeaderBytes, bytes);
}

}  // namespace

std::uint16_t Crc16(std::span<const std::uint8_t> bytes, std::uint16_t crc) {
  for (const std::uint8_t b : bytes) {
    std::uint8_t tmp = static_cast<std::uint8_t>(b ^ static_cast<std::uint8_t>(crc & 0xFF));
    tmp = static_cast<std::uint8_t>(tmp ^ (tmp << 4));
    crc = static_cast<std::uint16_t>((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4));
  }
  return crc;
}

std::size_t EncodeHeartbeat(const Heartbeat& m, const Header& h, std::span<std::uint8_t, kMaxPacketBytes> out) {
  wire::ByteWriter w(Payload(out, kHeartbeatPayloadBytes));
  w.U32(m.custom_mode);
  w.U8(m.type);
  w.U8(m.autopilot);
  w.U8(m.base_mode);
  w.U8(m.system_status);
  w.U8(m.mavlink_version);
  return Seal(kHeartbeatId, kHeartbeatCrcExtra, kHeartbeatPayloadBytes, h, out);
}

std::size_t EncodeOdometry(const Odometry& m, const Header& h, std::span<std::uint8_t, kMaxPacketBytes> out) {
  wire::ByteWriter w(Payload(out, kOdometryPayloadBytes));
  w.U64(m.time_usec);
  for (const float v : m.position) w.F32(v);
  for (const float v : m.q) w.F32(v);
  for (const float v : m.velocity) w.F32(v);
  for (const float v : m.angular_velocity) w.F32(v);
  for (const float v : m.pose_covariance) w.F32(v);
  for (const float v : m.velocity_covariance) w.F32(v);
  w.U8(m.frame_id);
  w.U8(m.child_frame_id);
  w.U8(m.reset_counter);
  w.U8(m.estimator_type);
  w.U8(static_cast<std::uint8_t>(m.quality));
  return Seal(kOdometryId, kOdometryCrcExtra, kOdometryPayloadBytes, h, out);
}

}  // namespace mavlink

const char* ToString(MavlinkAxes a) {
  switch (a) {
    case MavlinkAxes::kFrd: return "frd";
    case MavlinkAxes::kFlu: return "flu";
    case MavlinkAxes::kCount: break;
  }
  return "unknown";
}

mavlink::Odometry OdometryOf(const PoseRecord& r, MavlinkAxes axes, std::uint8_t reset_counter) {
  // T maps MFNS axes to FRD; a proper rotation (det +1), so it maps rotation vectors as vectors.
  const Eigen::Vector3d t = axes == MavlinkAxes::kFlu ? Eigen::Vector3d(1, -1, -1) : Eigen::Vector3d(1, 1, 1);
  const Eigen::Matrix3d T = t.asDiagonal();
  const Eigen::Matrix3d C_w_b = r.q_w_b.normalized().toRotationMatrix();
  const Eigen::Matrix3d C_l_c = T * C_w_b * T;  // child (body FRD) -> local FRD; T^-1 = T
  Eigen::Quaterniond q(C_l_c);
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  // [dr_w; dtheta_b] -> [dr_l; dtheta_l]: the body-frame angle error turned to the local axes.
  Eigen::Matrix<double, 6, 6> J = Eigen::Matrix<double, 6, 6>::Zero();
  J.topLeftCorner<3, 3>() = T;
  J.bottomRightCorner<3, 3>() = T * C_w_b;
  const Eigen::Matrix<double, 6, 6> P = J * r.covariance * J.transpose();

  mavlink::Odometry m;
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  m.time_usec = r.t_capture_ns / 1000;
  const Eigen::Vector3d p = T * r.r_w_wb;
  for (int i = 0; i < 3; ++i) m.position[static_cast<std::size_t>(i)] = static_cast<float>(p[i]);
  m.q = {static_cast<float>(q.w()), static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
  m.velocity.fill(kNan);  // not estimated: NaN is MAVLink's "unknown"
  m.angular_velocity.fill(kNan);
  m.velocity_covariance.fill(kNan);
  std::size_t k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) m.pose_covariance[k++] = static_cast<float>(0.5 * (P(i, j) + P(j, i)));
  m.reset_counter = reset_counter;
  m.quality = r.status == NavStatus::kFix ? 100 : 50;
  return m;
}

bool MavlinkStream::HeartbeatDue(const PoseRecord& r) {
  if (!heartbeat_sent_) return true;
  if (r.t_capture_ns == 0)  // no sample time: the monotonic clock keeps the heartbeat going
    return r.t_publish_ns < last_heartbeat_monotonic_ns_ || r.t_publish_ns - last_heartbeat_monotonic_ns_ >= kHeartbeatNs;
  // The first sample time, or a clock that went back (a driver restart): due now.
  if (next_heartbeat_sample_ns_ == 0 || r.t_capture_ns + kHeartbeatNs < next_heartbeat_sample_ns_) return true;
  return r.t_capture_ns >= next_heartbeat_sample_ns_;
}

// The sample-time schedule steps by whole seconds from the first heartbeat, so that a frame
// period that does not divide a second (18.6 Hz) still gives 1 Hz on average rather than one
// heartbeat every 19 frame sets (1.02 s); after a gap it restarts from now, without a burst.
void MavlinkStream::ScheduleHeartbeat(const PoseRecord& r) {
  heartbeat_sent_ = true;
  last_heartbeat_monotonic_ns_ = r.t_publish_ns;
  if (r.t_capture_ns == 0) return;
  const bool on_grid = next_heartbeat_sample_ns_ != 0 && r.t_capture_ns >= next_heartbeat_sample_ns_ &&
                       r.t_capture_ns < next_heartbeat_sample_ns_ + kHeartbeatNs;
  next_heartbeat_sample_ns_ = (on_grid ? next_heartbeat_sample_ns_ : r.t_capture_ns) + kHeartbeatNs;
}

int MavlinkStream::Next(const PoseRecord& r) {
  int n = 0;
  const bool lost = r.status == NavStatus::kLost;
  if (HeartbeatDue(r)) {
    mavlink::Heartbeat hb;
    hb.system_status = lost ? mavlink::kStateCritical : mavlink::kStateActive;
    sizes_[0] = mavlink::EncodeHeartbeat(hb, NextHeader(), packets_[0]);
    ScheduleHeartbeat(r);
    ++n;
  }
  if (lost) {
    lost_since_pose_ = had_pose_;
    return n;
  }
  if (lost_since_pose_) ++reset_counter_;  // a new track after a lost stretch (wraps at 256)
  lost_since_pose_ = false;
  had_pose_ = true;
  const auto i = static_cast<std::size_t>(n);
  sizes_[i] = mavlink::EncodeOdometry(OdometryOf(r, config_.axes, reset_counter_), NextHeader(), packets_[i]);
  return n + 1;
}

}  // namespace mfns::fw
