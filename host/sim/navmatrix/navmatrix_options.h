// `mfns-sim navmatrix`'s options and their one definition on a command line (issue 14); needs
// CLI11 only, so that the fuzz preset compiles it (tests/fuzz/host_cli_fuzz.cc) without the
// matrix. RunNavMatrixCommand (matrix.h) runs what they hold; mfns-sim parses first, then runs
// (host/sim/app/sim_cli.h).
#pragma once

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace mfns::host {

// As typed: --seeds and --facing are checked when the command runs (ParseSeeds, RunNavMatrixCommand),
// so that every bad value is a UserError naming the flag.
struct NavMatrixArgs {
  std::vector<std::string> presets{"free-flight", "station-cylinder", "station-box"};
  std::vector<int> counts{64, 128, 256};
  std::string seeds = "1-5";
  int frames = 600;
  int spurious = 2;
  int static_reflections = 0;
  std::string rig;  // a rig file in place of each preset's rig (empty: the preset's)
  std::string layout;    // beacons.layout of generated maps (empty: the preset's)
  double jitter = -1.0;  // beacons.jitter of generated maps (< 0: the preset's)
  std::string facing = "both";
  int jobs = 0;
  std::string out;
  std::string trace;
  bool check = false;
  bool three_beacon_fixes = false;  // TrackOptions::verify_three_beacons, three_beacon_fix_steady false, as mfns-navd's flag
};

// Adds the `navmatrix` subcommand and its options (values into *a) to app; runs nothing.
CLI::App* AddNavMatrixOptions(CLI::App& app, NavMatrixArgs* a);

}  // namespace mfns::host
