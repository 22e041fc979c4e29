// Rig file (YAML) reader and writer: the schema of DESIGN.md, "User-facing interfaces".
//
//   rig_id: <string>
//   cameras:
//     - name: x
//       width: 1280
//       height: 1024
//       intrinsics: [alpha_x, alpha_y, skew, u0, v0]      # px
//       distortion: [kc1, kc2, kc3, kc4, kc5]              # OpenCV k1 k2 p1 p2 k3
//       C_k_b: [9 numbers, row-major]                      # body -> camera k
//       euler_deg: [phi, theta, psi]                       # of C_k_b, 2-1-3 (for people)
//       r_b_bk_mm: [x, y, z]
//       sigma: {intrinsics: [5], distortion: [5], euler_deg: [3], r_b_bk_mm: [3]}  # optional
//   beacons_mm: [[x, y, z], ...]                           # world frame; optional
//   beacon_sigma_mm: 0.3963                                # optional (MFNS extension); or one
//                                                          # per beacons_mm entry: [0.1, 0.2, ...]
//   beacon_facing: [[nx, ny, nz, half_angle_deg], ...]    # optional, one per beacons_mm entry
//
// beacon_facing (Rig::has_facing): the unit normal of each LED's emitting side (world frame)
// and its beam half-angle, in (0, 180] deg; the list has exactly as many entries as beacons_mm,
// in its order. A normal within 1e-3 of unit length is normalised on reading, one further off
// is an error ("rig.yaml:40: beacon_facing[3]: normal length 0.5, expected 1"). Written back
// (normalised, 15 digits) whenever the rig has facing; absent means no facing data.
//
// Reading: C_k_b wins (within 1e-6 of orthonormal; the nearest exact rotation is kept, so that
// the euler_deg written from it reads back); when euler_deg is given too it must describe the
// same rotation within 1e-6 rad, and when only euler_deg is given C_k_b is computed from it. Sigma is all-or-none
// per file: cameras without a sigma block get zeros (unknown). Every error is a UserError
// whose one-line message names the file, the line and the field, e.g.
//   "rig.yaml:12: cameras[1].intrinsics: expected 5 numbers, got 4".
// Writing: numbers with 15 significant digits, so published values print as published and
// read(write(rig)) equals rig within 1e-15 relative; euler_deg on the principal branch
// |phi| <= 90 deg (common/rotation), so a camera near phi = 90 deg (the paper's camera y) gets
// the equivalent triple (180 - phi, theta + 180, psi + 180) wrapped to (-180, 180].
#pragma once

#include <filesystem>
#include <string>

#include "common/rig/rig.h"
#include "host/util/user_error.h"

namespace mfns::host {

// Parses YAML text; `source` names it in error messages (a path or "<stdin>").
Rig ParseRigYaml(const std::string& text, const std::string& source);
Rig ReadRigYaml(const std::filesystem::path& path);

std::string FormatRigYaml(const Rig& rig);
// Validates (ValidateRig) and writes atomically; throws UserError on an invalid rig.
void WriteRigYaml(const std::filesystem::path& path, const Rig& rig);

}  // namespace mfns::host
