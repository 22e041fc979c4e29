#include "firmware/modules/health/beacon_health.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <random>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/lib/testing/alloc_counter.h"
#include "firmware/modules/solve/solve.h"
#include "firmware/modules/solve/synthetic_scene.h"

namespace mfns::fw {
namespace {

using testing::Scene;
using Mat6 = Eigen::Matrix<double, 6, 6>;

constexpr double kSigmaPx = 0.1;
constexpr double kMapSigmaM = 3e-4;

// The paper's cameras inside a sphere of 60 beacons (radius 1.5-2.5 m). `believed` is the
// surveyed map (kMapSigmaM), `truth` where the beacons are: the surveyed one plus its error.
struct Station {
  Rig believed, truth;
};

Station MakeStation(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_real_distribution<double> radius(1.5, 2.5);
  Station s{PaperRig(), PaperRig()};
  s.truth.num_beacons = 60;
  for (int b = 0; b < 60; ++b)
    s.truth.beacons_w[static_cast<std::size_t>(b)] = radius(rng) * Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
  s.believed = s.truth;
  for (int b = 0; b < 60; ++b)
    s.believed.beacons_w[static_cast<std::size_t>(b)] += kMapSigmaM * Eigen::Vector3d(n(rng), n(rng), n(rng));
  s.believed.beacon_sigma = s.truth.beacon_sigma = kMapSigmaM;
  return s;
}

// A pose near the sphere's centre, in any attitude.
BodyPose RandomPose(std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  BodyPose p;
  p.C_w_b = ExpSO3(Eigen::Vector3d(u(*rng), u(*rng), u(*rng)) * 3.0);
  p.r_w_wb = 0.3 * Eigen::Vector3d(u(*rng), u(*rng), u(*rng));
  return p;
}

BeaconHealthOptions Options() {
  BeaconHealthOptions o;
  o.sigma_px = kSigmaPx;
  return o;
}

// One frame set: the truth's blobs (kSigmaPx, 2 spurious), the fix on the believed map with the
// true identities (outliers rejected as the navigator's solve does), and the health update.
// False when no fix.
struct Flight {
  Station station;
  BeaconHealth health;
  std::mt19937_64 rng;
  Scene scene;
  SolveResult solve;
  std::array<Match, limits::kMaxMatches> matches{}, used{};

  // A station of seed `seed`, the noise from rng_seed, beacon health reset.
  bool Start(std::uint64_t seed, std::uint64_t rng_seed) {
    station = MakeStation(seed);
    rng.seed(rng_seed);
    return health.Reset(station.believed, Options());
  }
  // Beacon m moved by shift_m along the wall (across the ray from the centre) after the survey.
  void Move(int m, double shift_m) {
    Eigen::Vector3d& P = station.truth.beacons_w[static_cast<std::size_t>(m)];
    P += shift_m * P.normalized().unitOrthogonal();
  }

