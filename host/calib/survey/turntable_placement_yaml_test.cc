// The turntable placement file (turntable_placement_yaml.h): what it reads, what it refuses and
// how it says so, and that its writer's text reads back.
#include "host/calib/survey/turntable_placement_yaml.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "common/rotation/rotation.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

const char kFull[] =
    "# a surveyed placement\n"
    "centre_mm: [531.2, -375.9, 154.8]\n"
    "centre_sigma_mm: 0.02\n"
    "centre_b_mm: [1.5, -2, 0]\n"
    "centre_b_sigma_mm: 0.05\n"
    "axis: [0, 0, 2]\n"
    "axis_sigma_deg: 0.0013889\n";

TEST(TurntablePlacementYamlTest, ReadsEveryPartInSiUnits) {
  const TurntablePlacement t = ParseTurntablePlacementYaml(kFull, "p.yaml");
  ASSERT_TRUE(t.has_centre && t.has_centre_b && t.has_axis);
  EXPECT_TRUE((t.centre_w - Eigen::Vector3d(0.5312, -0.3759, 0.1548)).norm() < 1e-12);
  EXPECT_DOUBLE_EQ(t.centre_sigma_m, 0.02e-3);
  EXPECT_TRUE((t.centre_b - Eigen::Vector3d(1.5e-3, -2e-3, 0)).norm() < 1e-15);
  EXPECT_DOUBLE_EQ(t.centre_b_sigma_m, 0.05e-3);
  EXPECT_EQ(t.axis_w, Eigen::Vector3d::UnitZ());  // normalised
  EXPECT_NEAR(t.axis_sigma_rad, DegToRad(0.0013889), 1e-15);
  const char* why = nullptr;
  EXPECT_TRUE(t.IsValid(&why)) << why;
}

TEST(TurntablePlacementYamlTest, EachPartIsOptional) {
  const TurntablePlacement axis = ParseTurntablePlacementYaml("axis: [0, 1, 0]\naxis_sigma_deg: 0.01\n", "a.yaml");
  EXPECT_FALSE(axis.has_centre);
  EXPECT_FALSE(axis.has_centre_b);
  EXPECT_TRUE(axis.has_axis);
  const TurntablePlacement centre = ParseTurntablePlacementYaml("centre_mm: [1, 2, 3]\ncentre_sigma_mm: 0.4\n", "c.yaml");
  EXPECT_TRUE(centre.has_centre);
  EXPECT_FALSE(centre.has_axis);
}

TEST(TurntablePlacementYamlTest, TheWrittenTextReadsBack) {
  const TurntablePlacement t = ParseTurntablePlacementYaml(kFull, "p.yaml");
  const TurntablePlacement u = ParseTurntablePlacementYaml(FormatTurntablePlacementYaml(t, "written"), "w.yaml");
  EXPECT_EQ(u.has_centre, t.has_centre);
  EXPECT_EQ(u.has_centre_b, t.has_centre_b);
  EXPECT_EQ(u.has_axis, t.has_axis);
  EXPECT_LT((u.centre_w - t.centre_w).norm(), 1e-9);  // 6 decimals in mm
  EXPECT_NEAR(u.centre_sigma_m, t.centre_sigma_m, 1e-9);
  EXPECT_LT((u.centre_b - t.centre_b).norm(), 1e-9);
  EXPECT_NEAR(u.centre_b_sigma_m, t.centre_b_sigma_m, 1e-9);
  EXPECT_LT((u.axis_w - t.axis_w).norm(), 1e-8);
  EXPECT_NEAR(u.axis_sigma_rad, t.axis_sigma_rad, 1e-9);
}

// Every refusal is one line naming the file, the line and the field.
TEST(TurntablePlacementYamlTest, BadFilesAreRefusedNamingTheField) {
  struct Bad {
    const char* text;
    const char* expected;
  };
  const Bad bad[] = {
      {"centre_mm: [1, 2, 3]\n", "bad.yaml:1: centre_mm: needs centre_sigma_mm beside it"},
      {"axis_sigma_deg: 0.1\n", "bad.yaml:1: axis_sigma_deg: needs axis beside it"},
      {"centre_b_mm: [0, 0, 0]\naxis: [0, 0, 1]\naxis_sigma_deg: 1\n", "centre_b_mm: needs centre_b_sigma_mm"},
      {"centre_mm: [1, 2]\ncentre_sigma_mm: 1\n", "bad.yaml:1: centre_mm: expected 3 numbers, got 2"},
      {"centre_mm: [1, 2, 3, 4]\ncentre_sigma_mm: 1\n", "centre_mm: expected 3 numbers, got 4"},
      {"centre_mm: [1, .nan, 3]\ncentre_sigma_mm: 1\n", "centre_mm[1]"},
      {"centre_mm: [1, 2, 3]\ncentre_sigma_mm: .inf\n", "centre_sigma_mm"},
      {"centre_mm: [1, 2, 3]\ncentre_sigma_mm: -0.4\n", "bad.yaml:2: centre_sigma_mm: must be positive"},
      {"centre_mm: [1, 2, 3]\ncentre_sigma_mm: 1e-320\n", "centre_sigma_mm: must be positive"},
      {"axis: [0, 0, 0]\naxis_sigma_deg: 1\n", "bad.yaml:1: axis: must not be 0"},
      {"axis: [1e-320, 0, 0]\naxis_sigma_deg: 1\n", "axis: must not be 0"},
      {"axis: [1e308, 1e308, 0]\naxis_sigma_deg: 1\n", "axis: must not be 0"},
      {"centre: [1, 2, 3]\n", "unknown field 'centre'"},
      {"# nothing\n", "bad.yaml"},
      {"[1, 2, 3]\n", "expected a map"},
      {"axis: [0, 0, 1]\naxis_sigma_deg: 1\n: [\n", "not valid YAML"},
      {"{}\n", "no placement"},
  };
  for (const Bad& b : bad) {
    try {
      ParseTurntablePlacementYaml(b.text, "bad.yaml");
      ADD_FAILURE() << b.text;
    } catch (const UserError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(b.expected), std::string::npos) << what;
      EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    }
  }
}

TEST(TurntablePlacementYamlTest, AMissingFileIsNamed) {
  try {
    ReadTurntablePlacementYaml("/nonexistent/placement.yaml");
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/placement.yaml: no such file"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mfns::host
