// libFuzzer target for the scenario reader (host/sim/scenario): whatever the text, it gives a
// scenario or a UserError of one line naming the file (scenario.yaml:LINE: field: why); any other
// exception, crash, ASan or UBSan report is a finding. A scenario that parses has a valid rig
// and its counts within the documented limits. (A `rig:` path resolves in an empty directory.)
#include <cstddef>
#include <cstdint>
#include <string>

#include "common/rig/rig.h"
#include "host/sim/scenario/scenario.h"
#include "host/util/user_error.h"
#include "tests/fuzz/fuzz_text.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  mfns::host::Scenario s;
  try {
    s = mfns::host::ParseScenarioYaml(text, "scenario.yaml", "/nonexistent-fuzz-dir");
  } catch (const mfns::host::UserError& e) {
    mfns::fuzz::CheckMessage(e.what(), "scenario.yaml");
    return 0;
  }
  if (mfns::ValidateRig(s.rig) != mfns::RigStatus::kOk) __builtin_trap();
  if (s.frames < 1 || s.frames > 1'000'000) __builtin_trap();
  return 0;
}
