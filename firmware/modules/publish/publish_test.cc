#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <limits>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "common/rotation/rotation.h"
#include "common/wire/byte_io.h"
#include "firmware/modules/publish/pose_message.h"
#include "firmware/modules/publish/publishers.h"
#include "common/blob/param_blob.h"

namespace mfns::fw {
namespace {

PoseRecord SampleRecord(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  PoseRecord r;
  r.sequence = static_cast<std::uint32_t>(rng());
  r.frame_set = static_cast<std::uint32_t>(rng());
  r.t_capture_ns = rng();
  r.t_publish_ns = rng();
  r.param_generation = rng();
  r.status = NavStatus::kDegraded;
  r.reason = NavReason::kLargeResidual;
  r.num_cameras = 3;
  r.num_beacons = 5;
  r.beacons_per_camera = {2, 1, 2, 0};
  r.r_w_wb = Eigen::Vector3d(u(rng), u(rng), u(rng));
  r.q_w_b = Eigen::Quaterniond(ExpSO3(Eigen::Vector3d(u(rng), u(rng), u(rng))));
  r.euler_deg = Eigen::Vector3f(1.5f, -2.25f, 170.0f);
  r.residual_rms_px = 0.125f;
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Random();
  r.covariance = A * A.transpose() * 1e-6;
  return r;
}

TEST(PoseMessage, RoundTripAndLayout) {
  std::mt19937_64 rng(3);
  for (int i = 0; i < 200; ++i) {
    const PoseRecord r = SampleRecord(rng);
    std::array<std::uint8_t, kPoseMessageBytes> bytes{};
    EncodePose(r, bytes);
    // Spot checks of the documented offsets, read independently of the decoder.
    EXPECT_EQ(std::string(bytes.begin(), bytes.begin() + 4), "MFNP");
    EXPECT_EQ(wire::LoadLe(bytes, 6, 2), kPoseMessageBytes);
    EXPECT_EQ(wire::LoadLe(bytes, 16, 8), r.t_capture_ns);
    EXPECT_EQ(bytes[40], 1);  // degraded
    EXPECT_EQ(std::bit_cast<double>(wire::LoadLe(bytes, 48, 8)), r.r_w_wb.x());
    PoseRecord back;
    ASSERT_EQ(DecodePose(bytes, &back), MessageStatus::kOk);
    EXPECT_EQ(back.sequence, r.sequence);
    EXPECT_EQ(back.frame_set, r.frame_set);
    EXPECT_EQ(back.t_publish_ns, r.t_publish_ns);
    EXPECT_EQ(back.param_generation, r.param_generation);
    EXPECT_EQ(back.status, r.status);
    EXPECT_EQ(back.reason, r.reason);
    EXPECT_EQ(back.beacons_per_camera, r.beacons_per_camera);
    EXPECT_EQ(back.r_w_wb, r.r_w_wb);
    EXPECT_EQ(back.q_w_b.coeffs(), r.q_w_b.coeffs());
    EXPECT_EQ(back.euler_deg, r.euler_deg);
    EXPECT_EQ(back.residual_rms_px, r.residual_rms_px);
    EXPECT_LT((back.covariance - r.covariance).cwiseAbs().maxCoeff(), 1e-6 * r.covariance.cwiseAbs().maxCoeff());
    EXPECT_TRUE(back.covariance.isApprox(back.covariance.transpose()));
  }
}

TEST(PoseMessage, RejectsEveryCorruption) {
  std::mt19937_64 rng(4);
  std::array<std::uint8_t, kPoseMessageBytes> bytes{};
  EncodePose(SampleRecord(rng), bytes);
  PoseRecord r;
  for (std::size_t n = 0; n < bytes.size(); ++n)
    EXPECT_EQ(DecodePose(std::span<const std::uint8_t>(bytes.data(), n), &r), MessageStatus::kTruncated) << n;
  for (std::size_t i = 0; i < bytes.size(); ++i)
    for (int bit = 0; bit < 8; ++bit) {
      auto bad = bytes;
      bad[i] ^= static_cast<std::uint8_t>(1u << bit);
      EXPECT_NE(DecodePose(bad, &r), MessageStatus::kOk) << i << ":" << bit;
    }
  std::array<std::uint8_t, kHealthMessageBytes> health{};
  EncodeHealth(HealthRecord{}, health);
  EXPECT_EQ(DecodePose(health, &r), MessageStatus::kBadType);
}

TEST(HealthMessage, RoundTrip) {
  HealthRecord h;
  h.sequence = 7;
  h.frame_sets = 1234;
  h.t_ns = 99;
  h.param_generation = 42;
  h.fixes = 1000;
  h.degraded = 200;
  h.lost = 34;
  h.deadline_slips = 3;
  h.worst_frame_set_us = 45678;
  h.num_cameras = 3;
  CameraHealth& c = h.cameras[1];
  c.state = 1;
  c.frames = 100;
  c.drops = 2;
  c.timeouts = 3;
  c.errors = 4;
  c.bad_frames = 5;
  c.detect_errors = 6;
  c.blobs_last = 17;
  h.clock_faults = 8;
  h.log_errors = 9;
  h.trigger_errors = 10;
  std::array<std::uint8_t, kHealthMessageBytes> bytes{};
  EncodeHealth(h, bytes);
  // The documented layout (pose_message.h): version 2, size 184, camera 1 at 56 + 28.
  EXPECT_EQ(bytes[4], 2);
  EXPECT_EQ(wire::LoadLe(bytes, 6, 2), 184u);
  EXPECT_EQ(wire::LoadLe(bytes, 84 + 2, 2), 17u);
  EXPECT_EQ(wire::LoadLe(bytes, 84 + 20, 4), 5u);
  EXPECT_EQ(wire::LoadLe(bytes, 84 + 24, 4), 6u);
  EXPECT_EQ(wire::LoadLe(bytes, 168, 4), 8u);
  EXPECT_EQ(wire::LoadLe(bytes, 172, 4), 9u);
  EXPECT_EQ(wire::LoadLe(bytes, 176, 4), 10u);
  HealthRecord back;
  ASSERT_EQ(DecodeHealth(bytes, &back), MessageStatus::kOk);
  EXPECT_EQ(back.frame_sets, 1234u);
  EXPECT_EQ(back.worst_frame_set_us, 45678u);
  EXPECT_EQ(back.cameras[1].state, 1);
  EXPECT_EQ(back.cameras[1].frames, 100u);
  EXPECT_EQ(back.cameras[1].drops, 2u);
  EXPECT_EQ(back.cameras[1].timeouts, 3u);
  EXPECT_EQ(back.cameras[1].errors, 4u);
  EXPECT_EQ(back.cameras[1].bad_frames, 5u);
  EXPECT_EQ(back.cameras[1].detect_errors, 6u);
  EXPECT_EQ(back.cameras[1].blobs_last, 17);
  EXPECT_EQ(back.clock_faults, 8u);
  EXPECT_EQ(back.log_errors, 9u);
  EXPECT_EQ(back.trigger_errors, 10u);
  for (std::size_t n = 0; n < bytes.size(); ++n)
    EXPECT_NE(DecodeHealth(std::span<const std::uint8_t>(bytes.data(), n), &back), MessageStatus::kOk) << n;
  bytes[100] ^= 4;
  EXPECT_EQ(DecodeHealth(bytes, &back), MessageStatus::kBadCrc);
}

// A v1 health message (140 bytes: 20 bytes per camera, no fault totals), as firmware before
// the v2 layout sends it, still decodes; the fields it lacks read zero.
TEST(HealthMessage, DecodesVersion1) {
  std::array<std::uint8_t, kHealthMessageV1Bytes> v1{};
  wire::ByteWriter w(v1);
  w.Bytes(std::array<std::uint8_t, 4>{'M', 'F', 'N', 'P'});
  w.U8(1);
  w.U8(2);
  w.U16(140);
  w.U32(7);       // sequence
  w.U32(1234);    // frame_sets
  w.U64(99);      // t_ns
  w.U64(42);      // param_generation
  w.U32(1000);    // fixes
  w.U32(200);     // degraded
  w.U32(34);      // lost
  w.U32(3);       // slips
  w.U32(45678);   // worst
  w.U8(3);
  for (int i = 0; i < 3; ++i) w.U8(0);
  for (int k = 0; k < 4; ++k) {
    w.U8(k == 1 ? 1 : 0);
    w.U8(0);
    w.U16(k == 1 ? 17 : 0);
    for (std::uint32_t x : {100u, 2u, 3u, 4u}) w.U32(k == 1 ? x : 0u);
  }
  const std::uint32_t crc = Crc32(std::span<const std::uint8_t>(v1.data(), 136));
  wire::ByteWriter tail(std::span<std::uint8_t>(v1.data() + 136, 4));
  tail.U32(crc);
  HealthRecord back;
  back.clock_faults = 77;
  ASSERT_EQ(DecodeHealth(v1, &back), MessageStatus::kOk);
  EXPECT_EQ(back.frame_sets, 1234u);
  EXPECT_EQ(back.worst_frame_set_us, 45678u);
  EXPECT_EQ(back.cameras[1].frames, 100u);
  EXPECT_EQ(back.cameras[1].errors, 4u);
  EXPECT_EQ(back.cameras[1].blobs_last, 17);
  EXPECT_EQ(back.cameras[1].bad_frames, 0u);
  EXPECT_EQ(back.clock_faults, 0u);
  v1[50] ^= 1;
  EXPECT_EQ(DecodeHealth(v1, &back), MessageStatus::kBadCrc);
}

BlobsRecord SampleBlobs(int n) {
  BlobsRecord b;
  b.sequence = 9;
  b.frame_set = 1234;
  b.t_capture_ns = 987654321012ULL;
  b.num_cameras = 3;
  b.truncated = n == limits::kMaxBlobsInMessage;
  b.num_blobs = n;
  for (int i = 0; i < n; ++i)
    b.blobs[static_cast<std::size_t>(i)] = BlobEntry{static_cast<std::uint8_t>(i % 3), static_cast<std::int16_t>(i % 5 == 0 ? -1 : 200 + i),
                                                     0.5f + static_cast<float>(i), 1023.25f - static_cast<float>(i)};
  return b;
}

TEST(BlobsMessage, RoundTripAndLayout) {
  for (const int n : {0, 1, 7, limits::kMaxBlobsInMessage}) {
    const BlobsRecord in = SampleBlobs(n);
    std::array<std::uint8_t, kMaxBlobsMessageBytes> bytes{};
    const std::size_t size = EncodeBlobs(in, bytes);
    ASSERT_EQ(size, 32u + 12u * static_cast<std::size_t>(n));
    EXPECT_EQ(bytes[5], 3);
    EXPECT_EQ(bytes[6] | bytes[7] << 8, static_cast<int>(size));
    BlobsRecord out;
    ASSERT_EQ(DecodeBlobs(std::span<const std::uint8_t>(bytes.data(), size), &out), MessageStatus::kOk) << n;
    EXPECT_EQ(out.frame_set, in.frame_set);
    EXPECT_EQ(out.t_capture_ns, in.t_capture_ns);
    EXPECT_EQ(out.truncated, in.truncated);
    ASSERT_EQ(out.num_blobs, n);
    for (int i = 0; i < n; ++i) {
      const BlobEntry &a = in.blobs[static_cast<std::size_t>(i)], &b = out.blobs[static_cast<std::size_t>(i)];
      EXPECT_EQ(a.camera, b.camera);
      EXPECT_EQ(a.beacon, b.beacon);
      EXPECT_EQ(a.u_px, b.u_px);
      EXPECT_EQ(a.v_px, b.v_px);
    }
  }
}

TEST(BlobsMessage, RejectsEveryCorruptionAndFieldsOutOfRange) {
  std::array<std::uint8_t, kMaxBlobsMessageBytes> bytes{};
  const std::size_t size = EncodeBlobs(SampleBlobs(5), bytes);
  BlobsRecord r;
  for (std::size_t n = 0; n < size; ++n)
    EXPECT_NE(DecodeBlobs(std::span<const std::uint8_t>(bytes.data(), n), &r), MessageStatus::kOk) << n;
  EXPECT_EQ(DecodeBlobs(std::span<const std::uint8_t>(bytes.data(), size + 1), &r), MessageStatus::kBadSize);
  for (std::size_t i = 0; i < size; ++i)
    for (int bit = 0; bit < 8; ++bit) {
      auto bad = bytes;
      bad[i] ^= static_cast<std::uint8_t>(1u << bit);
      EXPECT_NE(DecodeBlobs(std::span<const std::uint8_t>(bad.data(), size), &r), MessageStatus::kOk) << i << ":" << bit;
    }
  // Fields out of range, with a valid CRC: a camera beyond num_cameras, a beacon below -1, a
  // centroid that is not finite; a count above the limit.
  for (int c = 0; c < 3; ++c) {
    BlobsRecord b = SampleBlobs(2);
    if (c == 0) b.blobs[1].camera = 3;
    if (c == 1) b.blobs[1].beacon = -2;
    if (c == 2) b.blobs[0].u_px = std::numeric_limits<float>::infinity();
    const std::size_t n = EncodeBlobs(b, bytes);
    EXPECT_EQ(DecodeBlobs(std::span<const std::uint8_t>(bytes.data(), n), &r), MessageStatus::kBadField) << c;
  }
  const std::size_t n = EncodeBlobs(SampleBlobs(1), bytes);
  bytes[24] = 129;  // n = 129 > kMaxBlobsInMessage, before any size arithmetic
  EXPECT_EQ(DecodeBlobs(std::span<const std::uint8_t>(bytes.data(), n), &r), MessageStatus::kBadSize);
  std::array<std::uint8_t, kPoseMessageBytes> pose{};
  EncodePose(PoseRecord{}, pose);
  EXPECT_EQ(DecodeBlobs(pose, &r), MessageStatus::kBadType);
}

BeaconHealthRecord SampleBeaconHealth(int n) {
  BeaconHealthRecord r;
  r.sequence = 4;
  r.frame_sets = 950;
  r.t_ns = 123456789012ULL;
  r.map_beacons = 256;
  r.flagged = 2;
  r.first = 224;
  r.num_entries = n;
  for (int i = 0; i < n; ++i) {
    BeaconHealthEntry& e = r.entries[static_cast<std::size_t>(i)];
    e.beacon = static_cast<std::uint16_t>(224 + i);
    e.state = static_cast<std::uint8_t>(i % 3);
    e.judged = i % 2 == 0;
    e.in_view = 100u + static_cast<std::uint32_t>(i);
    e.used = 50u + static_cast<std::uint32_t>(i);
    e.rejected = 3u;
    e.seen = e.used + e.rejected;
    e.mean_residual_px = 0.125f * static_cast<float>(i);
    e.rms_residual_px = 0.25f * static_cast<float>(i);
    e.suggested_sigma_mm = e.state == 1 ? 5.5f : 0.0f;
  }
  return r;
}

TEST(BeaconHealthMessage, RoundTripAndLayout) {
  for (const int n : {0, 1, 13, limits::kBeaconHealthPerMessage}) {
    const BeaconHealthRecord in = SampleBeaconHealth(n);
    std::array<std::uint8_t, kMaxBeaconHealthMessageBytes> bytes{};
    const std::size_t size = EncodeBeaconHealth(in, bytes);
    ASSERT_EQ(size, 36u + 32u * static_cast<std::size_t>(n));
    EXPECT_EQ(bytes[5], 4);
    EXPECT_EQ(bytes[6] | bytes[7] << 8, static_cast<int>(size));
    BeaconHealthRecord out;
    ASSERT_EQ(DecodeBeaconHealth(std::span<const std::uint8_t>(bytes.data(), size), &out), MessageStatus::kOk) << n;
    EXPECT_EQ(out.sequence, in.sequence);
    EXPECT_EQ(out.frame_sets, in.frame_sets);
    EXPECT_EQ(out.t_ns, in.t_ns);
    EXPECT_EQ(out.map_beacons, in.map_beacons);
    EXPECT_EQ(out.flagged, in.flagged);
    EXPECT_EQ(out.first, in.first);
    ASSERT_EQ(out.num_entries, n);
    for (int i = 0; i < n; ++i) {
      const BeaconHealthEntry &a = in.entries[static_cast<std::size_t>(i)], &b = out.entries[static_cast<std::size_t>(i)];
      EXPECT_EQ(a.beacon, b.beacon);
      EXPECT_EQ(a.state, b.state);
      EXPECT_EQ(a.judged, b.judged);
      EXPECT_EQ(a.in_view, b.in_view);
      EXPECT_EQ(a.seen, b.seen);
      EXPECT_EQ(a.used, b.used);
      EXPECT_EQ(a.rejected, b.rejected);
      EXPECT_EQ(a.mean_residual_px, b.mean_residual_px);
      EXPECT_EQ(a.rms_residual_px, b.rms_residual_px);
      EXPECT_EQ(a.suggested_sigma_mm, b.suggested_sigma_mm);
    }
  }
}

TEST(BeaconHealthMessage, RejectsEveryCorruptionAndFieldsOutOfRange) {
  std::array<std::uint8_t, kMaxBeaconHealthMessageBytes> bytes{};
  const std::size_t size = EncodeBeaconHealth(SampleBeaconHealth(3), bytes);
  BeaconHealthRecord r;
  for (std::size_t n = 0; n < size; ++n)
    EXPECT_NE(DecodeBeaconHealth(std::span<const std::uint8_t>(bytes.data(), n), &r), MessageStatus::kOk) << n;
  EXPECT_EQ(DecodeBeaconHealth(std::span<const std::uint8_t>(bytes.data(), size + 1), &r), MessageStatus::kBadSize);
  for (std::size_t i = 0; i < size; ++i)
    for (int bit = 0; bit < 8; ++bit) {
      auto bad = bytes;
      bad[i] ^= static_cast<std::uint8_t>(1u << bit);
      EXPECT_NE(DecodeBeaconHealth(std::span<const std::uint8_t>(bad.data(), size), &r), MessageStatus::kOk) << i << ":" << bit;
    }
  // Fields out of range with a valid CRC: beyond the map, a page past its end, a beacon out of
  // order, a state past missing, seen > in view, used + rejected != seen, a negative or NaN
  // residual, more flagged than beacons.
  for (int c = 0; c < 9; ++c) {
    BeaconHealthRecord b = SampleBeaconHealth(2);
    BeaconHealthEntry& e = b.entries[1];
    if (c == 0) b.map_beacons = limits::kMaxBeacons + 1;
    if (c == 1) b.first = 255;
    if (c == 2) e.beacon = 7;
    if (c == 3) e.state = 3;
    if (c == 4) e.seen = e.in_view + 1;
    if (c == 5) e.rejected += 1;
    if (c == 6) e.rms_residual_px = -1.0f;
    if (c == 7) e.mean_residual_px = std::numeric_limits<float>::quiet_NaN();
    if (c == 8) b.flagged = 300;
    const std::size_t n = EncodeBeaconHealth(b, bytes);
    EXPECT_EQ(DecodeBeaconHealth(std::span<const std::uint8_t>(bytes.data(), n), &r), MessageStatus::kBadField) << c;
  }
  const std::size_t n = EncodeBeaconHealth(SampleBeaconHealth(1), bytes);
  bytes[30] = 33;  // n = 33 > kBeaconHealthPerMessage, before any size arithmetic
  EXPECT_EQ(DecodeBeaconHealth(std::span<const std::uint8_t>(bytes.data(), n), &r), MessageStatus::kBadSize);
  std::array<std::uint8_t, kPoseMessageBytes> pose{};
  EncodePose(PoseRecord{}, pose);
  EXPECT_EQ(DecodeBeaconHealth(pose, &r), MessageStatus::kBadType);
}

TEST(UdpPublisher, DeliversDatagramsOnLoopback) {
  const int rx = ::socket(AF_INET, SOCK_DGRAM, 0);
  ASSERT_GE(rx, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(rx, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  socklen_t len = sizeof(addr);
  ASSERT_EQ(::getsockname(rx, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  timeval tv{2, 0};
  ::setsockopt(rx, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));

  UdpPublisher pub;
  const std::string url = "udp://127.0.0.1:" + std::to_string(ntohs(addr.sin_port));
  ASSERT_EQ(pub.Open(url.c_str()), PublishStatus::kOk);
  std::mt19937_64 rng(5);
  const PoseRecord r = SampleRecord(rng);
  std::array<std::uint8_t, kPoseMessageBytes> bytes{};
  EncodePose(r, bytes);
  ASSERT_EQ(pub.Send(bytes), PublishStatus::kOk);
  std::array<std::uint8_t, 512> got{};
  const ssize_t n = ::recv(rx, got.data(), got.size(), 0);
  ASSERT_EQ(n, static_cast<ssize_t>(kPoseMessageBytes));
  PoseRecord back;
  ASSERT_EQ(DecodePose(std::span<const std::uint8_t>(got.data(), static_cast<std::size_t>(n)), &back), MessageStatus::kOk);
  EXPECT_EQ(back.sequence, r.sequence);
  EXPECT_EQ(pub.counters().sent, 1u);
  ::close(rx);
}

TEST(UdpPublisher, RefusesBadAddressesAndCountsFailures) {
  UdpPublisher pub;
  for (const char* bad : {"127.0.0.1:5000", "udp://", "udp://127.0.0.1", "udp://127.0.0.1:0", "udp://127.0.0.1:70000",
                          "udp://:5000", "udp://no.such.host.invalid:5000", "udp://127.0.0.1:12x"})
    EXPECT_EQ(pub.Open(bad), PublishStatus::kBadAddress) << bad;
  EXPECT_EQ(pub.Send(std::span<const std::uint8_t>()), PublishStatus::kNotOpen);
  EXPECT_EQ(pub.Open("udp://localhost:9"), PublishStatus::kOk);  // discard port: nobody listens
  std::array<std::uint8_t, 8> d{};
  int errors = 0;
  for (int i = 0; i < 5; ++i) errors += pub.Send(d) != PublishStatus::kOk;
  // Loopback reports ECONNREFUSED on a later send: counted, never fatal.
  EXPECT_EQ(pub.counters().sent + pub.counters().send_errors + pub.counters().would_block, 5u);
  EXPECT_EQ(static_cast<std::uint64_t>(errors), pub.counters().send_errors + pub.counters().would_block);
}

TEST(PoseLog, WritesTheDesignCsvAndRenamesOnClose) {
  std::string tmpl = (std::filesystem::temp_directory_path() / "mfns-poselog-XXXXXX").string();
  ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
  const std::string path = tmpl + "/poses.csv";
  PoseLog log;
  ASSERT_EQ(log.Open(path.c_str()), PublishStatus::kOk);
  PoseRecord r;
  r.frame_set = 12;
  r.t_capture_ns = 1053763441;
  r.status = NavStatus::kFix;
  r.r_w_wb = Eigen::Vector3d(0.001, -0.002, 0.0035);
  r.q_w_b = Eigen::Quaterniond(EulerToMatrix({DegToRad(1), DegToRad(2), DegToRad(30)}).transpose());
  r.num_beacons = 4;
  r.residual_rms_px = 0.25f;
  r.reason = NavReason::kCameraDown;
  ASSERT_EQ(log.Write(r), PublishStatus::kOk);
  ASSERT_EQ(log.Write(r, "7:inconsistent 40:missing"), PublishStatus::kOk);
  EXPECT_FALSE(std::filesystem::exists(path));  // only the .partial until Close
  ASSERT_EQ(log.Close(), PublishStatus::kOk);
  std::ifstream in(path);
  std::string header, row;
  std::getline(in, header);
  std::getline(in, row);
  EXPECT_EQ(header, "frame,t_ns,status,x_mm,y_mm,z_mm,roll_deg,pitch_deg,yaw_deg,n_beacons,rms_px,reason,flagged_beacons");
  EXPECT_EQ(row, "12,1053763441,fix,1.0000,-2.0000,3.5000,1.000000,2.000000,30.000000,4,0.2500,camera down,");
  std::getline(in, row);
  EXPECT_EQ(row, "12,1053763441,fix,1.0000,-2.0000,3.5000,1.000000,2.000000,30.000000,4,0.2500,camera down,"
                 "7:inconsistent 40:missing");
  EXPECT_FALSE(std::filesystem::exists(path + ".partial"));
  EXPECT_EQ(log.Open((tmpl + "/missing/x.csv").c_str()), PublishStatus::kFileError);
  std::filesystem::remove_all(tmpl);
}

// A path that is a FIFO (like /dev/null or /dev/stdout) is written in place and never renamed
// over: `mfns-navd --log /dev/null` as root would have replaced /dev/null with the log.
TEST(PoseLog, ASpecialFileIsWrittenInPlace) {
  std::string tmpl = (std::filesystem::temp_directory_path() / "mfns-poselog-XXXXXX").string();
  ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
  const std::string fifo = tmpl + "/fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  PoseLog log;
  ASSERT_EQ(log.Open(fifo.c_str()), PublishStatus::kOk);
  EXPECT_STREQ(log.partial_path(), fifo.c_str());
  PoseRecord r;
  r.frame_set = 3;
  ASSERT_EQ(log.Write(r), PublishStatus::kOk);
  ASSERT_EQ(log.Close(), PublishStatus::kOk);
  struct stat st {};
  ASSERT_EQ(::stat(fifo.c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  EXPECT_FALSE(std::filesystem::exists(fifo + ".partial"));
  char buf[512] = {};
  const ssize_t n = ::read(reader, buf, sizeof buf - 1);
  ::close(reader);
  ASSERT_GT(n, 0);
  EXPECT_EQ(std::string(buf).rfind("frame,t_ns,status,", 0), 0u);
  EXPECT_NE(std::string(buf).find("\n3,0,"), std::string::npos);
  std::filesystem::remove_all(tmpl);
}

// A temp directory holding a previous, good poses.csv.
struct LogDir {
  LogDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "mfns-poselog-XXXXXX").string();
    EXPECT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir = tmpl;
    path = dir + "/poses.csv";
    std::ofstream(path) << kOld;
  }
  ~LogDir() { std::filesystem::remove_all(dir); }
  std::string Target() const {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  static constexpr char kOld[] = "frame,t_ns,status\n0,1,fix\n";  // stands for a previous run's log
  std::string dir, path;
};

// A full disk, reproduced with a 2 KiB file-size limit (SIGXFSZ ignored, as mfns-navd does, so
// the limit is an EFBIG write error): the rows that do not fit fail, and Close must not rename
// the cut log over the previous one.
TEST(PoseLog, AFailedWriteNeverReplacesThePreviousLog) {
  LogDir d;
  rlimit old_limit{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  struct sigaction ignore {}, old_action {};
  ignore.sa_handler = SIG_IGN;
  ASSERT_EQ(::sigaction(SIGXFSZ, &ignore, &old_action), 0);
  rlimit small = old_limit;
  small.rlim_cur = 2048;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  PoseLog log;
  int failed_writes = 0;
  PublishStatus closed = PublishStatus::kOk;
  if (log.Open(d.path.c_str()) == PublishStatus::kOk) {
    std::mt19937_64 rng(5);
    for (int i = 0; i < 100; ++i) failed_writes += log.Write(SampleRecord(rng)) != PublishStatus::kOk;
    closed = log.Close();
  }
  ::setrlimit(RLIMIT_FSIZE, &old_limit);
  ::sigaction(SIGXFSZ, &old_action, nullptr);
  EXPECT_GT(failed_writes, 0);  // 100 rows of ~100 bytes do not fit in 2 KiB
  EXPECT_GT(log.counters().log_errors, 0u);
  EXPECT_EQ(closed, PublishStatus::kFileError);
  EXPECT_EQ(d.Target(), LogDir::kOld);  // the previous log, untouched
}

// A run whose start fails after the log was opened (the PoseLog is destroyed without Close)
// must not replace the previous log with a header-only one.
TEST(PoseLog, DestroyedWithoutCloseLeavesThePreviousLog) {
  LogDir d;
  {
    PoseLog log;
    ASSERT_EQ(log.Open(d.path.c_str()), PublishStatus::kOk);
  }
  EXPECT_EQ(d.Target(), LogDir::kOld);
}

}  // namespace
}  // namespace mfns::fw
