#include "host/rigio/rig_yaml.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

void ExpectRigNear(const Rig& a, const Rig& b, double tol) {
  EXPECT_STREQ(a.rig_id.data(), b.rig_id.data());
  ASSERT_EQ(a.num_cameras, b.num_cameras);
  ASSERT_EQ(a.num_beacons, b.num_beacons);
  EXPECT_EQ(a.has_sigma, b.has_sigma);
  for (int i = 0; i < a.num_cameras; ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_STREQ(a.cameras[k].name.data(), b.cameras[k].name.data());
    EXPECT_EQ(a.cameras[k].intrinsics.width, b.cameras[k].intrinsics.width);
    EXPECT_LT((a.cameras[k].intrinsics.ToVector() - b.cameras[k].intrinsics.ToVector()).cwiseAbs().maxCoeff(), tol * 1e3);
    EXPECT_LT((a.cameras[k].C_k_b - b.cameras[k].C_k_b).cwiseAbs().maxCoeff(), tol);
    EXPECT_LT((a.cameras[k].r_b_bk - b.cameras[k].r_b_bk).cwiseAbs().maxCoeff(), tol);
    if (a.has_sigma) {
      EXPECT_LT((a.sigma[k].euler - b.sigma[k].euler).cwiseAbs().maxCoeff(), tol);
      EXPECT_LT((a.sigma[k].r_b_bk - b.sigma[k].r_b_bk).cwiseAbs().maxCoeff(), tol);
      for (std::size_t j = 0; j < 5; ++j) EXPECT_NEAR(a.sigma[k].intrinsics[j], b.sigma[k].intrinsics[j], tol);
    }
  }
  for (int i = 0; i < a.num_beacons; ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_LT((a.beacons_w[k] - b.beacons_w[k]).cwiseAbs().maxCoeff(), tol);
  }
  EXPECT_NEAR(a.beacon_sigma, b.beacon_sigma, tol);
  EXPECT_EQ(a.has_facing, b.has_facing);
  for (int i = 0; a.has_facing && i < a.num_beacons; ++i) {
    const auto k = static_cast<std::size_t>(i);
    EXPECT_LT((a.beacon_normal_w[k] - b.beacon_normal_w[k]).cwiseAbs().maxCoeff(), tol) << "beacon " << i;
    EXPECT_NEAR(a.beacon_half_angle[k], b.beacon_half_angle[k], tol) << "beacon " << i;
  }
}

TEST(RigYaml, RoundTripOfThePaperRig) {
  const Rig rig = PaperRig();
  const Rig back = ParseRigYaml(FormatRigYaml(rig), "mem");
  ExpectRigNear(rig, back, 1e-14);
}

