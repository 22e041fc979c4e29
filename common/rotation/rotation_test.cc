#include "common/rotation/rotation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace mfns {
namespace {

EulerAngles RandomEuler(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> half(-kPi / 2 + 1e-3, kPi / 2 - 1e-3), full(-kPi, kPi);
  return {half(rng), full(rng), full(rng)};
}

// Eq. 9 of the paper written out element by element.
TEST(Rotation, EulerMatrixEqualsEquation9) {
  std::mt19937_64 rng(1);
  for (int i = 0; i < 1000; ++i) {
    const EulerAngles e = RandomEuler(rng);
    const double cf = std::cos(e.phi), sf = std::sin(e.phi);
    const double ct = std::cos(e.theta), st = std::sin(e.theta);
    const double cp = std::cos(e.psi), sp = std::sin(e.psi);
    const Eigen::Matrix3d C = EulerToMatrix(e);
    EXPECT_NEAR(C(0, 0), cp * ct + sp * st * sf, 1e-15);
    EXPECT_NEAR(C(0, 1), sp * cf, 1e-15);
    EXPECT_NEAR(C(0, 2), -cp * st + sp * ct * sf, 1e-15);
    EXPECT_NEAR(C(1, 0), -sp * ct + cp * st * sf, 1e-15);
    EXPECT_NEAR(C(1, 1), cp * cf, 1e-15);
    EXPECT_NEAR(C(1, 2), sp * st + cp * ct * sf, 1e-15);
    EXPECT_NEAR(C(2, 0), cf * st, 1e-15);
    EXPECT_NEAR(C(2, 1), -sf, 1e-15);
    EXPECT_NEAR(C(2, 2), ct * cf, 1e-15);
    EXPECT_TRUE(IsRotation(C, 1e-12));
  }
}

TEST(Rotation, ElementaryRotationsAreFrameRotations) {
  // A frame rotated by +a about z sees a fixed vector on its x axis turned by -a.
  const Eigen::Vector3d p = R3(DegToRad(90)) * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(p.x(), 0.0, 1e-15);
  EXPECT_NEAR(p.y(), -1.0, 1e-15);
  EXPECT_TRUE(R1(0.3).isApprox(ExpSO3(-0.3 * Eigen::Vector3d::UnitX()), 1e-14));
  EXPECT_TRUE(R2(0.3).isApprox(ExpSO3(-0.3 * Eigen::Vector3d::UnitY()), 1e-14));
  EXPECT_TRUE(R3(0.3).isApprox(ExpSO3(-0.3 * Eigen::Vector3d::UnitZ()), 1e-14));
}

TEST(Rotation, EulerMatrixRoundTrip) {
  std::mt19937_64 rng(2);
  for (int i = 0; i < 1000; ++i) {
    const EulerAngles e = RandomEuler(rng);
    const EulerAngles back = MatrixToEuler(EulerToMatrix(e));
    EXPECT_NEAR(back.phi, e.phi, 1e-9);
    EXPECT_NEAR(back.theta, e.theta, 1e-9);
    EXPECT_NEAR(back.psi, e.psi, 1e-9);
  }
}

TEST(Rotation, QuaternionRoundTrip) {
  std::mt19937_64 rng(3);
  for (int i = 0; i < 1000; ++i) {
    const EulerAngles e = RandomEuler(rng);
    const Eigen::Quaterniond q = EulerToQuaternion(e);
    EXPECT_NEAR(q.norm(), 1.0, 1e-14);
    EXPECT_TRUE(q.toRotationMatrix().isApprox(EulerToMatrix(e), 1e-12));
    const EulerAngles back = QuaternionToEuler(q);
    EXPECT_NEAR(back.phi, e.phi, 1e-9);
    EXPECT_NEAR(back.theta, e.theta, 1e-9);
    EXPECT_NEAR(back.psi, e.psi, 1e-9);
  }
}

TEST(Rotation, GimbalLockKeepsTheMatrix) {
  for (double phi : {kPi / 2, -kPi / 2}) {
    const Eigen::Matrix3d C = EulerToMatrix({phi, 0.4, -0.2});
    const Eigen::Matrix3d back = EulerToMatrix(MatrixToEuler(C));
    EXPECT_TRUE(back.isApprox(C, 1e-12)) << back << "\nvs\n" << C;
  }
}

// Eqs. A2/A3: the small-angle matrix differs from the exact one only at second order.
TEST(Rotation, SmallAngleFormAgreesToSecondOrder) {
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d dir(unit(rng), unit(rng), unit(rng));
    double previous_ratio = -1;
    for (double scale : {1e-2, 1e-3, 1e-4}) {
      const Eigen::Vector3d a = scale * dir;
      const Eigen::Matrix3d exact = EulerToMatrix({a.x(), a.y(), a.z()});
      const double err = (exact - SmallAngleMatrix(a)).cwiseAbs().maxCoeff();
      // Second order: err / |a|^2 stays bounded (<= 1.5 for unit-bounded components)...
      const double ratio = err / (scale * scale);
      EXPECT_LT(ratio, 1.5);
      // ...and is nearly constant as the angles shrink (not first order).
      if (previous_ratio > 0) {
        EXPECT_NEAR(ratio, previous_ratio, 0.05 * previous_ratio + 1e-6);
      }
      previous_ratio = ratio;
    }
  }
  // The paper's matrix written out: [[1, psi, -theta], [-psi, 1, phi], [theta, -phi, 1]].
  const Eigen::Matrix3d S = SmallAngleMatrix({0.01, 0.02, 0.03});
  Eigen::Matrix3d expected;
  expected << 1, 0.03, -0.02, -0.03, 1, 0.01, 0.02, -0.01, 1;
  EXPECT_TRUE(S.isApprox(expected, 1e-15));
}

