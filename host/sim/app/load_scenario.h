// The scenario of `mfns-sim render`, `crb` and `calib-dataset` (ScenarioArgs, sim_cli.h): a
// preset or a file with the command line's overrides. Apart from mfns_sim_main.cc so that its
// checks are unit-tested and fuzzed (tests/fuzz/host_cli_fuzz.cc) without rendering anything.
#pragma once

#include <string>

#include "host/sim/app/sim_cli.h"
#include "host/sim/scenario/scenario.h"

namespace mfns::host {

// The effective scenario; *text receives its YAML (with the overrides applied). Reads the
// scenario file (and what it names); writes nothing. Throws UserError (one line) for a bad
// option, file or field.
Scenario LoadScenario(const ScenarioArgs& a, std::string* text);

}  // namespace mfns::host
