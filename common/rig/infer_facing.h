// Beacon facing inferred from the map's geometry, for a surveyed map without facing data.
//
// An LED on a wall shines into the module, and a module's walls bound its beacons: a beacon
// on a wall lies on the boundary of the map's convex hull. Its normal is that of the hull's
// faces through it: planes through the beacon and two of its nearest neighbours with no other
// beacon behind them (beyond side_tolerance_m). On a flat wall (many beacons on one plane
// within flat_tolerance_m) it is the wall's; elsewhere (a curved wall) the axis of the cone of
// all its faces' normals, which holds a convex wall's true normal. The cone's angle is the
// normal's tolerance. A beacon that no such plane supports (inside the hull: a partition, a
// non-convex module's inner wall), or whose faces span two walls, keeps its facing unknown:
// half-angle pi, predicted from everywhere, its absence refuting nothing (match.h).
//
// Used by the navigator (firmware/app/navd/navigator.h) when the rig has no facing data: with it,
// a beacon seen at a grazing angle is no longer predicted where its LED cannot be seen (a missing
// beacon refutes a pose, the true one included), and lost-in-space's co-visibility table prunes
// as it does with surveyed facing. No heap: usable on the flyer at start.
#pragma once

#include "common/rig/rig.h"

namespace mfns {

struct InferFacingOptions {
  int neighbours = 20;                   // nearest beacons tried for each beacon's planes (2..24)
  double half_angle_rad = 1.0471975511965976;  // beam assumed for a beacon on a wall (60 deg)
  double side_tolerance_m = 0.05;        // beacons this close to a plane lie on it (survey, wall)
  // A flat wall: beacons this close to one plane (a panel's, surveyed to a millimetre). A curved
  // wall's beacons lie within side_tolerance_m of a plane over a band of it (a 2.1 m cylinder:
  // +-12.5 deg of its circumference), within 1 cm often by chance, within 3 mm rarely.
  double flat_tolerance_m = 0.003;
  // A beacon's faces must agree within this of their mean (a curved wall), or of the wall's
  // face (the face with >= 4 beacons on it): faces across an edge to the next wall lie beyond.
  double max_face_spread_rad = 0.6;
  // Unless this share of the beacons lie on walls, the map is no module's (the paper's ten
  // beacons around a turntable: one on the hull's faces) and gets no facing.
  double min_wall_share = 0.5;

  bool IsValid(const char** why = nullptr) const;
};

struct InferFacingResult {
  int on_planes = 0;  // beacons given a normal and half_angle_rad
  int unknown = 0;    // beacons left seen from everywhere (half-angle pi)
};

// Fills rig->beacon_normal_w / beacon_half_angle / beacon_normal_tolerance for every beacon and
// sets rig->has_facing. The tolerance is the angle of the cone of the faces the normal comes
// from, plus how far a wall may bend between the beacons on a face (4 x their distance off its
// plane / their span): the hull's normal cone at the beacon, within which a convex wall's true
// normal lies. Checked on generated cylinders and boxes (jittered grids, random layouts, 24-256
// beacons: host/sim/navmatrix/navmatrix_test.cc, InferFacingOnGeneratedModules): true normals
// beyond the tolerance plus 0.1 rad 0.0-0.3 % of a box's beacons and 0-2 % of a cylinder's (it
// was up to 8 % with the 5 cm planes alone); a box's tolerances mostly under 3 deg.
// A rig that already has facing data, with fewer than 4 beacons or fewer than min_wall_share
// on walls, or invalid options: false and the rig unchanged (*result still counts the walls'
// beacons when it got that far). O(beacons * neighbours^2 * beacons), no heap (~20 ms for 256
// beacons on the host: InferFacingOnGeneratedModules infers 96 maps of 64 and 256 in 1.9 s).
bool InferFacing(const InferFacingOptions& options, Rig* rig, InferFacingResult* result = nullptr);

}  // namespace mfns
