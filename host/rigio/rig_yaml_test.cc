#include "host/rigio/rig_yaml.h"

#include <gtest/gtest.h>

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
  EXPECT_EQ(ErrorOf(head + bad),
            "rig.yaml:3: cameras[0]: focal length not positive or principal point outside the image");
  EXPECT_EQ(ErrorOf(head + kCam + "beacons_mm: [[1, 2]]\n"), "rig.yaml:4: beacons_mm[0]: expected 3 numbers, got 2");
  EXPECT_NE(ErrorOf("rig_id: [unclosed\n").find("rig.yaml:"), std::string::npos);
  EXPECT_NE(ErrorOf("rig_id: [unclosed\n").find("not valid YAML"), std::string::npos);
  EXPECT_EQ(ErrorOf(head + kCam + "beacon_sigma_mm: -1\n"), "rig.yaml:4: beacon_sigma_mm: must not be negative");
  EXPECT_EQ(ErrorOf(head + kCam + "beacon_sigma_mm: .nan\n"), "rig.yaml:4: beacon_sigma_mm: value is not finite");
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
  std::filesystem::remove_all(tmpl);
}

}  // namespace
}  // namespace mfns::host
