#include "host/report/report_command.h"

#include <cstdio>
#include <iostream>

#include "common/rig/paper_rig.h"
#include "host/report/calib_errors.h"
#include "host/report/given_solve.h"
#include "host/report/html_report.h"
#include "host/report/pose_errors.h"
#include "host/report/tables.h"
#include "host/rigio/rig_yaml.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

// "LABEL=FILE" -> {LABEL, FILE}; a bare FILE gets default_label.
std::pair<std::string, std::string> SplitLabel(const std::string& arg, const std::string& default_label) {
  const std::size_t eq = arg.find('=');
  if (eq == std::string::npos) return {default_label, arg};
  if (eq == 0 || eq + 1 == arg.size()) throw UserError("expected LABEL=FILE, got '" + arg + "'");
  return {arg.substr(0, eq), arg.substr(eq + 1)};
}

}  // namespace

void RunReport(const ReportOptions& opt, std::ostream& out) {
  if (opt.poses.empty() && opt.calib.empty()) throw UserError("nothing to report: give --poses and/or --calib");
  if (!opt.poses.empty() && opt.sim_dir.empty()) throw UserError("--poses needs --sim DIR (truth.csv, crb.csv)");
  if (!opt.calib.empty() && opt.truth_rig.empty()) throw UserError("--calib needs --truth-rig");

  ReportInputs in;
  for (std::size_t i = 0; i < opt.poses.size(); ++i) {
    const auto [label, file] = SplitLabel(opt.poses[i], i == 0 ? "ours" : "run " + std::to_string(i + 1));
    const std::filesystem::path dir(opt.sim_dir);
    const std::filesystem::path crb = std::filesystem::exists(dir / "crb.csv") ? dir / "crb.csv" : "";
    in.runs.push_back({label, LoadPoseSeries(dir / "truth.csv", file, crb)});
    in.notes.push_back(label + ": " + file);
  }
  std::vector<const PoseSeries*> all;
  for (const NamedPoseSeries& r : in.runs) all.push_back(&r.series);
  const std::set<long> common = CommonPosedFrames(all, !opt.fix_only);
  std::vector<NamedPoseSummary> summaries;
  for (const NamedPoseSeries& r : in.runs)
    summaries.push_back({r.label, SummarizePoses(r.series, !opt.fix_only, opt.common_frames ? &common : nullptr)});
  if (!summaries.empty()) {
    std::vector<std::string> scope{opt.fix_only ? "statistics over status fix only"
                                                : "statistics over status fix and degraded (every frame set with a pose)"};
    if (opt.common_frames)
      scope.push_back("and only over the " + std::to_string(common.size()) + " frame sets that every run posed");
    in.table5 = Table5Cells(summaries);
    std::string text = FormatTable5(summaries);
    for (const std::string& line : scope) {
      text += "  " + line + "\n";
      in.table5.notes.push_back(line);
    }
    out << text << "\n";
  }
  if (!opt.calib.empty()) {
    const Rig truth = ReadRigYaml(opt.truth_rig);
    std::vector<NamedCalibration> methods;
    for (const std::string& c : opt.calib) {
      const auto [label, file] = SplitLabel(c, "calibration");
      methods.push_back({label, CompareCalibration(ReadRigYaml(file), truth)});
      in.notes.push_back("calibration " + label + ": " + file + " against " + opt.truth_rig);
    }
    in.table3 = Table3Cells(methods, PaperRig());
    out << FormatTable3(methods, PaperRig());
  }
  if (!opt.html.empty()) {
    if (!opt.sim_dir.empty()) in.notes.insert(in.notes.begin(), "simulation: " + opt.sim_dir);
    WriteFileAtomic(opt.html, RenderReportHtml(in));
    std::fprintf(stderr, "mfns-sim: wrote %s\n", opt.html.c_str());
  }
}

void RunMergeRig(const MergeRigOptions& o) {
  const Rig beacons = ReadRigYaml(o.beacons);
  if (beacons.num_beacons == 0) throw UserError(o.beacons + ": no beacons_mm");
  WriteRigYaml(o.out, MergeRig(ReadRigYaml(o.cameras), beacons));
  std::fprintf(stderr, "mfns-sim: wrote %s\n", o.out.c_str());
}

void RunSolveGiven(const SolveGivenCommandOptions& o) {
  const Rig rig = ReadRigYaml(o.rig);
  const GivenSolveSummary s = SolveGivenCorrespondences(o.dir, rig, o.opt, o.out);
  std::printf("solve-given: %d frame sets, fix %d, lost %d -> %s\n", s.frames, s.fixes, s.lost, o.out.c_str());
}

}  // namespace mfns::host
