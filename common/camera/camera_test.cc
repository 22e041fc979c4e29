#include "common/camera/camera.h"

#include <gtest/gtest.h>

#include <random>

#include "common/rig/paper_rig.h"
#include "common/testing/numeric_diff.h"

namespace mfns {
namespace {

CameraIntrinsics RandomCamera(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  CameraIntrinsics c;
  c.width = 1280;
  c.height = 1024;
  c.alpha_x = 1600 + 50 * u(rng);
  c.alpha_y = 1600 + 50 * u(rng);
  c.skew = 2.0 * u(rng);
  c.u0 = 640 + 20 * u(rng);
  c.v0 = 512 + 20 * u(rng);
  c.kc = {0.15 * u(rng), 0.3 * u(rng), 0.002 * u(rng), 0.002 * u(rng), 0.1 * u(rng)};
  return c;
}

Eigen::Vector3d RandomPoint(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double z = 0.5 + 1.5 * (u(rng) + 1.0);
  return {0.4 * z * u(rng), 0.32 * z * u(rng), z};
}

TEST(Camera, PointJacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(11);
  for (int i = 0; i < 500; ++i) {
    const CameraIntrinsics cam = RandomCamera(rng);
    const Eigen::Vector3d p = RandomPoint(rng);
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, 3> J;
    ASSERT_EQ(Project(cam, p, &uv, &J), ProjectStatus::kOk);
    const auto f = [&](const Eigen::Vector3d& q) {
      Eigen::Vector2d out;
      EXPECT_EQ(Project(cam, q, &out), ProjectStatus::kOk);
      return out;
    };
    const Eigen::Matrix<double, 2, 3> J_num = testing::CentralDiff<2, 3>(f, p);
    EXPECT_LT((J - J_num).cwiseAbs().maxCoeff(), 1e-5 * (1.0 + J.cwiseAbs().maxCoeff())) << J << "\n" << J_num;
  }
}

TEST(Camera, ParameterJacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(12);
  for (int i = 0; i < 500; ++i) {
    const CameraIntrinsics cam = RandomCamera(rng);
    const Eigen::Vector3d p = RandomPoint(rng);
    Eigen::Vector2d uv;
    Eigen::Matrix<double, 2, kNumCameraParams> J;
    ASSERT_EQ(Project(cam, p, &uv, nullptr, &J), ProjectStatus::kOk);
    const auto f = [&](const CameraParamVector& params) {
      CameraIntrinsics c = cam;
      c.SetFromVector(params);
      Eigen::Vector2d out;
      EXPECT_EQ(Project(c, p, &out), ProjectStatus::kOk);
      return out;
    };
    const auto J_num = testing::CentralDiff<2, kNumCameraParams>(f, cam.ToVector(), 1e-7);
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < kNumCameraParams; ++c)
        EXPECT_NEAR(J(r, c), J_num(r, c), 1e-5 * (1.0 + std::abs(J(r, c)))) << "param " << c;
  }
}

TEST(Camera, DistortionJacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  for (int i = 0; i < 500; ++i) {
    const CameraIntrinsics cam = RandomCamera(rng);
    const Eigen::Vector2d x(u(rng), u(rng));
    Eigen::Matrix2d J;
    Distort(cam, x, &J);
    const auto J_num = testing::CentralDiff<2, 2>(
        [&](const Eigen::Vector2d& q) { return Distort(cam, q); }, x);
    EXPECT_LT((J - J_num).cwiseAbs().maxCoeff(), 1e-8);
  }
}

// DESIGN.md: unproject(project(p)) within 1e-6 px across the whole image, each Table 2 camera.
TEST(Camera, UnprojectInvertsProjectAcrossTheImage) {
  const Rig rig = PaperRig();
  for (int k = 0; k < rig.num_cameras; ++k) {
    const CameraIntrinsics& cam = rig.cameras[static_cast<std::size_t>(k)].intrinsics;
    double worst = 0.0;
    for (double v = -0.5; v <= cam.height - 0.5; v += 8.0) {
      for (double u = -0.5; u <= cam.width - 0.5; u += 8.0) {
        const Eigen::Vector2d uv(u, v);
        Eigen::Vector2d x_n;
        ASSERT_EQ(Unproject(cam, uv, &x_n), UnprojectStatus::kOk) << u << "," << v;
        Eigen::Vector2d back;
        ASSERT_EQ(Project(cam, Eigen::Vector3d(x_n.x(), x_n.y(), 1.0), &back), ProjectStatus::kOk);
        worst = std::max(worst, (back - uv).norm());
      }
    }
    EXPECT_LT(worst, 1e-6) << "camera " << k;
  }
}

TEST(Camera, ProjectOfUnprojectRecoversTheRay) {
  std::mt19937_64 rng(14);
  const Rig rig = PaperRig();
  for (int i = 0; i < 1000; ++i) {
    const CameraIntrinsics& cam = rig.cameras[static_cast<std::size_t>(i % 3)].intrinsics;
    const Eigen::Vector3d p = RandomPoint(rng);
    Eigen::Vector2d uv, x_n;
    ASSERT_EQ(Project(cam, p, &uv), ProjectStatus::kOk);
    ASSERT_EQ(Unproject(cam, uv, &x_n), UnprojectStatus::kOk);
    EXPECT_NEAR(x_n.x(), p.x() / p.z(), 1e-9);
    EXPECT_NEAR(x_n.y(), p.y() / p.z(), 1e-9);
  }
}

TEST(Camera, PixelCentresAtIntegers) {
  CameraIntrinsics cam;
  cam.width = 640;
  cam.height = 480;
  cam.alpha_x = cam.alpha_y = 500;
  cam.u0 = 319.5;
  cam.v0 = 239.5;
  Eigen::Vector2d uv;
  ASSERT_EQ(Project(cam, {0, 0, 1}, &uv), ProjectStatus::kOk);
  EXPECT_DOUBLE_EQ(uv.x(), 319.5);  // optic axis through the centre of a 640-wide image
  EXPECT_TRUE(InImage(cam, {-0.5, -0.5}));
  EXPECT_TRUE(InImage(cam, {639.5, 479.5}));
  EXPECT_FALSE(InImage(cam, {639.6, 10}));
  EXPECT_FALSE(InImage(cam, {10, 10}, 10.6));
}

TEST(Camera, RejectsBehindAndNonFinite) {
  std::mt19937_64 rng(15);
  const CameraIntrinsics cam = RandomCamera(rng);
  Eigen::Vector2d uv(7, 7);
  EXPECT_EQ(Project(cam, {0.1, 0.1, -1.0}, &uv), ProjectStatus::kBehindCamera);
  EXPECT_EQ(Project(cam, {0.1, 0.1, 0.0}, &uv), ProjectStatus::kBehindCamera);
  EXPECT_EQ(Project(cam, {std::nan(""), 0.1, 1.0}, &uv), ProjectStatus::kNonFinite);
  EXPECT_EQ(uv, Eigen::Vector2d(7, 7));  // untouched on failure
  Eigen::Vector2d x_n;
  EXPECT_EQ(Unproject(cam, {std::numeric_limits<double>::infinity(), 3.0}, &x_n), UnprojectStatus::kNonFinite);
}

}  // namespace
}  // namespace mfns
