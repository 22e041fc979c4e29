// The matrix of issue 13 over RunNavigation (navmatrix.h): presets x beacon counts x seeds x
// map facing, run on worker threads, aggregated over seeds into one table row per preset x
// count x facing, and checked against the requirements. `mfns-sim navmatrix` is the
// command-line face (RunNavMatrixCommand).
#pragma once

#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "host/sim/navmatrix/navmatrix.h"
#include "host/sim/navmatrix/navmatrix_options.h"

namespace mfns::host {

enum class FacingMode { kBoth, kYes, kNo };

// Bounds refused before anything runs (issue 14): every seed of --seeds and every run of the
// matrix is held in memory first, and 100 000 runs of 600 frame sets are days of CPU already.
inline constexpr std::size_t kMaxSeeds = 10000;
inline constexpr std::size_t kMaxRuns = 100000;

struct MatrixSpec {
  std::vector<std::string> presets{"free-flight", "station-cylinder", "station-box"};
  std::vector<int> counts{64, 128, 256};  // beacons.count; presets without generated beacons ignore it
  std::vector<std::uint64_t> seeds{1, 2, 3, 4, 5};
  int frames = 600;
  int spurious = 2;  // clutter.spurious.count per camera (near_fraction as the preset has it: 0.5)
  // clutter.spurious.static_reflections: unmapped reflecting points on the module's walls,
  // imaged like beacons (clutter that moves with the scene, not from frame set to frame set);
  // presets with a module only.
  int static_reflections = 0;
  std::string rig = {};  // a rig file (path) in place of every preset's `rig:` (empty: the preset's)
  FacingMode facing = FacingMode::kBoth;
  // beacons.layout and beacons.jitter of presets with a generated map: maps unlike the presets'
  // ("jittered-grid" or "random"; empty, jitter < 0: the preset's).
  std::string layout = {};
  double jitter = -1.0;
};

// One run of the matrix.
struct RunSpec {
  std::string preset;
  int count = 0;               // beacons.count; 0: the preset's own map (no generated beacons)
  std::uint64_t seed = 1;      // the scenario's seed and, for a generated map, beacons.seed (mfns-sim --seed)
  bool facing = true;          // beacons.facing; a map without facing data has none either way
  bool map_has_facing = true;  // the preset's map carries facing at all (false: `facing` is moot)
  int map_beacons = 0;         // beacons in the map (count, or the preset's own)
  int frames = 600;
  int spurious = 2;
  int static_reflections = 0;
  std::string rig = {};  // MatrixSpec::rig
  std::string layout = {};  // MatrixSpec::layout, jitter (generated maps only)
  double jitter = -1.0;
};

// The preset's YAML with the run's overrides (frames, seed, beacons.count/seed/facing,
// clutter.spurious.count, rig), parsed.
Scenario MatrixScenario(const RunSpec& r);

// Every run of the spec, row by row (preset, count, facing), seeds innermost. A preset without
// generated beacons gives one count (its own map), and one facing row when its map has no facing
// data. Throws UserError naming the flag (--presets, --counts, --frames, --spurious, --layout,
// --jitter; a preset, count or seed given twice; more than kMaxRuns runs).
std::vector<RunSpec> ExpandMatrix(const MatrixSpec& m);

// "1-5", "1,3,8", "2": the seeds (kMaxSeeds at most); UserError naming --seeds otherwise.
std::vector<std::uint64_t> ParseSeeds(const std::string& text);

// Runs every spec on `jobs` threads (each with its own navigator), results in spec order. One
// progress line on *progress (nullptr: none), rewritten after each run. traces (nullptr: none)
// receives every run's frame records, in spec order.
std::vector<RunResult> RunMatrix(const std::vector<RunSpec>& runs, const NavMatrixOptions& o, int jobs,
                                 std::ostream* progress, std::vector<std::vector<FrameRecord>>* traces = nullptr);

// The frame records of every run as CSV (a header, then one row per frame set: the run's preset,
// count, facing and seed, the frame set, truth in view, blobs, the published status, reason,
// source, beacons, residual RMS and wrong identities (against the simulation), the errors in mm and deg, the published 1-sigma in mm, Step
// in ms), for
// finding where a run loses its track.
std::string FormatTraceCsv(const std::vector<RunSpec>& runs, const std::vector<std::vector<FrameRecord>>& traces);

// One table row: the runs of a preset x count x facing, over its seeds.
struct MatrixRow {
  std::string preset;
  int count = 0;
  bool facing = true, map_has_facing = true;
  int map_beacons = 0;
  int runs = 0;
  std::vector<int> lags;         // first fix - first frame set with >= 4 in view, runs that have both
  int lag_exceeded = 0;          // runs whose first fix came more than max_lag frame sets late (or never)
  std::vector<int> held_lags;     // first fix - first held view (NavMatrixOptions::held_view_frames)
  int held_lag_exceeded = 0;      // ... more than max_lag frame sets late (or never); <= lag_exceeded; reported, not required
  int never_fixed = 0;           // runs with >= 4 in view at some point and no fix at all
  int no_view4 = 0;              // runs that never had >= 4 beacons in view
  int fixed_runs = 0;            // runs with a first fix
  double min_posed_share = 1.0;  // over the runs with a first fix
  long eligible = 0, posed = 0;  // summed over runs
  long fixes = 0, degraded = 0;
  int wrong_fixes = 0, wrong_degraded = 0;
  double worst_fix_position_m = 0.0, worst_fix_attitude_rad = 0.0;
  double worst_step_s = 0.0, total_step_s = 0.0;
  long frames = 0;
  int slips = 0, slow = 0;
  double mean_in_view = 0.0;
};

struct MatrixLimits {
  int max_lag = 10;               // first fix within this many frame sets of the first >= 4 in view
  double min_posed_share = 0.99;  // after the first fix
  int max_wrong_fixes = 0;        // over the whole matrix
};

std::vector<MatrixRow> Summarise(const std::vector<RunSpec>& runs, const std::vector<RunResult>& results,
                                 const MatrixLimits& limits);

// The markdown table (with a legend under it).
std::string FormatMatrixTable(const std::vector<MatrixRow>& rows, const MatrixLimits& limits, double frame_period_s,
                              const NavMatrixOptions& o);

// One line per requirement the rows fail; empty when all hold.
std::vector<std::string> RequirementFailures(const std::vector<MatrixRow>& rows, const MatrixLimits& limits);

// `mfns-sim navmatrix` (options: navmatrix_options.h): runs the matrix, prints the table on
// stdout (and writes it to --out), progress on stderr; with --check it throws
// CLI::RuntimeError(1) (exit 1) when a requirement fails. Option errors are UserErrors naming the flag.
void RunNavMatrixCommand(const NavMatrixArgs& a);

// The spec the command's arguments describe: --seeds (ParseSeeds), --facing and --jobs checked;
// ExpandMatrix checks the rest. Runs nothing; UserError naming the flag (what host_cli_fuzz runs
// after each parse, with ExpandMatrix).
MatrixSpec MatrixSpecFromArgs(const NavMatrixArgs& a);

}  // namespace mfns::host