TEST(Rotation, ExpLogRoundTripAndSkew) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d w = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)) * 1.5;
    const Eigen::Vector3d b(unit(rng), unit(rng), unit(rng));
    EXPECT_TRUE((Skew(w) * b).isApprox(w.cross(b), 1e-14));
    const Eigen::Matrix3d C = ExpSO3(w);
    EXPECT_TRUE(IsRotation(C, 1e-12));
    EXPECT_TRUE(LogSO3(C).isApprox(w, 1e-9));
  }
}

// Exp(w + dw) = Exp(w) Exp(J_r(w) dw) and = Exp(J_r(-w) dw) Exp(w), by central differences,
// at small (series) and large angles.
TEST(Rotation, RightJacobianAgainstFiniteDifferences) {
  for (const Eigen::Vector3d& w : {Eigen::Vector3d(1e-6, -2e-6, 3e-7), Eigen::Vector3d(0.3, -0.2, 0.1),
                                   Eigen::Vector3d(-1.2, 2.0, 0.7), Eigen::Vector3d(0.0, 0.0, 3.0)}) {
    const Eigen::Matrix3d Jr = RightJacobianSO3(w), Jl = RightJacobianSO3(-w);
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(i) * h;
      const Eigen::Vector3d right = (LogSO3(ExpSO3(w).transpose() * ExpSO3(w + e)) -
                                     LogSO3(ExpSO3(w).transpose() * ExpSO3(w - e))) / (2 * h);
      const Eigen::Vector3d left = (LogSO3(ExpSO3(w + e) * ExpSO3(w).transpose()) -
                                    LogSO3(ExpSO3(w - e) * ExpSO3(w).transpose())) / (2 * h);
      EXPECT_LT((right - Jr.col(i)).norm(), 1e-8) << w.transpose() << " column " << i;
      EXPECT_LT((left - Jl.col(i)).norm(), 1e-8) << w.transpose() << " column " << i;
    }
  }
  EXPECT_LT((RightJacobianSO3(Eigen::Vector3d::Zero()) - Eigen::Matrix3d::Identity()).norm(), 1e-15);
}

TEST(Rotation, NearestRotationRepairsNoise) {
  const Eigen::Matrix3d C = EulerToMatrix({0.1, -0.7, 2.0});
  Eigen::Matrix3d noisy = C;
  noisy(0, 1) += 1e-4;
  noisy(2, 2) -= 1e-4;
  EXPECT_FALSE(IsRotation(noisy, 1e-6));
  const Eigen::Matrix3d fixed = NearestRotation(noisy);
  EXPECT_TRUE(IsRotation(fixed, 1e-12));
  EXPECT_LT((fixed - C).cwiseAbs().maxCoeff(), 2e-4);
}

}  // namespace
}  // namespace mfns

namespace mfns {
namespace {

// The one angle wrap: (-180, 180] and (-pi, pi]; half a turn reads +180 from either side (the
// three copies it replaced disagreed there: std::remainder alone gives -180 for -180 and for 540).
TEST(Rotation, WrapIsHalfOpenAtHalfATurn) {
  EXPECT_EQ(Wrap180Deg(180.0), 180.0);
  EXPECT_EQ(Wrap180Deg(-180.0), 180.0);
  EXPECT_EQ(Wrap180Deg(540.0), 180.0);
  EXPECT_EQ(Wrap180Deg(-540.0), 180.0);
  EXPECT_EQ(Wrap180Deg(0.0), 0.0);
  EXPECT_DOUBLE_EQ(Wrap180Deg(-179.5), -179.5);
  EXPECT_DOUBLE_EQ(Wrap180Deg(359.0), -1.0);
  EXPECT_DOUBLE_EQ(Wrap180Deg(-359.0), 1.0);
  EXPECT_DOUBLE_EQ(Wrap180Deg(3600.25), 0.25);
  EXPECT_EQ(WrapPi(kPi), kPi);
  EXPECT_EQ(WrapPi(-kPi), kPi);
  EXPECT_NEAR(WrapPi(0.1 + 4.0 * kPi), 0.1, 1e-12);
  EXPECT_NEAR(WrapPi(-0.1 - 6.0 * kPi), -0.1, 1e-12);
  EXPECT_TRUE(std::isnan(WrapPi(std::nan(""))));
  EXPECT_TRUE(std::isinf(Wrap180Deg(HUGE_VAL)));
  // Against a reference built from atan2 (a different route to the same wrap), over many turns.
  for (double a = -20.0; a <= 20.0; a += 0.0137) {
    const double ref = std::atan2(std::sin(a), std::cos(a));
    EXPECT_NEAR(WrapPi(a), ref, 1e-12) << a;
    EXPECT_GT(WrapPi(a), -kPi);
    EXPECT_LE(WrapPi(a), kPi);
  }
}

}  // namespace
}  // namespace mfns
