// MAVLink 2 out (issue 17): bytes against hand-checked fields, the checksum against a CRC
// written here independently (bit by bit, from the CRC-16/MCRF4XX parameters), CRC_EXTRA
// derived from the message definitions, the pose -> ODOMETRY mapping, the stream's schedule.
#include "firmware/modules/publish/mavlink.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <bit>
#include <cmath>
#include <string>
#include <vector>

#include "common/rotation/rotation.h"
#include "common/testing/loopback_udp.h"
#include "common/wire/byte_io.h"
#include "firmware/modules/publish/publishers.h"

namespace mfns::fw {
namespace {

using Packet = std::array<std::uint8_t, mavlink::kMaxPacketBytes>;

// CRC-16/MCRF4XX (X.25 as MAVLink uses it): reflected poly 0x1021 = 0x8408, init 0xFFFF, no
// final xor; bit by bit, unlike the table-free byte step of mavlink.cc.
std::uint16_t ReferenceCrc(const std::vector<std::uint8_t>& bytes, std::uint16_t crc = 0xFFFF) {
  for (const std::uint8_t b : bytes) {
    crc ^= b;
    for (int i = 0; i < 8; ++i) crc = (crc & 1) != 0 ? static_cast<std::uint16_t>((crc >> 1) ^ 0x8408) : crc >> 1;
  }
  return crc;
}

std::vector<std::uint8_t> Bytes(const std::string& s) { return {s.begin(), s.end()}; }

// The checksum a receiver computes: over bytes 1 .. end of payload, then CRC_EXTRA.
std::uint16_t ReceiverCrc(const Packet& p, std::size_t size, std::uint8_t crc_extra) {
  std::vector<std::uint8_t> covered(p.begin() + 1, p.begin() + static_cast<long>(size - 2));
  covered.push_back(crc_extra);
  return ReferenceCrc(covered);
}

float F32At(const Packet& p, std::size_t payload_offset) {
  return std::bit_cast<float>(static_cast<std::uint32_t>(wire::LoadLe(p, mavlink::kHeaderBytes + payload_offset, 4)));
}

TEST(MavlinkCrc, IsCrc16Mcrf4xx) {
  const std::vector<std::uint8_t> check = Bytes("123456789");
  EXPECT_EQ(ReferenceCrc(check), 0x6F91);  // the catalogued check value of CRC-16/MCRF4XX
  EXPECT_EQ(mavlink::Crc16(check), 0x6F91);
  std::vector<std::uint8_t> data(300);
  for (std::size_t i = 0; i < data.size(); ++i) data[i] = static_cast<std::uint8_t>(i * 37 + 11);
  EXPECT_EQ(mavlink::Crc16(data), ReferenceCrc(data));
}

// CRC_EXTRA as the MAVLink generator derives it: the CRC of "NAME ", then of "type name " per
// base field (extensions excluded) in wire order, then of the array length byte for an array;
// folded to a byte. The fields are those of common.xml / minimal.xml.
std::uint8_t CrcExtra(const std::string& name, const std::vector<std::pair<std::string, int>>& fields) {
  std::vector<std::uint8_t> in = Bytes(name + " ");
  for (const auto& [type_name, array] : fields) {
    const std::vector<std::uint8_t> f = Bytes(type_name + " ");
    in.insert(in.end(), f.begin(), f.end());
    if (array > 0) in.push_back(static_cast<std::uint8_t>(array));
  }
  const std::uint16_t crc = ReferenceCrc(in);
  return static_cast<std::uint8_t>((crc & 0xFF) ^ (crc >> 8));
}

TEST(MavlinkCrcExtra, DerivedFromTheMessageDefinitions) {
  EXPECT_EQ(CrcExtra("HEARTBEAT", {{"uint32_t custom_mode", 0}, {"uint8_t type", 0}, {"uint8_t autopilot", 0},
                                   {"uint8_t base_mode", 0}, {"uint8_t system_status", 0},
                                   {"uint8_t mavlink_version", 0}}),
            mavlink::kHeartbeatCrcExtra);
  EXPECT_EQ(CrcExtra("ODOMETRY", {{"uint64_t time_usec", 0}, {"float x", 0}, {"float y", 0}, {"float z", 0},
                                  {"float q", 4}, {"float vx", 0}, {"float vy", 0}, {"float vz", 0},
                                  {"float rollspeed", 0}, {"float pitchspeed", 0}, {"float yawspeed", 0},
                                  {"float pose_covariance", 21}, {"float velocity_covariance", 21},
                                  {"uint8_t frame_id", 0}, {"uint8_t child_frame_id", 0}}),
            mavlink::kOdometryCrcExtra);
  EXPECT_EQ(mavlink::kHeartbeatCrcExtra, 50);
  EXPECT_EQ(mavlink::kOdometryCrcExtra, 91);
}

TEST(MavlinkHeartbeat, BytesByHand) {
  Packet p{};
  mavlink::Heartbeat hb;
  hb.system_status = mavlink::kStateActive;
  const std::size_t n = mavlink::EncodeHeartbeat(hb, {7, 1, 197}, p);
  ASSERT_EQ(n, 10u + 9u + 2u);
  const std::vector<std::uint8_t> want = {0xFD, 9,    0, 0, 7, 1, 197, 0, 0, 0,   // header, msgid 0
                                          0,    0,    0, 0,                       // custom_mode
                                          18,   8,    0, 4, 3};                    // type .. mavlink_version
  EXPECT_EQ(std::vector<std::uint8_t>(p.begin(), p.begin() + 19), want);
  const std::uint16_t crc = ReceiverCrc(p, n, 50);
  EXPECT_EQ(p[19], crc & 0xFF);
  EXPECT_EQ(p[20], crc >> 8);
}

TEST(MavlinkOdometry, BytesByHand) {
  mavlink::Odometry m;
  m.time_usec = 0x0102030405060708ull;
  m.position = {1.5f, -2.0f, 0.25f};
  m.q = {0.5f, -0.5f, 0.5f, -0.5f};
  m.velocity = {NAN, NAN, NAN};
  m.angular_velocity = {NAN, NAN, NAN};
  for (std::size_t i = 0; i < 21; ++i) m.pose_covariance[i] = static_cast<float>(i + 1) * 1e-3f;
  m.velocity_covariance.fill(NAN);
  m.reset_counter = 3;
  m.quality = 100;
  Packet p{};
  const std::size_t n = mavlink::EncodeOdometry(m, {200, 42, 197}, p);
  ASSERT_EQ(n, 10u + 233u + 2u);  // quality (the last byte) is not zero: nothing truncated
  EXPECT_EQ(p[0], 0xFD);
  EXPECT_EQ(p[1], 233);
  EXPECT_EQ(p[4], 200);
  EXPECT_EQ(p[5], 42);
  EXPECT_EQ(p[6], 197);
  EXPECT_EQ(wire::LoadLe(p, 7, 3), 331u);
  EXPECT_EQ(wire::LoadLe(p, 10, 8), 0x0102030405060708ull);
  EXPECT_EQ(p[10], 0x08);  // little-endian
  EXPECT_EQ(F32At(p, 8), 1.5f);
  EXPECT_EQ(F32At(p, 12), -2.0f);
  EXPECT_EQ(F32At(p, 16), 0.25f);
  EXPECT_EQ(F32At(p, 20), 0.5f);   // q w
  EXPECT_EQ(F32At(p, 24), -0.5f);  // q x
  EXPECT_EQ(F32At(p, 32), -0.5f);  // q z
  for (std::size_t off = 36; off < 60; off += 4) EXPECT_TRUE(std::isnan(F32At(p, off))) << off;
  EXPECT_EQ(F32At(p, 60), 1e-3f);
  EXPECT_EQ(F32At(p, 60 + 20 * 4), m.pose_covariance[20]);
  EXPECT_TRUE(std::isnan(F32At(p, 144)));
  EXPECT_EQ(p[10 + 228], 20);  // MAV_FRAME_LOCAL_FRD
  EXPECT_EQ(p[10 + 229], 12);  // MAV_FRAME_BODY_FRD
  EXPECT_EQ(p[10 + 230], 3);
  EXPECT_EQ(p[10 + 231], 2);  // MAV_ESTIMATOR_TYPE_VISION
  EXPECT_EQ(p[10 + 232], 100);
  const std::uint16_t crc = ReceiverCrc(p, n, 91);
  EXPECT_EQ(wire::LoadLe(p, n - 2, 2), crc);
  // A negative quality is the int8 byte.
  m.quality = -1;
  mavlink::EncodeOdometry(m, {0, 1, 1}, p);
  EXPECT_EQ(p[10 + 232], 0xFF);
}

// MAVLink 2 drops the trailing zero bytes of a payload, never its first byte; the checksum
// covers the truncated payload.
TEST(MavlinkOdometry, TrailingZerosTruncated) {
  mavlink::Odometry m;
  m.q = {0, 0, 0, 0};
  m.frame_id = m.child_frame_id = m.estimator_type = 0;
  m.time_usec = 0;
  Packet p{};
  p.fill(0xAA);
  std::size_t n = mavlink::EncodeOdometry(m, {}, p);
  EXPECT_EQ(n, 10u + 1u + 2u);  // all zero: the first byte stays
  EXPECT_EQ(p[1], 1);
  EXPECT_EQ(wire::LoadLe(p, 11, 2), ReceiverCrc(p, n, 91));
  m.position[1] = 1.0f;  // bytes 12..15: 00 00 80 3F
  n = mavlink::EncodeOdometry(m, {}, p);
  EXPECT_EQ(p[1], 16);
  EXPECT_EQ(wire::LoadLe(p, 10 + 16, 2), ReceiverCrc(p, n, 91));
  m.estimator_type = mavlink::kEstimatorVision;  // quality 0 (unknown) is dropped
  n = mavlink::EncodeOdometry(m, {}, p);
  EXPECT_EQ(p[1], 232);
  EXPECT_EQ(n, 10u + 232u + 2u);
}

PoseRecord Fix(const Eigen::Matrix3d& C_w_b, const Eigen::Vector3d& r_w_wb) {
  PoseRecord r;
  r.status = NavStatus::kFix;
  r.reason = NavReason::kNone;
  r.t_capture_ns = 1'234'567'891'234ull;
  r.r_w_wb = r_w_wb;
  r.q_w_b = Eigen::Quaterniond(C_w_b);
  return r;
}

// Upper-right triangle index of (i, j), i <= j, row by row: MAVLink's pose_covariance order.
std::size_t Ut(int i, int j) { return static_cast<std::size_t>(i * 6 - i * (i - 1) / 2 + (j - i)); }

// The body yawed +90 deg: its x axis along the world's y (p_w = C_w_b p_b).
const Eigen::Matrix3d kYaw90 = (Eigen::Matrix3d() << 0, -1, 0, 1, 0, 0, 0, 0, 1).finished();

// A fix of the yawed body at (1, -2, 3.5) m with variances of dr_w (1, 2, 3) and of dtheta_b about
// the body axes (4, 5, 6) (1e-6 m^2, rad^2), and one cross term 0.5e-6 at (i, j).
PoseRecord YawedFix(int i, int j) {
  PoseRecord r = Fix(kYaw90, Eigen::Vector3d(1.0, -2.0, 3.5));
  r.covariance.setZero();
  r.covariance.diagonal() << 1e-6, 2e-6, 3e-6, 4e-6, 5e-6, 6e-6;
  r.covariance(i, j) = r.covariance(j, i) = 0.5e-6;
  return r;
}

TEST(MavlinkOdometry, OfAPoseRecordFrd) {
  PoseRecord r = YawedFix(0, 3);  // the cross term: dr_w x with dtheta_b x
  const mavlink::Odometry m = OdometryOf(r, MavlinkAxes::kFrd, 7);
  EXPECT_EQ(m.time_usec, 1'234'567'891ull);
  EXPECT_EQ(m.position[0], 1.0f);
  EXPECT_EQ(m.position[1], -2.0f);
  EXPECT_EQ(m.position[2], 3.5f);
  // Hamilton quaternion of C_w_b, (w, x, y, z): +90 deg about z.
  EXPECT_NEAR(m.q[0], std::sqrt(0.5), 1e-7);
  EXPECT_NEAR(m.q[1], 0.0, 1e-7);
  EXPECT_NEAR(m.q[2], 0.0, 1e-7);
  EXPECT_NEAR(m.q[3], std::sqrt(0.5), 1e-7);
  EXPECT_EQ(m.frame_id, mavlink::kFrameLocalFrd);
  EXPECT_EQ(m.child_frame_id, mavlink::kFrameBodyFrd);
  // Angles about the local axes: body x is local y, body y is local -x.
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(0, 0)], 1e-6f);
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(1, 1)], 2e-6f);
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(2, 2)], 3e-6f);
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(3, 3)], 5e-6f);
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(4, 4)], 4e-6f);
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(5, 5)], 6e-6f);
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(0, 4)], 0.5e-6f);  // x with the angle about local y
  EXPECT_NEAR(m.pose_covariance[Ut(0, 3)], 0.0f, 1e-12f);
  EXPECT_TRUE(std::isnan(m.velocity[0]) && std::isnan(m.angular_velocity[2]));
  EXPECT_TRUE(std::isnan(m.velocity_covariance[0]));
  EXPECT_EQ(m.reset_counter, 7);
  EXPECT_EQ(m.estimator_type, mavlink::kEstimatorVision);
  EXPECT_EQ(m.quality, 100);
  r.status = NavStatus::kDegraded;
  EXPECT_EQ(OdometryOf(r, MavlinkAxes::kFrd, 0).quality, 50);
}

