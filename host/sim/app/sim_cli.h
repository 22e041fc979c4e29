// mfns-sim's command line, parsed without running anything (issue 14): the one definition of
// every subcommand and option of the tool, used by mfns-sim (mfns_sim_main.cc, which then runs
// the command) and by its fuzz target (tests/fuzz/host_cli_fuzz.cc). The options of analyze,
// report, merge-rig, solve-given, navmatrix and faults are defined beside the code that runs
// them (analyze_options.h, report_options.h, navmatrix_options.h, faults.h), in sources that
// need CLI11 only.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "host/report/report_options.h"
#include "host/sim/analysis/analyze_options.h"
#include "host/sim/faults/faults.h"
#include "host/sim/navmatrix/navmatrix_options.h"

namespace mfns::host {

// The scenario of render, crb and calib-dataset: a preset or a file, with overrides.
struct ScenarioArgs {
  std::string preset, file;
  int frames = 0;
  long long seed = -1, map_seed = -1;
};

struct SimCommandLine {
  std::string command;  // the subcommand given: render, crb, calib-dataset, compare, preset, ...
  ScenarioArgs scenario;   // render, crb, calib-dataset
  std::string out;         // render, crb, calib-dataset --out
  int threads = 0;         // render, calib-dataset --threads (0: all cores)
  bool no_images = false;  // render
  std::string compare_dir, compare_poses;
  std::string preset_name;  // preset NAME
  bool list = false;        // preset --list
  AnalyzeOptions analyze;
  ReportCommandsOptions report;  // report, merge-rig, solve-given
  NavMatrixArgs navmatrix;
  FaultsCommandOptions faults;
};

// Defines mfns-sim's subcommands and options on `app` (a fresh one) and parses argv into *cl;
// runs nothing. Throws what app.parse throws (CLI::ParseError, --help included: app.exit(e)
// prints it).
void ParseSimCommandLine(CLI::App& app, int argc, char** argv, SimCommandLine* cl);

}  // namespace mfns::host
