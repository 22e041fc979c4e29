// Tests of the parameter blob v1 against an independent reference: the test writes the byte
// layout of README.md itself (TestHeader/Assemble below, byte vectors and a bitwise CRC), so
// every corruption is built byte for byte with correct CRCs where the test needs them.
#include "common/blob/param_blob.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"

namespace mfns {

// Readable statuses in gtest messages (found by ADL, so in namespace mfns).
void PrintTo(BlobStatus s, std::ostream* os) { *os << ToString(s); }

namespace {

using Bytes = std::vector<std::uint8_t>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------
// Independent references.

// CRC-32 bit by bit from its definition (reflected polynomial 0xEDB88320), no table.
std::uint32_t BitwiseCrc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc = 0) {
  crc ^= 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (int b = 0; b < 8; ++b) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xFFFFFFFFu;
}

void PutLe(Bytes* b, std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i) b->push_back(static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFu));
}
void PutF64(Bytes* b, double v) {
  std::uint64_t u = 0;
  std::memcpy(&u, &v, sizeof u);
  PutLe(b, u, 8);
}
void PutVec(Bytes* b, const Eigen::Vector3d& v) {
  PutF64(b, v.x());
  PutF64(b, v.y());
  PutF64(b, v.z());
}
template <std::size_t N>
void PutRaw(Bytes* b, const std::array<char, N>& a) {  // every byte as it is
  for (const char c : a) b->push_back(static_cast<std::uint8_t>(c));
}
void SetLe(Bytes* b, std::size_t off, std::uint64_t v, int n) {
  for (int i = 0; i < n; ++i)
    (*b)[off + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>((v >> (8 * i)) & 0xFFu);
}
std::uint64_t GetLe(const Bytes& b, std::size_t off, int n) {
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v |= std::uint64_t{b[off + static_cast<std::size_t>(i)]} << (8 * i);
  return v;
}

// README.md, "Header".
struct TestHeader {
  std::string magic = "MFNSPRM1";
  std::uint16_t version = 1;
  std::uint16_t header_size = 64;
  std::uint16_t flags = 0;
  std::optional<std::uint16_t> payload_bytes;  // default: the real payload length
  std::array<char, 32> rig_id{};
  std::uint64_t generation = 0;
  std::optional<std::uint32_t> payload_crc;    // default: the real CRC
};

struct TestSection {
  std::uint16_t type = 0;
  std::uint16_t version = 1;
  Bytes body;
  std::optional<std::uint32_t> length;  // default: body.size()
};

enum : std::uint16_t { kCam = 1, kExt = 2, kBea = 3, kSig = 4, kFac = 5, kBsg = 6 };

Bytes Assemble(const TestHeader& h, const std::vector<TestSection>& sections) {
  Bytes payload;
  for (const TestSection& s : sections) {
    PutLe(&payload, s.type, 2);
    PutLe(&payload, s.version, 2);
    PutLe(&payload, s.length.value_or(static_cast<std::uint32_t>(s.body.size())), 4);
    payload.insert(payload.end(), s.body.begin(), s.body.end());
  }
  Bytes b(h.magic.begin(), h.magic.end());
  PutLe(&b, h.version, 2);
  PutLe(&b, h.header_size, 2);
  PutLe(&b, h.flags, 2);
  PutLe(&b, h.payload_bytes.value_or(static_cast<std::uint16_t>(payload.size())), 2);
  PutRaw(&b, h.rig_id);
  PutLe(&b, h.generation, 8);
  PutLe(&b, h.payload_crc.value_or(BitwiseCrc32(payload.data(), payload.size())), 4);
  PutLe(&b, BitwiseCrc32(b.data(), b.size()), 4);
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}

// Section bodies from a rig: `records` records (camera i taken from i % num_cameras, so a
// body may hold more records than a Rig can) and a count field that may lie.
Bytes CamerasBody(const Rig& r, int records, std::uint32_t count) {
  Bytes b;
  PutLe(&b, count, 4);
  for (int i = 0; i < records; ++i) {
    const RigCamera& c = r.cameras[static_cast<std::size_t>(i % r.num_cameras)];
    const CameraIntrinsics& k = c.intrinsics;
    PutRaw(&b, c.name);
    PutLe(&b, static_cast<std::uint32_t>(k.width), 4);
    PutLe(&b, static_cast<std::uint32_t>(k.height), 4);
    for (const double v : {k.alpha_x, k.alpha_y, k.skew, k.u0, k.v0}) PutF64(&b, v);
    for (const double v : k.kc) PutF64(&b, v);
  }
  return b;
}
Bytes ExtrinsicsBody(const Rig& r, int records, std::uint32_t count) {
  Bytes b;
  PutLe(&b, count, 4);
  for (int i = 0; i < records; ++i) {
    const RigCamera& c = r.cameras[static_cast<std::size_t>(i % r.num_cameras)];
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) PutF64(&b, c.C_k_b(row, col));
    PutVec(&b, c.r_b_bk);
  }
  return b;
}
Bytes BeaconsBody(const Rig& r, int records, std::uint32_t count) {
  Bytes b;
  PutLe(&b, count, 4);
  PutF64(&b, r.beacon_sigma);
  for (int i = 0; i < records; ++i) PutVec(&b, r.beacons_w[static_cast<std::size_t>(i % r.num_beacons)]);
  return b;
}
Bytes SigmaBody(const Rig& r, int records, std::uint32_t count) {
  Bytes b;
  PutLe(&b, count, 4);
  for (int i = 0; i < records; ++i) {
    const RigCameraSigma& s = r.sigma[static_cast<std::size_t>(i % r.num_cameras)];
    for (const double v : s.intrinsics) PutF64(&b, v);
    for (const double v : s.distortion) PutF64(&b, v);
    PutVec(&b, s.euler);
    PutVec(&b, s.r_b_bk);
  }
  return b;
}

Bytes FacingBody(const Rig& r, int records, std::uint32_t count) {
  Bytes b;
  PutLe(&b, count, 4);
  for (int i = 0; i < records; ++i) {
    const auto m = static_cast<std::size_t>(i % std::max(r.num_beacons, 1));
    PutVec(&b, r.beacon_normal_w[m]);
    PutF64(&b, r.beacon_half_angle[m]);
  }
  return b;
}

Bytes BeaconSigmasBody(const Rig& r, int records, std::uint32_t count) {
  Bytes b;
  PutLe(&b, count, 4);
  for (int i = 0; i < records; ++i) PutF64(&b, r.beacon_sigmas[static_cast<std::size_t>(i % std::max(r.num_beacons, 1))]);
  return b;
}

std::vector<TestSection> SectionsOf(const Rig& r) {
  const int nc = r.num_cameras;
  const int nb = r.num_beacons;
  const auto unc = static_cast<std::uint32_t>(nc);
  std::vector<TestSection> s = {{kCam, 1, CamerasBody(r, nc, unc), {}},
                                {kExt, 1, ExtrinsicsBody(r, nc, unc), {}},
                                {kBea, 1, BeaconsBody(r, nb, static_cast<std::uint32_t>(nb)), {}}};
  if (r.has_sigma) s.push_back({kSig, 1, SigmaBody(r, nc, unc), {}});
  if (r.has_facing) s.push_back({kFac, 1, FacingBody(r, nb, static_cast<std::uint32_t>(nb)), {}});
  if (r.has_beacon_sigmas) s.push_back({kBsg, 1, BeaconSigmasBody(r, nb, static_cast<std::uint32_t>(nb)), {}});
  return s;
}

TestHeader HeaderOf(const Rig& r, std::uint64_t generation) {
  TestHeader h;
  h.flags = r.has_sigma ? 1 : 0;
  h.version = r.has_beacon_sigmas ? 2 : 1;
  h.rig_id = r.rig_id;
  h.generation = generation;
  return h;
}

Bytes Reference(const Rig& r, std::uint64_t generation) {
  return Assemble(HeaderOf(r, generation), SectionsOf(r));
}

// Re-computes the payload CRC and the header CRC of a blob in place (optionally also the
// payload length) so that a corruption reaches the checks behind them.
void RepairCrcs(Bytes* b, bool fix_length = false) {
  if (b->size() < 64) return;
  if (fix_length) SetLe(b, 14, std::min<std::size_t>(b->size() - 64, 0xFFFF), 2);
  SetLe(b, 56, Crc32(std::span<const std::uint8_t>(*b).subspan(64)), 4);
  SetLe(b, 60, Crc32(std::span<const std::uint8_t>(*b).first(60)), 4);
}

// ---------------------------------------------------------------------------------------------
// Rigs and comparisons.

Rig PaperRigNoSigma() {
  Rig r = PaperRig();
  r.has_sigma = false;
  r.sigma = {};
  return r;
}

