#include "host/sim/scenario/module.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "common/rig/infer_facing.h"
#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/sim/scenario/scenario.h"
#include "host/sim/scenario/scenario_test_util.h"

namespace mfns::host {
namespace {

StationModule ModuleBox() {
  StationModule m;
  m.shape = ModuleShape::kBox;
  m.size = Eigen::Vector3d(5.0, 2.2, 2.2);
  return m;
}

BeaconLayout Layout(BeaconLayoutKind kind, int count, double jitter, bool end_caps) {
  BeaconLayout b;
  b.present = true;
  b.layout = kind;
  b.count = count;
  b.jitter = jitter;
  b.end_caps = end_caps;
  return b;
}

// The wall a point lies on, worked out from the shape alone (not from WallConstraints), with
// its distance to that wall and the wall's inward normal. on_end: an x = +-end wall.
struct OnWall {
  double distance = 1e9;
  Eigen::Vector3d inward = Eigen::Vector3d::Zero();
  bool on_end = false;
};

OnWall NearestWall(const StationModule& m, const Eigen::Vector3d& p) {
  OnWall best;
  const auto consider = [&](double distance, const Eigen::Vector3d& inward, bool inside, bool on_end) {
    if (inside && distance < best.distance) best = {distance, inward, on_end};
  };
  if (m.shape == ModuleShape::kCylinder) {
    const double rho = std::hypot(p.y(), p.z()), R = 0.5 * m.diameter, h = 0.5 * m.length;
    consider(std::abs(rho - R), -Eigen::Vector3d(0, p.y(), p.z()) / rho, std::abs(p.x()) <= h + 1e-12, false);
    for (const double s : {1.0, -1.0})
      consider(std::abs(p.x() - s * h), Eigen::Vector3d(-s, 0, 0), rho <= R + 1e-12, true);
  } else {
    const Eigen::Vector3d h = 0.5 * m.size;
    const bool inside = (p.cwiseAbs() - h).maxCoeff() <= 1e-12;
    for (int i = 0; i < 3; ++i)
      for (const double s : {1.0, -1.0}) consider(std::abs(p[i] - s * h[i]), -s * Eigen::Vector3d::Unit(i), inside, i == 0);
  }
  return best;
}

TEST(ModuleBeacons, LieOnTheWallsFacingInwardWithTheExactCount) {
  for (const StationModule& m : {TestCylinder(), ModuleBox()})
    for (const BeaconLayoutKind kind : {BeaconLayoutKind::kJitteredGrid, BeaconLayoutKind::kRandom})
      for (const bool end_caps : {true, false})
        for (const int count : {10, 37, 128, 256}) {
          const auto beacons = GenerateWallBeacons(m, Layout(kind, count, 0.3, end_caps), 7);
          ASSERT_EQ(static_cast<int>(beacons.size()), count);
          int on_ends = 0;
          for (const WallBeacon& b : beacons) {
            const OnWall w = NearestWall(m, b.p_w);
            EXPECT_LT(w.distance, 1e-9) << b.p_w.transpose();
            EXPECT_NEAR(b.normal_w.norm(), 1.0, 1e-12);
            EXPECT_LT((b.normal_w - w.inward).norm(), 1e-9) << b.p_w.transpose();
            EXPECT_NEAR(WallClearance(m, b.p_w), 0.0, 1e-9);
            on_ends += w.on_end;
          }
          if (end_caps) {
            EXPECT_GT(on_ends, 0);
          } else {
            EXPECT_EQ(on_ends, 0);
          }
        }
}

double NearestNeighbour(const std::vector<WallBeacon>& b, std::size_t i) {
  double d = 1e9;
  for (std::size_t j = 0; j < b.size(); ++j)
    if (j != i) d = std::min(d, (b[i].p_w - b[j].p_w).norm());
  return d;
}

TEST(ModuleBeacons, JitterIsBoundedAndTheGridSpread) {
  for (const StationModule& m : {TestCylinder(), ModuleBox()}) {
    const int n = 128;
    const auto grid = GenerateWallBeacons(m, Layout(BeaconLayoutKind::kJitteredGrid, n, 0.0, true), 3);
    const auto jittered = GenerateWallBeacons(m, Layout(BeaconLayoutKind::kJitteredGrid, n, 0.3, true), 3);
    ASSERT_EQ(grid.size(), jittered.size());
    double area = 0.0;
    if (m.shape == ModuleShape::kCylinder) {
      area = kPi * m.diameter * m.length + 2.0 * kPi * 0.25 * m.diameter * m.diameter;
    } else {
      area = 2.0 * (m.size.x() * m.size.y() + m.size.y() * m.size.z() + m.size.z() * m.size.x());
    }
    const double spacing = std::sqrt(area / n);
    double moved = 0.0;
    for (std::size_t i = 0; i < grid.size(); ++i) {
      const double offset = (jittered[i].p_w - grid[i].p_w).norm();
      EXPECT_LE(offset, 0.3 * jittered[i].cell_m.norm() + 1e-12) << i;
      EXPECT_LT(jittered[i].cell_m.maxCoeff(), 2.5 * spacing);  // cells about square, about the spacing
      moved = std::max(moved, offset);
      // A regular grid: no two beacons closer than 40% of the mean spacing.
      EXPECT_GT(NearestNeighbour(grid, i), 0.4 * spacing) << i;
    }
    EXPECT_GT(moved, 0.05 * spacing);  // the jitter does move them
  }
}

TEST(ModuleBeacons, DeterministicPerSeedAndDifferentAcrossSeeds) {
  for (const BeaconLayoutKind kind : {BeaconLayoutKind::kJitteredGrid, BeaconLayoutKind::kRandom}) {
    const BeaconLayout layout = Layout(kind, 64, 0.25, true);
    const auto a = GenerateWallBeacons(TestCylinder(), layout, 11), b = GenerateWallBeacons(TestCylinder(), layout, 11);
    const auto c = GenerateWallBeacons(TestCylinder(), layout, 12);
    int differ = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].p_w, b[i].p_w);
      differ += (a[i].p_w - c[i].p_w).norm() > 1e-3;
    }
    EXPECT_GT(differ, 60);
  }
}

