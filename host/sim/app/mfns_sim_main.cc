// mfns-sim: the simulator (DESIGN.md, "Simulator"; issue 3).
//   mfns-sim render --preset NAME|--scenario FILE --out DIR [--frames N] [--seed S] [--map-seed M]
//   mfns-sim crb    --preset NAME|--scenario FILE --out FILE.csv [--frames N] [--seed S] [--map-seed M]
//   mfns-sim calib-dataset --preset NAME|--scenario FILE --out DIR [--seed S]
//   mfns-sim compare DIR POSES.csv  estimates against truth and the bound (host/report/compare.h)
//   mfns-sim preset NAME            print a built-in scenario (to start a custom one)
//   mfns-sim analyze --out DIR ...  Figures 4-6 of the paper (error analysis)
//   mfns-sim report | merge-rig | solve-given   replication tables and report (host/report)
//   mfns-sim navmatrix ...          acquisition test matrix (host/sim/navmatrix)
//   mfns-sim faults --out DIR ...   fault scenarios through NavLoop (host/sim/faults)
// Exit 0 on success, 1 on a user error with a one-line reason on stderr.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>

#include "host/report/compare.h"
#include "host/report/report_command.h"
#include "host/sim/app/load_scenario.h"
#include "host/sim/app/sim_cli.h"
#include "host/sim/analysis/analyze_command.h"
#include "host/sim/calibdata/calib_dataset.h"
#include "host/sim/faults/faults.h"
#include "host/sim/frames/render_run.h"
#include "host/sim/navmatrix/matrix.h"
#include "host/sim/scenario/scenario.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

void PrintSummary(const RenderSummary& s) {
  std::printf("frame sets %d: >= 3 beacons visible in %d (%.1f%%), none in %d (%.1f%%), mean %.2f beacons\n", s.frames,
              s.frames_with_3, 100.0 * s.frames_with_3 / s.frames, s.frames_with_none,
              100.0 * s.frames_with_none / s.frames, s.mean_visible);
}

void RunCommand(const SimCommandLine& cl) {
  const std::string& c = cl.command;
  if (c == "render") {
    std::string text;
    const Scenario s = LoadScenario(cl.scenario, &text);
    RenderOptions opt;
    opt.out_dir = cl.out;
    opt.threads = cl.threads;
    opt.write_images = !cl.no_images;
    PrintSummary(RenderScenario(s, text, opt));
  }
  if (c == "crb") {
    std::string text;
    PrintSummary(WriteBoundCsv(LoadScenario(cl.scenario, &text), cl.out));
  }
  if (c == "calib-dataset") {
    std::string text;
    const Scenario s = LoadScenario(cl.scenario, &text);
    CalibDatasetOptions opt;
    opt.out_dir = cl.out;
    opt.threads = cl.threads;
    const CalibDatasetSummary sum = WriteCalibDataset(s, text, opt);
    std::printf("calibration images %d, with the whole target in view %d\n", sum.images, sum.complete);
    for (const std::string& w : TurntableWarnings(s, sum)) std::fprintf(stderr, "mfns-sim: warning: %s\n", w.c_str());
  }
  if (c == "compare") std::fputs(FormatCompare(ComparePoses(cl.compare_dir, cl.compare_poses)).c_str(), stdout);
  if (c == "preset") {
    if (cl.list || cl.preset_name.empty()) {
      for (const std::string& n : PresetNames()) std::printf("%s\n", n.c_str());
    } else {
      std::fputs(PresetYaml(cl.preset_name).c_str(), stdout);
    }
  }
  if (c == "analyze") RunAnalyze(cl.analyze, std::cout, std::cerr);
  if (c == "report") RunReport(cl.report.report, std::cout);
  if (c == "merge-rig") RunMergeRig(cl.report.merge);
  if (c == "solve-given") RunSolveGiven(cl.report.given);
  if (c == "navmatrix") RunNavMatrixCommand(cl.navmatrix);
  if (c == "faults") RunFaultsCommand(cl.faults);
}

int Run(int argc, char** argv) {
  CLI::App app;
  SimCommandLine cl;
  try {
    ParseSimCommandLine(app, argc, argv, &cl);
    RunCommand(cl);  // inside: navmatrix and faults --check end with CLI::RuntimeError(1), exit 1 and no message
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 1;
  }
  return 0;
}

}  // namespace
}  // namespace mfns::host

int main(int argc, char** argv) {
  try {
    return mfns::host::Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mfns-sim: %s\n", e.what());
    return 1;
  }
}
