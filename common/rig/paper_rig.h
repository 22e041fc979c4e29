// The published rig of the MFNS paper (reference/paper-tables.yaml): Table 2 intrinsics,
// Table 3 extrinsics and Table 4 beacons, with their 1-sigma. This is the one place these
// numbers live in code; config/paper-rig.yaml is generated from it (`mfns-calib paper-rig`)
// and a test keeps the two equal.
//
// Table 3's directions are not fully recoverable from the paper; per DESIGN.md its Euler angles
// are read as C_k_b (body -> camera, 2-1-3 set) and its positions as r_b_bk.
#pragma once

#include "common/rig/rig.h"

namespace mfns {

inline constexpr char kPaperRigId[] = "mfns-paper-2017";

// Cameras x, y, z (1280x1024 mono8), the 10 beacons of Table 4, sigma from Tables 2-4.
Rig PaperRig();

}  // namespace mfns