// InferFacing (common/rig/infer_facing.h) on the simulator's modules, maps and layouts, against
// the walls' true normals: a normal off by more than its tolerance plus the matcher's beam margin
// (0.1 rad) makes the LED "surely seen" where it is not, and every pose near there, the true one
// included, refuted (seen in session 32: a cylinder's rim beacon 60 deg off with 22 deg of
// tolerance lost 66 frame sets with 44-54 beacons in view).
struct FacingScore {
  int beacons = 0, unknown = 0, beyond = 0, flipped = 0;
  double tolerance_sum = 0.0;
};

FacingScore InferredAgainstTruth(const StationModule& module, const BeaconLayout& layout, std::uint64_t seed) {
  const std::vector<WallBeacon> truth = GenerateWallBeacons(module, layout, seed);
  Rig rig = PaperRig();
  rig.num_beacons = static_cast<int>(truth.size());
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> survey(0.0, 0.0005);  // 0.5 mm per coordinate
  for (std::size_t i = 0; i < truth.size(); ++i)
    rig.beacons_w[i] = truth[i].p_w + Eigen::Vector3d(survey(rng), survey(rng), survey(rng));
  FacingScore s;
  if (!InferFacing(InferFacingOptions{}, &rig)) return s;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    ++s.beacons;
    if (rig.beacon_half_angle[i] >= kPi) {
      ++s.unknown;
      continue;
    }
    const double off = std::acos(std::clamp(rig.beacon_normal_w[i].dot(truth[i].normal_w), -1.0, 1.0));
    s.beyond += off > rig.beacon_normal_tolerance[i] + 0.1;
    s.flipped += off > kPi / 2;
    s.tolerance_sum += rig.beacon_normal_tolerance[i];
  }
  return s;
}