// The shipped config/paper-rig.yaml is generated from PaperRig(); they must not drift apart.
TEST(RigYaml, ShippedPaperRigFileEqualsPaperRig) {
  const char* src = std::getenv("MFNS_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  const Rig shipped = ReadRigYaml(std::filesystem::path(src) / "config" / "paper-rig.yaml");
  ExpectRigNear(PaperRig(), shipped, 1e-14);
}

TEST(RigYaml, EulerOnlyFileGivesTheMatrix) {
  const Rig rig = ParseRigYaml(R"(
rig_id: test
cameras:
  - {name: z, width: 640, height: 480, intrinsics: [500, 500, 0, 320, 240],
     distortion: [0, 0, 0, 0, 0], euler_deg: [1, 2, 3], r_b_bk_mm: [1, 2, 3]}
)", "mem");
  EXPECT_TRUE(rig.cameras[0].C_k_b.isApprox(EulerToMatrix({DegToRad(1), DegToRad(2), DegToRad(3)}), 1e-15));
  EXPECT_NEAR(rig.cameras[0].r_b_bk.z(), 0.003, 1e-18);
  EXPECT_EQ(rig.num_beacons, 0);
  EXPECT_FALSE(rig.has_sigma);
}

std::string ErrorOf(const std::string& yaml) {
  try {
    ParseRigYaml(yaml, "rig.yaml");
  } catch (const UserError& e) {
    return e.what();
  }
  return "(no error)";
}

const char* kCam = "  - {name: x, width: 1280, height: 1024, intrinsics: [1600, 1600, 0, 640, 512], "
                   "distortion: [0, 0, 0, 0, 0], euler_deg: [0, 0, 0], r_b_bk_mm: [0, 0, 0]}\n";

TEST(RigYaml, ErrorsNameTheFieldAndLine) {
  const std::string head = "rig_id: r\ncameras:\n";
  EXPECT_EQ(ErrorOf("cameras: []\n"), "rig.yaml:1: missing field 'rig_id'");
  EXPECT_EQ(ErrorOf("rig_id: r\n"), "rig.yaml:1: missing field 'cameras'");
  std::string bad = kCam;
  bad.replace(bad.find("[1600, 1600, 0, 640, 512]"), 25, "[1600, 1600, 640, 512]");
  EXPECT_EQ(ErrorOf(head + bad), "rig.yaml:3: cameras[0].intrinsics: expected 5 numbers, got 4");
  bad = kCam;
  bad.replace(bad.find("width: 1280"), 11, "width: wide");
  EXPECT_EQ(ErrorOf(head + bad), "rig.yaml:3: cameras[0].width: expected an integer");
  bad = kCam;
  bad.replace(bad.find("[0, 0, 0]}"), 10, "[0, x, 0]}");
  EXPECT_EQ(ErrorOf(head + bad), "rig.yaml:3: cameras[0].r_b_bk_mm[1]: expected a number, got 'x'");
  EXPECT_EQ(ErrorOf(head + kCam + kCam), "rig.yaml:4: cameras[1].name: repeats the name of cameras[0]");
  bad = kCam;
  bad.replace(bad.find("euler_deg: [0, 0, 0]"), 20, "C_k_b: [1, 0, 0, 0, 1, 0, 0, 0, 2]");
  EXPECT_EQ(ErrorOf(head + bad), "rig.yaml:3: cameras[0].C_k_b: not a rotation matrix (orthonormal, det +1)");
  bad = kCam;
  bad.replace(bad.find("euler_deg: [0, 0, 0]"), 20, "euler_deg: [0, 0, 1], C_k_b: [1, 0, 0, 0, 1, 0, 0, 0, 1]");
  EXPECT_NE(ErrorOf(head + bad).find("cameras[0].euler_deg: disagrees with C_k_b by 1.0"), std::string::npos);
  bad = kCam;
  bad.replace(bad.find("640, 512"), 8, "9640, 512");
  EXPECT_EQ(ErrorOf(head + bad), "rig.yaml:3: cameras[0].intrinsics: focal length outside 1..1e6 px, |skew| above "
                                 "alpha_x or principal point outside the image");
  EXPECT_EQ(ErrorOf(head + kCam + "beacons_mm: [[1, 2]]\n"), "rig.yaml:4: beacons_mm[0]: expected 3 numbers, got 2");
  EXPECT_NE(ErrorOf("rig_id: [unclosed\n").find("rig.yaml:"), std::string::npos);
  EXPECT_NE(ErrorOf("rig_id: [unclosed\n").find("not valid YAML"), std::string::npos);
  EXPECT_EQ(ErrorOf(head + kCam + "beacon_sigma_mm: -1\n"), "rig.yaml:4: beacon_sigma_mm: must not be negative");
  EXPECT_EQ(ErrorOf(head + kCam + "beacon_sigma_mm: .nan\n"), "rig.yaml:4: beacon_sigma_mm: value is not finite");
}

// Issue 14, defect 10: a list or a map where a name belongs is named with the file, the line
// and the field (yaml-cpp said "bad conversion" and nothing else).
TEST(RigYaml, WrongNodeTypesNameTheFieldNotBadConversion) {
  const std::string head = "rig_id: r\ncameras:\n";
  EXPECT_EQ(ErrorOf("rig_id: [a, b]\ncameras: []\n"), "rig.yaml:1: rig_id: expected a string");
  std::string cam = kCam;
  cam.replace(cam.find("name: x"), 7, "name: {a: 1}");
  EXPECT_EQ(ErrorOf(head + cam), "rig.yaml:3: cameras[0].name: expected a string");
  for (const std::string& yaml : {std::string("rig_id: {a: [1]}\n"), head + "  - [1, 2]\n", head + "  - {name: [x]}\n"}) {
    const std::string e = ErrorOf(yaml);
    EXPECT_EQ(e.rfind("rig.yaml:", 0), 0u) << e;
    EXPECT_EQ(e.find("bad conversion"), std::string::npos) << e;
  }
}

// Found by rig_yaml_fuzz (issue 14 item 2): a NUL byte in a flow list made yaml-cpp's message
// quote raw control characters, so the "one-line" error spanned two lines; text from the file
// (a quoted scalar) could carry any control character too. Both are escaped now, long text cut.
TEST(RigYaml, ErrorsStayOnOneLineWhateverTheFileHolds) {
  const std::string head = "rig_id: r\ncameras:\n";
  const std::string nul = ErrorOf("rig_id: [0.04" + std::string(1, '\0') + "\n0.09]\ncameras: []\n");
  EXPECT_EQ(nul.rfind("rig.yaml:", 0), 0u) << nul;
  EXPECT_EQ(nul.find('\n'), std::string::npos) << nul;
  EXPECT_EQ(nul.find('\0'), std::string::npos) << nul;
  std::string cam = kCam;
  cam.replace(cam.find("width: 1280"), 11, "width: \"12\\t\\u0001x\"");
  EXPECT_EQ(ErrorOf(head + cam), "rig.yaml:3: cameras[0].width: expected an integer");
  std::string number = kCam;
  number.replace(number.find("r_b_bk_mm: [0, 0, 0]"), 20, "r_b_bk_mm: [0, \"" + std::string(500, 'y') + "\\x01\", 0]");
  const std::string e = ErrorOf(head + number);
  EXPECT_EQ(e.rfind("rig.yaml:3: cameras[0].r_b_bk_mm[1]: expected a number, got 'yyy", 0), 0u) << e;
  EXPECT_LT(e.size(), 320u);
  EXPECT_EQ(e.substr(e.size() - 3), "...");
}

// Found by rig_yaml_fuzz: a C_k_b near the 2-1-3 set's singularity (the paper's camera y, one
// element 4e-8 off) was kept as read, 1e-7 off orthonormal; the writer's euler_deg from it then
// disagreed with it by 0.0008 deg and the file it wrote was refused on reading. The reader keeps
// the nearest rotation, so what it writes it reads back.
TEST(RigYaml, WhatItWritesItReadsBackNearTheEulerSingularity) {
  const std::string yaml =
      "rig_id: r\ncameras:\n  - {name: y, width: 1280, height: 1024, intrinsics: [1600, 1600, 0, 640, 512], "
      "distortion: [0, 0, 0, 0, 0], r_b_bk_mm: [0, 0, 0], C_k_b: [0.999916009944187, -9.59328531735502e-06, "
      "0.0129604384673377, -0.0129604130246433, -0.00285533866069538, 0.999911933489827, 2.74540005451568e-05, "
      "-0.999995923466242, -0.00285522317358188]}\n";
  const Rig rig = ParseRigYaml(yaml, "rig.yaml");
  EXPECT_TRUE(IsRotation(rig.cameras[0].C_k_b, 1e-12));
  const std::string written = FormatRigYaml(rig);
  Rig again;
  ASSERT_NO_THROW(again = ParseRigYaml(written, "written.yaml")) << written;
  EXPECT_LT(LogSO3(again.cameras[0].C_k_b * rig.cameras[0].C_k_b.transpose()).norm(), 1e-12);
}

// Issue 14, defect 6: finite but absurd numbers (1e300) and repeated beacons are refused with
// the file, the line and the field (ranges: common/limits.h, README "Rig file").
TEST(RigYaml, AbsurdValuesAndRepeatedBeaconsNameTheField) {
  const std::string head = "rig_id: r\ncameras:\n";
  const std::string three = "beacons_mm:\n  - [0, 0, 1000]\n  - [500, 0, 1000]\n  - [0, 500, 1000]\n";
  EXPECT_EQ(ErrorOf(head + kCam + three), "(no error)");
  const auto with = [&](const char* from, const char* to) {
    std::string cam = kCam;
    cam.replace(cam.find(from), std::string(from).size(), to);
    return ErrorOf(head + cam + three);
  };
  EXPECT_EQ(with("[1600, 1600, 0, 640, 512]", "[1e300, 1600, 0, 640, 512]"),
            "rig.yaml:3: cameras[0].intrinsics: focal length outside 1..1e6 px, |skew| above alpha_x or principal point "
            "outside the image");
  EXPECT_NE(with("[1600, 1600, 0, 640, 512]", "[1600, 1600, -1e300, 640, 512]").find("cameras[0].intrinsics: "),
            std::string::npos);
  EXPECT_EQ(with("distortion: [0, 0, 0, 0, 0]", "distortion: [0, 0, 0, 0, 1e300]"),
            "rig.yaml:3: cameras[0].distortion: distortion coefficient outside -1000..1000");
  EXPECT_EQ(with("r_b_bk_mm: [0, 0, 0]", "r_b_bk_mm: [0, 1e300, 0]"),
            "rig.yaml:3: cameras[0].r_b_bk_mm: camera position r_b_bk outside +-10000 mm of the body origin");
  EXPECT_EQ(ErrorOf(head + kCam + "beacons_mm:\n  - [0, 0, 1000]\n  - [1e300, 0, 0]\n"),
            "rig.yaml:6: beacons_mm[1]: beacon position outside +-1e6 mm (1 km) of the world origin");
  EXPECT_EQ(ErrorOf(head + kCam + three + "  - [500, 0, 1000.5]\n"),
            "rig.yaml:8: beacons_mm[3]: same position as beacons_mm[1] (closer than 1 mm)");
  EXPECT_EQ(ErrorOf(head + kCam + three + "beacon_sigma_mm: 1e300\n"),
            "rig.yaml:8: beacon_sigma_mm: negative sigma, or a beacon sigma above 1000 mm");
  // 1.2 mm apart is two beacons.
  EXPECT_EQ(ErrorOf(head + kCam + three + "  - [500, 0, 1001.2]\n"), "(no error)");
}

// The paper rig with a facing for each of its 10 beacons: odd normals, half-angles from the
// smallest printable to exactly 180 deg.
Rig PaperRigWithFacing() {
  Rig r = PaperRig();
  r.has_facing = true;
  for (int i = 0; i < r.num_beacons; ++i) {
    const auto m = static_cast<std::size_t>(i);
    r.beacon_normal_w[m] = Eigen::Vector3d(std::sin(0.7 * i + 0.1), std::cos(1.3 * i), 0.3 - 0.1 * i).normalized();
    r.beacon_half_angle[m] = DegToRad(5.0 + 17.5 * i);
  }
  r.beacon_normal_w[0] = Eigen::Vector3d(0, 0, -1);
  r.beacon_half_angle[0] = kPi;     // 180 deg, the largest
  r.beacon_half_angle[1] = 1e-9;    // tiny but positive
  return r;
}

TEST(RigYaml, BeaconFacingRoundTrips) {
  const Rig rig = PaperRigWithFacing();
  ASSERT_EQ(ValidateRig(rig), RigStatus::kOk);
  const std::string text = FormatRigYaml(rig);
  EXPECT_NE(text.find("beacon_facing:"), std::string::npos);
  EXPECT_NE(text.find("\n  - [0, 0, -1, 180]\n"), std::string::npos) << text;
  const Rig back = ParseRigYaml(text, "mem");
  ASSERT_TRUE(back.has_facing);
  EXPECT_EQ(back.beacon_half_angle[0], kPi);  // 180 deg reads back as pi exactly
  ExpectRigNear(rig, back, 1e-14);
  EXPECT_EQ(ValidateRig(back), RigStatus::kOk);
  // The facing lines are exact to the printed precision (euler_deg, derived from C_k_b, is not).
  const std::string again = FormatRigYaml(back);
  ASSERT_NE(again.find("beacon_facing:"), std::string::npos);
  EXPECT_EQ(again.substr(again.find("beacon_facing:")), text.substr(text.find("beacon_facing:")));

  // No beacons, with facing: an empty list, written and read back.
  Rig none = PaperRig();
  none.num_beacons = 0;
  none.has_facing = true;
  const std::string empty = FormatRigYaml(none);
  EXPECT_NE(empty.find("beacon_facing: []"), std::string::npos) << empty;
  const Rig none_back = ParseRigYaml(empty, "mem");
  EXPECT_TRUE(none_back.has_facing);
  EXPECT_EQ(none_back.num_beacons, 0);
}

TEST(RigYaml, AbsentBeaconFacingMeansNoFacing) {
  const Rig rig = ParseRigYaml(std::string("rig_id: r\ncameras:\n") + kCam + "beacons_mm: [[1, 2, 3]]\n", "mem");
  EXPECT_FALSE(rig.has_facing);
  EXPECT_EQ(rig.num_beacons, 1);
  EXPECT_EQ(FormatRigYaml(PaperRig()).find("beacon_facing"), std::string::npos);  // not written
  EXPECT_FALSE(ParseRigYaml(FormatRigYaml(PaperRig()), "mem").has_facing);
  EXPECT_FALSE(ParseRigYaml(std::string("rig_id: r\ncameras:\n") + kCam + "beacon_facing:\n", "mem").has_facing);
}

TEST(RigYaml, BeaconFacingNormalsWithin1e3AreNormalised) {
  const Rig rig = ParseRigYaml(std::string("rig_id: r\ncameras:\n") + kCam +
                                   "beacons_mm: [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]\n"
                                   "beacon_facing:\n"
                                   "  - [0, 0, 1.0009, 90]\n"
                                   "  - [0.6, 0.8, 0, 30]\n"
                                   "  - [0, -0.9991, 0, 180]\n"
                                   "  - [0.577, 0.577, 0.577, 0.001]\n",
                               "mem");
  ASSERT_TRUE(rig.has_facing);
  EXPECT_EQ(rig.beacon_normal_w[0], Eigen::Vector3d(0, 0, 1));
  EXPECT_NEAR((rig.beacon_normal_w[1] - Eigen::Vector3d(0.6, 0.8, 0)).norm(), 0.0, 1e-15);
  EXPECT_EQ(rig.beacon_normal_w[2], Eigen::Vector3d(0, -1, 0));
  EXPECT_NEAR(rig.beacon_normal_w[3].norm(), 1.0, 1e-15);
  EXPECT_NEAR(rig.beacon_normal_w[3].x(), 1 / std::sqrt(3.0), 1e-15);
  EXPECT_DOUBLE_EQ(rig.beacon_half_angle[0], kPi / 2);
  EXPECT_DOUBLE_EQ(rig.beacon_half_angle[1], kPi / 6);
  EXPECT_EQ(rig.beacon_half_angle[2], kPi);
  EXPECT_DOUBLE_EQ(rig.beacon_half_angle[3], DegToRad(0.001));
  EXPECT_EQ(ValidateRig(rig), RigStatus::kOk);
}

// Issue 16: beacon_sigma_mm as one number per beacon (mfns-calib survey); beacon_sigma their largest.
TEST(RigYaml, BeaconSigmaPerBeacon) {
  const std::string head = std::string("rig_id: r\ncameras:\n") + kCam + "beacons_mm: [[0, 0, 0], [1000, 0, 0], [0, 1000, 0]]\n";
  const Rig rig = ParseRigYaml(head + "beacon_sigma_mm: [0.1, 0.25, 0.05]\n", "rig.yaml");
  ASSERT_TRUE(rig.has_beacon_sigmas);
  EXPECT_DOUBLE_EQ(rig.beacon_sigmas[0], 0.1e-3);
  EXPECT_DOUBLE_EQ(rig.beacon_sigmas[1], 0.25e-3);
  EXPECT_DOUBLE_EQ(rig.beacon_sigmas[2], 0.05e-3);
  EXPECT_DOUBLE_EQ(rig.beacon_sigma, 0.25e-3);
  const Rig again = ParseRigYaml(FormatRigYaml(rig), "again.yaml");
  ASSERT_TRUE(again.has_beacon_sigmas);
  for (std::size_t i = 0; i < 3; ++i) EXPECT_DOUBLE_EQ(again.beacon_sigmas[i], rig.beacon_sigmas[i]);
  EXPECT_EQ(again.beacon_sigma, rig.beacon_sigma);
  EXPECT_FALSE(ParseRigYaml(head + "beacon_sigma_mm: 0.4\n", "rig.yaml").has_beacon_sigmas);
  // Line 5 is beacon_sigma_mm.
  EXPECT_EQ(ErrorOf(head + "beacon_sigma_mm: [0.1, 0.2]\n"),
            "rig.yaml:5: beacon_sigma_mm: expected one number or 3 entries (one per beacons_mm entry), got 2");
  EXPECT_EQ(ErrorOf(head + "beacon_sigma_mm: [0.1, -0.2, 0.3]\n"), "rig.yaml:5: beacon_sigma_mm[1]: must not be negative");
  EXPECT_EQ(ErrorOf(head + "beacon_sigma_mm: [0.1, 2000, 0.3]\n").find("rig.yaml:5: beacon_sigma_mm[1]: "), 0u)
      << ErrorOf(head + "beacon_sigma_mm: [0.1, 2000, 0.3]\n");
}

TEST(RigYaml, BeaconFacingErrorsNameTheFieldAndLine) {
  const std::string head = std::string("rig_id: r\ncameras:\n") + kCam + "beacons_mm: [[0, 0, 0], [1, 0, 0]]\n";
  auto facing = [&head](const std::string& entries) { return ErrorOf(head + "beacon_facing:\n" + entries); };
  // Line 5 is "beacon_facing:", its entries start on line 6.
  EXPECT_EQ(ErrorOf(head + "beacon_facing: inward\n"),
            "rig.yaml:5: beacon_facing: expected a list of [nx, ny, nz, half_angle_deg]");
  EXPECT_EQ(ErrorOf(head + "beacon_facing: {normal: [0, 0, 1]}\n"),
            "rig.yaml:5: beacon_facing: expected a list of [nx, ny, nz, half_angle_deg]");
  EXPECT_EQ(facing("  - [0, 0, 1, 60]\n"),
            "rig.yaml:6: beacon_facing: expected 2 entries (one per beacons_mm entry), got 1");
  EXPECT_EQ(facing("  - [0, 0, 1, 60]\n  - [0, 0, 1, 60]\n  - [0, 0, 1, 60]\n"),
            "rig.yaml:6: beacon_facing: expected 2 entries (one per beacons_mm entry), got 3");
  EXPECT_EQ(ErrorOf(std::string("rig_id: r\ncameras:\n") + kCam + "beacon_facing: [[0, 0, 1, 60]]\n"),
            "rig.yaml:4: beacon_facing: expected 0 entries (one per beacons_mm entry), got 1");
  EXPECT_EQ(facing("  - [0, 0, 1, 60]\n  - [0, 0, 1]\n"), "rig.yaml:7: beacon_facing[1]: expected 4 numbers, got 3");
  EXPECT_EQ(facing("  - [0, 0, 1, 60]\n  - 60\n"), "rig.yaml:7: beacon_facing[1]: expected a list of 4 numbers");
  EXPECT_EQ(facing("  - [0, 0, x, 60]\n  - [0, 0, 1, 60]\n"),
            "rig.yaml:6: beacon_facing[0][2]: expected a number, got 'x'");
  EXPECT_EQ(facing("  - [0, 0, 1, 60]\n  - [0, 0.5, 0, 60]\n"),
            "rig.yaml:7: beacon_facing[1]: normal length 0.5, expected 1");
  EXPECT_EQ(facing("  - [0, 0, 0, 60]\n  - [0, 0, 1, 60]\n"), "rig.yaml:6: beacon_facing[0]: normal length 0, expected 1");
  EXPECT_EQ(facing("  - [0, 0, 1.0011, 60]\n  - [0, 0, 1, 60]\n"),
            "rig.yaml:6: beacon_facing[0]: normal length 1.0011, expected 1");
  EXPECT_EQ(facing("  - [3, 4, 0, 60]\n  - [0, 0, 1, 60]\n"), "rig.yaml:6: beacon_facing[0]: normal length 5, expected 1");
  EXPECT_EQ(facing("  - [0, 0, 1, 60]\n  - [0, 0, 1, 0]\n"),
            "rig.yaml:7: beacon_facing[1]: half-angle 0 deg, expected (0, 180]");
  EXPECT_EQ(facing("  - [0, 0, 1, -10]\n  - [0, 0, 1, 60]\n"),
            "rig.yaml:6: beacon_facing[0]: half-angle -10 deg, expected (0, 180]");
  EXPECT_EQ(facing("  - [0, 0, 1, 180.5]\n  - [0, 0, 1, 60]\n"),
            "rig.yaml:6: beacon_facing[0]: half-angle 180.5 deg, expected (0, 180]");
  EXPECT_EQ(facing("  - [0, 0, 1, .nan]\n  - [0, 0, 1, 60]\n"), "rig.yaml:6: beacon_facing[0][3]: value is not finite");
  EXPECT_EQ(facing("  - [.inf, 0, 1, 60]\n  - [0, 0, 1, 60]\n"), "rig.yaml:6: beacon_facing[0][0]: value is not finite");
  EXPECT_EQ(facing("  - [0, 0, 1, 60]\n  - [0, 0, 1, 180]\n"), "(no error)");  // 180 deg is allowed
}

TEST(RigYaml, WriterRefusesInvalidRigAndKeepsTheOldFile) {
  std::string tmpl = (std::filesystem::temp_directory_path() / "mfns-rigyaml-XXXXXX").string();
  ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
  const std::filesystem::path file = std::filesystem::path(tmpl) / "rig.yaml";
  WriteRigYaml(file, PaperRig());
  Rig bad = PaperRig();
  bad.cameras[1].C_k_b(0, 0) = 3.0;
  EXPECT_THROW(WriteRigYaml(file, bad), UserError);
  ExpectRigNear(PaperRig(), ReadRigYaml(file), 1e-14);
  Rig bad_facing = PaperRigWithFacing();
  bad_facing.beacon_normal_w[2] *= 2.0;
  EXPECT_THROW(WriteRigYaml(file, bad_facing), UserError);
  WriteRigYaml(file, PaperRigWithFacing());
  ExpectRigNear(PaperRigWithFacing(), ReadRigYaml(file), 1e-14);
  std::filesystem::remove_all(tmpl);
}

}  // namespace
}  // namespace mfns::host
