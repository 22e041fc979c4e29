#include "common/rig/paper_rig.h"

#include <gtest/gtest.h>

#include "common/rotation/rotation.h"

namespace mfns {
namespace {

TEST(PaperRig, MatchesTables) {
  const Rig rig = PaperRig();
  ASSERT_EQ(ValidateRig(rig), RigStatus::kOk);
  EXPECT_STREQ(rig.rig_id.data(), "mfns-paper-2017");
  ASSERT_EQ(rig.num_cameras, 3);
  ASSERT_EQ(rig.num_beacons, 10);
  EXPECT_DOUBLE_EQ(rig.cameras[1].intrinsics.alpha_x, 1605.35286);
  EXPECT_DOUBLE_EQ(rig.cameras[2].intrinsics.kc[3], 0.00184);
  EXPECT_NEAR(rig.cameras[0].r_b_bk.z(), 0.0788949, 1e-12);
  EXPECT_NEAR(rig.beacons_w[9].z(), 0.5625394, 1e-12);
  const EulerAngles ez = MatrixToEuler(rig.cameras[2].C_k_b);
  EXPECT_NEAR(RadToDeg(ez.psi), 1.1690, 1e-9);
}

// DESIGN.md: with Table 3 read as C_k_b / r_b_bk, body at the world origin yawed through 360 deg
// in 1 deg steps, the rig sees on average 3.1 Table 4 beacons, >= 3 in 86% of steps, none in 1%.
TEST(PaperRig, VisibilityOverAYawSweepMatchesDesign) {
  const Rig rig = PaperRig();
  int total = 0, at_least_3 = 0, none = 0;
  for (int step = 0; step < 360; ++step) {
    BodyPose pose;
    pose.C_w_b = R3(DegToRad(step)).transpose();  // C_b_w = R3(psi)
    int seen = 0;
    for (int k = 0; k < rig.num_cameras; ++k) {
      const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
      for (int i = 0; i < rig.num_beacons; ++i) {
        Eigen::Vector2d uv;
        if (ProjectBeacon(cam, pose, rig.beacons_w[static_cast<std::size_t>(i)], &uv) == ProjectStatus::kOk &&
            InImage(cam.intrinsics, uv))
          ++seen;
      }
    }
    total += seen;
    at_least_3 += seen >= 3;
    none += seen == 0;
  }
  EXPECT_NEAR(total / 360.0, 3.1, 0.1);
  EXPECT_NEAR(at_least_3 / 360.0, 0.86, 0.015);
  EXPECT_NEAR(none / 360.0, 0.01, 0.01);
}

}  // namespace
}  // namespace mfns