// kMaxCameras cameras with sigma and kMaxBeacons beacons, random but valid, with a rig id of
// the maximum length, the largest images, -0.0 and a subnormal to check bit-exactness.
Rig MaxRig() {
  std::mt19937_64 rng(2024);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Rig r;
  const std::string id(static_cast<std::size_t>(limits::kMaxRigIdChars), 'm');
  std::copy(id.begin(), id.end(), r.rig_id.begin());
  r.num_cameras = limits::kMaxCameras;
  r.has_sigma = true;
  for (std::size_t i = 0; i < r.cameras.size(); ++i) {
    RigCamera& c = r.cameras[i];
    const std::string name = "cam" + std::to_string(i) + "abc";  // 7 chars, the maximum
    std::copy(name.begin(), name.end(), c.name.begin());
    CameraIntrinsics& k = c.intrinsics;
    k.width = limits::kMaxImageWidth;
    k.height = limits::kMaxImageHeight;
    k.alpha_x = 1500.0 + 500.0 * u(rng);
    k.alpha_y = 1500.0 + 500.0 * u(rng);
    k.skew = i == 0 ? -0.0 : u(rng);
    k.u0 = 1024.0 + 900.0 * u(rng);
    k.v0 = 1024.0 + 900.0 * u(rng);
    for (double& v : k.kc) v = 0.3 * u(rng);
    k.kc[4] = i == 1 ? std::numeric_limits<double>::denorm_min() : k.kc[4];
    c.C_k_b = ExpSO3(Eigen::Vector3d(u(rng), u(rng), u(rng)) * 2.0);
    c.r_b_bk = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.2;
    RigCameraSigma& s = r.sigma[i];
    for (double& v : s.intrinsics) v = std::abs(u(rng));
    for (double& v : s.distortion) v = 0.01 * std::abs(u(rng));
    s.euler = Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseAbs() * 1e-3;
    s.r_b_bk = Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseAbs() * 1e-3;
  }
  r.num_beacons = limits::kMaxBeacons;
  for (Eigen::Vector3d& b : r.beacons_w) b = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 5.0;
  r.beacon_sigma = 4e-4;
  return r;
}

// Facing for every beacon of r: random unit normals (one exactly an axis, one with a -0.0),
// half-angles across (0, pi], the boundary pi and a tiny one included.
Rig WithFacing(Rig r) {
  std::mt19937_64 rng(99);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  r.has_facing = true;
  for (std::size_t m = 0; m < static_cast<std::size_t>(r.num_beacons); ++m) {
    Eigen::Vector3d n(u(rng), u(rng), u(rng));
    r.beacon_normal_w[m] = n.normalized();
    r.beacon_half_angle[m] = std::max(1e-3, (0.5 + 0.5 * u(rng)) * kPi);
  }
  if (r.num_beacons >= 3) {
    r.beacon_normal_w[0] = Eigen::Vector3d(-0.0, 0.0, 1.0);
    r.beacon_half_angle[0] = kPi;                                   // the largest allowed
    r.beacon_normal_w[1] = Eigen::Vector3d(1.0, 0.0, 0.0);
    r.beacon_half_angle[1] = std::numeric_limits<double>::denorm_min();  // the smallest
    r.beacon_half_angle[2] = DegToRad(60.0);
  }
  return r;
}

Rig PaperRigWithFacing() { return WithFacing(PaperRig()); }

// A 1-sigma for every beacon of r (as mfns-calib survey writes): zero, subnormal, the limit and
// ordinary values; beacon_sigma their largest.
Rig WithBeaconSigmas(Rig r) {
  r.has_beacon_sigmas = true;
  double largest = 0.0;
  for (std::size_t m = 0; m < static_cast<std::size_t>(r.num_beacons); ++m) {
    r.beacon_sigmas[m] = 1e-4 * static_cast<double>(m % 7 + 1) / 3.0;
    if (m == 0) r.beacon_sigmas[m] = 0.0;
    if (m == 1) r.beacon_sigmas[m] = std::numeric_limits<double>::denorm_min();
    if (m == 2 && r.num_beacons > 20) r.beacon_sigmas[m] = limits::kMaxBeaconSigmaM;
    largest = std::max(largest, r.beacon_sigmas[m]);
  }
  r.beacon_sigma = largest;
  return r;
}

bool Same(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

::testing::AssertionResult RigsBitEqual(const Rig& a, const Rig& b) {
  std::ostringstream diff;
  auto check = [&diff](bool same, const std::string& what) {
    if (!same) diff << what << " ";
  };
  check(a.rig_id == b.rig_id, "rig_id");
  check(a.num_cameras == b.num_cameras, "num_cameras");
  check(a.has_sigma == b.has_sigma, "has_sigma");
  check(a.has_facing == b.has_facing, "has_facing");
  check(a.num_beacons == b.num_beacons, "num_beacons");
  check(Same(a.beacon_sigma, b.beacon_sigma), "beacon_sigma");
  check(a.has_beacon_sigmas == b.has_beacon_sigmas, "has_beacon_sigmas");
  for (std::size_t i = 0; a.has_beacon_sigmas && i < static_cast<std::size_t>(a.num_beacons); ++i)
    check(Same(a.beacon_sigmas[i], b.beacon_sigmas[i]), "beacon sigma " + std::to_string(i));
  if (!diff.str().empty()) return ::testing::AssertionFailure() << "differ: " << diff.str();
  for (std::size_t i = 0; i < static_cast<std::size_t>(a.num_cameras) && i < a.cameras.size(); ++i) {
    const RigCamera& ca = a.cameras[i];
    const RigCamera& cb = b.cameras[i];
    const std::string cam = "camera " + std::to_string(i) + " ";
    check(ca.name == cb.name, cam + "name");
    check(ca.intrinsics.width == cb.intrinsics.width, cam + "width");
    check(ca.intrinsics.height == cb.intrinsics.height, cam + "height");
    for (int p = 0; p < kNumCameraParams; ++p)
      check(Same(ca.intrinsics.ToVector()(p), cb.intrinsics.ToVector()(p)), cam + "param " + std::to_string(p));
    for (int e = 0; e < 9; ++e) check(Same(ca.C_k_b(e), cb.C_k_b(e)), cam + "C_k_b");
    for (int e = 0; e < 3; ++e) check(Same(ca.r_b_bk(e), cb.r_b_bk(e)), cam + "r_b_bk");
    if (!a.has_sigma) continue;
    const RigCameraSigma& sa = a.sigma[i];
    const RigCameraSigma& sb = b.sigma[i];
    for (std::size_t e = 0; e < 5; ++e) {
      check(Same(sa.intrinsics[e], sb.intrinsics[e]), cam + "sigma intrinsics");
      check(Same(sa.distortion[e], sb.distortion[e]), cam + "sigma distortion");
    }
    for (int e = 0; e < 3; ++e) {
      check(Same(sa.euler(e), sb.euler(e)), cam + "sigma euler");
      check(Same(sa.r_b_bk(e), sb.r_b_bk(e)), cam + "sigma r_b_bk");
    }
  }
  for (std::size_t i = 0; i < static_cast<std::size_t>(a.num_beacons) && i < a.beacons_w.size(); ++i)
    for (int e = 0; e < 3; ++e) check(Same(a.beacons_w[i](e), b.beacons_w[i](e)), "beacon " + std::to_string(i));
  for (std::size_t i = 0; a.has_facing && i < static_cast<std::size_t>(a.num_beacons) && i < a.beacons_w.size(); ++i) {
    for (int e = 0; e < 3; ++e)
      check(Same(a.beacon_normal_w[i](e), b.beacon_normal_w[i](e)), "normal " + std::to_string(i));
    check(Same(a.beacon_half_angle[i], b.beacon_half_angle[i]), "half-angle " + std::to_string(i));
  }
  if (!diff.str().empty()) return ::testing::AssertionFailure() << "differ: " << diff.str();
  return ::testing::AssertionSuccess();
}

Bytes Encode(const Rig& rig, std::uint64_t generation) {
  Bytes out(limits::kMaxBlobBytes);
  std::size_t written = 0;
  EXPECT_EQ(EncodeParamBlob(rig, generation, out, &written), BlobStatus::kOk);
  out.resize(written);
  return out;
}

BlobStatus Decode(const Bytes& b, const char* expected_rig_id = nullptr) {
  return DecodeParamBlob(b, expected_rig_id, nullptr, nullptr);
}

// A rig the decoder must not touch unless it succeeds.
Rig Sentinel() {
  Rig r;
  r.num_cameras = -7;
  return r;
}

constexpr std::uint64_t kGeneration = 0x0102030405060708ull;

// ---------------------------------------------------------------------------------------------
// CRC-32.

TEST(Crc32, CheckValue) {
  const std::string check = "123456789";
  const std::span<const std::uint8_t> bytes(reinterpret_cast<const std::uint8_t*>(check.data()), check.size());
  EXPECT_EQ(Crc32(bytes), 0xCBF43926u);
  EXPECT_EQ(BitwiseCrc32(bytes.data(), bytes.size()), 0xCBF43926u);  // the reference itself
  EXPECT_EQ(Crc32({}), 0u);
}

TEST(Crc32, MatchesBitwiseReferenceOnRandomDataAndContinues) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 300; ++trial) {
    Bytes data(rng() % 1500);
    for (std::uint8_t& b : data) b = static_cast<std::uint8_t>(rng());
    const std::span<const std::uint8_t> all(data);
    const std::uint32_t expected = BitwiseCrc32(data.data(), data.size());
    ASSERT_EQ(Crc32(all), expected) << "length " << data.size();
    const std::size_t split = data.empty() ? 0 : rng() % data.size();
    EXPECT_EQ(Crc32(all.subspan(split), Crc32(all.first(split))), expected);
  }
}

// ---------------------------------------------------------------------------------------------
// Layout and round trip.

TEST(ParamBlob, ToStringGivesADistinctReasonForEveryStatus) {
  std::set<std::string> reasons;
  for (int i = 0; i < kNumBlobStatuses; ++i) {
    const std::string r = ToString(static_cast<BlobStatus>(i));
    EXPECT_FALSE(r.empty());
    EXPECT_EQ(r.find("unknown"), std::string::npos) << i;
    EXPECT_EQ(r.find('\n'), std::string::npos) << i;
    reasons.insert(r);
  }
  EXPECT_EQ(reasons.size(), static_cast<std::size_t>(kNumBlobStatuses));
}

