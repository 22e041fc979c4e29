// `mfns-sim faults`: the fault scenarios of issue 14 (faults.h) from the command line.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include "host/sim/faults/faults.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

struct FaultsArgs {
  FaultRunOptions run;
  std::vector<std::string> only;
  std::string out;
  std::string trace;
  bool cold = false;
  bool check = false;
};

std::vector<FaultSpec> Selected(const FaultsArgs& a) {
  std::vector<FaultSpec> all = IssueFaults(a.run), chosen;
  for (const FaultSpec& f : all)
    if (a.only.empty() || std::find(a.only.begin(), a.only.end(), f.name) != a.only.end()) chosen.push_back(f);
  for (const std::string& name : a.only) {
    bool known = false;
    for (const FaultSpec& f : all) known = known || f.name == name;
    if (!known) throw UserError("--only: no fault named '" + name + "'");
  }
  return chosen;
}

void RunFaultsCommand(const FaultsArgs& a) {
  namespace fs = std::filesystem;
  const std::vector<FaultSpec> faults = Selected(a);
  std::error_code ec;
  fs::create_directories(a.out, ec);
  if (ec) throw UserError("--out " + a.out + ": " + ec.message());
  const auto start = std::chrono::steady_clock::now();
  const FaultCampaign c = RunFaultCampaign(a.run, faults, a.cold, [](const std::string& line) {
    std::fprintf(stderr, "faults: %s\n", line.c_str());
  });
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::ostringstream md;
  md << FormatFaultTable(c);
  int wrong = 0;
  for (const FaultResult& r : c.results) {
    WriteFileAtomic(fs::path(a.out) / ("fault-" + r.run.fault.name + ".svg"), FaultFigureSvg(r, c.baseline, c.period_s));
    wrong += r.wrong_fixes;
  }
  WriteFileAtomic(fs::path(a.out) / "faults.md", md.str());
  if (!a.trace.empty()) WriteFileAtomic(a.trace, FormatFaultTrace(c));
  std::fputs(md.str().c_str(), stdout);
  std::fprintf(stderr, "faults: %zu faults x %d frame sets in %.0f s; %d wrong fixes; %s/faults.md and %zu figures\n",
               c.results.size(), a.run.frames, elapsed, wrong, a.out.c_str(), c.results.size());
  if (a.check && wrong > 0) throw CLI::RuntimeError(1);
}

}  // namespace

void AddFaultsCommand(CLI::App& app) {
  auto a = std::make_shared<FaultsArgs>();
  CLI::App* cmd = app.add_subcommand(
      "faults",
      "Fault scenarios (issue 14): rendered frames through the real NavLoop with a camera stalled, unplugged, "
      "corrupt frames, reflections, an occlusion, clock jumps, a wrong-rig reload; a markdown table and one SVG per fault");
  cmd->add_option("--out", a->out, "Folder for faults.md and fault-<name>.svg")->required();
  cmd->add_option("--preset", a->run.preset, "Scenario preset")->capture_default_str();
  cmd->add_option("--seed", a->run.seed, "Scenario seed")->capture_default_str();
  cmd->add_option("--frames", a->run.frames, "Frame sets per run")->capture_default_str();
  cmd->add_option("--fault-at", a->run.fault_at, "First frame set of every fault")->capture_default_str();
  cmd->add_option("--divisor", a->run.image_divisor, "Image size divisor (same field of view)")->capture_default_str();
  cmd->add_option("--only", a->only, "Faults to run, comma-separated (default: all)")->delimiter(',');
  cmd->add_option("--trace", a->trace, "Also write every run's frame sets (status, reason, errors) to this CSV file");
  cmd->add_flag("--cold", a->cold, "Also run the baseline without a start pose and report its first fix");
  cmd->add_flag("--check", a->check, "Exit 1 when a fault gave a wrong fix");
  cmd->callback([a]() { RunFaultsCommand(*a); });
}

}  // namespace mfns::host
