// `mfns-sim navmatrix`: the acquisition matrix of issue 13 (matrix.h) from the command line.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <thread>

#include "host/sim/navmatrix/matrix.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

struct NavMatrixArgs {
  std::vector<std::string> presets{"free-flight", "station-cylinder", "station-box"};
  std::vector<int> counts{64, 128, 256};
  std::string seeds = "1-5";
  int frames = 600;
  int spurious = 2;
  std::string facing = "both";
  int jobs = 0;
  std::string out;
  std::string trace;
  bool check = false;
};

FacingMode ParseFacing(const std::string& text) {
  if (text == "both") return FacingMode::kBoth;
  if (text == "yes") return FacingMode::kYes;
  if (text == "no") return FacingMode::kNo;
  throw UserError("--facing: expected both, yes or no, got '" + text + "'");
}

void RunNavMatrixCommand(const NavMatrixArgs& a) {
  MatrixSpec spec;
  spec.presets = a.presets;
  spec.counts = a.counts;
  spec.seeds = ParseSeeds(a.seeds);
  spec.frames = a.frames;
  spec.spurious = a.spurious;
  spec.facing = ParseFacing(a.facing);
  if (a.jobs < 0) throw UserError("--jobs: must be >= 0 (0: all cores)");
  const int jobs = a.jobs > 0 ? a.jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const std::vector<RunSpec> runs = ExpandMatrix(spec);
  const NavMatrixOptions options;
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
  const std::string table = FormatMatrixTable(rows, limits, period_s, options.slow_frame_s);
  std::fputs(table.c_str(), stdout);
  std::printf("\n%zu runs x %d frame sets in %.0f s on %d threads\n", runs.size(), spec.frames, elapsed, jobs);
  if (!a.out.empty()) WriteFileAtomic(a.out, table);
  const std::vector<std::string> failures = RequirementFailures(rows, limits);
  for (const std::string& f : failures) std::fprintf(stderr, "navmatrix: requirement not met: %s\n", f.c_str());
  if (failures.empty()) std::fprintf(stderr, "navmatrix: every requirement met\n");
  if (a.check && !failures.empty()) throw CLI::RuntimeError(1);
}

}  // namespace

void AddNavMatrixCommand(CLI::App& app) {
  auto a = std::make_shared<NavMatrixArgs>();
  CLI::App* cmd = app.add_subcommand(
      "navmatrix",
      "Acquisition test matrix (issue 13): the navigator on blob-level simulations of presets x beacon counts x "
      "seeds x map facing, from a cold start; a markdown table of first-fix lag, posed share, wrong poses, CPU time");
  cmd->add_option("--presets", a->presets, "Presets, comma-separated")->delimiter(',')->capture_default_str();
  cmd->add_option("--counts", a->counts, "beacons.count of presets with a generated map, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--seeds", a->seeds, "Seeds (trajectory, noise, clutter and the generated map): 1-5 or 1,3,8")
      ->capture_default_str();
  cmd->add_option("--frames", a->frames, "Frame sets per run")->capture_default_str();
  cmd->add_option("--spurious", a->spurious, "clutter.spurious.count: spurious blobs per camera per frame set")
      ->capture_default_str();
  cmd->add_option("--facing", a->facing, "Beacon facing in the navigator's map: both, yes or no")
      ->capture_default_str();
  cmd->add_option("--jobs", a->jobs, "Worker threads, each with its own navigator (0: all cores)")
      ->capture_default_str();
  cmd->add_option("--out", a->out, "Also write the table to this markdown file");
  cmd->add_option("--trace", a->trace, "Also write every run's frame sets (status, reason, errors) to this CSV file");
  cmd->add_flag("--check", a->check, "Exit 1 when a requirement of issue 13 fails");
  cmd->callback([a]() { RunNavMatrixCommand(*a); });
}

}  // namespace mfns::host