TEST(ParamBlob, EncoderWritesTheDocumentedLayout) {
  for (const Rig& rig : {PaperRig(), PaperRigNoSigma(), MaxRig(), PaperRigWithFacing(), WithFacing(MaxRig()),
                         WithFacing(PaperRigNoSigma())}) {
    const Bytes blob = Encode(rig, kGeneration);
    EXPECT_EQ(blob, Reference(rig, kGeneration)) << rig.rig_id.data();
    const std::size_t nc = static_cast<std::size_t>(rig.num_cameras);
    const std::size_t nb = static_cast<std::size_t>(rig.num_beacons);
    EXPECT_EQ(blob.size(), 64 + (12 + 96 * nc) + (12 + 96 * nc) + (20 + 24 * nb) +
                               (rig.has_sigma ? 12 + 128 * nc : 0) + (rig.has_facing ? 12 + 32 * nb : 0));
  }
  // README.md's sizes: the paper rig (3 cameras, 10 beacons) and the largest rig.
  EXPECT_EQ(Encode(PaperRig(), 1).size(), 1320u);
  EXPECT_EQ(Encode(PaperRigNoSigma(), 1).size(), 924u);
  EXPECT_EQ(Encode(PaperRigWithFacing(), 1).size(), 1652u);
  EXPECT_EQ(Encode(WithFacing(MaxRig()), 1).size(), 1412u + 56u * limits::kMaxBeacons);
  EXPECT_LE(1412u + 56u * limits::kMaxBeacons, limits::kMaxBlobBytes);

  // The facing section (type 5) comes last, after SIGMA; its first record checked literally.
  const Rig facing = PaperRigWithFacing();
  const Bytes f = Encode(facing, kGeneration);
  const std::size_t at = f.size() - (12 + 32 * 10);
  EXPECT_EQ(GetLe(f, 14, 2), f.size() - 64);
  EXPECT_EQ(GetLe(f, at, 2), 5u);            // BEACON_FACING
  EXPECT_EQ(GetLe(f, at + 2, 2), 1u);        // its version
  EXPECT_EQ(GetLe(f, at + 4, 4), 4u + 32 * 10);
  EXPECT_EQ(GetLe(f, at + 8, 4), 10u);       // beacon count
  EXPECT_EQ(GetLe(f, at + 12, 8), 0x8000000000000000ull);  // normal x of beacon 0: -0.0
  EXPECT_EQ(GetLe(f, at + 20, 8), 0u);                     // y: +0.0
  EXPECT_EQ(GetLe(f, at + 28, 8), std::bit_cast<std::uint64_t>(1.0));
  EXPECT_EQ(GetLe(f, at + 36, 8), std::bit_cast<std::uint64_t>(kPi));  // half-angle, rad
  EXPECT_EQ(GetLe(f, 12, 2), 1u);  // flags: sigma only; facing has no flag bit

  // A few bytes of README.md's table checked literally on the paper rig.
  const Bytes b = Encode(PaperRig(), kGeneration);
  EXPECT_EQ(std::string(b.begin(), b.begin() + 8), "MFNSPRM1");
  EXPECT_EQ(GetLe(b, 8, 2), 1u);     // format version
  EXPECT_EQ(GetLe(b, 10, 2), 64u);   // header size
  EXPECT_EQ(GetLe(b, 12, 2), 1u);    // flags: has sigma
  EXPECT_EQ(GetLe(b, 14, 2), b.size() - 64);
  EXPECT_EQ(std::string(reinterpret_cast<const char*>(&b[16])), kPaperRigId);
  EXPECT_TRUE(std::all_of(b.begin() + 16 + 15, b.begin() + 48, [](std::uint8_t c) { return c == 0; }));
  EXPECT_EQ(b[48], 0x08);  // generation, little-endian
  EXPECT_EQ(b[55], 0x01);
  EXPECT_EQ(GetLe(b, 56, 4), BitwiseCrc32(&b[64], b.size() - 64));
  EXPECT_EQ(GetLe(b, 60, 4), BitwiseCrc32(b.data(), 60));
  EXPECT_EQ(GetLe(b, 64, 2), 1u);          // CAMERAS section
  EXPECT_EQ(GetLe(b, 66, 2), 1u);          // its version
  EXPECT_EQ(GetLe(b, 68, 4), 4u + 3 * 96);  // its length
  EXPECT_EQ(GetLe(b, 72, 4), 3u);          // camera count
  EXPECT_EQ(b[76], 'x');
  EXPECT_EQ(GetLe(b, 84, 4), 1280u);
  EXPECT_EQ(GetLe(b, 88, 4), 1024u);
  EXPECT_EQ(GetLe(b, 92, 8), std::bit_cast<std::uint64_t>(1599.26136));  // alpha_x of x
}

