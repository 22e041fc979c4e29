// MotionModel (motion_model.h): constant-velocity prediction against an analytic trajectory,
// the error bounds' growth with the elapsed time, what starts and forgets the velocity.
#include "firmware/modules/identify/motion_model.h"

#include <gtest/gtest.h>

#include <cmath>

#include "common/rotation/rotation.h"
#include "firmware/lib/testing/alloc_counter.h"

namespace mfns::fw {
namespace {

constexpr std::uint64_t kT0 = 1'000'000'000;  // ns
constexpr std::uint64_t kFrameNs = 33'333'333;

// A body moving at constant velocity: r_w_wb(t) = r0 + v_w t, C_w_b(t) = C0 Exp(omega_b t).
struct Trajectory {
  Eigen::Vector3d r0{1.0, -0.5, 0.3};
  Eigen::Vector3d v_w{0.05, 0.02, -0.01};        // m/s
  Eigen::Matrix3d C0 = ExpSO3(Eigen::Vector3d(0.3, -0.2, 1.0));
  Eigen::Vector3d omega_b{0.01, -0.02, 0.2};      // rad/s
  BodyPose At(std::uint64_t t_ns) const {
    const double t = Seconds(t_ns, kT0);
    BodyPose p;
    p.r_w_wb = r0 + v_w * t;
    p.C_w_b = C0 * ExpSO3(omega_b * t);
    return p;
  }
};

double PositionError(const BodyPose& a, const BodyPose& b) { return (a.r_w_wb - b.r_w_wb).norm(); }
double AttitudeError(const BodyPose& a, const BodyPose& b) { return LogSO3(a.C_w_b.transpose() * b.C_w_b).norm(); }

// The Kalman filter beside the model (pose_filter.h) follows the same poses: a start pose with
// its 1-sigma starts it at the next Add (which brings the motion bounds), accepted poses update
// it, and its prediction covers the truth; Forget drops it.
TEST(MotionModelTest, FilterFollowsTheAcceptedPoses) {
  const Trajectory truth;
  const MotionLimits lim;
  MotionModel m;
  m.Start(truth.At(kT0), kT0, 0.002, 0.001);
  EXPECT_FALSE(m.filter().started());
  Matrix6d cov = Matrix6d::Identity() * 1e-6;
  for (int i = 1; i < 10; ++i) {
    const std::uint64_t t = kT0 + static_cast<std::uint64_t>(i) * kFrameNs;
    m.Add(truth.At(t), t, 1e-3, 1e-3, 0.5, lim, &cov);
    ASSERT_TRUE(m.filter().started());
    EXPECT_EQ(m.filter().t_ns(), t);
  }
  const std::uint64_t later = kT0 + 9 * kFrameNs + 500'000'000;
  const double m2 = m.filter().Distance2(truth.At(later), Matrix6d::Zero(), later);
  EXPECT_LT(m2, 1.0);  // a constant velocity, well inside a prediction sized for accelerations
  EXPECT_LT((m.filter().v_w() - truth.v_w).norm(), 0.02);
  m.Forget();
  EXPECT_FALSE(m.filter().started());
}

// A velocity taken across a gap is the mean over it: under the largest accelerations it lags
// the velocity at the last pose by half the gap's change, and the bounds count that. Two poses
// 2.5 s apart on a path accelerating at the bounds (0.1 m/s^2, 0.2 rad/s^2 about one axis): one
// frame set later the prediction's error stays within the bounds less their slack (the part the
// tracking gate sees). Before, the bounds held only 0.5 a t^2 over the frame set: 0.3 mrad
// against a 13.5 mrad error (20 px at 1600 px/rad), and the track was refuted.
TEST(MotionModelTest, AVelocityAcrossAGapCountsTheAccelerationsOverIt) {
  const MotionLimits lim;
  const auto at = [&](double t) {
    BodyPose p;
    p.r_w_wb = Eigen::Vector3d(0.5 * lim.max_accel_m_s2 * t * t, 0.0, 0.0);
    p.C_w_b = ExpSO3(Eigen::Vector3d(0.0, 0.0, 0.5 * lim.max_angular_accel_rad_s2 * t * t));
    return p;
  };
  const double gap_s = 2.5, frame_s = 0.054;
  MotionModel m;
  m.Add(at(0.0), kT0, 0.0, 0.0, 0.0, lim);
  const std::uint64_t t1 = kT0 + static_cast<std::uint64_t>(gap_s * 1e9);
  m.Add(at(gap_s), t1, 0.0, 0.0, 0.0, lim);
  ASSERT_TRUE(m.has_velocity());
  const std::uint64_t t2 = t1 + static_cast<std::uint64_t>(frame_s * 1e9);
  const BodyPose predicted = m.Predict(t2);
  const PoseBounds b = m.Bounds(frame_s, lim);
  const double err_m = PositionError(predicted, at(gap_s + frame_s));
  const double err_rad = AttitudeError(predicted, at(gap_s + frame_s));
  EXPECT_GT(err_rad, 0.01);  // the lag itself: 0.2 x 1.25 x 0.054 rad
  EXPECT_LE(err_m, b.max_m - lim.slack_m + 1e-9);  // (the bound is exact for this path)
  EXPECT_LE(err_rad, b.max_rad - lim.slack_rad + 1e-9);
  // Within the window nothing changes: the same motion sampled 0.1 s apart.
  MotionModel near;
  near.Add(at(gap_s - 0.1), t1 - 100'000'000, 0.0, 0.0, 0.0, lim);
  near.Add(at(gap_s), t1, 0.0, 0.0, 0.0, lim);
  EXPECT_NEAR(near.Bounds(frame_s, lim).max_rad,
              lim.slack_rad + 0.5 * lim.max_angular_accel_rad_s2 * frame_s * frame_s, 1e-12);
}

TEST(MotionModelTest, ConstantVelocityPredictionFollowsTheTrajectory) {
  const Trajectory truth;
  const MotionLimits lim;
  MotionModel m;
  m.Forget();
  for (int i = 0; i < 10; ++i) {
    const std::uint64_t t = kT0 + static_cast<std::uint64_t>(i) * kFrameNs;
    m.Add(truth.At(t), t, 0.0, 0.0, 0.0, lim);
  }
  ASSERT_TRUE(m.known());
  ASSERT_TRUE(m.has_velocity());
  // Exact poses on a constant-velocity path: the prediction is exact at any lead (2 s here).
  const std::uint64_t later = kT0 + 9 * kFrameNs + 2'000'000'000;
  EXPECT_LT(PositionError(m.Predict(later), truth.At(later)), 1e-10);
  EXPECT_LT(AttitudeError(m.Predict(later), truth.At(later)), 1e-10);
  // Carried back by the velocity, the prediction lands on the last pose again.
  double dv_m = 0.0, dv_rad = 0.0;
  const BodyPose back = m.CarryBack(m.Predict(later), later, 2.0, lim, &dv_m, &dv_rad);
  EXPECT_LT(PositionError(back, m.last_pose()), 1e-12);
  EXPECT_LT(AttitudeError(back, m.last_pose()), 1e-12);
  // The velocity's error: the accelerations over the 2 s since the last pose (exact poses).
  EXPECT_NEAR(dv_m, lim.max_accel_m_s2 * 2.0, 1e-9);
  EXPECT_NEAR(dv_rad, lim.max_angular_accel_rad_s2 * 2.0, 1e-9);
}

TEST(MotionModelTest, VelocityIsTakenOverTheWindow) {
  // Noise on one pose spreads over the window's baseline: the oldest pose within
  // velocity_window_s is used, so a 1 mm error on the newest moves the velocity by 1 mm / 0.2 s.
  const Trajectory truth;
  MotionLimits lim;
  lim.velocity_window_s = 0.2;
  MotionModel m;
  for (int i = 0; i <= 12; ++i) {  // 0.4 s at 30 Hz
    const std::uint64_t t = kT0 + static_cast<std::uint64_t>(i) * kFrameNs;
    BodyPose p = truth.At(t);
    if (i == 12) p.r_w_wb.x() += 1e-3;
    m.Add(p, t, 0.0, 0.0, 0.0, lim);
  }
  const std::uint64_t t12 = kT0 + 12 * kFrameNs;
  const BodyPose one_second = m.Predict(t12 + 1'000'000'000);
  // Baseline: 6 frames (0.2 s) back; the error 1 mm now, plus 1 mm / 0.2 s over 1 s.
  const double expected = 1e-3 + 1e-3 / (6.0 * static_cast<double>(kFrameNs) * 1e-9);
  EXPECT_NEAR(one_second.r_w_wb.x() - truth.At(t12 + 1'000'000'000).r_w_wb.x(), expected, 1e-9);
}

TEST(MotionModelTest, HeldPoseBoundsGrowWithTheSpeedBounds) {
  MotionLimits lim;
  MotionModel m;
  const BodyPose pose = Trajectory{}.At(kT0);
  m.Start(pose, kT0, 0.0, 0.0);
  EXPECT_TRUE(m.known());
  EXPECT_FALSE(m.has_velocity());
  EXPECT_LT(PositionError(m.Predict(kT0 + 500'000'000), pose), 1e-15);  // held
  for (const double s : {0.0, 0.1, 1.0, 3.0}) {
    const PoseBounds b = m.Bounds(s, lim);
    EXPECT_NEAR(b.max_m, lim.slack_m + lim.max_speed_m_s * s, 1e-12);
    EXPECT_NEAR(b.max_rad, lim.slack_rad + lim.max_rate_rad_s * s, 1e-12);
  }
  // A start pose's 1-sigma widens them by sigmas of it.
  m.Start(pose, kT0, 0.01, 0.002);
  EXPECT_NEAR(m.Bounds(0.0, lim).max_m, lim.slack_m + lim.sigmas * 0.01, 1e-12);
  EXPECT_NEAR(m.Bounds(0.0, lim).max_rad, lim.slack_rad + lim.sigmas * 0.002, 1e-12);
}

TEST(MotionModelTest, PredictionBoundsGrowWithTheAccelerationsAndTheVelocityLever) {
  const Trajectory truth;
  const MotionLimits lim;
  const double sigma_m = 1e-3, sigma_rad = 2e-4;
  MotionModel m;
  m.Add(truth.At(kT0), kT0, sigma_m, sigma_rad, 0.0, lim);
  const std::uint64_t t1 = kT0 + 100'000'000;  // baseline 0.1 s
  m.Add(truth.At(t1), t1, sigma_m, sigma_rad, 0.0, lim);
  ASSERT_TRUE(m.has_velocity());
  double previous = 0.0;
  for (const double s : {0.0, 0.05, 0.5, 2.0}) {
    const PoseBounds b = m.Bounds(s, lim);
    const double lead = 1.0 + s / 0.1;  // the velocity's error grows over the extrapolation
    EXPECT_NEAR(b.max_m, lim.slack_m + lim.sigmas * sigma_m * lead + 0.5 * lim.max_accel_m_s2 * s * s, 1e-12);
    EXPECT_NEAR(b.max_rad, lim.slack_rad + lim.sigmas * sigma_rad * lead + 0.5 * lim.max_angular_accel_rad_s2 * s * s,
                1e-12);
    EXPECT_GE(b.max_m, previous);
    previous = b.max_m;
  }
  // The truth of a path that accelerates within the bounds stays inside them: a = max_accel.
  const double a = lim.max_accel_m_s2, s = 1.5;
  const double off = 0.5 * a * s * s;  // constant-velocity extrapolation error
  EXPECT_LE(off, m.Bounds(s, lim).max_m);
}

TEST(MotionModelTest, UncertainStartIsNoVelocitySampleAndForgetDropsTheHistory) {
  const Trajectory truth;
  const MotionLimits lim;
  MotionModel m;
  m.Start(truth.At(kT0), kT0, 0.05, 0.0);  // uncertain: not in the history
  m.Add(truth.At(kT0 + kFrameNs), kT0 + kFrameNs, 0.0, 0.0, 0.0, lim);
  EXPECT_FALSE(m.has_velocity());
  m.Start(truth.At(kT0), kT0, 0.0, 0.0);  // exact: a velocity sample
  m.Add(truth.At(kT0 + kFrameNs), kT0 + kFrameNs, 0.0, 0.0, 0.0, lim);
  EXPECT_TRUE(m.has_velocity());
  m.Forget();
  EXPECT_FALSE(m.known());
  EXPECT_FALSE(m.has_velocity());
  // A pose after Forget does not continue the old history: no velocity from it.
  m.Add(truth.At(kT0 + 2 * kFrameNs), kT0 + 2 * kFrameNs, 0.0, 0.0, 0.0, lim);
  EXPECT_TRUE(m.known());
  EXPECT_FALSE(m.has_velocity());
}

TEST(MotionModelTest, MapErrorSigmaFollowsTheRatio) {
  const MotionLimits lim;
  MotionModel m;
  m.Add(Trajectory{}.At(kT0), kT0, 1e-3, 2e-4, 8.0, lim);
  EXPECT_DOUBLE_EQ(m.last_map_sigma_m(), 8e-3);
  EXPECT_DOUBLE_EQ(m.last_map_sigma_rad(), 1.6e-3);
  m.Start(Trajectory{}.At(kT0), kT0, 0.0, 0.0);
  EXPECT_EQ(m.last_map_sigma_m(), 0.0);
}

TEST(MotionModelTest, NothingAllocates) {
  const Trajectory truth;
  const MotionLimits lim;
  static MotionModel m;
  const std::uint64_t before = testing::AllocationCount();
  for (int i = 0; i < 100; ++i) {
    const std::uint64_t t = kT0 + static_cast<std::uint64_t>(i) * kFrameNs;
    m.Add(truth.At(t), t, 1e-3, 1e-4, 1.0, lim);
    static_cast<void>(m.Predict(t + kFrameNs));
    static_cast<void>(m.Bounds(0.1, lim));
  }
  EXPECT_EQ(testing::AllocationCount() - before, 0u);
}

}  // namespace
}  // namespace mfns::fw
