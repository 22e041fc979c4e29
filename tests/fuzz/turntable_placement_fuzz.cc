// libFuzzer target for the turntable placement reader (host/calib/survey/
// turntable_placement_yaml.h, `mfns-calib survey --turntable-placement`): whatever the text, it
// gives a placement or a UserError of one line naming the file (placement.yaml:LINE: field:
// why); any other exception, crash, ASan or UBSan report is a finding. A placement that parses
// is usable (TurntablePlacement::IsValid, header only: finite, sigmas whose inverse squares are
// finite, a unit axis) and its written text reads back with the same parts.
#include <cstddef>
#include <cstdint>
#include <string>

#include "host/calib/survey/turntable_placement_yaml.h"
#include "host/util/user_error.h"
#include "tests/fuzz/fuzz_text.h"

namespace {

bool Valid(const mfns::host::TurntablePlacement& t) {
  return t.Any() && t.IsValid();
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
