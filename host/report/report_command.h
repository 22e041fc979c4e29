// The replication subcommands of mfns-sim (issue 7), registered by AddReportCommands:
//
//   mfns-sim report [--sim DIR] [--poses [LABEL=]FILE]... [--truth-rig RIG --calib LABEL=RIG...]
//                   [--html FILE] [--fix-only] [--common-frames]
//     Table 5 (pose error per axis over the sweep beside the paper and the Cramér-Rao bound;
//     DIR/truth.csv and DIR/crb.csv of `mfns-sim render`) and Table 3 (calibrated cameras
//     against the truth rig, beside the paper's sigma) on stdout; the HTML report with plots.
//   mfns-sim merge-rig --cameras RIG --beacons RIG --out FILE
//     the calibrated cameras with a surveyed beacon map: what the flyer's blob is made from.
//   mfns-sim solve-given DIR --rig RIG --out POSES.csv [--geometric] [--sigma-px S]
//     the paper's pipeline: Newton with the true correspondences of DIR/blobs.csv.
//
// Errors propagate out of app.parse() as UserError (one line; mfns-sim prints it, exits 1).
#pragma once

#include <CLI/CLI.hpp>

#include <iosfwd>
#include <string>
#include <vector>

namespace mfns::host {

struct ReportOptions {
  std::string sim_dir;
  std::vector<std::string> poses;  // [LABEL=]FILE
  std::string truth_rig;
  std::vector<std::string> calib;  // LABEL=RIG
  std::string html;
  bool fix_only = false;
  bool common_frames = false;  // Table 5 over the frame sets every run posed
};

// Prints the tables to `out`; writes opt.html when set. Throws UserError on bad options or
// input.
void RunReport(const ReportOptions& opt, std::ostream& out);

void AddReportCommands(CLI::App& app);

}  // namespace mfns::host
