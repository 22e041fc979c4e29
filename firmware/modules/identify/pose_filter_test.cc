#include "firmware/modules/identify/pose_filter.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/rotation/rotation.h"

namespace mfns::fw {
namespace {

struct State {
  BodyPose pose;
  Eigen::Vector3d v_w = Eigen::Vector3d::Zero();
  Eigen::Vector3d omega_b = Eigen::Vector3d::Zero();
};

State Move(const State& s, double dt) {
  State n = s;
  n.pose.r_w_wb += s.v_w * dt;
  n.pose.C_w_b = s.pose.C_w_b * ExpSO3(s.omega_b * dt);
  return n;
}

State Perturb(const State& s, const PoseFilter::Vector12d& dx) {
  State n = s;
  n.pose.r_w_wb += dx.segment<3>(0);
  n.pose.C_w_b = s.pose.C_w_b * ExpSO3(dx.segment<3>(3));
  n.v_w += dx.segment<3>(6);
  n.omega_b += dx.segment<3>(9);
  return n;
}

PoseFilter::Vector12d Difference(const State& a, const State& b) {  // a - b in the error state
  PoseFilter::Vector12d d;
  d << a.pose.r_w_wb - b.pose.r_w_wb, LogSO3(b.pose.C_w_b.transpose() * a.pose.C_w_b), a.v_w - b.v_w,
      a.omega_b - b.omega_b;
  return d;
}

// The error-state transition against central finite differences of the true motion.
TEST(PoseFilter, TransitionMatchesFiniteDifferences) {
  State s;
  s.pose.C_w_b = ExpSO3(Eigen::Vector3d(0.3, -1.1, 2.0));
  s.pose.r_w_wb = Eigen::Vector3d(1.0, -2.0, 0.5);
  s.v_w = Eigen::Vector3d(0.2, -0.1, 0.05);
  s.omega_b = Eigen::Vector3d(0.4, -0.7, 0.9);
  for (const double dt : {0.054, 0.5, 2.0}) {
    const PoseFilter::Matrix12d F = PoseFilter::Transition(s.omega_b, dt);
    const State moved = Move(s, dt);
    for (int j = 0; j < 12; ++j) {
      const double h = 1e-6;
      const PoseFilter::Vector12d e = PoseFilter::Vector12d::Unit(j) * h;
      const PoseFilter::Vector12d col =
          (Difference(Move(Perturb(s, e), dt), moved) - Difference(Move(Perturb(s, -e), dt), moved)) / (2 * h);
      EXPECT_LT((col - F.col(j)).norm(), 1e-6) << "dt " << dt << " column " << j;
    }
  }
}

// A body under white random acceleration of the filter's own densities, measured with known
// noise at 18.6 Hz and sometimes not for a second (coasting): the squared Mahalanobis distance
// of each measurement from the prediction averages 6 (chi-square, 6 dof), and the truth lies
// within the chi-square(6) 99.9 % gate about as often as it should.
TEST(PoseFilter, PredictionIsConsistentWithItsCovariance) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  const PoseFilterNoise noise;  // the defaults
  const double h = 1e-3, period = 1.0 / 18.6;
  State truth;
  truth.v_w = Eigen::Vector3d(0.1, 0.0, -0.05);
  truth.omega_b = Eigen::Vector3d(0.0, 0.2, 0.1);
  Matrix6d R = Matrix6d::Zero();
  R.diagonal() << 1e-6, 4e-6, 1e-6, 1e-7, 4e-8, 1e-7;
  const Matrix6d L = R.llt().matrixL();
  auto measure = [&](const State& s) {
    Eigen::Matrix<double, 6, 1> n;
    for (int i = 0; i < 6; ++i) n(i) = g(rng);
    const Eigen::Matrix<double, 6, 1> e = L * n;
    BodyPose z = s.pose;
    z.r_w_wb += e.head<3>();
    z.C_w_b = s.pose.C_w_b * ExpSO3(e.tail<3>());
    return z;
  };
  PoseFilter f;
  ASSERT_TRUE(f.Start(measure(truth), 0, R, noise));
  double sum = 0.0;
  int n = 0, outside = 0;
  std::uint64_t t_ns = 0;
  for (int k = 1; k <= 3000; ++k) {
    const double gap = (k % 200 == 0) ? 1.0 : period;  // a one-second coast now and then
    for (double t = 0; t < gap - 1e-12; t += h) {
      for (int i = 0; i < 3; ++i) {
        truth.v_w(i) += std::sqrt(noise.accel_psd * h) * g(rng);
        truth.omega_b(i) += std::sqrt(noise.angular_accel_psd * h) * g(rng);
      }
      truth = Move(truth, h);
    }
    t_ns += static_cast<std::uint64_t>(std::llround(gap * 1e9));
    const BodyPose z = measure(truth);
    const double m2 = f.Distance2(z, R, t_ns);
    if (k > 20) {  // past the start's unknown velocity
      sum += m2;
      ++n;
      outside += m2 > 22.46;
    }
    ASSERT_TRUE(f.Update(z, t_ns, R));
  }
  EXPECT_NEAR(sum / n, 6.0, 0.5);
  EXPECT_LT(outside, 0.004 * n);
}

// Without process noise to speak of, a constant-velocity motion is learnt: the prediction one
// second ahead lands within a millimetre and a milliradian.
TEST(PoseFilter, LearnsAConstantVelocity) {
  PoseFilterNoise noise;
  noise.accel_psd = 1e-8;
  noise.angular_accel_psd = 1e-8;
  State truth;
  truth.pose.C_w_b = ExpSO3(Eigen::Vector3d(0.1, 0.2, 0.3));
  truth.v_w = Eigen::Vector3d(0.2, -0.1, 0.05);
  truth.omega_b = Eigen::Vector3d(0.3, 0.0, -0.2);
  const Matrix6d R = Matrix6d::Identity() * 1e-8;
  PoseFilter f;
  ASSERT_TRUE(f.Start(truth.pose, 0, R, noise));
  std::uint64_t t_ns = 0;
  for (int k = 0; k < 50; ++k) {
    truth = Move(truth, 0.05);
    t_ns += 50'000'000;
    ASSERT_TRUE(f.Update(truth.pose, t_ns, R));
  }
  BodyPose pred;
  Matrix6d P;
  ASSERT_TRUE(f.Predict(t_ns + 1'000'000'000, &pred, &P));
  const State ahead = Move(truth, 1.0);
  EXPECT_LT((pred.r_w_wb - ahead.pose.r_w_wb).norm(), 1e-3);
  EXPECT_LT(LogSO3(ahead.pose.C_w_b.transpose() * pred.C_w_b).norm(), 1e-3);
  EXPECT_LT((f.v_w() - truth.v_w).norm(), 1e-3);
}

TEST(PoseFilter, RefusesWhatItCannotUse) {
  PoseFilter f;
  const Matrix6d R = Matrix6d::Identity() * 1e-6;
  BodyPose p;
  EXPECT_FALSE(f.Update(p, 1, R));  // not started
  EXPECT_TRUE(std::isinf(f.Distance2(p, R, 1)));
  PoseFilterNoise bad;
  bad.accel_psd = 0.0;
  EXPECT_FALSE(f.Start(p, 0, R, bad));
  BodyPose nan = p;
  nan.r_w_wb.x() = std::nan("");
  EXPECT_FALSE(f.Start(nan, 0, R, PoseFilterNoise{}));
  ASSERT_TRUE(f.Start(p, 10, R, PoseFilterNoise{}));
  EXPECT_FALSE(f.Update(p, 5, R));  // earlier than the state
  EXPECT_FALSE(f.Update(nan, 20, R));
  EXPECT_EQ(f.t_ns(), 10u);
}

}  // namespace
}  // namespace mfns::fw
