// `mfns-sim faults`: the fault scenarios of issue 14 (faults.h) from the command line.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>

#include "host/sim/faults/faults.h"
#include "host/util/atomic_file.h"

namespace mfns::host {

void RunFaultsCommand(const FaultsCommandOptions& a) {
  namespace fs = std::filesystem;
  const std::vector<FaultSpec> faults = SelectFaults(a);
  std::error_code ec;
  fs::create_directories(a.out, ec);
  if (ec) throw UserError("--out " + OneLine(a.out) + ": " + ec.message());
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

void AddFaultsCommand(CLI::App& app) {
  auto a = std::make_shared<FaultsCommandOptions>();
  AddFaultsOptions(app, a.get())->callback([a]() { RunFaultsCommand(*a); });
}

}  // namespace mfns::host