TEST(InferFacingOnGeneratedModules, TrueNormalsLieWithinTheTolerance) {
  StationModule narrow = TestCylinder();
  narrow.diameter = 3.0;
  narrow.length = 9.0;
  StationModule cube = ModuleBox();
  cube.size = Eigen::Vector3d(3.0, 3.0, 3.0);
  const struct {
    const char* name;
    StationModule module;
    double max_beyond;  // share of the beacons given a normal
  } modules[] = {{"cylinder 4.2 x 6 m", TestCylinder(), 0.01}, {"cylinder 3 x 9 m", narrow, 0.03},
                 {"box 5 x 2.2 x 2.2 m", ModuleBox(), 0.005}, {"box 3 m", cube, 0.005}};
  const struct {
    const char* name;
    BeaconLayoutKind kind;
    double jitter;
  } layouts[] = {{"grid, jitter 0.25", BeaconLayoutKind::kJitteredGrid, 0.25},
                 {"grid, jitter 0.5", BeaconLayoutKind::kJitteredGrid, 0.5},
                 {"random", BeaconLayoutKind::kRandom, 0.0}};
  for (const auto& mod : modules)
    for (const auto& lay : layouts) {
      FacingScore all;
      for (const int count : {64, 256})
        for (std::uint64_t seed = 1; seed <= 4; ++seed) {
          const FacingScore s = InferredAgainstTruth(mod.module, Layout(lay.kind, count, lay.jitter, true), seed);
          all.beacons += s.beacons;
          all.unknown += s.unknown;
          all.beyond += s.beyond;
          all.flipped += s.flipped;
          all.tolerance_sum += s.tolerance_sum;
        }
      const int given = all.beacons - all.unknown;
      SCOPED_TRACE(std::string(mod.name) + ", " + lay.name);
      std::printf("%s, %s: %d beacons, %d unknown, %d beyond the tolerance, mean tolerance %.1f deg\n", mod.name,
                  lay.name, all.beacons, all.unknown, all.beyond, given > 0 ? RadToDeg(all.tolerance_sum / given) : 0.0);
      ASSERT_EQ(all.beacons, 8 * (64 + 256) / 2);  // every map was a module's walls
      EXPECT_EQ(all.flipped, 0);                 // never the wrong side of a wall
      EXPECT_LE(all.beyond, mod.max_beyond * given);
      // Most beacons keep a beam: measured 3-23 % unknown (edges, sparse curved walls).
      EXPECT_LE(all.unknown, 0.3 * all.beacons);
      // A flat wall's beacons keep a tolerance that still refutes (measured 3-6 deg on average).
      if (mod.module.shape == ModuleShape::kBox) {
        EXPECT_LE(all.tolerance_sum / given, DegToRad(8.0));
      }
    }
}

TEST(ModuleBeacons, UniformInsideKeepsTheMargin) {
  std::mt19937_64 rng(5);
  for (const StationModule& m : {TestCylinder(), ModuleBox()}) {
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
    for (int i = 0; i < 4000; ++i) {
      const Eigen::Vector3d p = UniformInside(m, 0.3, &rng);
      EXPECT_GE(WallClearance(m, p), 0.3 - 1e-12);
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    // ...and reaches it: the drawn extent covers at least 95% of the allowed one on each axis.
    const Eigen::Vector3d allowed =
        m.shape == ModuleShape::kBox ? Eigen::Vector3d(m.size.array() - 0.6)
                                     : Eigen::Vector3d(m.length - 0.6, m.diameter - 0.6, m.diameter - 0.6);
    for (int a = 0; a < 3; ++a) EXPECT_GT(hi[a] - lo[a], 0.95 * allowed[a]) << a;
  }
}

// Scenario YAML: the generated map, its seed and its facing data.
constexpr char kStation[] = R"(name: s
seed: 4
module: {shape: cylinder, diameter_mm: 4200, length_mm: 6000}
beacons: {layout: jittered-grid, count: 40, jitter: 0.2, half_angle_deg: 60}
)";

