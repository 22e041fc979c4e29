#include "host/sim/crb/pose_bound.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <random>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"

namespace mfns::host {
namespace {

// Reprojection residual of one beacon, numerically differentiated by Ceres: an estimator that
// shares nothing with the analytic Jacobians behind the bound.
struct Reprojection {
  const RigCamera* cam;
  const BodyPose* reference;
  Eigen::Vector3d P_w;
  Eigen::Vector2d uv_obs;
  bool operator()(const double* delta, double* residual) const {
    Eigen::Vector2d uv;
    if (ProjectBeacon(*cam, Retract(*reference, Eigen::Map<const PoseDelta>(delta)), P_w, &uv) != ProjectStatus::kOk)
      return false;
    residual[0] = uv.x() - uv_obs.x();
    residual[1] = uv.y() - uv_obs.y();
    return true;
  }
};

TEST(PoseBound, MatchesTheScatterOfALeastSquaresSolve) {
  const Rig rig = PaperRig();
  BodyPose truth;
  // A yaw step with 4+ beacons split over the cameras.
  int step = 0;
  std::vector<VisibleBeacon> seen;
  for (; step < 360; ++step) {
    truth.C_w_b = R3(DegToRad(step)).transpose();
    seen = VisibleBeacons(rig, truth);
    if (seen.size() >= 4) break;
  }
  ASSERT_GE(seen.size(), 4u);
  const double sigma_px = 0.05;
  const PoseBound bound = PoseCramerRao(rig, truth, seen, sigma_px);
  ASSERT_TRUE(bound.valid);

  std::mt19937_64 rng(5);
  std::normal_distribution<double> noise(0.0, sigma_px);
  const int trials = 1500;
  Eigen::Matrix<double, 6, 6> scatter = Eigen::Matrix<double, 6, 6>::Zero();
  for (int t = 0; t < trials; ++t) {
    std::vector<Reprojection> terms;
    for (const VisibleBeacon& v : seen)
      terms.push_back({&rig.cameras[static_cast<std::size_t>(v.camera)], &truth,
                       rig.beacons_w[static_cast<std::size_t>(v.beacon)],
                       v.uv_px + Eigen::Vector2d(noise(rng), noise(rng))});
    double delta[6] = {0, 0, 0, 0, 0, 0};
    ceres::Problem problem;
    for (const Reprojection& r : terms)
      problem.AddResidualBlock(new ceres::NumericDiffCostFunction<Reprojection, ceres::CENTRAL, 2, 6>(new Reprojection(r)),
                               nullptr, delta);
    ceres::Solver::Options options;
    options.function_tolerance = 1e-14;
    options.parameter_tolerance = 1e-14;
    options.gradient_tolerance = 1e-16;
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    ASSERT_TRUE(summary.IsSolutionUsable());
    const Eigen::Map<PoseDelta> d(delta);
    scatter += d * d.transpose();
  }
  scatter /= trials;
  for (int i = 0; i < 6; ++i) {
    const double ratio = std::sqrt(scatter(i, i) / bound.covariance(i, i));
    EXPECT_NEAR(ratio, 1.0, 0.10) << "axis " << i;
  }
}

TEST(PoseBound, SingularBelowThreeBeaconsAndScalesWithNoise) {
  const Rig rig = PaperRig();
  BodyPose pose;
  std::vector<VisibleBeacon> seen;
  for (int step = 0; step < 360 && seen.size() < 3; ++step) {
    pose.C_w_b = R3(DegToRad(step)).transpose();
    seen = VisibleBeacons(rig, pose);
  }
  ASSERT_GE(seen.size(), 3u);
  const PoseBound one = PoseCramerRao(rig, pose, seen, 0.1);
  const PoseBound two = PoseCramerRao(rig, pose, seen, 0.2);
  ASSERT_TRUE(one.valid && two.valid);
  EXPECT_TRUE(two.sigma_position.isApprox(2.0 * one.sigma_position, 1e-9));
  EXPECT_TRUE(two.sigma_euler.isApprox(2.0 * one.sigma_euler, 1e-9));
  seen.resize(2);
  EXPECT_FALSE(PoseCramerRao(rig, pose, seen, 0.1).valid);
}

TEST(PoseBound, EulerJacobianAtZeroAttitude) {
  // C_b_w <- Exp(-dtheta) C_b_w: at identity a small body rotation is the Euler triple itself
  // (I - [a]x, eqs. A2/A3).
  const Eigen::Matrix3d J = EulerJacobian(BodyPose{});
  EXPECT_TRUE(J.isApprox(Eigen::Matrix3d::Identity(), 1e-6)) << J;
}

TEST(PoseBound, VisibilityRespectsOcclusionAndMargin) {
  const Rig rig = PaperRig();
  BodyPose pose;
  const auto all = VisibleBeacons(rig, pose);
  ASSERT_FALSE(all.empty());
  const auto fewer = VisibleBeacons(rig, pose, 0.0, {all.front().beacon});
  EXPECT_EQ(fewer.size(), all.size() - 1);
  for (const auto& v : VisibleBeacons(rig, pose, 100.0)) {
    EXPECT_GE(v.uv_px.x(), 99.5);
    EXPECT_LE(v.uv_px.y(), 1024 - 100.5);
  }
}

}  // namespace
}  // namespace mfns::host
