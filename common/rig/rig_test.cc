#include "common/rig/rig.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "common/testing/numeric_diff.h"

namespace mfns {
namespace {

BodyPose RandomPose(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  BodyPose pose;
  pose.C_w_b = ExpSO3(Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.3);
  pose.r_w_wb = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.05;
  return pose;
}

// Eq. 2 written as the paper writes it: C_k_b (C_b_w P_w + r_b_bw - r_b_bk).
TEST(Rig, WorldToCameraIsEquation2) {
  std::mt19937_64 rng(21);
  const Rig rig = PaperRig();
  for (int i = 0; i < 100; ++i) {
    const BodyPose pose = RandomPose(rng);
    const Eigen::Matrix3d C_b_w = pose.C_w_b.transpose();
    const Eigen::Vector3d r_b_bw = C_b_w * (-pose.r_w_wb);
    for (int k = 0; k < 3; ++k) {
      const RigCamera& cam = rig.cameras[static_cast<std::size_t>(k)];
      const Eigen::Vector3d P_w = rig.beacons_w[static_cast<std::size_t>(i % 10)];
      const Eigen::Vector3d expected = cam.C_k_b * (C_b_w * P_w + r_b_bw - cam.r_b_bk);
      EXPECT_TRUE(WorldToCamera(cam, pose, P_w).isApprox(expected, 1e-12));
    }
  }
}

TEST(Rig, PoseAndBeaconJacobiansMatchCentralDifferences) {
  std::mt19937_64 rng(22);
  const Rig rig = PaperRig();
  int checked = 0;
  for (int i = 0; i < 2000 && checked < 300; ++i) {
    const BodyPose pose = RandomPose(rng);
    const RigCamera& cam = rig.cameras[static_cast<std::size_t>(i % 3)];
    const Eigen::Vector3d P_w = rig.beacons_w[static_cast<std::size_t>(i % 10)];
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 6> J_pose;
    Eigen::Matrix<double, 2, 3> J_P;
    if (ProjectBeacon(cam, pose, P_w, &uv, &J_pose, &J_P) != ProjectStatus::kOk) continue;
    ++checked;
    const auto f_pose = [&](const PoseDelta& d) {
      Eigen::Vector2d out;
      EXPECT_EQ(ProjectBeacon(cam, Retract(pose, d), P_w, &out), ProjectStatus::kOk);
      return out;
    };
    const auto J_pose_num = testing::CentralDiff<2, 6>(f_pose, PoseDelta::Zero(), 1e-7);
    EXPECT_LT((J_pose - J_pose_num).cwiseAbs().maxCoeff(), 1e-4 * (1 + J_pose.cwiseAbs().maxCoeff()));
    const auto f_P = [&](const Eigen::Vector3d& q) {
      Eigen::Vector2d out;
      EXPECT_EQ(ProjectBeacon(cam, pose, q, &out), ProjectStatus::kOk);
      return out;
    };
    const auto J_P_num = testing::CentralDiff<2, 3>(f_P, P_w, 1e-7);
    EXPECT_LT((J_P - J_P_num).cwiseAbs().maxCoeff(), 1e-4 * (1 + J_P.cwiseAbs().maxCoeff()));
  }
  EXPECT_GT(checked, 100);
}

TEST(Rig, RetractComposesOnTheRight) {
  BodyPose pose;
  pose.C_w_b = EulerToMatrix({0.1, 0.2, 0.3}).transpose();
  PoseDelta d;
  d << 0.01, 0.02, 0.03, 0.0, 0.0, 0.05;
  const BodyPose out = Retract(pose, d);
  EXPECT_TRUE(out.r_w_wb.isApprox(Eigen::Vector3d(0.01, 0.02, 0.03)));
  EXPECT_TRUE(out.C_w_b.isApprox(pose.C_w_b * ExpSO3(Eigen::Vector3d(0, 0, 0.05)), 1e-14));
}

TEST(Rig, ValidateNamesEachProblem) {
  const Rig good = PaperRig();
  int cam = -2;
  EXPECT_EQ(ValidateRig(good, &cam), RigStatus::kOk);
  EXPECT_EQ(cam, -1);

  Rig r = good;
  r.rig_id.fill('\0');
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadRigId);
  r = good;
  r.num_cameras = 0;
  EXPECT_EQ(ValidateRig(r), RigStatus::kNoCameras);
  r = good;
  r.num_cameras = limits::kMaxCameras + 1;
  EXPECT_EQ(ValidateRig(r), RigStatus::kTooManyCameras);
  r = good;
  r.num_beacons = limits::kMaxBeacons + 1;
  EXPECT_EQ(ValidateRig(r), RigStatus::kTooManyBeacons);
  r = good;
  r.cameras[2].name = r.cameras[0].name;
  EXPECT_EQ(ValidateRig(r, &cam), RigStatus::kBadCameraName);
  EXPECT_EQ(cam, 2);
  r = good;
  r.cameras[1].intrinsics.width = 0;
  EXPECT_EQ(ValidateRig(r, &cam), RigStatus::kBadImageSize);
  EXPECT_EQ(cam, 1);
  r = good;
  r.cameras[1].intrinsics.alpha_y = -3;
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadIntrinsics);
  r = good;
  r.cameras[0].C_k_b(0, 0) += 1e-3;
  EXPECT_EQ(ValidateRig(r), RigStatus::kNotARotation);
  r = good;
  r.cameras[0].r_b_bk.x() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(ValidateRig(r), RigStatus::kNonFinite);
  r = good;
  r.beacons_w[3].y() = std::nan("");
  EXPECT_EQ(ValidateRig(r), RigStatus::kNonFinite);
  r = good;
  r.sigma[0].r_b_bk.z() = -1;
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadSigma);
}

