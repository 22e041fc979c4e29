#include "host/report/paper_numbers.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/report/pose_errors.h"

namespace mfns::host {
namespace {

// reference/paper-tables.yaml, the transcription of the paper the constants are copied from.
YAML::Node PaperTables() {
  const char* src = std::getenv("MFNS_SOURCE_DIR");
  if (src == nullptr) throw std::runtime_error("MFNS_SOURCE_DIR is not set (mfns_gtest sets it)");
  return YAML::LoadFile((std::filesystem::path(src) / "reference" / "paper-tables.yaml").string());
}

double Value(const YAML::Node& n) { return n["value"].as<double>(); }
double Sigma(const YAML::Node& n) { return n["sigma"].as<double>(); }

TEST(PaperNumbers, Table5MatchesPaperTablesYaml) {
  const YAML::Node t5 = PaperTables()["table5_navigation"];
  ASSERT_TRUE(t5);
  for (std::size_t a = 0; a < 6; ++a) {
    const YAML::Node axis = t5[kPoseAxes[a]];
    ASSERT_TRUE(axis) << kPoseAxes[a];
    EXPECT_DOUBLE_EQ(axis["mean"].as<double>(), kPaperTable5[a].mean) << kPoseAxes[a];
    EXPECT_DOUBLE_EQ(axis["std"].as<double>(), kPaperTable5[a].std) << kPoseAxes[a];
  }
}

// Table 2 (intrinsics, distortion, their sigma) of one camera of PaperRig().
void ExpectTable2(const YAML::Node& t, const RigCamera& c, const RigCameraSigma& s) {
  const CameraIntrinsics& k = c.intrinsics;
  EXPECT_DOUBLE_EQ(k.alpha_x, Value(t["alpha_x"]));
  EXPECT_DOUBLE_EQ(k.alpha_y, Value(t["alpha_y"]));
  EXPECT_DOUBLE_EQ(k.u0, Value(t["u0"]));
  EXPECT_DOUBLE_EQ(k.v0, Value(t["v0"]));
  EXPECT_DOUBLE_EQ(k.skew, Value(t["skew"]));
  const std::array<double, 5> sigma = {Sigma(t["alpha_x"]), Sigma(t["alpha_y"]), Sigma(t["skew"]), Sigma(t["u0"]),
                                       Sigma(t["v0"])};
  EXPECT_EQ(s.intrinsics, sigma);
  EXPECT_EQ(k.kc, (t["kc"]["value"].as<std::array<double, 5>>()));
  EXPECT_EQ(s.distortion, (t["kc"]["sigma"].as<std::array<double, 5>>()));
}

// Table 3 (C_b_k read as C_k_b, r_bk_b, their sigma; DESIGN.md) of one camera of PaperRig().
void ExpectTable3(const YAML::Node& rot, const YAML::Node& pos, const RigCamera& c, const RigCameraSigma& s) {
  const EulerAngles e{DegToRad(Value(rot["phi"])), DegToRad(Value(rot["theta"])), DegToRad(Value(rot["psi"]))};
  EXPECT_TRUE(c.C_k_b.isApprox(EulerToMatrix(e), 1e-15)) << c.C_k_b;
  EXPECT_TRUE(s.euler.isApprox(
      Eigen::Vector3d(DegToRad(Sigma(rot["phi"])), DegToRad(Sigma(rot["theta"])), DegToRad(Sigma(rot["psi"]))), 1e-15));
  const auto r = pos["value"].as<std::array<double, 3>>(), sr = pos["sigma"].as<std::array<double, 3>>();
  EXPECT_TRUE(c.r_b_bk.isApprox(Eigen::Vector3d(r[0], r[1], r[2]) * 1e-3, 1e-15)) << c.r_b_bk.transpose();
  EXPECT_TRUE(s.r_b_bk.isApprox(Eigen::Vector3d(sr[0], sr[1], sr[2]) * 1e-3, 1e-15)) << s.r_b_bk.transpose();
}

// common/rig/paper_rig.cc copies Tables 2-4 by hand (common/ reads no YAML): they must not drift.
TEST(PaperNumbers, PaperRigIsTables2To4) {
  const YAML::Node tables = PaperTables();
  const Rig rig = PaperRig();
  ASSERT_EQ(rig.num_cameras, 3);
  const YAML::Node t3 = tables["table3_extrinsics"];
  const std::array<std::string, 3> table_names = {"X", "Y", "Z"}, rig_names = {"x", "y", "z"};
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string& k = rig_names[i];
    SCOPED_TRACE(k);
    EXPECT_EQ(rig.cameras[i].name.data(), k);
    ExpectTable2(tables["table2_intrinsics"][table_names[i]], rig.cameras[i], rig.sigma[i]);
    ExpectTable3(t3["C_b_" + k], t3["r_b" + k + "_b"], rig.cameras[i], rig.sigma[i]);
  }
  const YAML::Node beacons = tables["table4_beacons_mm"];
  ASSERT_EQ(rig.num_beacons, static_cast<int>(beacons.size()));
  for (std::size_t m = 0; m < beacons.size(); ++m) {
    const auto p = beacons[m].as<std::array<double, 3>>();
    EXPECT_TRUE(rig.beacons_w[m].isApprox(Eigen::Vector3d(p[0], p[1], p[2]) * 1e-3, 1e-15)) << m;
  }
  EXPECT_DOUBLE_EQ(rig.beacon_sigma * 1e3, tables["hardware"]["beacons"]["position_accuracy_mm"].as<double>());
}

}  // namespace
}  // namespace mfns::host
