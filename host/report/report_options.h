// The options of mfns-sim's report, merge-rig and solve-given (report_command.h) and their one
// definition on a command line; needs CLI11 only (the fuzz preset compiles it,
// tests/fuzz/host_cli_fuzz.cc).
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "host/report/given_solve.h"

namespace mfns::host {

struct ReportOptions {
  std::string sim_dir;
  std::vector<std::string> poses;  // [LABEL=]FILE
  std::string truth_rig;
  std::vector<std::string> calib;  // LABEL=RIG
  std::string html;
  bool fix_only = false;
  bool common_frames = false;  // Table 5 over the frame sets every run posed
};

struct MergeRigOptions {
  std::string cameras, beacons, out;
};

struct SolveGivenCommandOptions {
  std::string dir, rig, out;
  GivenSolveOptions opt;
};

struct ReportCommandsOptions {
  ReportOptions report;
  MergeRigOptions merge;
  SolveGivenCommandOptions given;
};

// Adds the report, merge-rig and solve-given subcommands and their options (values into *o) to
// app; runs nothing.
void AddReportOptions(CLI::App& app, ReportCommandsOptions* o);

}  // namespace mfns::host