// Issue 14, defect 6: finite but absurd values (1e300) and repeated beacons are refused here,
// so rig files and blobs alike (common/blob decodes through ValidateRig) keep them out.
TEST(Rig, ValidateRefusesAbsurdValuesAndRepeatedBeacons) {
  const Rig good = PaperRig();
  int cam = -2, beacon = -2;
  EXPECT_EQ(ValidateRig(good, &cam, &beacon), RigStatus::kOk);
  EXPECT_EQ(beacon, -1);
  Rig r = good;
  r.cameras[1].intrinsics.alpha_x = 1e300;
  EXPECT_EQ(ValidateRig(r, &cam), RigStatus::kBadIntrinsics);
  EXPECT_EQ(cam, 1);
  r = good;
  r.cameras[1].intrinsics.alpha_y = 0.5;
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadIntrinsics);
  r = good;
  r.cameras[0].intrinsics.skew = 1e300;
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadIntrinsics);
  r = good;
  r.cameras[2].intrinsics.kc[4] = -1e300;
  EXPECT_EQ(ValidateRig(r, &cam), RigStatus::kBadDistortion);
  EXPECT_EQ(cam, 2);
  r = good;
  r.cameras[0].r_b_bk.y() = 1e300;
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadCameraOffset);
  r = good;
  r.beacons_w[7].z() = 1e300;
  EXPECT_EQ(ValidateRig(r, &cam, &beacon), RigStatus::kBadBeaconPosition);
  EXPECT_EQ(cam, -1);
  EXPECT_EQ(beacon, 7);
  r = good;
  r.beacons_w[6] = r.beacons_w[2] + Eigen::Vector3d(0.0, 0.0005, 0.0);
  EXPECT_EQ(ValidateRig(r, &cam, &beacon), RigStatus::kDuplicateBeacon);
  EXPECT_EQ(beacon, 6);
  EXPECT_EQ(SameBeaconAs(r, 6), 2);
  EXPECT_EQ(SameBeaconAs(r, 5), -1);
  r = good;
  r.beacon_sigma = 1e300;
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadSigma);
  // The limits themselves are legal.
  r = good;
  r.beacons_w[0] = Eigen::Vector3d(limits::kMaxBeaconCoordinateM, -limits::kMaxBeaconCoordinateM, 0.0);
  r.cameras[0].r_b_bk.x() = -limits::kMaxCameraOffsetM;
  r.cameras[0].intrinsics.kc[0] = limits::kMaxDistortion;
  r.beacon_sigma = limits::kMaxBeaconSigmaM;
  EXPECT_EQ(ValidateRig(r), RigStatus::kOk);
}

// An inferred normal's tolerance narrows the beam for "surely seen" (margin < 0: a missing
// beacon refutes a pose) and leaves "may be seen" as it was; validation keeps it in [0, pi/2].
TEST(Rig, NormalToleranceNarrowsOnlySurelySeen) {
  Rig r = PaperRig();
  r.has_facing = true;
  for (int m = 0; m < r.num_beacons; ++m) {
    r.beacon_normal_w[static_cast<std::size_t>(m)] = Eigen::Vector3d::UnitZ();
    r.beacon_half_angle[static_cast<std::size_t>(m)] = DegToRad(60.0);
  }
  r.beacon_normal_tolerance[3] = DegToRad(15.0);
  EXPECT_EQ(ValidateRig(r), RigStatus::kOk);
  // A point 50 deg off beacon 3's normal: inside the beam, surely seen only without tolerance.
  const Eigen::Vector3d p_w = r.beacons_w[3] + Eigen::Vector3d(std::sin(DegToRad(50.0)), 0.0, std::cos(DegToRad(50.0)));
  EXPECT_TRUE(BeaconFaces(r, 3, p_w, 0.1));
  EXPECT_TRUE(BeaconFaces(r, 3, p_w, 0.0));
  EXPECT_FALSE(BeaconFaces(r, 3, p_w, -0.1));
  EXPECT_NEAR(FacingCosine(r, 3, -0.1), std::cos(DegToRad(45.0) - 0.1), 1e-12);
  EXPECT_NEAR(FacingCosine(r, 3, 0.1), std::cos(DegToRad(60.0) + 0.1), 1e-12);
  r.beacon_normal_tolerance[3] = 0.0;
  EXPECT_TRUE(BeaconFaces(r, 3, p_w, -0.1));
  // 65 deg off: may be seen (margin 0.1 rad), never widened further by the tolerance.
  const Eigen::Vector3d q_w = r.beacons_w[3] + Eigen::Vector3d(std::sin(DegToRad(67.0)), 0.0, std::cos(DegToRad(67.0)));
  r.beacon_normal_tolerance[3] = DegToRad(15.0);
  EXPECT_FALSE(BeaconFaces(r, 3, q_w, 0.1));
  r.beacon_normal_tolerance[3] = -0.01;
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadFacing);
  r.beacon_normal_tolerance[3] = 2.0;
  EXPECT_EQ(ValidateRig(r), RigStatus::kBadFacing);
  r.beacon_normal_tolerance[3] = std::nan("");
  int beacon = -1;
  EXPECT_EQ(ValidateRig(r, nullptr, &beacon), RigStatus::kNonFinite);
  EXPECT_EQ(beacon, 3);
}

}  // namespace
}  // namespace mfns