TEST(ModuleScenario, GeneratedMapFacesInwardAndFollowsItsSeed) {
  const Scenario s = ParseScenarioYaml(kStation, "s.yaml", ".");
  EXPECT_EQ(ValidateRig(s.rig), RigStatus::kOk);
  ASSERT_EQ(s.rig.num_beacons, 40);
  ASSERT_TRUE(s.rig.has_facing);
  EXPECT_EQ(s.map_seed, 4u);  // no beacons.seed: the scenario's
  for (int i = 0; i < 40; ++i) {
    EXPECT_NEAR(s.rig.beacon_half_angle[static_cast<std::size_t>(i)], DegToRad(60.0), 1e-15);
    // Inward: the module's centre is in front of every beacon.
    EXPECT_GT(s.rig.beacon_normal_w[static_cast<std::size_t>(i)].dot(-s.rig.beacons_w[static_cast<std::size_t>(i)]), 0.0);
  }
  EXPECT_TRUE(BelievedRig(s).has_facing);
  EXPECT_TRUE(TruthMapRig(s).has_facing);

  std::string yaml = kStation;
  const Scenario other_seed = ParseScenarioYaml(yaml.replace(yaml.find("seed: 4"), 7, "seed: 5"), "s.yaml", ".");
  EXPECT_NE(other_seed.rig.beacons_w[3], s.rig.beacons_w[3]);
  const std::string pinned = std::string(kStation).replace(std::string(kStation).find("jitter:"), 0, "seed: 4, ");
  const Scenario a = ParseScenarioYaml(pinned, "s.yaml", ".");
  std::string pinned5 = pinned;
  const Scenario b = ParseScenarioYaml(pinned5.replace(pinned5.find("seed: 4\n"), 7, "seed: 5"), "s.yaml", ".");
  EXPECT_EQ(b.map_seed, 4u);  // beacons.seed wins over the scenario's
  EXPECT_EQ(a.rig.beacons_w[3], b.rig.beacons_w[3]);
  EXPECT_EQ(a.rig.beacons_w[3], s.rig.beacons_w[3]);
}

TEST(ModuleScenario, FacingFalseKeepsTheBeamsOutOfTheMapsOnly) {
  std::string yaml = kStation;
  yaml.replace(yaml.find("half_angle_deg"), 0, "facing: false, ");
  const Scenario s = ParseScenarioYaml(yaml, "s.yaml", ".");
  EXPECT_TRUE(s.rig.has_facing);  // the LEDs still have beams: the truth renders with them
  EXPECT_FALSE(s.map_facing);
  EXPECT_FALSE(BelievedRig(s).has_facing);
  EXPECT_FALSE(TruthMapRig(s).has_facing);
  EXPECT_EQ(TruthMapRig(s).beacons_w[7], s.rig.beacons_w[7]);
}


// Explicit maps keep working, and may carry facing as the rig file does.
TEST(ModuleScenario, ExplicitBeaconsWithFacing) {
  const std::string yaml =
      "beacons_mm: [[1000, 0, 0], [0, 1000, 0], [0, 0, 1000]]\n"
      "beacon_facing: [[-1, 0, 0, 60], [0, -1, 0, 90], [0, 0, -1.0005, 30]]\n";
  const Scenario s = ParseScenarioYaml(yaml, "s.yaml", ".");
  ASSERT_EQ(s.rig.num_beacons, 3);
  ASSERT_TRUE(s.rig.has_facing);
  EXPECT_EQ(ValidateRig(s.rig), RigStatus::kOk);
  EXPECT_NEAR(s.rig.beacon_normal_w[2].norm(), 1.0, 1e-15);
  EXPECT_NEAR(s.rig.beacon_half_angle[1], DegToRad(90.0), 1e-15);
  EXPECT_TRUE(BeaconFaces(s.rig, 0, Eigen::Vector3d::Zero()));
  EXPECT_FALSE(BeaconFaces(s.rig, 0, Eigen::Vector3d(2, 0, 0)));
  EXPECT_FALSE(ParseScenarioYaml("beacons_mm: [[1000, 0, 0]]\n", "s.yaml", ".").rig.has_facing);
}

