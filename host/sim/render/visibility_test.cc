#include "host/sim/render/visibility.h"

#include <gtest/gtest.h>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

// A beacon on a wall is seen only from inside its beam: SightBeacon, the simulator's one
// visibility decision, follows the rig's facing data.
TEST(Visibility, BeaconSeenFromBehindIsNotVisible) {
  Rig rig = PaperRig();
  const BodyPose pose;
  int seen = 0;
  for (int k = 0; k < rig.num_cameras; ++k)
    for (int m = 0; m < rig.num_beacons; ++m) seen += SightBeacon(rig, pose, k, m, 0.0).visible;
  ASSERT_GE(seen, 2);  // without facing data: the paper's view at yaw 0

  rig.has_facing = true;
  for (int m = 0; m < rig.num_beacons; ++m) {
    rig.beacon_half_angle[static_cast<std::size_t>(m)] = DegToRad(60.0);
    // Every beacon faces the body origin...
    rig.beacon_normal_w[static_cast<std::size_t>(m)] = (pose.r_w_wb - rig.beacons_w[static_cast<std::size_t>(m)]).normalized();
  }
  ASSERT_EQ(ValidateRig(rig), RigStatus::kOk);
  int seen_facing = 0;
  for (int k = 0; k < rig.num_cameras; ++k)
    for (int m = 0; m < rig.num_beacons; ++m) {
      const BeaconSight facing = SightBeacon(rig, pose, k, m, 0.0);
      EXPECT_TRUE(facing.faces);
      seen_facing += facing.visible;
      rig.beacon_normal_w[static_cast<std::size_t>(m)] *= -1.0;  // ...then away from it
      const BeaconSight behind = SightBeacon(rig, pose, k, m, 0.0);
      rig.beacon_normal_w[static_cast<std::size_t>(m)] *= -1.0;
      EXPECT_FALSE(behind.faces);
      EXPECT_FALSE(behind.visible);
      EXPECT_FALSE(behind.Drawn());
      EXPECT_EQ(behind.projection.status, facing.projection.status);  // same geometry, only the beam differs
    }
  EXPECT_EQ(seen_facing, seen);
}

TEST(Visibility, CameraCentreIsTheBodyPoseAppliedToTheMount) {
  RigCamera cam;
  cam.r_b_bk = Eigen::Vector3d(0.1, 0.0, 0.0);
  BodyPose pose;
  pose.r_w_wb = Eigen::Vector3d(1, 2, 3);
  pose.C_w_b << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // body x -> world y
  EXPECT_TRUE(CameraCentreWorld(cam, pose).isApprox(Eigen::Vector3d(1, 2.1, 3), 1e-15));
}

}  // namespace
}  // namespace mfns::host
