// The projection uncertainty map against Monte-Carlo sampling: intrinsics drawn from their
// covariance, the fixed ray (unprojected with the estimate) projected with each draw, the
// sample covariance of the pixels; its worst-direction 1-sigma must equal the first-order map's.
#include "host/calib/uncertainty/projection_uncertainty.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <random>

namespace mfns::host {
namespace {

// A wide-angle camera (issue 18's: f = 760 px, k1 = -0.27 on 1280x1024).
CameraIntrinsics WideAngle() {
  CameraIntrinsics c;
  c.width = 1280;
  c.height = 1024;
  c.alpha_x = 760;
  c.alpha_y = 758;
  c.u0 = 641.3;
  c.v0 = 509.8;
  c.kc = {-0.27, 0.07, 4e-4, -3e-4, 0.0};
  return c;
}

// A realistic covariance: sigma^2 (J^T J)^-1 of the intrinsics fitted to 300 rays spread over
// the image at 0.1 px (skew and kc5 fixed: zero rows and columns, as the calibration leaves them).
IntrinsicsCovariance FittedCovariance(const CameraIntrinsics& cam, std::mt19937_64* rng) {
  const int free[8] = {kAlphaX, kAlphaY, kU0, kV0, kKc1, kKc2, kKc3, kKc4};
  Eigen::Matrix<double, 8, 8> info = Eigen::Matrix<double, 8, 8>::Zero();
  std::uniform_real_distribution<double> u(0.0, cam.width - 1.0), v(0.0, cam.height - 1.0);
  for (int i = 0; i < 300; ++i) {
    Eigen::Vector2d x_n, uv;
    EXPECT_EQ(Unproject(cam, {u(*rng), v(*rng)}, &x_n), UnprojectStatus::kOk);
    Eigen::Matrix<double, 2, kNumCameraParams> J;
    Project(cam, Eigen::Vector3d(x_n.x(), x_n.y(), 1.0), &uv, nullptr, &J);
    Eigen::Matrix<double, 2, 8> Jf;
    for (int a = 0; a < 8; ++a) Jf.col(a) = J.col(free[a]);
    info += Jf.transpose() * Jf / (0.1 * 0.1);
  }
  const Eigen::Matrix<double, 8, 8> cov8 = info.inverse();
  IntrinsicsCovariance cov = IntrinsicsCovariance::Zero();
  for (int a = 0; a < 8; ++a)
    for (int b = 0; b < 8; ++b) cov(free[a], free[b]) = cov8(a, b);
  return cov;
}

TEST(ProjectionUncertainty, FirstOrderMapMatchesMonteCarloSampling) {
  std::mt19937_64 rng(18);
  const CameraIntrinsics cam = WideAngle();
  const IntrinsicsCovariance cov = FittedCovariance(cam, &rng);
  // Draws x = mean + V sqrt(lambda) z: the fixed parameters' zero (or round-off negative)
  // eigenvalues give no spread.
  const Eigen::SelfAdjointEigenSolver<IntrinsicsCovariance> eig(cov);
  const IntrinsicsCovariance L = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  constexpr int kDraws = 4000;
  std::vector<CameraIntrinsics> draws;
  std::normal_distribution<double> n01;
  for (int i = 0; i < kDraws; ++i) {
    CameraParamVector z;
    for (int a = 0; a < kNumCameraParams; ++a) z[a] = n01(rng);
    CameraIntrinsics d = cam;
    d.SetFromVector(cam.ToVector() + L * z);
    draws.push_back(d);
  }
  const ProjectionSigmaGrid grid = ProjectionSigmaMap(cam, cov, 8, 6);
  double worst_ratio = 1.0;
  for (int r = 0; r < grid.rows; ++r)
    for (int c = 0; c < grid.cols; ++c) {
      const Eigen::Vector2d q = GridCellCentre(cam, grid.cols, grid.rows, c, r);
      EXPECT_EQ(grid.At(c, r), ProjectionSigmaPx(cam, cov, q));
      Eigen::Vector2d x_n;
      ASSERT_EQ(Unproject(cam, q, &x_n), UnprojectStatus::kOk);
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      Eigen::Matrix2d second = Eigen::Matrix2d::Zero();
      for (const CameraIntrinsics& d : draws) {
        Eigen::Vector2d uv;
        ASSERT_EQ(Project(d, Eigen::Vector3d(x_n.x(), x_n.y(), 1.0), &uv), ProjectStatus::kOk);
        mean += uv;
        second += uv * uv.transpose();
      }
      mean /= kDraws;
      const Eigen::Matrix2d sample = (second / kDraws - mean * mean.transpose()) * kDraws / (kDraws - 1.0);
      const double mc = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(sample).eigenvalues()[1]);
      const double ratio = grid.At(c, r) / mc;
      if (std::abs(ratio - 1) > std::abs(worst_ratio - 1)) worst_ratio = ratio;
      // 4000 draws: the sample sigma's own error is 1.1 %; 5 % allows it and the model's curvature.
      EXPECT_NEAR(ratio, 1.0, 0.05) << "cell " << c << "," << r << ": first order " << grid.At(c, r)
                                    << " px, Monte Carlo " << mc << " px";
    }
  std::printf("projection sigma: centre %.4f px, corner %.4f px; worst first-order / Monte Carlo ratio %.4f\n",
              ProjectionSigmaPx(cam, cov, {cam.u0, cam.v0}), grid.At(0, 0), worst_ratio);
  // Fitted to rays over the whole image, the uncertainty is smallest inside and grows to the corners.
  EXPECT_LT(ProjectionSigmaPx(cam, cov, {cam.u0, cam.v0}), grid.At(0, 0));
}

TEST(ProjectionUncertainty, NoCovarianceNoUncertaintyAndOutsideTheModelIsNaN) {
  const CameraIntrinsics cam = WideAngle();
  EXPECT_EQ(ProjectionSigmaPx(cam, IntrinsicsCovariance::Zero(), {100.0, 200.0}), 0.0);
  // A principal-point-only covariance moves every pixel by the same amount.
  IntrinsicsCovariance pp = IntrinsicsCovariance::Zero();
  pp(kU0, kU0) = 0.04;
  pp(kV0, kV0) = 0.01;
  EXPECT_NEAR(ProjectionSigmaPx(cam, pp, {100.0, 900.0}), 0.2, 1e-9);
  CameraIntrinsics bad = cam;
  bad.alpha_x = std::nan("");
  EXPECT_TRUE(std::isnan(ProjectionSigmaPx(bad, pp, {100.0, 900.0})));
}

}  // namespace
}  // namespace mfns::host
