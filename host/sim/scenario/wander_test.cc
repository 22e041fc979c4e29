#include "host/sim/scenario/wander.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "common/rotation/rotation.h"
#include "host/sim/scenario/scenario.h"
#include "host/sim/scenario/scenario_test_util.h"

namespace mfns::host {
namespace {

constexpr double kDt = 1.0 / 18.6;

StationModule WanderBox() {
  StationModule m;
  m.shape = ModuleShape::kBox;
  m.size = Eigen::Vector3d(2.2, 2.2, 5.0);
  return m;
}

// 600 frames over several seeds in both modules: never closer to a wall than the margin, and
// speed, rate and accelerations (finite differences of the poses) within their bounds.
TEST(Wander, StaysInsideTheMarginWithinItsBounds) {
  const WanderLimits l;  // 0.3 m, 0.3 m/s, 0.1 m/s^2, 0.5 rad/s, 0.5 rad/s^2
  for (const StationModule& m : {TestCylinder(), WanderBox()}) {
    double closest = 1e9, fastest = 0, quickest = 0, hardest = 0, hardest_turn = 0, travelled = 0;
    for (std::uint64_t seed = 1; seed <= 12; ++seed) {
      const std::vector<BodyPose> p = WanderPoses(m, l, 600, kDt, seed);
      ASSERT_EQ(p.size(), 600u);
      for (std::size_t i = 0; i < p.size(); ++i) {
        closest = std::min(closest, WallClearance(m, p[i].r_w_wb));
        if (i == 0) continue;
        const Eigen::Vector3d v = (p[i].r_w_wb - p[i - 1].r_w_wb) / kDt;
        const Eigen::Vector3d w = LogSO3(p[i - 1].C_w_b.transpose() * p[i].C_w_b) / kDt;  // body rate
        fastest = std::max(fastest, v.norm());
        quickest = std::max(quickest, w.norm());
        travelled += v.norm() * kDt;
        if (i < 2) continue;
        const Eigen::Vector3d v0 = (p[i - 1].r_w_wb - p[i - 2].r_w_wb) / kDt;
        const Eigen::Vector3d w0 = LogSO3(p[i - 2].C_w_b.transpose() * p[i - 1].C_w_b) / kDt;
        hardest = std::max(hardest, (v - v0).norm() / kDt);
        hardest_turn = std::max(hardest_turn, (w - w0).norm() / kDt);
      }
    }
    std::printf("wander in a %s: closest %.3f m, max speed %.3f m/s, rate %.3f rad/s, accel %.3f m/s^2, "
                "angular accel %.3f rad/s^2, mean path %.1f m per run\n",
                m.shape == ModuleShape::kBox ? "box" : "cylinder", closest, fastest, quickest, hardest, hardest_turn,
                travelled / 12);
    EXPECT_GE(closest, l.margin);
    EXPECT_LT(closest, l.margin + 0.15);  // it does go near the walls
    EXPECT_LE(fastest, l.max_speed * (1 + 1e-9));
    EXPECT_GT(fastest, 0.5 * l.max_speed);
    EXPECT_LE(quickest, l.max_rate * (1 + 1e-9));
    EXPECT_GT(quickest, 0.5 * l.max_rate);
    // Second differences average the sub-steps' accelerations (with a small rotation term for
    // the body rate): within the bounds to 1%.
    EXPECT_LE(hardest, l.max_accel * 1.01);
    EXPECT_LE(hardest_turn, l.max_angular_accel * 1.01);
    EXPECT_GT(travelled / 12, 3.0);  // it wanders (32 s at up to 0.3 m/s)
  }
}

TEST(Wander, StartsAnywhereWithAnyAttitude) {
  const WanderLimits l;
  const StationModule m = TestCylinder();
  constexpr int kSeeds = 400;
  Eigen::Vector3d mean_axis = Eigen::Vector3d::Zero();
  std::array<int, 8> octants{};
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
  for (std::uint64_t seed = 0; seed < kSeeds; ++seed) {
    const BodyPose start = WanderPoses(m, l, 1, kDt, seed)[0];
    EXPECT_GE(WallClearance(m, start.r_w_wb), l.margin);
    lo = lo.cwiseMin(start.r_w_wb);
    hi = hi.cwiseMax(start.r_w_wb);
    // Body z axis (in the world) over the sphere: every octant, no preferred direction.
    const Eigen::Vector3d z = start.C_w_b.col(2);
    mean_axis += z / kSeeds;
    ++octants[static_cast<std::size_t>((z.x() > 0) + 2 * (z.y() > 0) + 4 * (z.z() > 0))];
  }
  for (int o : octants) EXPECT_GT(o, kSeeds / 8 / 2);  // ~50 expected in each
  EXPECT_LT(mean_axis.norm(), 0.15);                    // 3/sqrt(3 * 400) = 0.087 is 3 sigma per axis
  EXPECT_GT(hi.x() - lo.x(), 0.9 * (m.length - 2 * l.margin));
  EXPECT_GT(hi.y() - lo.y(), 0.8 * (m.diameter - 2 * l.margin));
}

TEST(Wander, DeterministicPerSeed) {
  const auto a = WanderPoses(WanderBox(), WanderLimits{}, 200, kDt, 9), b = WanderPoses(WanderBox(), WanderLimits{}, 200, kDt, 9);
  const auto c = WanderPoses(WanderBox(), WanderLimits{}, 200, kDt, 10);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].r_w_wb, b[i].r_w_wb);
    EXPECT_EQ(a[i].C_w_b, b[i].C_w_b);
  }
  EXPECT_GT((a[100].r_w_wb - c[100].r_w_wb).norm(), 1e-3);
}