TEST(ParamBlob, RoundTripIsBitExact) {
  for (const Rig& rig : {PaperRig(), PaperRigNoSigma(), MaxRig(), PaperRigWithFacing(), WithFacing(MaxRig()),
                         WithBeaconSigmas(PaperRig()), WithBeaconSigmas(WithFacing(MaxRig()))}) {
    for (const std::uint64_t generation : {std::uint64_t{0}, kGeneration, ~std::uint64_t{0}}) {
      const Bytes blob = Encode(rig, generation);
      EXPECT_LE(blob.size(), limits::kMaxBlobBytes);
      Rig decoded = Sentinel();
      BlobInfo info;
      ASSERT_EQ(DecodeParamBlob(blob, rig.rig_id.data(), &decoded, &info), BlobStatus::kOk);
      EXPECT_TRUE(RigsBitEqual(decoded, rig));
      // Version 2 only for per-beacon sigmas: every other blob stays loadable by older flyers.
      EXPECT_EQ(info.format_version, rig.has_beacon_sigmas ? kBlobFormatVersion : kOldestBlobFormatVersion);
      EXPECT_EQ(info.generation, generation);
      EXPECT_EQ(info.rig_id, rig.rig_id);
      EXPECT_EQ(info.payload_bytes, blob.size() - kBlobHeaderBytes);
      EXPECT_EQ(info.payload_crc32, BitwiseCrc32(&blob[64], blob.size() - 64));
      EXPECT_EQ(DecodeParamBlob(blob, nullptr, nullptr, nullptr), BlobStatus::kOk);

      // The header alone is enough for DecodeBlobHeader (the store reads it first).
      BlobInfo header_info;
      const std::span<const std::uint8_t> header(blob.data(), kBlobHeaderBytes);
      EXPECT_EQ(DecodeBlobHeader(header, &header_info), BlobStatus::kOk);
      EXPECT_EQ(header_info.generation, generation);
      EXPECT_EQ(header_info.payload_bytes, info.payload_bytes);
      EXPECT_EQ(DecodeBlobHeader(header.first(kBlobHeaderBytes - 1), &header_info), BlobStatus::kTruncated);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Corruption classes on the encoder's own output.

TEST(ParamBlob, EveryTruncationIsTruncated) {
  for (const Rig& rig : {PaperRig(), MaxRig(), PaperRigWithFacing()}) {
    const Bytes blob = Encode(rig, kGeneration);
    for (std::size_t n = 0; n < blob.size(); ++n) {
      Rig out = Sentinel();
      BlobInfo info;
      ASSERT_EQ(DecodeParamBlob(std::span<const std::uint8_t>(blob.data(), n), nullptr, &out, &info),
                BlobStatus::kTruncated)
          << "length " << n;
      EXPECT_EQ(out.num_cameras, -7);
      EXPECT_EQ(info.generation, n >= kBlobHeaderBytes ? kGeneration : 0u);  // header valid
    }
  }
}

TEST(ParamBlob, EverySingleBitFlipIsDetectedByItsField) {
  const Bytes blob = Encode(PaperRig(), kGeneration);
  std::map<BlobStatus, int> seen;
  for (std::size_t i = 0; i < blob.size(); ++i) {
    const BlobStatus expected = i < 8      ? BlobStatus::kBadMagic
                                : i < 10   ? BlobStatus::kUnsupportedVersion
                                : i < 64   ? BlobStatus::kHeaderCrcMismatch
                                           : BlobStatus::kPayloadCrcMismatch;
    for (int bit = 0; bit < 8; ++bit) {
      Bytes b = blob;
      b[i] = static_cast<std::uint8_t>(b[i] ^ (1u << bit));
      Rig out = Sentinel();
      const BlobStatus s = DecodeParamBlob(b, nullptr, &out, nullptr);
      ++seen[s];
      ASSERT_EQ(s, expected) << "byte " << i << " bit " << bit;
      EXPECT_EQ(out.num_cameras, -7);
    }
  }
  std::ostringstream record;
  for (const auto& [status, count] : seen) record << ToString(status) << ": " << count << "; ";
  ::testing::Test::RecordProperty("statuses", record.str());
  EXPECT_EQ(seen.size(), 4u);
}

// Every bit of the header's fields flipped, the header CRC repaired: each field's own check.
TEST(ParamBlob, HeaderFieldFlipsWithRepairedCrcGiveTheFieldsError) {
  const Bytes blob = Encode(PaperRig(), kGeneration);
  const std::size_t payload = blob.size() - 64;
  // README.md's rig id rule, written again.
  auto good_id = [](const Bytes& b) {
    const auto first = b.begin() + 16, last = b.begin() + 48;
    const auto nul = std::find(first, last, 0);
    return nul != first && nul != last &&
           std::all_of(first, nul, [](std::uint8_t c) { return c >= 0x21 && c <= 0x7e; }) &&
           std::all_of(nul, last, [](std::uint8_t c) { return c == 0; });
  };
  for (std::size_t i = 0; i < 60; ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      Bytes b = blob;
      b[i] = static_cast<std::uint8_t>(b[i] ^ (1u << bit));
      SetLe(&b, 60, BitwiseCrc32(b.data(), 60), 4);
      BlobStatus expected = BlobStatus::kOk;
      if (i < 8) {
        expected = BlobStatus::kBadMagic;
      } else if (i < 10) {
        expected = BlobStatus::kUnsupportedVersion;
      } else if (i < 12) {
        expected = BlobStatus::kBadHeader;  // header size
      } else if (i < 14) {
        // Flag bit 0 cleared while the SIGMA section is there; any other bit is unknown.
        expected = (i == 12 && bit == 0) ? BlobStatus::kBadSection : BlobStatus::kBadHeader;
      } else if (i < 16) {
        const std::size_t length = GetLe(b, 14, 2);
        expected = 64 + length > limits::kMaxBlobBytes ? BlobStatus::kTooLarge
                   : length > payload                  ? BlobStatus::kTruncated
                                                       : BlobStatus::kTrailingBytes;
      } else if (i < 48) {
        expected = good_id(b) ? BlobStatus::kRigIdMismatch : BlobStatus::kBadHeader;
      } else if (i < 56) {
        expected = BlobStatus::kOk;  // generation: any value is valid
      } else {
        expected = BlobStatus::kPayloadCrcMismatch;
      }
      Rig out = Sentinel();
      BlobInfo info;
      ASSERT_EQ(DecodeParamBlob(b, kPaperRigId, &out, &info), expected) << "byte " << i << " bit " << bit;
      if (expected == BlobStatus::kOk) {
        EXPECT_EQ(info.generation, kGeneration ^ (std::uint64_t{1} << (8 * (i - 48) + static_cast<std::size_t>(bit))));
        EXPECT_TRUE(RigsBitEqual(out, PaperRig()));
      }
      if (expected == BlobStatus::kRigIdMismatch) {  // a valid id, just not the paper's
        EXPECT_EQ(DecodeParamBlob(b, nullptr, &out, &info), BlobStatus::kOk);
      }
    }
  }
}

// Every bit of the payload flipped with both CRCs repaired: the section and value checks
// catch it, or the result is a valid rig that re-encodes to exactly these bytes (the encoding
// is canonical, so nothing decodes "successfully" to something else).
TEST(ParamBlob, PayloadFlipsWithRepairedCrcsAreCaughtOrCanonical) {
  std::map<BlobStatus, int> seen;
  int skipped = 0;
  for (const Rig& rig : {PaperRig(), PaperRigWithFacing()}) {
    const Bytes blob = Encode(rig, kGeneration);
    // The facing section is optional and has no flag (an older decoder skips it), so a type
    // flipped to an unknown one is skipped like any unknown section: the CRCs guard that.
    const std::size_t facing_type = blob.size() - (12 + 32 * static_cast<std::size_t>(rig.num_beacons));
    for (std::size_t i = 64; i < blob.size(); ++i) {
      for (int bit = 0; bit < 8; ++bit) {
        Bytes b = blob;
        b[i] = static_cast<std::uint8_t>(b[i] ^ (1u << bit));
        RepairCrcs(&b);
        Rig out = Sentinel();
        BlobInfo info;
        const BlobStatus s = DecodeParamBlob(b, nullptr, &out, &info);
        ++seen[s];
        if (s == BlobStatus::kOk && rig.has_facing && !out.has_facing) {
          ASSERT_TRUE(i >= facing_type && i < facing_type + 2) << "byte " << i << " bit " << bit;
          ASSERT_TRUE(RigsBitEqual(out, PaperRig()));
          ++skipped;
        } else if (s == BlobStatus::kOk) {
          ASSERT_EQ(Encode(out, info.generation), b) << "byte " << i << " bit " << bit;
        } else {
          EXPECT_EQ(out.num_cameras, -7);
        }
      }
    }
  }
  std::ostringstream record;
  for (const auto& [status, count] : seen) record << ToString(status) << ": " << count << "; ";
  ::testing::Test::RecordProperty("statuses", record.str());
  // The flips reach every kind of check (types, versions, lengths, counts, names, values).
  for (const BlobStatus s : {BlobStatus::kOk, BlobStatus::kBadSection, BlobStatus::kMissingSection,
                             BlobStatus::kDuplicateSection, BlobStatus::kTooManyCameras,
                             BlobStatus::kTooManyBeacons, BlobStatus::kInvalidValue})
    EXPECT_GT(seen[s], 0) << ToString(s) << "; seen " << record.str();
  // Type 5's bits: 0 -> 4 (SIGMA twice), 2 -> 1 (CAMERAS twice), the other 14 -> unknown.
  EXPECT_EQ(skipped, 14);
}

TEST(ParamBlob, TrailingBytes) {
  const Bytes blob = Encode(PaperRig(), kGeneration);
  for (const Bytes& extra : {Bytes{0}, Bytes{0xFF}, blob}) {
    Bytes b = blob;
    b.insert(b.end(), extra.begin(), extra.end());
    BlobInfo info;
    EXPECT_EQ(DecodeParamBlob(b, nullptr, nullptr, &info), BlobStatus::kTrailingBytes);
    EXPECT_EQ(info.generation, kGeneration);
  }
}

TEST(ParamBlob, RigIdMustMatchTheExpectedOne) {
  const Bytes blob = Encode(PaperRig(), kGeneration);
  EXPECT_EQ(Decode(blob, kPaperRigId), BlobStatus::kOk);
  for (const char* other : {"other-rig", "mfns-paper-201", "mfns-paper-2017x", "", "MFNS-PAPER-2017",
                            "mfns-paper-2017-and-more-than-32-chars"}) {
    Rig out = Sentinel();
    BlobInfo info;
    EXPECT_EQ(DecodeParamBlob(blob, other, &out, &info), BlobStatus::kRigIdMismatch) << other;
    EXPECT_EQ(out.num_cameras, -7);
    EXPECT_STREQ(info.rig_id.data(), kPaperRigId);  // the header is reported
  }
}

// ---------------------------------------------------------------------------------------------
// Corruptions built byte for byte with correct CRCs.

TEST(ParamBlob, TheReferenceBuilderMakesValidBlobs) {  // so the failures below are the edits'
  const Rig rig = PaperRig();
  EXPECT_EQ(Decode(Reference(rig, 5)), BlobStatus::kOk);
  EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 5), SectionsOf(rig))), BlobStatus::kOk);
}

TEST(ParamBlob, BadMagic) {
  const Rig rig = PaperRig();
  for (const char* magic : {"MFNSPRM2", "mfnsprm1", "MFNSPRM0", "XFNSPRM1"}) {
    TestHeader h = HeaderOf(rig, 1);
    h.magic = magic;
    EXPECT_EQ(Decode(Assemble(h, SectionsOf(rig))), BlobStatus::kBadMagic) << magic;
  }
  EXPECT_EQ(Decode(Bytes(64, 0)), BlobStatus::kBadMagic);
  EXPECT_EQ(Decode(Bytes(2000, 0xFF)), BlobStatus::kBadMagic);
}

TEST(ParamBlob, OtherFormatVersionsAreUnsupported) {
  const Rig rig = PaperRig();
  for (const std::uint16_t version : {3, 0, 0xFFFF}) {
    TestHeader h = HeaderOf(rig, 1);
    h.version = version;  // header CRC computed over it: a well-formed blob of another version
    BlobInfo info;
    EXPECT_EQ(DecodeParamBlob(Assemble(h, SectionsOf(rig)), nullptr, nullptr, &info),
              BlobStatus::kUnsupportedVersion)
        << version;
    EXPECT_EQ(info.generation, 0u);  // not reported: the header is not understood
  }
}

TEST(ParamBlob, MalformedHeaderFields) {
  const Rig rig = PaperRig();
  std::vector<TestHeader> bad;
  for (const std::uint16_t size : {0, 63, 65, 72, 0xFFFF}) {
    bad.push_back(HeaderOf(rig, 1));
    bad.back().header_size = size;
  }
  for (const std::uint16_t flags : {0x2, 0x3, 0x8000, 0xFFFF}) {
    bad.push_back(HeaderOf(rig, 1));
    bad.back().flags = flags;
  }
  auto with_id = [&](const std::string& bytes) {
    bad.push_back(HeaderOf(rig, 1));
    bad.back().rig_id = {};
    std::copy(bytes.begin(), bytes.end(), bad.back().rig_id.begin());
  };
  with_id(std::string(32, 'a'));                      // not NUL-terminated
  with_id("");                                        // empty
  with_id("mfns paper");                              // space
  with_id("mfns\x7fpaper");                           // DEL
  with_id("mfns\xe9paper");                           // not ASCII
  with_id(std::string("mfns\0junk", 9));              // garbage after the NUL
  with_id(std::string(31, 'a') + std::string(1, 'b'));  // 32 chars, no NUL
  for (const TestHeader& h : bad) {
    BlobInfo info;
    EXPECT_EQ(DecodeParamBlob(Assemble(h, SectionsOf(rig)), nullptr, nullptr, &info), BlobStatus::kBadHeader)
        << "size " << h.header_size << " flags " << h.flags;
    EXPECT_EQ(info.generation, 0u);
  }
}

