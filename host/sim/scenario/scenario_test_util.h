// Test helper shared by the scenario tests (scenario_test.cc, module_test.cc, wander_test.cc).
#pragma once

#include <string>

#include "host/sim/scenario/scenario.h"
#include "host/util/user_error.h"

namespace mfns::host {

// The one-line error ParseScenarioYaml gives for `yaml` (file "s.yaml"), or "(no error)".
inline std::string ScenarioErrorOf(const std::string& yaml) {
  try {
    ParseScenarioYaml(yaml, "s.yaml", ".");
  } catch (const UserError& e) {
    return e.what();
  }
  return "(no error)";
}

// The cylindrical module: 4.2 m across, 6 m long.
inline StationModule TestCylinder() {
  StationModule m;
  m.shape = ModuleShape::kCylinder;
  m.diameter = 4.2;
  m.length = 6.0;
  return m;
}

}  // namespace mfns::host
