#include "host/report/calib_errors.h"

#include <gtest/gtest.h>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

TEST(CalibErrors, RecoversAKnownRotationAndOffset) {
  const Rig truth = PaperRig();
  Rig est = truth;
  const Eigen::Vector3d e_deg(0.01, -0.02, 0.005);
  const Eigen::Vector3d dr_mm(0.1, -0.2, 0.3);
  for (int i = 0; i < est.num_cameras; ++i) {
    RigCamera& c = est.cameras[static_cast<std::size_t>(i)];
    c.C_k_b = c.C_k_b * ExpSO3(e_deg * DegToRad(1.0));
    c.r_b_bk += dr_mm * 1e-3;
  }
  const auto errs = CompareCalibration(est, truth);
  ASSERT_EQ(errs.size(), 3u);
  for (const CameraCalibError& c : errs) {
    EXPECT_LT((c.rotation_error_b_deg - e_deg).norm(), 1e-9) << c.name;
    EXPECT_NEAR(c.rotation_deg, e_deg.norm(), 1e-9);
    EXPECT_LT((c.position_error_mm - dr_mm).norm(), 1e-9);
    EXPECT_NEAR(c.position_mm, dr_mm.norm(), 1e-9);
    EXPECT_TRUE(c.has_sigma);
  }
  EXPECT_EQ(errs[0].name, "x");
  // The paper's sigma passes through (Table 3, camera x phi: 0.0413 deg; r_bx_b y: 0.4498 mm).
  EXPECT_NEAR(errs[0].euler_sigma_deg.x(), 0.0413, 1e-9);
  EXPECT_NEAR(errs[0].position_sigma_mm.y(), 0.4498, 1e-9);
}

TEST(CalibErrors, EulerErrorOfAKnownAngleChange) {
  const Rig truth = PaperRig();
  Rig est = truth;
  RigCamera& x = est.cameras[0];  // camera x: far from the phi = 90 deg singularity
  EulerAngles a = MatrixToEuler(x.C_k_b);
  a.phi += DegToRad(0.02);
  a.psi -= DegToRad(0.05);
  x.C_k_b = EulerToMatrix(a);
  const auto errs = CompareCalibration(est, truth);
  EXPECT_NEAR(errs[0].euler_error_deg.x(), 0.02, 1e-9);
  EXPECT_NEAR(errs[0].euler_error_deg.y(), 0.0, 1e-9);
  EXPECT_NEAR(errs[0].euler_error_deg.z(), -0.05, 1e-9);
  EXPECT_LT(errs[1].rotation_deg, 1e-9);  // cameras y and z untouched
}

TEST(CalibErrors, MatchesCamerasByNameAndRefusesNone) {
  const Rig truth = PaperRig();
  Rig est = truth;
  est.num_cameras = 1;
  est.cameras[0] = truth.cameras[2];  // only camera z, in first place
  est.has_sigma = false;
  const auto errs = CompareCalibration(est, truth);
  ASSERT_EQ(errs.size(), 1u);
  EXPECT_EQ(errs[0].name, "z");
  EXPECT_LT(errs[0].rotation_deg, 1e-12);
  EXPECT_FALSE(errs[0].has_sigma);
  std::snprintf(est.cameras[0].name.data(), est.cameras[0].name.size(), "w");
  EXPECT_THROW(CompareCalibration(est, truth), UserError);
}

TEST(CalibErrors, MergeTakesCamerasFromOneAndBeaconsFromTheOther) {
  Rig cams = PaperRig();
  cams.num_beacons = 0;
  cams.cameras[0].r_b_bk.x() += 0.001;
  Rig map = PaperRig();
  map.beacons_w[3].z() += 0.0004;
  map.has_facing = true;  // the map's facing comes along, the cameras' rig has none
  for (int i = 0; i < map.num_beacons; ++i) {
    map.beacon_normal_w[static_cast<std::size_t>(i)] = Eigen::Vector3d::UnitZ();
    map.beacon_half_angle[static_cast<std::size_t>(i)] = 1.0;
  }
  const Rig m = MergeRig(cams, map);
  EXPECT_TRUE(m.has_facing);
  EXPECT_EQ(m.beacon_normal_w[3], Eigen::Vector3d::UnitZ());
  EXPECT_EQ(m.beacon_half_angle[3], 1.0);
  EXPECT_EQ(m.num_beacons, map.num_beacons);
  EXPECT_EQ(m.beacons_w[3], map.beacons_w[3]);
  EXPECT_EQ(m.cameras[0].r_b_bk, cams.cameras[0].r_b_bk);
  EXPECT_EQ(m.beacon_sigma, map.beacon_sigma);
  EXPECT_EQ(ValidateRig(m), RigStatus::kOk);
}

}  // namespace
}  // namespace mfns::host