TEST(ParamBlob, PayloadLengthAboveTheLimitIsTooLarge) {
  const Rig rig = PaperRig();
  for (const std::size_t length : {limits::kMaxBlobBytes - 64 + 1, std::size_t{0xFFFF}}) {
    TestHeader h = HeaderOf(rig, 9);
    h.payload_bytes = static_cast<std::uint16_t>(length);
    const Bytes b = Assemble(h, SectionsOf(rig));
    BlobInfo info;
    EXPECT_EQ(DecodeParamBlob(b, nullptr, nullptr, &info), BlobStatus::kTooLarge);
    EXPECT_EQ(info.generation, 9u);  // the header itself was valid
    EXPECT_EQ(info.payload_bytes, length);
    EXPECT_EQ(DecodeBlobHeader(b, &info), BlobStatus::kTooLarge);
  }
  // The largest accepted payload is kMaxBlobBytes - 64: an unknown section filling it decodes.
  std::vector<TestSection> s = SectionsOf(rig);
  const Bytes reference = Reference(rig, 9);
  s.push_back({0x1234, 1, Bytes(limits::kMaxBlobBytes - reference.size() - 8, 0xAB), {}});
  const Bytes full = Assemble(HeaderOf(rig, 9), s);
  EXPECT_EQ(full.size(), limits::kMaxBlobBytes);
  EXPECT_EQ(Decode(full), BlobStatus::kOk);
}

TEST(ParamBlob, CountsAboveTheLimits) {
  const Rig rig = PaperRig();
  constexpr int kTooMany = limits::kMaxCameras + 1;
  constexpr auto kTooManyU = static_cast<std::uint32_t>(kTooMany);
  constexpr std::uint32_t kHuge = 0xFFFFFFFFu;
  auto blob = [&rig](std::vector<TestSection> s) { return Decode(Assemble(HeaderOf(rig, 1), s)); };
  std::vector<TestSection> s = SectionsOf(rig);

  // kMaxCameras + 1 consistent everywhere (count and records), and lying counts.
  std::vector<TestSection> five = s;
  five[0].body = CamerasBody(rig, kTooMany, kTooManyU);
  five[1].body = ExtrinsicsBody(rig, kTooMany, kTooManyU);
  five[3].body = SigmaBody(rig, kTooMany, kTooManyU);
  EXPECT_EQ(blob(five), BlobStatus::kTooManyCameras);
  for (std::size_t section : {0u, 1u, 3u}) {
    for (const std::uint32_t count : {kTooManyU, kHuge}) {
      std::vector<TestSection> t = s;
      SetLe(&t[section].body, 0, count, 4);  // 3 records, count above the limit
      EXPECT_EQ(blob(t), BlobStatus::kTooManyCameras) << "section " << section << " count " << count;
    }
  }
  std::vector<TestSection> ext5 = s;
  ext5[1].body = ExtrinsicsBody(rig, kTooMany, kTooManyU);  // only extrinsics above the limit
  EXPECT_EQ(blob(ext5), BlobStatus::kTooManyCameras);

  constexpr int kTooManyBeacons = limits::kMaxBeacons + 1;
  std::vector<TestSection> b65 = s;
  b65[2].body = BeaconsBody(rig, kTooManyBeacons, static_cast<std::uint32_t>(kTooManyBeacons));
  EXPECT_EQ(blob(b65), BlobStatus::kTooManyBeacons);
  std::vector<TestSection> bhuge = s;
  SetLe(&bhuge[2].body, 0, kHuge, 4);
  EXPECT_EQ(blob(bhuge), BlobStatus::kTooManyBeacons);
}

TEST(ParamBlob, SectionLengthsAreNeverTrusted) {
  const Rig rig = PaperRig();
  auto decode = [&rig](const std::vector<TestSection>& s, std::uint16_t flags = 1) {
    TestHeader h = HeaderOf(rig, 1);
    h.flags = flags;
    return Decode(Assemble(h, s));
  };
  const std::vector<TestSection> good = SectionsOf(rig);
  std::vector<TestSection> s = good;
  s.back().length = static_cast<std::uint32_t>(s.back().body.size() + 1);  // overruns the payload
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s.front().length = 0xFFFFFFFFu;
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s.front().length = static_cast<std::uint32_t>(Reference(rig, 1).size() - 64);  // one header past
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);

  // A partial section header at the end of the payload.
  TestHeader h = HeaderOf(rig, 1);
  Bytes b = Assemble(h, good);
  b.insert(b.end(), {0x77, 0x00, 0x01, 0x00});
  RepairCrcs(&b, true);
  EXPECT_EQ(Decode(b), BlobStatus::kBadSection);

  // Body lengths that disagree with their counts, or too short for a count.
  s = good;
  s[0].body.push_back(0);
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s[0].body = CamerasBody(rig, 2, 3);
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s[2].body.resize(s[2].body.size() - 8);
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s[1].body = {3, 0};
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);

  // A known section in another version.
  s = good;
  s[2].version = 2;
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  // SIGMA present while the header's flag says there is none.
  EXPECT_EQ(decode(good, 0), BlobStatus::kBadSection);
}

TEST(ParamBlob, UnknownSectionsAreSkipped) {
  const Rig rig = PaperRig();
  std::vector<TestSection> s = SectionsOf(rig);
  s.insert(s.begin() + 1, {0x00AB, 7, Bytes(13, 0xCD), {}});
  s.insert(s.begin(), {0, 0, Bytes{}, {}});
  s.push_back({0xFFFF, 0xFFFF, Bytes(3, 0x01), {}});
  Rig out = Sentinel();
  ASSERT_EQ(DecodeParamBlob(Assemble(HeaderOf(rig, 1), s), nullptr, &out, nullptr), BlobStatus::kOk);
  EXPECT_TRUE(RigsBitEqual(out, rig));
  s.back().length = 4;  // an unknown section must still fit
  EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 1), s)), BlobStatus::kBadSection);
}

TEST(ParamBlob, DuplicateAndMissingSections) {
  const Rig rig = PaperRig();
  const std::vector<TestSection> good = SectionsOf(rig);
  for (std::size_t i = 0; i < good.size(); ++i) {
    std::vector<TestSection> dup = good;
    dup.push_back(good[i]);
    EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 1), dup)), BlobStatus::kDuplicateSection) << i;
    std::vector<TestSection> missing = good;
    missing.erase(missing.begin() + static_cast<std::ptrdiff_t>(i));
    EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 1), missing)), BlobStatus::kMissingSection) << i;
  }
  EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 1), {})), BlobStatus::kMissingSection);
}

TEST(ParamBlob, SectionsMustAgreeOnTheCameraCount) {
  const Rig rig = PaperRig();
  std::vector<TestSection> s = SectionsOf(rig);
  s[1].body = ExtrinsicsBody(rig, 2, 2);
  EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 1), s)), BlobStatus::kCountMismatch);
  s = SectionsOf(rig);
  s[3].body = SigmaBody(rig, 4, 4);
  EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 1), s)), BlobStatus::kCountMismatch);
  s = SectionsOf(rig);
  s[0].body = CamerasBody(rig, 1, 1);
  EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 1), s)), BlobStatus::kCountMismatch);
}

TEST(ParamBlob, NonFiniteValuesAreRefused) {
  using Edit = void (*)(Rig*, double);
  const std::vector<std::pair<const char*, Edit>> places = {
      {"alpha_x", [](Rig* r, double v) { r->cameras[1].intrinsics.alpha_x = v; }},
      {"v0", [](Rig* r, double v) { r->cameras[0].intrinsics.v0 = v; }},
      {"kc3", [](Rig* r, double v) { r->cameras[2].intrinsics.kc[2] = v; }},
      {"C_k_b(1,2)", [](Rig* r, double v) { r->cameras[2].C_k_b(1, 2) = v; }},
      {"r_b_bk", [](Rig* r, double v) { r->cameras[0].r_b_bk.x() = v; }},
      {"beacon", [](Rig* r, double v) { r->beacons_w[5].y() = v; }},
      {"beacon_sigma", [](Rig* r, double v) { r->beacon_sigma = v; }},
      {"sigma euler", [](Rig* r, double v) { r->sigma[1].euler.z() = v; }},
  };
  for (const auto& [name, edit] : places) {
    for (const double bad : {kNaN, kInf, -kInf}) {
      Rig rig = PaperRig();
      edit(&rig, bad);
      Rig out = Sentinel();
      EXPECT_EQ(DecodeParamBlob(Reference(rig, 1), nullptr, &out, nullptr), BlobStatus::kNonFiniteValue)
          << name << " = " << bad;
      EXPECT_EQ(out.num_cameras, -7);
      std::array<std::uint8_t, limits::kMaxBlobBytes> buffer{};
      EXPECT_EQ(EncodeParamBlob(rig, 1, buffer, nullptr), BlobStatus::kNonFiniteValue) << name;
    }
  }
}