  bool Step() {
    const BodyPose truth = RandomPose(&rng);
    testing::Observe(station.truth, truth, kSigmaPx, &rng, &scene);
    testing::AddSpurious(station.truth, 2, &rng, &scene);
    int n = 0;
    for (int i = 0; i < scene.num_blobs; ++i)
      if (const int b = scene.truth_beacon[static_cast<std::size_t>(i)]; b >= 0)
        matches[static_cast<std::size_t>(n++)] = Match{i, b, scene.blobs[static_cast<std::size_t>(i)].camera};
    SolveOptions o;
    o.sigma_px = kSigmaPx;
    o.outlier_threshold_px = std::hypot(1.0, 4.0 * 1600.0 * kMapSigmaM / 1.0);
    if (SolvePose(station.believed, scene.blobs.data(), scene.num_blobs, matches.data(), n, truth, o, &solve) !=
            SolveStatus::kOk ||
        solve.num_beacons < 4)
      return false;
    int u = 0;
    for (int i = 0; i < n; ++i)
      if (solve.inlier[static_cast<std::size_t>(i)]) used[static_cast<std::size_t>(u++)] = matches[static_cast<std::size_t>(i)];
    const double k = 1600.0 * kMapSigmaM / kSigmaPx;
    health.Update(station.believed, solve.pose, (1.0 + k * k) * solve.covariance, scene.blobs.data(),
                  scene.num_blobs, used.data(), u, 0x7U);
    return true;
  }
};

// A beacon moved 5 mm along the wall (across the ray from the centre) after the survey: flagged
// inconsistent within 50 frame sets of being in view, its suggested sigma near the move, and no
// other beacon flagged inconsistent over the flight (5 stations, 300 frame sets each).
TEST(BeaconHealthTest, AMovedBeaconIsFlaggedWithinFiftyFrameSetsInView) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    static Flight f;
    ASSERT_TRUE(f.Start(seed, 100 + seed));
    const int moved = static_cast<int>(seed * 7 % 60);
    f.Move(moved, 5e-3);
    int in_view_until_flag = -1, fixes = 0, false_flags = 0;
    for (int t = 0; t < 300; ++t) {
      if (!f.Step()) continue;
      ++fixes;
      const BeaconStats& s = f.health.stats(moved);
      if (in_view_until_flag < 0 && s.state == BeaconState::kInconsistent) in_view_until_flag = static_cast<int>(s.in_view);
      for (int b = 0; b < 60; ++b)
        false_flags += b != moved && f.health.stats(b).state == BeaconState::kInconsistent ? 1 : 0;
    }
    const BeaconStats& s = f.health.stats(moved);
    std::printf("seed %d: beacon %d flagged after %d in-view observations (%u in view, %u seen, %u used, %u rejected, "
                "RMS %.2f px), suggested sigma %.2f mm, %d fixes\n",
                static_cast<int>(seed), moved, in_view_until_flag, s.in_view, s.seen, s.used, s.rejected,
                s.RmsResidualPx(), 1e3 * f.health.SuggestedSigmaM(moved), fixes);
    EXPECT_GT(fixes, 250);
    ASSERT_GT(in_view_until_flag, 0) << "seed " << seed;
    EXPECT_LE(in_view_until_flag, 50) << "seed " << seed;
    EXPECT_EQ(s.state, BeaconState::kInconsistent);
    EXPECT_GT(f.health.SuggestedSigmaM(moved), 2e-3);
    EXPECT_LT(f.health.SuggestedSigmaM(moved), 7e-3);
    EXPECT_EQ(false_flags, 0) << "seed " << seed;
    EXPECT_EQ(f.health.NumFlagged(), 1);
  }
}

// Two beacons moved after the survey (8 and 4 mm): one turns inconsistent per update, the
// worst; the other's window starts over (and a beacon flagged just before a worse one gets its
// flag judged again, once), so both end flagged and neither flips for good (5 stations, 400
// frame sets). Not asserted: that no third beacon is flagged. On the host none is; under
// qemu-aarch64 (other rounding) a third was, in 2 of the 5 stations, for 155-169 frame sets
// (session 30): two moved beacons bend the fixes more than one does, which this rule does not cover.
TEST(BeaconHealthTest, TwoMovedBeaconsAreBothFlagged) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    static Flight f;
    ASSERT_TRUE(f.Start(seed, 200 + seed));
    const int a = static_cast<int>(seed * 7 % 60), b = static_cast<int>((seed * 7 + 13) % 60);
    f.Move(a, 8e-3);
    f.Move(b, 4e-3);
    int other_flags = 0;
    for (int t = 0; t < 400; ++t) {
      if (!f.Step()) continue;
      for (int m = 0; m < 60; ++m)
        other_flags += m != a && m != b && f.health.stats(m).state == BeaconState::kInconsistent ? 1 : 0;
    }
    std::printf("seed %d: beacons %d (8 mm) and %d (4 mm): states %s / %s, flags %u / %u; another beacon "
                "inconsistent in %d beacon-frame sets\n",
                static_cast<int>(seed), a, b, ToString(f.health.stats(a).state), ToString(f.health.stats(b).state),
                f.health.stats(a).flags, f.health.stats(b).flags, other_flags);
    EXPECT_EQ(f.health.stats(a).state, BeaconState::kInconsistent) << seed;
    EXPECT_EQ(f.health.stats(b).state, BeaconState::kInconsistent) << seed;
    EXPECT_LE(f.health.stats(a).flags + f.health.stats(b).flags, 4u) << seed;
  }
}

