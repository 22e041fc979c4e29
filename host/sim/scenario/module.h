// Station modules for the simulator: the walls LED beacons sit on and the volume a free-flyer
// moves in (acquisition from no prior anywhere in the station, DESIGN.md round 2).
//
// World frame: the module is centred at the origin. A cylinder's axis is world x (its end caps
// are the walls at x = +-length/2); a box has its edges along the world axes (its "end caps"
// are the walls at x = +-size.x/2). Units: m and rad.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <random>
#include <vector>

namespace mfns::host {

enum class ModuleShape { kNone, kCylinder, kBox };

struct StationModule {
  ModuleShape shape = ModuleShape::kNone;
  double diameter = 0.0;                           // cylinder (m)
  double length = 0.0;                             // cylinder, along world x (m)
  Eigen::Vector3d size = Eigen::Vector3d::Zero();  // box extents along x, y, z (m)
};

// One wall as seen from a point inside: the outward unit normal of the wall at the point's
// nearest wall point, and the clearance (distance to the wall, positive inside, m).
struct WallConstraint {
  Eigen::Vector3d n_out = Eigen::Vector3d::UnitX();
  double clearance = 0.0;
};

// The module's walls seen from p_w: 6 for a box (its faces), 3 for a cylinder (the curved
// wall, radial normal, any radial direction on the axis; the two end caps). Because the module
// is convex, p_w is inside the module shrunk by m exactly when every clearance is >= m.
// Returns how many entries of *out are set.
int WallConstraints(const StationModule& module, const Eigen::Vector3d& p_w, std::array<WallConstraint, 6>* out);

// The smallest clearance of WallConstraints (m; negative outside). No module: +infinity.
double WallClearance(const StationModule& module, const Eigen::Vector3d& p_w);

// A point drawn uniformly inside the module shrunk by margin (m) on every side; needs a module
// with room (every inner extent > 2 margin).
Eigen::Vector3d UniformInside(const StationModule& module, double margin, std::mt19937_64* rng);

enum class BeaconLayoutKind { kJitteredGrid, kRandom };

// How beacons are generated on the module's walls (scenario YAML `beacons:`).
struct BeaconLayout {
  bool present = false;  // false: beacons come from beacons_mm or the rig
  BeaconLayoutKind layout = BeaconLayoutKind::kJitteredGrid;
  int count = 0;
  bool seed_given = false;  // map seed: `beacons.seed`, else the scenario's seed
  std::uint64_t seed = 0;
  // Jittered grid: each beacon moves from its cell's centre by up to jitter x the cell's size
  // along each of the wall's two axes, uniformly (0 = a regular grid, 0.5 = anywhere in its
  // cell).
  double jitter = 0.25;
  bool end_caps = true;                              // beacons on the x = +-end walls too
  double half_angle = 60.0 * 3.14159265358979323846 / 180.0;  // beam half-angle (rad)
  bool facing = true;  // the navigator's maps (rig.yaml, believed-rig.yaml) carry the facing
};

struct WallBeacon {
  Eigen::Vector3d p_w = Eigen::Vector3d::Zero();       // on a wall (m)
  Eigen::Vector3d normal_w = Eigen::Vector3d::UnitX();  // unit, inward (the wall's normal)
  // Jittered grid: the cell's size along the wall's two axes (m; on an end disc radial and
  // along the arc at the cell's outer radius). The beacon lies within jitter * |cell_m| of its
  // cell's centre (the point the same seed puts there with jitter 0). Random layout: zero.
  Eigen::Vector2d cell_m = Eigen::Vector2d::Zero();
};

// `layout.count` beacons on the walls (end caps per layout.end_caps), deterministic for `seed`.
// Jittered grid: the count is split between the walls by area (largest remainder), each wall
// gets a grid of about square cells (rows of equal counts; end discs: rings of equal radial
// step, counts by circumference). Random: each beacon on a wall drawn by area, uniform on it.
std::vector<WallBeacon> GenerateWallBeacons(const StationModule& module, const BeaconLayout& layout,
                                            std::uint64_t seed);

}  // namespace mfns::host