// flu: x forward, y left, z up, turned half a turn about x into FRD.
TEST(MavlinkOdometry, OfAPoseRecordFlu) {
  const PoseRecord r = YawedFix(1, 2);  // the cross term: dr_w y with dr_w z
  const mavlink::Odometry m = OdometryOf(r, MavlinkAxes::kFlu, 0);
  EXPECT_EQ(m.position[0], 1.0f);
  EXPECT_EQ(m.position[1], 2.0f);
  EXPECT_EQ(m.position[2], -3.5f);
  // A left turn about z up is a turn of -90 deg about z down.
  EXPECT_NEAR(m.q[0], std::sqrt(0.5), 1e-7);
  EXPECT_NEAR(m.q[3], -std::sqrt(0.5), 1e-7);
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(1, 2)], 0.5e-6f);  // y and z both negated: sign kept
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(3, 3)], 5e-6f);
  EXPECT_FLOAT_EQ(m.pose_covariance[Ut(4, 4)], 4e-6f);
}

// The covariance's attitude block, the attitude error turned from body to local axes, matches
// a perturbation: C_w_b Exp(dtheta_b) = Exp(C_w_b dtheta_b) C_w_b.
TEST(MavlinkOdometry, AttitudeCovarianceIsAboutTheLocalAxes) {
  const Eigen::Matrix3d C_w_b = ExpSO3(Eigen::Vector3d(0.3, -0.7, 1.1));
  const Eigen::Vector3d dtheta_b(1e-3, -2e-3, 0.5e-3);
  const Eigen::Vector3d dtheta_w = LogSO3(C_w_b * ExpSO3(dtheta_b) * C_w_b.transpose());
  PoseRecord r = Fix(C_w_b, Eigen::Vector3d::Zero());
  r.covariance.setZero();
  r.covariance.bottomRightCorner<3, 3>() = dtheta_b * dtheta_b.transpose();  // rank one along dtheta_b
  const mavlink::Odometry m = OdometryOf(r, MavlinkAxes::kFrd, 0);
  for (int i = 0; i < 3; ++i)
    for (int j = i; j < 3; ++j)
      EXPECT_NEAR(m.pose_covariance[Ut(3 + i, 3 + j)], dtheta_w[i] * dtheta_w[j], 1e-11) << i << j;
}