TEST(ParamBlob, InvalidRigsAreRefused) {
  using Edit = void (*)(Rig*);
  const std::vector<std::pair<const char*, Edit>> edits = {
      {"C_k_b scaled", [](Rig* r) { r->cameras[0].C_k_b *= 1.001; }},
      {"C_k_b reflection", [](Rig* r) { r->cameras[1].C_k_b.col(2) *= -1.0; }},
      {"C_k_b zero", [](Rig* r) { r->cameras[2].C_k_b.setZero(); }},
      {"u0 outside", [](Rig* r) { r->cameras[0].intrinsics.u0 = 5000.0; }},
      {"alpha_y negative", [](Rig* r) { r->cameras[0].intrinsics.alpha_y = -1.0; }},
      {"width 0", [](Rig* r) { r->cameras[1].intrinsics.width = 0; }},
      {"width 0xFFFFFFFF", [](Rig* r) { r->cameras[1].intrinsics.width = -1; }},
      {"height too big", [](Rig* r) { r->cameras[1].intrinsics.height = limits::kMaxImageHeight + 1; }},
      {"name empty", [](Rig* r) { r->cameras[2].name = {}; }},
      {"names equal", [](Rig* r) { r->cameras[2].name = r->cameras[0].name; }},
      {"name unterminated", [](Rig* r) { r->cameras[0].name.fill('n'); }},
      {"name garbage after NUL", [](Rig* r) { r->cameras[0].name[5] = 'q'; }},
      {"negative sigma", [](Rig* r) { r->sigma[0].intrinsics[3] = -1.0; }},
      {"negative beacon sigma", [](Rig* r) { r->beacon_sigma = -1e-3; }},
  };
  for (const auto& [name, edit] : edits) {
    Rig rig = PaperRig();
    edit(&rig);
    Rig out = Sentinel();
    EXPECT_EQ(DecodeParamBlob(Reference(rig, 1), nullptr, &out, nullptr), BlobStatus::kInvalidValue) << name;
    EXPECT_EQ(out.num_cameras, -7);
  }
  // Zero cameras, sections consistent.
  const Rig rig = PaperRig();
  std::vector<TestSection> s = SectionsOf(rig);
  s[0].body = CamerasBody(rig, 0, 0);
  s[1].body = ExtrinsicsBody(rig, 0, 0);
  s[3].body = SigmaBody(rig, 0, 0);
  EXPECT_EQ(Decode(Assemble(HeaderOf(rig, 1), s)), BlobStatus::kInvalidValue);
}

// Issue 14, defect 6: finite but absurd values and repeated beacons in a blob (CRCs right) are
// refused by the decoder and the encoder alike (ValidateRig's ranges, common/limits.h).
TEST(ParamBlob, AbsurdValuesAndRepeatedBeaconsAreRefused) {
  using Edit = void (*)(Rig*);
  const std::vector<std::pair<const char*, Edit>> edits = {
      {"alpha_x 1e300", [](Rig* r) { r->cameras[0].intrinsics.alpha_x = 1e300; }},
      {"skew 1e300", [](Rig* r) { r->cameras[1].intrinsics.skew = 1e300; }},
      {"kc1 1e300", [](Rig* r) { r->cameras[2].intrinsics.kc[0] = 1e300; }},
      {"r_b_bk 1e300", [](Rig* r) { r->cameras[0].r_b_bk.z() = 1e300; }},
      {"beacon 1e300", [](Rig* r) { r->beacons_w[4].x() = 1e300; }},
      {"beacon sigma 1e300", [](Rig* r) { r->beacon_sigma = 1e300; }},
      {"beacon repeated", [](Rig* r) { r->beacons_w[9] = r->beacons_w[0]; }},
  };
  for (const auto& [name, edit] : edits) {
    Rig rig = PaperRig();
    edit(&rig);
    Rig out = Sentinel();
    EXPECT_EQ(DecodeParamBlob(Reference(rig, 1), nullptr, &out, nullptr), BlobStatus::kInvalidValue) << name;
    EXPECT_EQ(out.num_cameras, -7) << name;
    std::array<std::uint8_t, limits::kMaxBlobBytes> buffer{};
    EXPECT_EQ(EncodeParamBlob(rig, 1, buffer, nullptr), BlobStatus::kInvalidValue) << name;
  }
}

// ---------------------------------------------------------------------------------------------
// Section 5, BEACON_FACING (optional; no header flag, so older decoders skip it).

TEST(ParamBlob, FacingRoundTripsAtTheBeaconLimitWithAndWithoutFacing) {
  const Rig without = MaxRig();
  const Rig with = WithFacing(MaxRig());
  ASSERT_EQ(with.num_beacons, limits::kMaxBeacons);
  for (const Rig& rig : {without, with}) {
    const Bytes blob = Encode(rig, kGeneration);
    EXPECT_EQ(blob, Reference(rig, kGeneration));
    Rig out = Sentinel();
    ASSERT_EQ(DecodeParamBlob(blob, rig.rig_id.data(), &out, nullptr), BlobStatus::kOk);
    EXPECT_TRUE(RigsBitEqual(out, rig));
    EXPECT_EQ(out.has_facing, rig.has_facing);
  }
}

// README.md's largest blob: 4 cameras with sigma, 256 beacons with facing.
TEST(ParamBlob, TheLargestBlobIs15748BytesAt256BeaconsWithFacing) {
  if constexpr (limits::kMaxBeacons >= 256 && limits::kMaxCameras >= 4) {
    Rig r256 = WithFacing(MaxRig());
    r256.num_beacons = 256;
    r256.num_cameras = 4;
    const Bytes blob = Encode(r256, 1);
    EXPECT_EQ(blob.size(), 15748u);
    Rig out = Sentinel();
    ASSERT_EQ(DecodeParamBlob(blob, nullptr, &out, nullptr), BlobStatus::kOk);
    EXPECT_TRUE(RigsBitEqual(out, r256));
    r256.has_facing = false;
    EXPECT_EQ(Encode(r256, 1).size(), 15748u - (12 + 32 * 256));
  } else {
    GTEST_SKIP() << "the 256-beacon case needs limits::kMaxBeacons >= 256 (now " << limits::kMaxBeacons << ")";
  }
}

// A version-1 blob as written before section 5 existed decodes, without facing.
TEST(ParamBlob, BlobsWithoutTheFacingSectionDecodeWithoutFacing) {
  for (const Rig& rig : {PaperRig(), PaperRigNoSigma(), MaxRig()}) {
    Rig out = Sentinel();
    out.has_facing = true;
    out.beacon_half_angle[0] = 1.0;
    ASSERT_EQ(DecodeParamBlob(Reference(rig, 4), nullptr, &out, nullptr), BlobStatus::kOk);
    EXPECT_FALSE(out.has_facing);
    EXPECT_EQ(out.beacon_half_angle[0], 0.0);  // the whole rig is replaced, no stale facing
    EXPECT_TRUE(RigsBitEqual(out, rig));
  }
  // The facing rig's blob with section 5 left out: the same rig without facing.
  const Rig facing = PaperRigWithFacing();
  std::vector<TestSection> s = SectionsOf(facing);
  ASSERT_EQ(s.back().type, kFac);
  s.pop_back();
  Rig out = Sentinel();
  ASSERT_EQ(DecodeParamBlob(Assemble(HeaderOf(facing, 4), s), nullptr, &out, nullptr), BlobStatus::kOk);
  EXPECT_TRUE(RigsBitEqual(out, PaperRig()));
}

// Section 5 anywhere in the payload, with unknown sections (types 6 and up) around it.
TEST(ParamBlob, FacingInAnyOrderAndUnknownSection6AreFine) {
  const Rig rig = PaperRigWithFacing();
  const std::vector<TestSection> good = SectionsOf(rig);
  std::vector<TestSection> s = good;
  std::rotate(s.begin(), s.end() - 1, s.end());  // facing first
  s.insert(s.begin() + 2, {6, 1, Bytes(40, 0x5A), {}});
  s.push_back({6, 2, Bytes{}, {}});  // unknown types may repeat: they are not read
  Rig out = Sentinel();
  ASSERT_EQ(DecodeParamBlob(Assemble(HeaderOf(rig, 1), s), nullptr, &out, nullptr), BlobStatus::kOk);
  EXPECT_TRUE(RigsBitEqual(out, rig));
  // An unknown section 6 that looks like a facing section does not make facing.
  std::vector<TestSection> six = SectionsOf(PaperRig());
  six.push_back({6, 1, FacingBody(rig, 10, 10), {}});
  out = Sentinel();
  ASSERT_EQ(DecodeParamBlob(Assemble(HeaderOf(rig, 1), six), nullptr, &out, nullptr), BlobStatus::kOk);
  EXPECT_FALSE(out.has_facing);
  EXPECT_TRUE(RigsBitEqual(out, PaperRig()));
}

TEST(ParamBlob, FacingCountMustEqualTheBeaconCount) {
  const Rig rig = PaperRigWithFacing();  // 10 beacons
  auto decode = [&rig](const Bytes& facing_body) {
    std::vector<TestSection> s = SectionsOf(rig);
    s.back().body = facing_body;
    return Decode(Assemble(HeaderOf(rig, 1), s));
  };
  EXPECT_EQ(decode(FacingBody(rig, 10, 10)), BlobStatus::kOk);
  EXPECT_EQ(decode(FacingBody(rig, 9, 9)), BlobStatus::kCountMismatch);
  EXPECT_EQ(decode(FacingBody(rig, 11, 11)), BlobStatus::kCountMismatch);
  EXPECT_EQ(decode(FacingBody(rig, 0, 0)), BlobStatus::kCountMismatch);
  // Beacons and facing agree with each other but not with 10: fine, they are the rig's.
  Rig nine = rig;
  nine.num_beacons = 9;
  std::vector<TestSection> s = SectionsOf(nine);
  EXPECT_EQ(Decode(Assemble(HeaderOf(nine, 1), s)), BlobStatus::kOk);
  s[2].body = BeaconsBody(nine, 10, 10);
  EXPECT_EQ(Decode(Assemble(HeaderOf(nine, 1), s)), BlobStatus::kCountMismatch);
  // No beacons, with facing: an empty facing section.
  Rig none = rig;
  none.num_beacons = 0;
  Rig out = Sentinel();
  ASSERT_EQ(DecodeParamBlob(Encode(none, 1), nullptr, &out, nullptr), BlobStatus::kOk);
  EXPECT_TRUE(out.has_facing);
  EXPECT_EQ(out.num_beacons, 0);
}

