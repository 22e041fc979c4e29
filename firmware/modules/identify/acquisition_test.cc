// Acquisition (acquisition.h): followed poses kept within their motion bounds and dropped
// outside, stale chains dropped, a chain seeded by the motion model's prediction, the prior.
#include "firmware/modules/identify/acquisition.h"

#include <gtest/gtest.h>

#include <initializer_list>

#include "common/rotation/rotation.h"
#include "firmware/lib/testing/alloc_counter.h"

namespace mfns::fw {
namespace {

constexpr std::uint64_t kT0 = 5'000'000'000;  // ns
constexpr std::uint64_t kFrameNs = 100'000'000;  // 0.1 s

BodyPose PoseAt(double x_m, double yaw_rad) {
  BodyPose p;
  p.r_w_wb = Eigen::Vector3d(x_m, 0.2, -0.1);
  p.C_w_b = ExpSO3(Eigen::Vector3d(0.0, 0.0, yaw_rad));
  return p;
}

// LostInSpace's list of consistent poses of a frame set (complete).
LisResult List(std::initializer_list<BodyPose> poses) {
  LisResult l;
  l.complete = true;
  l.num_consistent = 0;
  for (const BodyPose& p : poses) l.consistent_poses[static_cast<std::size_t>(l.num_consistent++)] = p;
  return l;
}

AcquisitionLimits Limits() {
  AcquisitionLimits lim;
  lim.motion.max_speed_m_s = 0.5;
  lim.motion.max_rate_rad_s = 1.0;
  lim.slack_m = 0.02;
  lim.slack_rad = 0.02;
  lim.stale_s = 1.0;
  return lim;
}

TEST(AcquisitionTest, FollowsPosesWithinTheirBoundsAndDropsTheOthers) {
  static Acquisition a;  // (large: kept off the stack)
  static LisResult first, second;
  first = List({PoseAt(0.0, 0.0), PoseAt(1.0, 0.0), PoseAt(2.0, 1.0)});
  a.Start(first, kT0);
  EXPECT_EQ(a.size(), 3);
  EXPECT_EQ(a.frames(), 1);
  EXPECT_FALSE(a.seeded());
  // 0.1 s later an unseeded pose may have moved 0.5 m/s * 0.1 s + 0.02 m = 0.07 m, 0.12 rad.
  a.Prepare(kT0 + kFrameNs, Limits(), nullptr);
  LisPrior prior;
  ASSERT_TRUE(a.Prior(&prior));
  EXPECT_EQ(prior.num_poses, 3);
  EXPECT_NEAR(prior.max_m, 0.07, 1e-12);
  EXPECT_NEAR(prior.max_rad, 0.12, 1e-12);
  // The first moved 0.06 m (kept), the second 0.08 m (dropped), the third turned 0.15 rad
  // (dropped); a pose far from all is not followed.
  second = List({PoseAt(0.06, 0.0), PoseAt(1.08, 0.0), PoseAt(2.0, 1.15), PoseAt(5.0, 0.0)});
  a.Follow(second, kT0 + kFrameNs);
  ASSERT_EQ(a.size(), 1);
  EXPECT_EQ(a.frames(), 2);
  EXPECT_NEAR(a.pose(0).r_w_wb.x(), 0.06, 1e-15);
  // Nothing near it in the next frame set: the chain is emptied.
  a.Prepare(kT0 + 2 * kFrameNs, Limits(), nullptr);
  second = List({PoseAt(0.5, 0.0)});
  a.Follow(second, kT0 + 2 * kFrameNs);
  EXPECT_TRUE(a.empty());
  EXPECT_FALSE(a.Prior(&prior));
}

TEST(AcquisitionTest, OnePoseMayBeFollowedByManyAndBoundsCountFromTheLastConfirmation) {
  static Acquisition a;
  static LisResult list;
  list = List({PoseAt(0.0, 0.0)});
  a.Start(list, kT0);
  // Two poses within the bounds of the one followed: both followed (either may be the truth).
  a.Prepare(kT0 + kFrameNs, Limits(), nullptr);
  list = List({PoseAt(0.03, 0.0), PoseAt(-0.03, 0.05)});
  a.Follow(list, kT0 + kFrameNs);
  EXPECT_EQ(a.size(), 2);
  // No complete list for 0.3 s (the caller does not Follow): the bounds keep growing from the
  // last confirmation, 0.5 m/s * 0.4 s + 0.02 m.
  a.Prepare(kT0 + 5 * kFrameNs, Limits(), nullptr);
  LisPrior prior;
  ASSERT_TRUE(a.Prior(&prior));
  EXPECT_NEAR(prior.max_m, 0.22, 1e-12);
}

TEST(AcquisitionTest, StaleChainsAreDropped) {
  static Acquisition a;
  static LisResult list;
  list = List({PoseAt(0.0, 0.0), PoseAt(1.0, 0.0)});
  a.Start(list, kT0);
  a.Prepare(kT0 + 9 * kFrameNs, Limits(), nullptr);  // 0.9 s <= stale_s
  EXPECT_EQ(a.size(), 2);
  a.Prepare(kT0 + 11 * kFrameNs, Limits(), nullptr);  // 1.1 s: unconfirmed too long
  EXPECT_TRUE(a.empty());
}

TEST(AcquisitionTest, AnEmptyChainIsSeededByThePrediction) {
  static Acquisition a;
  const AcquisitionLimits lim = Limits();
  MotionModel seed;
  seed.Add(PoseAt(0.0, 0.0), kT0, 1e-3, 1e-4, 0.0, lim.motion);
  seed.Add(PoseAt(0.01, 0.01), kT0 + kFrameNs, 1e-3, 1e-4, 0.0, lim.motion);  // 0.1 m/s, 0.1 rad/s
  a.Clear();
  const std::uint64_t t = kT0 + 6 * kFrameNs;  // 0.5 s after the seed's last pose
  a.Prepare(t, lim, &seed);
  ASSERT_EQ(a.size(), 1);
  EXPECT_TRUE(a.seeded());
  EXPECT_EQ(a.frames(), 1);
  EXPECT_NEAR(a.pose(0).r_w_wb.x(), 0.06, 1e-12);  // the prediction
  LisPrior prior;
  ASSERT_TRUE(a.Prior(&prior));
  const PoseBounds b = seed.Bounds(0.5, lim.motion);  // the prediction's own bounds
  EXPECT_NEAR(prior.max_m, b.max_m + lim.slack_m, 1e-12);
  EXPECT_NEAR(prior.max_rad, b.max_rad + lim.slack_rad, 1e-12);
  // A chain that exists is not reseeded; its bounds are then the speed bounds.
  a.Prepare(t + kFrameNs, lim, &seed);
  ASSERT_TRUE(a.Prior(&prior));
  EXPECT_NEAR(prior.max_m, 0.5 * 0.6 + lim.slack_m, 1e-12);
}

TEST(AcquisitionTest, NothingAllocates) {
  static Acquisition a;
  static LisResult list;
  list = List({PoseAt(0.0, 0.0), PoseAt(1.0, 0.0)});
  const std::uint64_t before = testing::AllocationCount();
  a.Start(list, kT0);
  for (int i = 1; i < 20; ++i) {
    const std::uint64_t t = kT0 + static_cast<std::uint64_t>(i) * kFrameNs;
    a.Prepare(t, Limits(), nullptr);
    LisPrior prior;
    a.Prior(&prior);
    a.Follow(list, t);
  }
  EXPECT_EQ(testing::AllocationCount() - before, 0u);
}

}  // namespace
}  // namespace mfns::fw
