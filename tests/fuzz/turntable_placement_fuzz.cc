// libFuzzer target for the turntable placement reader (host/calib/survey/
// turntable_placement_yaml.h, `mfns-calib survey --turntable-placement`): whatever the text, it
// gives a placement or a UserError of one line naming the file (placement.yaml:LINE: field:
// why); any other exception, crash, ASan or UBSan report is a finding. A placement that parses
// is usable (finite, positive sigmas whose inverse squares are finite, a unit axis: what
// TurntablePlacement::IsValid asks, checked here without the adjustment) and its written text
// reads back as the same placement.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "host/calib/survey/turntable_placement_yaml.h"
#include "host/util/user_error.h"
#include "tests/fuzz/fuzz_text.h"

namespace {

bool Usable(double sigma) { return sigma > 0.0 && std::isfinite(sigma) && std::isnormal(sigma * sigma); }

bool Valid(const mfns::host::TurntablePlacement& t) {
  if (!t.has_centre && !t.has_centre_b && !t.has_axis) return false;
  if (t.has_centre && (!t.centre_w.allFinite() || !Usable(t.centre_sigma_m))) return false;
  if (t.has_centre_b && (!t.centre_b.allFinite() || !Usable(t.centre_b_sigma_m))) return false;
  return !t.has_axis || (t.axis_w.allFinite() && std::abs(t.axis_w.norm() - 1.0) <= 1e-6 && Usable(t.axis_sigma_rad));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mfns::host::TurntablePlacement t;
  try {
    t = mfns::host::ParseTurntablePlacementYaml(text, "placement.yaml");
  } catch (const mfns::host::UserError& e) {
    mfns::fuzz::CheckMessage(e.what(), "placement.yaml");
    return 0;
  }
  if (!Valid(t)) __builtin_trap();
  // The writer's text reads back (its 6 decimals in mm may round a tiny value or sigma away:
  // then a one-line refusal is all that may happen).
  try {
    const mfns::host::TurntablePlacement u =
        mfns::host::ParseTurntablePlacementYaml(mfns::host::FormatTurntablePlacementYaml(t), "written.yaml");
    if (u.has_centre != t.has_centre || u.has_centre_b != t.has_centre_b || u.has_axis != t.has_axis || !Valid(u))
      __builtin_trap();
  } catch (const mfns::host::UserError& e) {
    mfns::fuzz::CheckMessage(e.what(), "written.yaml");
  }
  return 0;
}
