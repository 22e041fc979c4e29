#include "host/calib/core/kinematics.h"

#include <gtest/gtest.h>

#include <random>

#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

// Main alone is the paper's eq. A5, aux alone the rotation of A9 (active rotations).
TEST(Kinematics, SingleAxesAreThePapersA5AndA9) {
  const double a = 0.3, c = std::cos(a), s = std::sin(a);
  Eigen::Matrix3d A5, Rx;
  A5 << c, -s, 0, s, c, 0, 0, 0, 1;
  Rx << 1, 0, 0, 0, c, -s, 0, s, c;
  EXPECT_LT((PlatformRotation(a, 0.0) - A5).norm(), 1e-15);
  EXPECT_LT((PlatformRotation(0.0, a) - Rx).norm(), 1e-15);
  // aux is the outer axis: C_t_p = Rx(aux) Rz(main).
  EXPECT_LT((PlatformRotation(0.2, 0.7) - PlatformRotation(0.0, 0.7) * PlatformRotation(0.2, 0.0)).norm(), 1e-15);
}

TEST(Kinematics, CameraInWorldIsEquationTwoInverted) {
  Transform body{ExpSO3(Eigen::Vector3d(0.1, -0.4, 0.9)), Eigen::Vector3d(0.1, 0.2, 0.3)};
  const Eigen::Matrix3d C_k_b = ExpSO3(Eigen::Vector3d(1.0, 0.2, -0.3));
  const Eigen::Vector3d r_b_bk(0.05, -0.02, 0.1), P_w(0.3, -0.1, 1.2);
  const Transform k = CameraInWorld(body, C_k_b, r_b_bk);
  // Eq. 2: p_k = C_k_b (C_b_w P_w + r_b_bw - r_b_bk).
  const Eigen::Vector3d eq2 = C_k_b * (body.C.transpose() * P_w - body.C.transpose() * body.r - r_b_bk);
  EXPECT_LT((k.C.transpose() * (P_w - k.r) - eq2).norm(), 1e-15);
}

TEST(Kinematics, NearestAxisAlignedFindsTheNominalFrame) {
  const Eigen::Matrix3d flip = Eigen::Vector3d(1, -1, -1).asDiagonal();
  EXPECT_EQ(NearestAxisAligned(flip * ExpSO3(Eigen::Vector3d(0.05, -0.1, 0.2))), flip);
  EXPECT_EQ(NearestAxisAligned(ExpSO3(Eigen::Vector3d(0.01, 0.0, 0.3))), Eigen::Matrix3d::Identity());
  const Eigen::Matrix3d Rz90 = ExpSO3(Eigen::Vector3d(0, 0, kPi / 2));
  EXPECT_LT((NearestAxisAligned(Rz90 * ExpSO3(Eigen::Vector3d(0.1, 0.1, 0.1))) - Rz90).norm(), 1e-12);
  EXPECT_NEAR(RotationAngle(Rz90), kPi / 2, 1e-12);
}

}  // namespace
}  // namespace mfns::host
