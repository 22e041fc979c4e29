#include "firmware/modules/identify/map_repeats.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "firmware/modules/solve/synthetic_scene.h"

namespace mfns::fw {
namespace {

int Wall(int beacon) { return beacon / 16; }  // testing::CubeGridRig's walls

TEST(MapRepeatsTest, OptionsAreChecked) {
  const char* why = nullptr;
  EXPECT_TRUE(MapRepeatsOptions{}.IsValid(&why)) << why;
  MapRepeatsOptions o;
  o.neighbours = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "neighbours");
  o = MapRepeatsOptions{};
  o.tolerance_m = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_STREQ(why, "tolerance_m");
  o = MapRepeatsOptions{};
  o.facing_tolerance_rad = -1.0;
  EXPECT_FALSE(o.IsValid(&why));
  MapRepeatsResult r;
  r.repeated = 5;
  EXPECT_FALSE(FindMapRepeats(PaperRig(), o, &r));
  EXPECT_EQ(r.repeated, 0);
}

// A regular grid repeats every patch (the cube's rotations take each wall's grid onto the
// others'); the same grid jittered by a tenth of its step repeats none.
TEST(MapRepeatsTest, RegularGridRepeatsEverywhereAndJitteredNowhere) {
  std::mt19937_64 rng(1);
  MapRepeatsResult r;
  const Rig regular = testing::CubeGridRig(0.0, 0x3F, &rng);
  ASSERT_TRUE(FindMapRepeats(regular, MapRepeatsOptions{}, &r));
  EXPECT_EQ(r.beacons, 96);
  EXPECT_EQ(r.repeated, 96);
  EXPECT_GE(r.example, 0);
  EXPECT_NE(r.example_copy, r.example);
  Rig no_facing = regular;
  no_facing.has_facing = false;
  ASSERT_TRUE(FindMapRepeats(no_facing, MapRepeatsOptions{}, &r));
  EXPECT_EQ(r.repeated, 96);
  for (int seed = 1; seed <= 5; ++seed) {
    rng.seed(static_cast<std::uint64_t>(seed));
    const Rig jittered = testing::CubeGridRig(0.05, 0, &rng);
    ASSERT_TRUE(FindMapRepeats(jittered, MapRepeatsOptions{}, &r));
    EXPECT_EQ(r.repeated, 0) << "seed " << seed << ": beacon " << r.example << " onto " << r.example_copy;
  }
}

// One regular wall among jittered ones: its square grid's own symmetries repeat the patches
// that lie on it alone, and no beacon of another wall is called repeated.
TEST(MapRepeatsTest, OneRegularWallRepeatsOnlyItsOwnPatches) {
  for (int seed = 1; seed <= 3; ++seed) {
    std::mt19937_64 rng(static_cast<std::uint64_t>(seed));
    const Rig rig = testing::CubeGridRig(0.05, 1U << 2, &rng);
    MapRepeatsOptions o;
    o.neighbours = 4;  // the centre beacons' patches stay on the wall
    MapRepeatsResult r;
    ASSERT_TRUE(FindMapRepeats(rig, o, &r));
    int on_wall = 0;
    for (int m = 0; m < rig.num_beacons; ++m) {
      if (!r.repeated_beacons.Has(m)) continue;
      EXPECT_EQ(Wall(m), 2) << "seed " << seed << ": beacon " << m;
      ++on_wall;
    }
    std::printf("seed %d: %d of 16 beacons of the regular wall repeated, %d in all\n", seed, on_wall, r.repeated);
    EXPECT_GE(on_wall, 4);
  }
}

TEST(MapRepeatsTest, PaperMapDoesNotRepeat) {
  MapRepeatsResult r;
  ASSERT_TRUE(FindMapRepeats(PaperRig(), MapRepeatsOptions{}, &r));
  EXPECT_EQ(r.beacons, 10);
  EXPECT_EQ(r.repeated, 0);
}

// Two copies of a random 3-D cluster, the second moved by a known rotation and translation:
// FindMapCopies gives that motion and the beacon each lands on; facing that the motion does not
// carry over refutes the copy.
TEST(MapRepeatsTest, CopiesOfAClusterGiveTheirMotion) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  Rig rig = PaperRig();
  constexpr int kCluster = 7;
  rig.num_beacons = 2 * kCluster;
  rig.has_facing = true;
  const Eigen::Matrix3d C = EulerToMatrix(EulerAngles{DegToRad(20.0), DegToRad(-35.0), DegToRad(110.0)});
  const Eigen::Vector3d t(3.0, -1.0, 0.5);
  for (int i = 0; i < kCluster; ++i) {
    const auto a = static_cast<std::size_t>(i), b = static_cast<std::size_t>(i + kCluster);
    rig.beacons_w[a] = Eigen::Vector3d(u(rng), u(rng), u(rng));
    rig.beacons_w[b] = C * rig.beacons_w[a] + t;
    rig.beacon_normal_w[a] = Eigen::Vector3d::UnitZ();
    rig.beacon_normal_w[b] = C * Eigen::Vector3d::UnitZ();
    rig.beacon_half_angle[a] = rig.beacon_half_angle[b] = DegToRad(60.0);
  }
  const auto dist = [&rig](int i, int j) {
    return (rig.beacons_w[static_cast<std::size_t>(i)] - rig.beacons_w[static_cast<std::size_t>(j)]).norm();
  };
  std::array<int, kCluster> set{};
  for (int i = 0; i < kCluster; ++i) set[static_cast<std::size_t>(i)] = i;
  int copies = 0;
  FindMapCopies(rig, set.data(), kCluster, 0.01, dist, [&](const MapCopy& copy) {
    ++copies;
    EXPECT_LT((copy.C - C).norm(), 1e-9);
    EXPECT_LT((copy.t - t).norm(), 1e-9);
    for (int i = 0; i < kCluster; ++i) EXPECT_EQ(copy.image[static_cast<std::size_t>(i)], i + kCluster);
    return false;
  });
  EXPECT_EQ(copies, 1);  // a random cluster has no symmetry of its own
  MapRepeatsResult r;
  MapRepeatsOptions o;
  o.neighbours = kCluster - 1;
  ASSERT_TRUE(FindMapRepeats(rig, o, &r));
  EXPECT_EQ(r.repeated, 2 * kCluster);
  // The copy's LEDs face the other way: not seen the same, not repeated.
  for (int i = kCluster; i < 2 * kCluster; ++i) rig.beacon_normal_w[static_cast<std::size_t>(i)] *= -1.0;
  ASSERT_TRUE(FindMapRepeats(rig, o, &r));
  EXPECT_EQ(r.repeated, 0);
  // Unknown facing (seen from everywhere) refutes nothing.
  for (int i = kCluster; i < 2 * kCluster; ++i) rig.beacon_half_angle[static_cast<std::size_t>(i)] = kPi;
  ASSERT_TRUE(FindMapRepeats(rig, o, &r));
  EXPECT_EQ(r.repeated, 2 * kCluster);
}

