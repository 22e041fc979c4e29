// The projection uncertainty map against Monte-Carlo sampling: the camera's parameters
// (intrinsics, and C_k_b for the body-frame ray) drawn from their joint covariance, the fixed
// ray projected with each draw, the sample covariance of the pixels; its worst-direction 1-sigma
// must equal the first-order map's.
#include "host/calib/uncertainty/projection_uncertainty.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <random>

#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

constexpr int kState = kNumCameraParams + 3;  // intrinsics and the rotation phi
using Cov = Eigen::Matrix<double, kState, kState>;

// A wide-angle camera (issue 18's: f = 760 px, k1 = -0.27 on 1280x1024) looking along body -y.
CameraResult WideAngle() {
  CameraResult c;
  c.name = "w";
  CameraIntrinsics& in = c.intrinsics;
  in.width = 1280;
  in.height = 1024;
  in.alpha_x = 760;
  in.alpha_y = 758;
  in.u0 = 641.3;
  in.v0 = 509.8;
  in.kc = {-0.27, 0.07, 4e-4, -3e-4, 0.0};
  c.C_k_b = EulerToMatrix({DegToRad(90.0), DegToRad(10.0), DegToRad(-30.0)});
  return c;
}

// A realistic joint covariance: sigma^2 (J^T J)^-1 of the intrinsics and C_k_b fitted to 300
// body-frame rays spread over the image at 0.1 px, with a 0.01 deg prior on the rotation (rays
// at infinity barely separate it from the principal point: strongly correlated, as on a
// turntable). Skew and kc5 fixed: zero rows and columns.
CameraStateCovariance FittedCovariance(const CameraResult& cam, std::mt19937_64* rng) {
  const int free[11] = {
      kAlphaX, kAlphaY, kU0, kV0, kKc1, kKc2, kKc3, kKc4, kNumCameraParams, kNumCameraParams + 1, kNumCameraParams + 2};
  Eigen::Matrix<double, 11, 11> info = Eigen::Matrix<double, 11, 11>::Zero();
  info.bottomRightCorner<3, 3>().diagonal().setConstant(1.0 / std::pow(DegToRad(0.01), 2));
  std::uniform_real_distribution<double> u(0.0, cam.intrinsics.width - 1.0), v(0.0, cam.intrinsics.height - 1.0);
  for (int i = 0; i < 300; ++i) {
    Eigen::Vector2d x_n, uv;
    EXPECT_EQ(Unproject(cam.intrinsics, {u(*rng), v(*rng)}, &x_n), UnprojectStatus::kOk);
    const Eigen::Vector3d ray(x_n.x(), x_n.y(), 1.0);
    Eigen::Matrix<double, 2, 3> J_p;
    Eigen::Matrix<double, 2, kNumCameraParams> J_in;
    Project(cam.intrinsics, ray, &uv, &J_p, &J_in);
    Eigen::Matrix3d S;
    S << 0, -ray.z(), ray.y(), ray.z(), 0, -ray.x(), -ray.y(), ray.x(), 0;
    Eigen::Matrix<double, 2, kState> J;
    J << J_in, J_p * S * cam.C_k_b;
    Eigen::Matrix<double, 2, 11> Jf;
    for (int a = 0; a < 11; ++a) Jf.col(a) = J.col(free[a]);
    info += Jf.transpose() * Jf / (0.1 * 0.1);
  }
  const Eigen::Matrix<double, 11, 11> cov11 = info.inverse();
  CameraStateCovariance cov = CameraStateCovariance::Zero();
  for (int a = 0; a < 11; ++a)
    for (int b = 0; b < 11; ++b) cov(free[a], free[b]) = cov11(a, b);
  return cov;
}

