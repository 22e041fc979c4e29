// `mfns-sim analyze`: Figures 4-6 of the paper (Section 3) by Monte Carlo with the first-order
// analytic prediction beside it. Writes into --out DIR one CSV and one SVG per figure:
//   fig4_beacon_position.{csv,svg}  fig5_camera_position.{csv,svg}  fig6_camera_attitude.{csv,svg}
// and prints a summary (slopes, the paper's conclusion check) on stdout, progress on stderr.
#pragma once

#include <array>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "host/sim/analysis/analyze_options.h"
#include "host/sim/analysis/error_analysis.h"

namespace mfns::host {

// The analysis set-up the options describe (Table 1 camera). Throws UserError (one line) on any
// option a user can get wrong.
AnalysisSetup SetupFromOptions(const AnalyzeOptions& o);

struct AnalyzeResult {
  AnalysisSetup setup;
  std::array<FigureResult, 3> figures;  // 4, 5, 6
};

// Runs the three figures, writes the CSVs and SVGs into o.out_dir (created if missing; every
// file through WriteFileAtomic), the summary to `summary` and a line per point to `progress`.
// Throws UserError on bad options or an unwritable output.
AnalyzeResult RunAnalyze(const AnalyzeOptions& o, std::ostream& summary, std::ostream& progress);

// Registers the `analyze` subcommand on app (AddAnalyzeOptions) with a callback that runs
// RunAnalyze with std::cout and std::cerr (mfns-sim parses first and runs after, sim_cli.h).
// Errors propagate out of app.parse() as UserError (or CLI11's ParseError for malformed
// arguments).
void AddAnalyzeCommand(CLI::App& app);

// Output file stem of a figure, e.g. "fig4_beacon_position".
std::string FigureStem(ErrorFigure f);

}  // namespace mfns::host