PoseRecord At(NavStatus s, std::uint64_t t_ns) {
  PoseRecord r = Fix(Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 2, 3));
  r.status = s;
  r.t_capture_ns = t_ns;
  r.t_publish_ns = 5'000'000'000ull + t_ns;
  return r;
}

std::uint32_t MessageId(std::span<const std::uint8_t> p) { return static_cast<std::uint32_t>(wire::LoadLe(p, 7, 3)); }

// HEARTBEAT at the first record and every second of sample time; ODOMETRY unless lost; the
// sequence counts every packet; reset_counter counts the tracks after a lost stretch.
TEST(MavlinkStream, HeartbeatPerSecondOfSampleTimeOdometryUnlessLost) {
  MavlinkStream s({9, 197, MavlinkAxes::kFrd});
  constexpr std::uint64_t kPeriod = 50'000'000, kT0 = 10'000'000'000;
  std::string kinds;
  int expected_seq = 0;
  for (int i = 0; i < 80; ++i) {
    const bool lost = i >= 30 && i < 35;
    const int n = s.Next(At(lost ? NavStatus::kLost : NavStatus::kFix, kT0 + static_cast<std::uint64_t>(i) * kPeriod));
    for (int k = 0; k < n; ++k) {
      const auto p = s.packet(k);
      EXPECT_EQ(p[4], expected_seq++ & 0xFF);
      EXPECT_EQ(p[5], 9);
      const bool hb = MessageId(p) == mavlink::kHeartbeatId;
      kinds += hb ? 'H' : 'O';
      if (hb) {
        EXPECT_EQ(p[10 + 7], lost ? mavlink::kStateCritical : mavlink::kStateActive);
      } else {
        EXPECT_EQ(p[10 + 230], i < 30 ? 0 : 1) << i;  // reset_counter
      }
    }
  }
  // 20 frame sets per second: heartbeats at 0, 20, 40 (lost: no odometry), 60.
  std::string want;
  for (int i = 0; i < 80; ++i) {
    if (i % 20 == 0) want += 'H';
    if (i < 30 || i >= 35) want += 'O';
  }
  EXPECT_EQ(kinds, want);
  EXPECT_EQ(s.reset_counter(), 1);
}