// In a scenario: the trajectory follows the scenario's seed and keeps the beacon map.
TEST(Wander, ScenarioSeedMovesTheTrajectoryNotAPinnedMap) {
  const std::string yaml =
      "seed: 3\nframes: 50\nmodule: {shape: box, size_mm: [2200, 2200, 5000]}\n"
      "beacons: {count: 40, seed: 8}\ntrajectory: {kind: wander, margin_mm: 400, max_speed_mm_s: 200}\n";
  const Scenario s = ParseScenarioYaml(yaml, "s.yaml", ".");
  EXPECT_EQ(s.trajectory.kind, TrajectoryKind::kWander);
  EXPECT_NEAR(s.trajectory.wander.margin, 0.4, 1e-15);
  EXPECT_NEAR(s.trajectory.wander.max_speed, 0.2, 1e-15);
  Scenario t = s;
  t.seed = 4;
  const auto fs = SimulateTrajectory(s), ft = SimulateTrajectory(t);
  ASSERT_EQ(fs.size(), 50u);
  EXPECT_GT((fs[0].pose.r_w_wb - ft[0].pose.r_w_wb).norm(), 1e-3);
  for (const FrameTruth& f : fs) EXPECT_GE(WallClearance(s.module, f.pose.r_w_wb), 0.4);
}


TEST(Wander, ErrorsNameTheField) {
  const std::string box = "module: {shape: box, size_mm: [2200, 2200, 5000]}\n";
  EXPECT_EQ(ScenarioErrorOf("trajectory: {kind: wander}\n"), "s.yaml:1: trajectory.kind: wander needs a module (module: {shape: ...})");
  EXPECT_EQ(ScenarioErrorOf(box + "trajectory: {kind: wander, max_speed_mm_s: 0}\n"),
            "s.yaml:2: trajectory.max_speed_mm_s: must be positive");
  EXPECT_EQ(ScenarioErrorOf(box + "trajectory: {kind: wander, margin_mm: -5}\n"), "s.yaml:2: trajectory.margin_mm: must not be negative");
  EXPECT_EQ(ScenarioErrorOf(box + "trajectory: {kind: wander, speed: 3}\n"), "s.yaml:2: trajectory: unknown field 'speed'");
  EXPECT_EQ(ScenarioErrorOf(box + "trajectory: {kind: wander, margin_mm: 1100}\n"),
            "s.yaml:2: trajectory: the module (2200 mm at its narrowest) has no room for 1145 mm (margin and steering band) on both sides");
}

}  // namespace
}  // namespace mfns::host