TEST(ParamBlob, FacingSectionLengthsAndCountsAreNeverTrusted) {
  const Rig rig = PaperRigWithFacing();
  const std::vector<TestSection> good = SectionsOf(rig);
  auto decode = [&rig](const std::vector<TestSection>& s) { return Decode(Assemble(HeaderOf(rig, 1), s)); };
  std::vector<TestSection> s = good;
  s.back().body.resize(s.back().body.size() - 8);  // truncated record
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s.back().body.resize(s.back().body.size() - 32);  // a whole record short of its count
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s.back().body.push_back(0);  // one byte too many
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s.back().body.resize(s.back().body.size() + 32);  // a whole record too many
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  for (const Bytes& tiny : {Bytes{}, Bytes{10}, Bytes{10, 0, 0}}) {  // too short for the count
    s = good;
    s.back().body = tiny;
    EXPECT_EQ(decode(s), BlobStatus::kBadSection) << tiny.size();
  }
  s = good;
  s.back().length = static_cast<std::uint32_t>(s.back().body.size() + 1);  // overruns the payload
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s.back().length = 0xFFFFFFFFu;
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s.back().version = 2;
  EXPECT_EQ(decode(s), BlobStatus::kBadSection);
  s = good;
  s.push_back(good.back());
  EXPECT_EQ(decode(s), BlobStatus::kDuplicateSection);
  // Counts above kMaxBeacons, before any record is read: consistent and lying.
  constexpr int kTooMany = limits::kMaxBeacons + 1;
  s = good;
  s.back().body = FacingBody(rig, kTooMany, static_cast<std::uint32_t>(kTooMany));
  EXPECT_EQ(decode(s), BlobStatus::kTooManyBeacons);
  for (const std::uint32_t count : {static_cast<std::uint32_t>(kTooMany), 0xFFFFFFFFu}) {
    s = good;
    SetLe(&s.back().body, 0, count, 4);
    EXPECT_EQ(decode(s), BlobStatus::kTooManyBeacons) << count;
  }
}

TEST(ParamBlob, InvalidFacingIsRefused) {
  using Edit = void (*)(Rig*);
  const std::vector<std::pair<const char*, Edit>> edits = {
      {"normal length 1.001", [](Rig* r) { r->beacon_normal_w[3] *= 1.001; }},
      {"normal length 0.5", [](Rig* r) { r->beacon_normal_w[3] *= 0.5; }},
      {"normal length 1 + 2e-6", [](Rig* r) { r->beacon_normal_w[9] = Eigen::Vector3d(0, 1 + 2e-6, 0); }},
      {"normal zero", [](Rig* r) { r->beacon_normal_w[0].setZero(); }},
      {"half-angle 0", [](Rig* r) { r->beacon_half_angle[4] = 0.0; }},
      {"half-angle -0", [](Rig* r) { r->beacon_half_angle[4] = -0.0; }},
      {"half-angle negative", [](Rig* r) { r->beacon_half_angle[4] = -0.5; }},
      {"half-angle just above pi", [](Rig* r) { r->beacon_half_angle[5] = std::nextafter(kPi, 4.0); }},
      {"half-angle 2 pi", [](Rig* r) { r->beacon_half_angle[5] = 2 * kPi; }},
  };
  for (const auto& [name, edit] : edits) {
    Rig rig = PaperRigWithFacing();
    edit(&rig);
    ASSERT_EQ(ValidateRig(rig), RigStatus::kBadFacing) << name;
    Rig out = Sentinel();
    EXPECT_EQ(DecodeParamBlob(Reference(rig, 1), nullptr, &out, nullptr), BlobStatus::kInvalidValue) << name;
    EXPECT_EQ(out.num_cameras, -7);
    Bytes buffer(limits::kMaxBlobBytes, 0xA5);
    EXPECT_EQ(EncodeParamBlob(rig, 1, buffer, nullptr), BlobStatus::kInvalidValue) << name;
    EXPECT_TRUE(std::all_of(buffer.begin(), buffer.end(), [](std::uint8_t c) { return c == 0xA5; })) << name;
  }
  // The limits themselves are valid: pi exactly, the smallest positive half-angle, a normal
  // within 1e-6 of unit length (the decoder keeps it as it is).
  Rig edge = PaperRigWithFacing();
  edge.beacon_half_angle[6] = kPi;
  edge.beacon_half_angle[7] = std::numeric_limits<double>::denorm_min();
  edge.beacon_normal_w[8] = Eigen::Vector3d(0, 0, 1 + 5e-7);
  Rig out = Sentinel();
  ASSERT_EQ(DecodeParamBlob(Reference(edge, 1), nullptr, &out, nullptr), BlobStatus::kOk);
  EXPECT_TRUE(RigsBitEqual(out, edge));
}

TEST(ParamBlob, NonFiniteFacingIsRefused) {
  using Edit = void (*)(Rig*, double);
  const std::vector<std::pair<const char*, Edit>> places = {
      {"normal x", [](Rig* r, double v) { r->beacon_normal_w[0].x() = v; }},
      {"normal z", [](Rig* r, double v) { r->beacon_normal_w[9].z() = v; }},
      {"half-angle", [](Rig* r, double v) { r->beacon_half_angle[2] = v; }},
  };
  for (const auto& [name, edit] : places) {
    for (const double bad : {kNaN, -kNaN, kInf, -kInf}) {
      Rig rig = PaperRigWithFacing();
      edit(&rig, bad);
      Rig out = Sentinel();
      EXPECT_EQ(DecodeParamBlob(Reference(rig, 1), nullptr, &out, nullptr), BlobStatus::kNonFiniteValue)
          << name << " = " << bad;
      EXPECT_EQ(out.num_cameras, -7);
      Bytes buffer(limits::kMaxBlobBytes);
      EXPECT_EQ(EncodeParamBlob(rig, 1, buffer, nullptr), BlobStatus::kNonFiniteValue) << name;
    }
  }
  // Non-finite beats an invalid facing elsewhere (checks in README.md's order: 6 before 7).
  Rig rig = PaperRigWithFacing();
  rig.beacon_half_angle[1] = 0.0;
  rig.beacon_half_angle[8] = kNaN;
  EXPECT_EQ(Decode(Reference(rig, 1)), BlobStatus::kNonFiniteValue);
}

// ---------------------------------------------------------------------------------------------
// Encoder.

TEST(ParamBlob, EncoderNeedsABufferLargeEnoughAndLeavesItAloneOtherwise) {
  const Rig rig = PaperRig();
  const Bytes expected = Encode(rig, kGeneration);
  for (std::size_t n = 0; n < expected.size(); ++n) {
    Bytes out(n, 0xA5);
    std::size_t written = 12345;
    ASSERT_EQ(EncodeParamBlob(rig, kGeneration, out, &written), BlobStatus::kBufferTooSmall) << n;
    EXPECT_EQ(written, 12345u);
    EXPECT_TRUE(std::all_of(out.begin(), out.end(), [](std::uint8_t c) { return c == 0xA5; }));
  }
  Bytes out(expected.size() + 10, 0xA5);
  std::size_t written = 0;
  ASSERT_EQ(EncodeParamBlob(rig, kGeneration, out, &written), BlobStatus::kOk);
  EXPECT_EQ(written, expected.size());
  EXPECT_TRUE(std::equal(expected.begin(), expected.end(), out.begin()));
  EXPECT_TRUE(std::all_of(out.begin() + static_cast<std::ptrdiff_t>(written), out.end(),
                          [](std::uint8_t c) { return c == 0xA5; }));
}

// ValidateRig ignores what follows a name's NUL; the blob must not carry it (the decoder
// requires zeros there), so the encoding only depends on the strings.
TEST(ParamBlob, EncoderWritesStringsNulPadded) {
  Rig dirty = PaperRig();
  dirty.rig_id[20] = 'j';
  dirty.cameras[1].name[4] = 'k';
  dirty.cameras[2].name[7] = 'z';
  ASSERT_EQ(ValidateRig(dirty), RigStatus::kOk);
  const Bytes blob = Encode(dirty, 3);
  EXPECT_EQ(blob, Encode(PaperRig(), 3));
  Rig out;
  ASSERT_EQ(DecodeParamBlob(blob, kPaperRigId, &out, nullptr), BlobStatus::kOk);
  EXPECT_TRUE(RigsBitEqual(out, PaperRig()));
}