// A record with no sample time (no camera delivered) keeps the heartbeat on the monotonic clock.
TEST(MavlinkStream, HeartbeatWithoutFramesOnTheMonotonicClock) {
  MavlinkStream s;
  int heartbeats = 0;
  for (int i = 0; i < 25; ++i) {
    PoseRecord r = At(NavStatus::kLost, 0);
    r.t_publish_ns = 1'000'000'000 + static_cast<std::uint64_t>(i) * 200'000'000;  // 5 Hz
    const int n = s.Next(r);
    ASSERT_LE(n, 1);
    heartbeats += n;
  }
  EXPECT_EQ(heartbeats, 5);  // at 0, 1, 2, 3, 4 s
}

TEST(Outputs, RefusesUnknownSchemesAndMoreThanTheLimit) {
  Outputs o;
  for (const char* bad : {"tcp://127.0.0.1:5000", "mavlink://127.0.0.1:5000", "mavlink+tcp://h:1", "127.0.0.1:1", ""})
    EXPECT_EQ(o.Add(bad), PublishStatus::kBadScheme) << bad;
  EXPECT_EQ(o.Add("mavlink+udp://127.0.0.1"), PublishStatus::kBadAddress);
  for (int i = 0; i < limits::kMaxOutputs; ++i) EXPECT_EQ(o.Add("mavlink+udp://127.0.0.1:9"), PublishStatus::kOk);
  EXPECT_EQ(o.Add("udp://127.0.0.1:9"), PublishStatus::kTooMany);
  EXPECT_EQ(o.count(), limits::kMaxOutputs);
  EXPECT_FALSE(o.wants_health());
}


