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
// Their options are defined by AddReportOptions (report_options.h; mfns-sim parses them first,
// then runs one of these). Errors are UserError (one line; mfns-sim prints it, exits 1).
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

#include "host/report/report_options.h"

namespace mfns::host {

// Prints the tables to `out`; writes opt.html when set. Throws UserError on bad options or
// input.
void RunReport(const ReportOptions& opt, std::ostream& out);

// merge-rig: writes o.out. Throws UserError.
void RunMergeRig(const MergeRigOptions& o);

// solve-given: writes o.out and prints a summary line. Throws UserError.
void RunSolveGiven(const SolveGivenCommandOptions& o);

}  // namespace mfns::host
