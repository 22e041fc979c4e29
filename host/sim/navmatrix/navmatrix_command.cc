// `mfns-sim navmatrix`: the acquisition matrix of issue 13 (matrix.h) from the command line,
// run after the parse (its options: navmatrix_options.cc).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <thread>

#include "host/sim/navmatrix/matrix.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

FacingMode ParseFacing(const std::string& text) {
  if (text == "both") return FacingMode::kBoth;
  if (text == "yes") return FacingMode::kYes;
  if (text == "no") return FacingMode::kNo;
  throw UserError("--facing: expected both, yes or no, got '" + OneLine(text) + "'");
}

}  // namespace

MatrixSpec MatrixSpecFromArgs(const NavMatrixArgs& a) {
  MatrixSpec spec;
  spec.presets = a.presets;
  spec.counts = a.counts;
  spec.seeds = ParseSeeds(a.seeds);
  spec.frames = a.frames;
  spec.spurious = a.spurious;
  spec.static_reflections = a.static_reflections;
  // Absolute, so that the scenarios find it whatever directory they resolve paths against.
  if (!a.rig.empty()) spec.rig = std::filesystem::absolute(a.rig).string();
  spec.facing = ParseFacing(a.facing);
  spec.layout = a.layout;
  spec.jitter = a.jitter;
  if (a.jobs < 0) throw UserError("--jobs: must be >= 0 (0: all cores)");
  return spec;
}

void RunNavMatrixCommand(const NavMatrixArgs& a) {
  const MatrixSpec spec = MatrixSpecFromArgs(a);
  const int jobs = a.jobs > 0 ? a.jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const std::vector<RunSpec> runs = ExpandMatrix(spec);
  NavMatrixOptions options;
  options.navigator.track.verify_three_beacons = !a.three_beacon_fixes;
  options.navigator.track.three_beacon_fix_steady = !a.three_beacon_fixes;
  const MatrixLimits limits;
  std::fprintf(stderr, "navmatrix: %zu runs of %d frame sets on %d threads\n", runs.size(), spec.frames, jobs);
  const auto start = std::chrono::steady_clock::now();
  std::vector<std::vector<FrameRecord>> traces;
  const std::vector<RunResult> results =
      RunMatrix(runs, options, jobs, &std::cerr, a.trace.empty() ? nullptr : &traces);
  if (!a.trace.empty()) WriteFileAtomic(a.trace, FormatTraceCsv(runs, traces));
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::vector<MatrixRow> rows = Summarise(runs, results, limits);
  // The deadline of the first run's scenario (every preset runs at 18.6 Hz).
  const double period_s = 1.0 / MatrixScenario(runs.front()).frame_rate_hz;
  const std::string table = FormatMatrixTable(rows, limits, period_s, options);
  std::fputs(table.c_str(), stdout);
  std::printf("\n%zu runs x %d frame sets in %.0f s on %d threads\n", runs.size(), spec.frames, elapsed, jobs);
  if (!a.out.empty()) WriteFileAtomic(a.out, table);
  const std::vector<std::string> failures = RequirementFailures(rows, limits);
  for (const std::string& f : failures) std::fprintf(stderr, "navmatrix: requirement not met: %s\n", f.c_str());
  if (failures.empty()) std::fprintf(stderr, "navmatrix: every requirement met\n");
  if (a.check && !failures.empty()) throw CLI::RuntimeError(1);
}

}  // namespace mfns::host