// A dead beacon (no blob where it should be) is reported missing, and clears once lit again.
TEST(BeaconHealthTest, ADeadBeaconIsMissingUntilItIsLitAgain) {
  static Flight f;
  f.station = MakeStation(11);
  f.rng.seed(12);
  ASSERT_TRUE(f.health.Reset(f.station.believed, Options()));
  const int dead = 17;
  const Eigen::Vector3d lit = f.station.truth.beacons_w[dead];
  f.station.truth.beacons_w[dead] = Eigen::Vector3d(100.0, 0.0, 0.0);  // out of every view
  for (int t = 0; t < 300; ++t) f.Step();
  EXPECT_EQ(f.health.stats(dead).state, BeaconState::kMissing);
  EXPECT_GE(f.health.stats(dead).in_view, static_cast<std::uint32_t>(Options().min_observations));  // judged
  EXPECT_EQ(f.health.stats(dead).seen, 0u);
  EXPECT_EQ(f.health.NumFlagged(), 1);
  f.station.truth.beacons_w[dead] = lit;
  for (int t = 0; t < 300; ++t) f.Step();
  EXPECT_EQ(f.health.stats(dead).state, BeaconState::kOk);
  EXPECT_EQ(f.health.stats(dead).flags, 1u);
  EXPECT_GT(f.health.stats(dead).used, 10u);
  EXPECT_EQ(f.health.NumFlagged(), 0);
}

// The counters add up, residuals of a consistent map are at the noise, and Update allocates nothing.
TEST(BeaconHealthTest, CountersAddUpWithoutAllocating) {
  static Flight f;
  f.station = MakeStation(21);
  f.rng.seed(22);
  ASSERT_TRUE(f.health.Reset(f.station.believed, Options()));
  const std::uint64_t before = testing::AllocationCount();
  for (int t = 0; t < 200; ++t) f.Step();
  EXPECT_EQ(testing::AllocationCount() - before, 0u);
  std::uint32_t in_view = 0, judged = 0;
  for (int b = 0; b < 60; ++b) {
    const BeaconStats& s = f.health.stats(b);
    EXPECT_EQ(s.seen, s.used + s.rejected) << b;
    EXPECT_LE(s.seen, s.in_view) << b;
    EXPECT_EQ(s.state, BeaconState::kOk) << b;
    if (s.seen > 0) {
      EXPECT_LT(s.RmsResidualPx(), 1.0) << b;  // 0.1 px noise, 0.3 mm map at 2 m
    }
    in_view += s.in_view;
    judged += s.judged ? 1 : 0;
  }
  EXPECT_GT(in_view, 1000u);
  EXPECT_GT(judged, 50u);
}

TEST(BeaconHealthTest, BadOptionsAndRigsAreRefused) {
  BeaconHealth h;
  const Station s = MakeStation(1);
  const char* why = nullptr;
  BeaconHealthOptions o = Options();
  o.min_observations = limits::kBeaconHealthWindow + 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "min_observations");
  EXPECT_FALSE(h.Reset(s.believed, o));
  o = Options();
  o.clear_mean_z2 = o.flag_mean_z2;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "clear_mean_z2");
  Rig empty = s.believed;
  empty.num_beacons = 0;
  EXPECT_FALSE(h.Reset(empty, Options()));
  ASSERT_TRUE(h.Reset(s.believed, Options()));
  // Matches naming blobs or beacons out of range are ignored, not trusted.
  std::array<BlobObs, 1> blobs{};
  const Match bad[] = {{5, 3, 0}, {0, 999, 0}, {0, 3, 9}};
  EXPECT_EQ(h.Update(s.believed, BodyPose{}, Mat6::Identity() * 1e-6, blobs.data(), 1, bad, 3, 0x7U), 0);
  EXPECT_EQ(h.Update(s.believed, BodyPose{}, Mat6::Constant(NAN), blobs.data(), 1, bad, 3, 0x7U), 0);
}

}  // namespace
}  // namespace mfns::fw
