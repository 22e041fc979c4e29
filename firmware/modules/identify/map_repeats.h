// Copies within the beacon map: rigid motions that take a set of beacons onto other beacons.
//
// A regular layout (a grid without jitter, a symmetric module) repeats its views exactly: the
// blobs of a view fit the pose on its own beacons and the moved pose on the copy equally well,
// and nothing in one frame set tells them apart. Two users of the same search:
// - lost-in-space refuses to confirm a pose whose beacons have a copy from which the moved pose
//   explains the blobs as well (LostInSpace::RepeatedElsewhere, lost_in_space.h), and the
//   tracker then reports the reason (TrackReason::kRepeatedView);
// - at start, FindMapRepeats tells the user which beacons lie in a patch the map repeats
//   (mfns-navd and `mfns-calib blob` warn; docs/navd.md "A map that repeats itself").
// No heap, bounded loops: usable on the flyer at start and in a frame set's search.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "common/limits.h"
#include "common/rig/beacon_set.h"
#include "common/rig/rig.h"
#include "firmware/modules/identify/p3p.h"

namespace mfns::fw {

// The most beacons of a set FindMapCopies moves (the rest are ignored).
inline constexpr int kMaxCopySet = 64;

// A copy: the motion p -> C p + t, and for each beacon of the set (in its order) the beacon it
// lands on.
struct MapCopy {
  Eigen::Matrix3d C = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  std::array<short, kMaxCopySet> image{};
};

// The best-spread triangle of beacons set[0..n) (n >= 3, valid indices): (a, b) the farthest
// pair, t the beacon farthest from their line. False when t lies within 4 tol_m of that line
// (collinear beacons: no frame for a copy's motion).
template <class Dist>
bool SpreadTriangle(const Rig& rig, const int* set, int n, double tol_m, Dist&& dist, int* a, int* b, int* t) {
  const auto P = [&rig](int m) -> const Eigen::Vector3d& { return rig.beacons_w[static_cast<std::size_t>(m)]; };
  *a = set[0], *b = set[1], *t = set[2];
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (dist(set[i], set[j]) > dist(*a, *b)) *a = set[i], *b = set[j];
  double best_area = -1.0;
  for (int i = 0; i < n; ++i) {
    const double area = (P(*b) - P(*a)).cross(P(set[i]) - P(*a)).norm();
    if (set[i] != *a && set[i] != *b && area > best_area) best_area = area, *t = set[i];
  }
  return best_area > 4.0 * tol_m * dist(*a, *b);
}

// Calls visit(const MapCopy&) for each rigid motion, other than the identity, that takes every
// beacon of set[0..n) within tol_m of a beacon of the map (n clamped to kMaxCopySet; a beacon
// index outside the map makes it return false). The motions come from the set's best-spread
// triangle (its farthest pair, then the beacon farthest from their line) and each congruent
// beacon triangle within tol_m: O(map beacons^2) pairs, then thirds. dist(i, j) is the distance
// of beacons i and j in metres (a table where the caller has one). Stops at the first visit
// returning true and returns true; false when none did, the set has fewer than 3 beacons, or
// they are collinear within tol_m.
template <class Dist, class Visit>
bool FindMapCopies(const Rig& rig, const int* set, int n, double tol_m, Dist&& dist, Visit&& visit) {
  n = n > kMaxCopySet ? kMaxCopySet : n;
  if (n < 3 || !(tol_m > 0.0)) return false;
  for (int i = 0; i < n; ++i)
    if (set[i] < 0 || set[i] >= rig.num_beacons) return false;
  const auto P = [&rig](int m) -> const Eigen::Vector3d& { return rig.beacons_w[static_cast<std::size_t>(m)]; };
  int a = 0, b = 0, t = 0;
  if (!SpreadTriangle(rig, set, n, tol_m, dist, &a, &b, &t)) return false;
  const std::array<Eigen::Vector3d, 3> abt{P(a), P(b), P(t)};
  const double d_ab = dist(a, b), d_at = dist(a, t), d_bt = dist(b, t), tol2 = tol_m * tol_m;
  const int nb = rig.num_beacons;
  MapCopy copy;
  for (int i = 0; i < nb; ++i)
    for (int j = 0; j < nb; ++j) {
      if (j == i || std::abs(dist(i, j) - d_ab) > tol_m) continue;
      for (int k = 0; k < nb; ++k) {
        if (k == i || k == j || (i == a && j == b && k == t)) continue;
        if (std::abs(dist(i, k) - d_at) > tol_m || std::abs(dist(j, k) - d_bt) > tol_m) continue;
        BodyPose motion;  // takes (a, b, t) onto (i, j, k)
        if (!TriangleOrientation(abt, {P(i), P(j), P(k)}, &motion)) continue;
        bool all = true;
        for (int s = 0; s < n && all; ++s) {
          const Eigen::Vector3d q = motion.C_w_b * P(set[s]) + motion.r_w_wb;
          all = false;
          for (int m = 0; m < nb && !all; ++m)
            if ((P(m) - q).squaredNorm() <= tol2) {
              all = true;
              copy.image[static_cast<std::size_t>(s)] = static_cast<short>(m);
            }
        }
        bool moved = false;  // (a near-duplicate beacon gives the identity again)
        for (int s = 0; s < n && !moved; ++s) moved = copy.image[static_cast<std::size_t>(s)] != set[s];
        if (!all || !moved) continue;
        copy.C = motion.C_w_b;
        copy.t = motion.r_w_wb;
        if (visit(static_cast<const MapCopy&>(copy))) return true;
      }
    }
  return false;
}

struct MapRepeatsOptions {
  // A beacon's patch: it and this many nearest beacons (2..24), more while they lie on one line
  // (a dense row: no frame for a copy), up to 24.
  int neighbours = 6;
  double tolerance_m = 0.01;   // moved beacons this close to a beacon coincide (LisOptions::repeat_tolerance_m)
  // With facing data: a copy also turns each beacon's normal to within this of its image's
  // (a copy whose LEDs face elsewhere is not seen the same way).
  double facing_tolerance_rad = 0.35;

  bool IsValid(const char** why = nullptr) const;
};

struct MapRepeatsResult {
  int beacons = 0;       // beacons checked (the map's)
  int repeated = 0;      // of them, those whose patch has a copy (a collinear patch has none)
  BeaconSet repeated_beacons;
  int example = -1;      // a repeated beacon, and the beacon its patch's copy puts it on
  int example_copy = -1;
  double tolerance_m = 0.0;  // the options' (for the report)
};

// Which beacons lie in a patch (the beacon and its nearest: options.neighbours) that a rigid
// motion other than the identity takes onto other beacons within tolerance_m (facing too, when
// the rig has it). A camera that sees such a patch sees its copy the same way: lost-in-space
// cannot fix there (RepeatedElsewhere) until the view holds beacons the copy does not repeat.
// A map with none repeated: result->repeated 0. False (result zeroed) on invalid options or a
// rig without 3 beacons. O(beacons^3) distance tests at most (~50 ms for 256 beacons on the
// host), no heap.
bool FindMapRepeats(const Rig& rig, const MapRepeatsOptions& options, MapRepeatsResult* result);

// The user's one-line warning for a result with repeated beacons (no newline; mfns-navd and
// mfns-calib blob print it), truncated to fit out[0..size). False when nothing repeats (out "").
bool DescribeMapRepeats(const MapRepeatsResult& result, char* out, std::size_t size);

}  // namespace mfns::fw
