// The options of `mfns-sim analyze` (analyze_command.h) and their one definition on a command
// line; needs CLI11 only (the fuzz preset compiles it, tests/fuzz/host_cli_fuzz.cc).
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>
#include <vector>

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

// Adds the `analyze` subcommand and its options (values into *o) to app; runs nothing.
CLI::App* AddAnalyzeOptions(CLI::App& app, AnalyzeOptions* o);

}  // namespace mfns::host