TEST(ModuleScenario, ErrorsNameFileLineAndField) {
  const std::string cyl = "module: {shape: cylinder, diameter_mm: 4200, length_mm: 6000}\n";
  EXPECT_EQ(ScenarioErrorOf("module: {shape: sphere}\n"), "s.yaml:1: module.shape: expected cylinder or box, got 'sphere'");
  EXPECT_EQ(ScenarioErrorOf("module: {shape: box}\n"), "s.yaml:1: module: missing field 'size_mm'");
  EXPECT_EQ(ScenarioErrorOf("module: {shape: box, size_mm: [1, 2]}\n"), "s.yaml:1: module.size_mm: expected 3 numbers, got 2");
  EXPECT_EQ(ScenarioErrorOf("module: {shape: box, size_mm: [100, 2000, 2000]}\n"),
            "s.yaml:1: module.size_mm: every side must be 500..200000");
  EXPECT_EQ(ScenarioErrorOf("module: {shape: cylinder, diameter_mm: -1, length_mm: 6000}\n"),
            "s.yaml:1: module.diameter_mm: must be 500..50000");
  EXPECT_EQ(ScenarioErrorOf("module: {shape: cylinder, diameter: 4200}\n"), "s.yaml:1: module: unknown field 'diameter'");
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons: {count: 9}\n"),
            "s.yaml:2: beacons.count: must be 10.." + std::to_string(limits::kMaxBeacons));
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons:\n  count: " + std::to_string(limits::kMaxBeacons + 1) + "\n"),
            "s.yaml:3: beacons.count: must be 10.." + std::to_string(limits::kMaxBeacons));
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons: {layout: spiral, count: 20}\n"),
            "s.yaml:2: beacons.layout: expected jittered-grid or random, got 'spiral'");
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons: {count: 20, jitter: 0.7}\n"), "s.yaml:2: beacons.jitter: must be 0..0.5 (a fraction of the cell)");
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons: {count: 20, half_angle_deg: 0}\n"), "s.yaml:2: beacons.half_angle_deg: must be in (0, 180]");
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons: {count: 20, seed: -3}\n"), "s.yaml:2: beacons.seed: expected a non-negative integer");
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons: {count: 20, facing: maybe}\n"), "s.yaml:2: beacons.facing: expected true or false");
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons: {count: 20}\nbeacons_mm: [[0, 0, 0]]\n"),
            "s.yaml:2: beacons: give beacons (generated) or beacons_mm, not both");
  EXPECT_EQ(ScenarioErrorOf("beacons: {count: 20}\n"), "s.yaml:1: beacons: generated beacons need a module");
  EXPECT_EQ(ScenarioErrorOf(cyl + "beacons: {count: 20}\nbeacon_facing: []\n"),
            "s.yaml:3: beacon_facing: generated beacons take their facing from beacons.half_angle_deg");
  EXPECT_EQ(ScenarioErrorOf("beacons_mm: [[1000, 0, 0]]\nbeacon_facing: [[1, 0, 0, 60], [1, 0, 0, 60]]\n"),
            "s.yaml:2: beacon_facing: expected 1 entries (one per beacon), got 2");
  EXPECT_EQ(ScenarioErrorOf("beacons_mm: [[1000, 0, 0]]\nbeacon_facing: [[1, 0, 0, 200]]\n"),
            "s.yaml:2: beacon_facing[0]: half-angle must be in (0, 180] deg");
}

}  // namespace
}  // namespace mfns::host