TEST(MapRepeatsTest, DegenerateSetsGiveNoCopy) {
  std::mt19937_64 rng(1);
  const Rig rig = testing::CubeGridRig(0.0, 0x3F, &rng);
  const auto dist = [&rig](int i, int j) {
    return (rig.beacons_w[static_cast<std::size_t>(i)] - rig.beacons_w[static_cast<std::size_t>(j)]).norm();
  };
  int visits = 0;
  const auto count = [&](const MapCopy&) { return ++visits > 0; };
  const std::array<int, 4> line{0, 1, 2, 3};  // one grid row: collinear
  EXPECT_FALSE(FindMapCopies(rig, line.data(), 4, 0.01, dist, count));
  const std::array<int, 3> outside{0, 5, 400};
  EXPECT_FALSE(FindMapCopies(rig, outside.data(), 3, 0.01, dist, count));
  const std::array<int, 2> two{0, 5};
  EXPECT_FALSE(FindMapCopies(rig, two.data(), 2, 0.01, dist, count));
  EXPECT_EQ(visits, 0);
  const std::array<int, 3> corner{0, 1, 4};
  EXPECT_TRUE(FindMapCopies(rig, corner.data(), 3, 0.01, dist, count));
  EXPECT_EQ(visits, 1);
}

}  // namespace
}  // namespace mfns::fw