TEST(ParamBlob, EncoderRefusesInvalidRigs) {
  using Edit = void (*)(Rig*);
  const std::vector<std::tuple<const char*, Edit, BlobStatus>> cases = {
      {"too many cameras", [](Rig* r) { r->num_cameras = limits::kMaxCameras + 1; }, BlobStatus::kTooManyCameras},
      {"too many beacons", [](Rig* r) { r->num_beacons = limits::kMaxBeacons + 1; }, BlobStatus::kTooManyBeacons},
      {"negative beacons", [](Rig* r) { r->num_beacons = -1; }, BlobStatus::kTooManyBeacons},
      {"NaN", [](Rig* r) { r->cameras[0].intrinsics.skew = kNaN; }, BlobStatus::kNonFiniteValue},
      {"not a rotation", [](Rig* r) { r->cameras[1].C_k_b(0, 0) += 1e-3; }, BlobStatus::kInvalidValue},
      {"no cameras", [](Rig* r) { r->num_cameras = 0; }, BlobStatus::kInvalidValue},
      {"empty rig id", [](Rig* r) { r->rig_id = {}; }, BlobStatus::kInvalidValue},
      {"rig id unterminated", [](Rig* r) { r->rig_id.fill('r'); }, BlobStatus::kInvalidValue},
      {"negative sigma", [](Rig* r) { r->sigma[2].r_b_bk.y() = -1.0; }, BlobStatus::kInvalidValue},
  };
  for (const auto& [name, edit, status] : cases) {
    Rig rig = PaperRig();
    edit(&rig);
    Bytes out(limits::kMaxBlobBytes, 0xA5);
    std::size_t written = 777;
    EXPECT_EQ(EncodeParamBlob(rig, 1, out, &written), status) << name;
    EXPECT_EQ(written, 777u);
    EXPECT_TRUE(std::all_of(out.begin(), out.end(), [](std::uint8_t c) { return c == 0xA5; })) << name;
  }
}

// ---------------------------------------------------------------------------------------------
// Random mutations: never a crash (asan), never kOk for something that is not a valid rig.

class SplitMix64 {  // fully specified, so the mutations are the same on every platform
 public:
  explicit SplitMix64(std::uint64_t seed) : s_(seed) {}
  std::uint64_t Next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::size_t Below(std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(Next() % n); }

 private:
  std::uint64_t s_;
};

void Mutate(SplitMix64& rng, Bytes* b) {
  const std::size_t ops = 1 + rng.Below(3);
  for (std::size_t op = 0; op < ops; ++op) {
    switch (rng.Below(7)) {
      case 0:  // random byte anywhere
        if (!b->empty()) (*b)[rng.Below(b->size())] = static_cast<std::uint8_t>(rng.Next());
        break;
      case 1:  // random byte in the header or the first section header
        if (b->size() > 72) (*b)[rng.Below(72)] = static_cast<std::uint8_t>(rng.Next());
        break;
      case 2: {  // insertion
        const std::size_t at = rng.Below(b->size() + 1);
        for (std::size_t k = 1 + rng.Below(16); k > 0; --k)
          b->insert(b->begin() + static_cast<std::ptrdiff_t>(at), static_cast<std::uint8_t>(rng.Next()));
        break;
      }
      case 3: {  // deletion
        if (b->empty()) break;
        const std::size_t at = rng.Below(b->size());
        const std::size_t n = std::min(b->size() - at, 1 + rng.Below(16));
        b->erase(b->begin() + static_cast<std::ptrdiff_t>(at), b->begin() + static_cast<std::ptrdiff_t>(at + n));
        break;
      }
      case 4:  // truncation
        b->resize(rng.Below(b->size() + 1));
        break;
      case 5:  // a plausible or extreme u32 (count, length) at an aligned payload position
        if (b->size() >= 72) {
          const std::size_t at = 64 + 4 * rng.Below((b->size() - 64) / 4);
          const std::uint32_t v = rng.Below(2) == 0 ? static_cast<std::uint32_t>(rng.Below(80)) : 0xFFFFFFFFu;
          SetLe(b, at, v, 4);
        }
        break;
      default: {  // a non-finite or odd double at an 8-byte position of the payload
        if (b->size() >= 72) {
          const std::size_t at = 64 + 8 * rng.Below((b->size() - 64) / 8);
          const double values[] = {kNaN, kInf, -kInf, 0.0, -1.0, 1e300};
          SetLe(b, at, std::bit_cast<std::uint64_t>(values[rng.Below(6)]), 8);
        }
        break;
      }
    }
  }
}

TEST(ParamBlob, RandomMutationsNeverCrashOrDecodeToAnotherRig) {
  const std::vector<Rig> rigs = {PaperRig(), PaperRigNoSigma(), MaxRig(), PaperRigWithFacing(),
                                 WithFacing(MaxRig())};
  std::vector<Bytes> blobs;
  for (const Rig& r : rigs) blobs.push_back(Encode(r, kGeneration));
  SplitMix64 rng(0x0B10B5EEDull);
  std::map<BlobStatus, int> seen;
  int repaired_ok = 0;
  for (int iter = 0; iter < 4000; ++iter) {
    const std::size_t which = static_cast<std::size_t>(iter) % rigs.size();
    Bytes b = blobs[which];
    Mutate(rng, &b);
    const bool repair = rng.Below(2) == 0;
    if (repair) RepairCrcs(&b, rng.Below(2) == 0);
    Rig out = Sentinel();
    BlobInfo info;
    const BlobStatus s = DecodeParamBlob(b, nullptr, &out, &info);
    ++seen[s];
    if (s != BlobStatus::kOk) {
      ASSERT_EQ(out.num_cameras, -7) << "iteration " << iter;
      continue;
    }
    // Without CRC repair only the original rig can pass (an unchanged or no-op mutation).
    if (!repair) {
      ASSERT_TRUE(RigsBitEqual(out, rigs[which])) << "iteration " << iter;
    }
    repaired_ok += repair ? 1 : 0;
    // Whatever passed is a valid rig: it re-encodes, and that decodes to the same rig.
    Bytes re(limits::kMaxBlobBytes);
    std::size_t written = 0;
    ASSERT_EQ(EncodeParamBlob(out, info.generation, re, &written), BlobStatus::kOk) << "iteration " << iter;
    re.resize(written);
    Rig again = Sentinel();
    ASSERT_EQ(DecodeParamBlob(re, out.rig_id.data(), &again, nullptr), BlobStatus::kOk);
    ASSERT_TRUE(RigsBitEqual(again, out)) << "iteration " << iter;
  }
  std::ostringstream record;
  for (const auto& [status, count] : seen) record << ToString(status) << ": " << count << "; ";
  ::testing::Test::RecordProperty("statuses", record.str());
  ::testing::Test::RecordProperty("repaired_ok", repaired_ok);
  EXPECT_GE(seen.size(), 12u) << record.str();  // the mutations reach most checks
}

}  // namespace
}  // namespace mfns

namespace mfns {
namespace {

// Issue 16: per-beacon sigmas (format version 2). The largest rig still fits; a version-1 blob
// reads as before and treats section 6 as unknown; counts and values are checked.
TEST(ParamBlob, BeaconSigmasNeedVersion2AndAreChecked) {
  const Rig rig = WithBeaconSigmas(PaperRig());
  const Bytes largest = Encode(WithBeaconSigmas(WithFacing(MaxRig())), 1);
  EXPECT_LE(largest.size(), limits::kMaxBlobBytes);
  Rig out = Sentinel();
  ASSERT_EQ(DecodeParamBlob(Assemble(HeaderOf(rig, 1), SectionsOf(rig)), nullptr, &out, nullptr), BlobStatus::kOk);
  EXPECT_TRUE(RigsBitEqual(out, rig));
  // In a version-1 header the section is unknown, skipped: the rig has no per-beacon sigmas.
  TestHeader v1 = HeaderOf(rig, 1);
  v1.version = 1;
  out = Sentinel();
  ASSERT_EQ(DecodeParamBlob(Assemble(v1, SectionsOf(rig)), nullptr, &out, nullptr), BlobStatus::kOk);
  EXPECT_FALSE(out.has_beacon_sigmas);
  // A count other than the beacons', a negative or NaN sigma, beacon_sigma not their largest.
  std::vector<TestSection> s = SectionsOf(rig);
  s.back().body = BeaconSigmasBody(rig, rig.num_beacons - 1, static_cast<std::uint32_t>(rig.num_beacons - 1));
  EXPECT_EQ(DecodeParamBlob(Assemble(HeaderOf(rig, 1), s), nullptr, nullptr, nullptr), BlobStatus::kCountMismatch);
  s.back().body = BeaconSigmasBody(rig, rig.num_beacons, 1000);
  EXPECT_EQ(DecodeParamBlob(Assemble(HeaderOf(rig, 1), s), nullptr, nullptr, nullptr), BlobStatus::kTooManyBeacons);
  Rig bad = rig;
  bad.beacon_sigmas[3] = -1e-4;
  EXPECT_EQ(DecodeParamBlob(Assemble(HeaderOf(bad, 1), SectionsOf(bad)), nullptr, nullptr, nullptr),
            BlobStatus::kInvalidValue);
  bad = rig;
  bad.beacon_sigmas[3] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(DecodeParamBlob(Assemble(HeaderOf(bad, 1), SectionsOf(bad)), nullptr, nullptr, nullptr),
            BlobStatus::kNonFiniteValue);
  bad = rig;
  bad.beacon_sigma *= 2.0;
  EXPECT_EQ(DecodeParamBlob(Assemble(HeaderOf(bad, 1), SectionsOf(bad)), nullptr, nullptr, nullptr),
            BlobStatus::kInvalidValue);
  Bytes buf(limits::kMaxBlobBytes);
  EXPECT_EQ(EncodeParamBlob(bad, 1, buf, nullptr), BlobStatus::kInvalidValue);
}

}  // namespace
}  // namespace mfns
