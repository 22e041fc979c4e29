// `mfns-sim analyze`: Figures 4-6 of the paper (Section 3) by Monte Carlo with the first-order
// analytic prediction beside it. Writes into --out DIR one CSV and one SVG per figure:
//   fig4_beacon_position.{csv,svg}  fig5_camera_position.{csv,svg}  fig6_camera_attitude.{csv,svg}
// and prints a summary (slopes, the paper's conclusion check) on stdout, progress on stderr.
#pragma once

#include <CLI/CLI.hpp>

#include <array>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "host/sim/analysis/error_analysis.h"

namespace mfns::host {

// Command-line options, in the units the user types (mm, deg).
struct AnalyzeOptions {
  std::string out_dir;
  std::int64_t trials = 10000;
  int points = 11;
  std::uint64_t seed = 1;
  std::vector<double> beacon_x_range_mm{0.0, 1000.0};
  std::vector<double> beacon_y_range_mm{0.0, 1000.0};
  std::vector<double> beacon_z_range_mm{0.0, 1000.0};
  double min_depth_mm = 100.0;
  std::string error_draw = "gaussian";
  bool no_fov_gate = false;
  double fig4_max_mm = 3.0;
  double fig5_max_mm = 3.0;
  double fig6_max_deg = 0.17;
  double few_px = 10.0;  // what "a few pixels" means in the conclusion check
};

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

// Registers the `analyze` subcommand on app; its callback runs RunAnalyze with std::cout and
// std::cerr. Errors propagate out of app.parse() as UserError (or CLI11's ParseError for
// malformed arguments).
void AddAnalyzeCommand(CLI::App& app);

// Output file stem of a figure, e.g. "fig4_beacon_position".
std::string FigureStem(ErrorFigure f);

}  // namespace mfns::host