// The worst-direction 1-sigma of the pixel a ray lands on over `draws` parameter draws.
double MonteCarloSigma(const CameraResult& cam, RayFrame frame, const Eigen::Vector2d& q,
                       const std::vector<Eigen::Matrix<double, kState, 1>>& draws) {
  Eigen::Vector2d x_n;
  EXPECT_EQ(Unproject(cam.intrinsics, q, &x_n), UnprojectStatus::kOk);
  const Eigen::Vector3d v_k(x_n.x(), x_n.y(), 1.0), v_b = cam.C_k_b.transpose() * v_k;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  Eigen::Matrix2d second = Eigen::Matrix2d::Zero();
  for (const Eigen::Matrix<double, kState, 1>& d : draws) {
    CameraIntrinsics in = cam.intrinsics;
    in.SetFromVector(cam.intrinsics.ToVector() + d.head<kNumCameraParams>());
    // C_b_k' = Exp(phi) C_b_k, so C_k_b' = C_k_b Exp(-phi).
    const Eigen::Vector3d p = frame == RayFrame::kBody ? Eigen::Vector3d(cam.C_k_b * ExpSO3(-d.tail<3>()) * v_b) : v_k;
    Eigen::Vector2d uv;
    EXPECT_EQ(Project(in, p, &uv), ProjectStatus::kOk);
    mean += uv;
    second += uv * uv.transpose();
  }
  const double n = static_cast<double>(draws.size());
  mean /= n;
  const Eigen::Matrix2d sample = (second / n - mean * mean.transpose()) * n / (n - 1.0);
  return std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(sample).eigenvalues()[1]);
}

TEST(ProjectionUncertainty, FirstOrderMapsMatchMonteCarloSampling) {
  std::mt19937_64 rng(18);
  CameraResult cam = WideAngle();
  cam.covariance = FittedCovariance(cam, &rng);
  // Draws V sqrt(lambda) z: the fixed parameters' zero (or round-off negative) eigenvalues give no spread.
  const Eigen::SelfAdjointEigenSolver<Cov> eig(cam.covariance.topLeftCorner<kState, kState>());
  const Cov L = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  std::vector<Eigen::Matrix<double, kState, 1>> draws;
  std::normal_distribution<double> n01;
  for (int i = 0; i < 4000; ++i) {
    Eigen::Matrix<double, kState, 1> z;
    for (int a = 0; a < kState; ++a) z[a] = n01(rng);
    draws.push_back(L * z);
  }
  for (RayFrame frame : {RayFrame::kCamera, RayFrame::kBody}) {
    const ProjectionSigmaGrid grid = ProjectionSigmaMap(cam, frame, 8, 6);
    double worst = 1.0;
    for (int r = 0; r < grid.rows; ++r)
      for (int c = 0; c < grid.cols; ++c) {
        const Eigen::Vector2d q = GridCellCentre(cam.intrinsics, grid.cols, grid.rows, c, r);
        EXPECT_EQ(grid.At(c, r), ProjectionSigmaPx(cam, frame, q));
        const double ratio = grid.At(c, r) / MonteCarloSigma(cam, frame, q, draws);
        if (std::abs(ratio - 1) > std::abs(worst - 1)) worst = ratio;
        // 4000 draws: the sample sigma's own error is 1.1 %; 5 % allows it and the model's curvature.
        EXPECT_NEAR(ratio, 1.0, 0.05) << (frame == RayFrame::kBody ? "body" : "camera") << " cell " << c << "," << r;
      }
    std::printf("%s-frame ray: centre %.4f px, corner %.4f px; worst first-order / Monte Carlo ratio %.4f\n",
                frame == RayFrame::kBody ? "body" : "camera",
                ProjectionSigmaPx(cam, frame, {cam.intrinsics.u0, cam.intrinsics.v0}), grid.At(0, 0), worst);
  }
  // The principal point and C_k_b are correlated: the body-frame ray is the better known.
  EXPECT_LT(ProjectionSigmaPx(cam, RayFrame::kBody, {cam.intrinsics.u0, cam.intrinsics.v0}),
            0.5 * ProjectionSigmaPx(cam, RayFrame::kCamera, {cam.intrinsics.u0, cam.intrinsics.v0}));
}

TEST(ProjectionUncertainty, NoCovarianceNoUncertaintyAndOutsideTheModelIsNaN) {
  CameraResult cam = WideAngle();
  EXPECT_EQ(ProjectionSigmaPx(cam, RayFrame::kBody, {100.0, 200.0}), 0.0);
  // A principal-point-only covariance moves every pixel by the same amount.
  cam.covariance(kU0, kU0) = 0.04;
  cam.covariance(kV0, kV0) = 0.01;
  EXPECT_NEAR(ProjectionSigmaPx(cam, RayFrame::kCamera, {100.0, 900.0}), 0.2, 1e-9);
  cam.intrinsics.alpha_x = std::nan("");
  EXPECT_TRUE(std::isnan(ProjectionSigmaPx(cam, RayFrame::kCamera, {100.0, 900.0})));
}

}  // namespace
}  // namespace mfns::host