// Both protocols at once: the MFNS datagrams to one socket, MAVLink to another.
TEST(Outputs, MfnsAndMavlinkAtOnceOnLoopback) {
  std::string mfns_port, mav_port;
  const int mfns = ::mfns::testing::LoopbackUdpSocket(&mfns_port, 2), mav = ::mfns::testing::LoopbackUdpSocket(&mav_port, 2);
  ASSERT_GE(mfns, 0);
  ASSERT_GE(mav, 0);
  Outputs o;
  ASSERT_EQ(o.Add(("udp://127.0.0.1:" + mfns_port).c_str()), PublishStatus::kOk);
  ASSERT_EQ(o.Add(("mavlink+udp://127.0.0.1:" + mav_port).c_str(), {3, 197, MavlinkAxes::kFrd}), PublishStatus::kOk);
  EXPECT_TRUE(o.wants_health());
  EXPECT_EQ(o.protocol(1), OutputProtocol::kMavlink);
  o.Pose(At(NavStatus::kFix, 2'000'000'000));
  o.Health(HealthRecord{});
  std::array<std::uint8_t, 512> buf{};
  EXPECT_EQ(::recv(mfns, buf.data(), buf.size(), 0), static_cast<ssize_t>(kPoseMessageBytes));
  EXPECT_EQ(::recv(mfns, buf.data(), buf.size(), 0), static_cast<ssize_t>(kHealthMessageBytes));
  ssize_t n = ::recv(mav, buf.data(), buf.size(), 0);
  ASSERT_GT(n, 10);
  EXPECT_EQ(MessageId(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n))), mavlink::kHeartbeatId);
  n = ::recv(mav, buf.data(), buf.size(), 0);
  ASSERT_GT(n, 10);
  EXPECT_EQ(MessageId(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n))), mavlink::kOdometryId);
  EXPECT_EQ(buf[5], 3);
  EXPECT_EQ(o.counters(1).sent, 2u);
  ::close(mfns);
  ::close(mav);
}

}  // namespace
}  // namespace mfns::fw
