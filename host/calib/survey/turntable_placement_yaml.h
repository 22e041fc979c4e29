// A turntable run's surveyed placement as a YAML file (issue 16): what `mfns-calib survey
// --turntable-placement FILE` reads for one recording, and what `mfns-sim render` writes into a
// turntable run (turntable-survey.yaml). Keys, each pair optional, at least one pair given:
//   centre_mm: [x, y, z]       the turntable's centre (where its axes meet), world, mm
//   centre_sigma_mm: s         its 1-sigma per coordinate, mm (> 0)
//   centre_b_mm: [x, y, z]     the same point in the body frame (the mount), mm
//   centre_b_sigma_mm: s       its 1-sigma per coordinate, mm (> 0)
//   axis: [x, y, z]            the rotation axis in the world (any length, not 0; its sign kept)
//   axis_sigma_deg: s          its 1-sigma across it, deg (> 0)
// A value without its sigma, a sigma without its value, or an unknown key (a typo) is refused.
// Units in the file: mm and deg; in TurntablePlacement (survey.h): m and rad.
#pragma once

#include <filesystem>
#include <string>

#include "host/calib/survey/survey.h"

namespace mfns::host {

// The placement in `text`; throws UserError with one line naming the source, the line and the
// field ("placement.yaml:3: centre_sigma_mm: ..."). Never trusts a count: lists must hold
// exactly three finite numbers. The result passes TurntablePlacement::IsValid (survey.h, header
// only: this reader links without the adjustment, for its fuzzer).
TurntablePlacement ParseTurntablePlacementYaml(const std::string& text, const std::string& source);
// The same from a file (at most 64 kB); a missing or unreadable file is a UserError naming it.
TurntablePlacement ReadTurntablePlacementYaml(const std::filesystem::path& path);
// The file text of a placement (the keys above for the parts it has; 6 decimals in mm, 9 in the
// axis, 7 in deg), which ParseTurntablePlacementYaml reads back.
std::string FormatTurntablePlacementYaml(const TurntablePlacement& t, const std::string& comment = "");

}  // namespace mfns::host
