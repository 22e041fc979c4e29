// `mfns-sim compare`: navigation estimates against the simulator's truth and the Cramér-Rao
// bound (issue 4's acceptance, issue 7's Table 5), as a fixed-width table for people.
//
// Inputs: DIR/truth.csv and DIR/crb.csv (from `mfns-sim render`), and a poses CSV (from
// `mfns-navd --log`), joined by pose_errors.h (LoadPoseSeries): errors are estimate - truth per
// axis, position in mm (world axes) and the Euler angles of C_b_w in deg (wrapped to +-180).
// The statistics (SummarizePoses) are over the frame sets whose status is fix and whose bound
// is valid, so that the bound's RMS is over exactly the frames of the errors.
#pragma once

#include <filesystem>
#include <string>

#include "host/report/pose_errors.h"

namespace mfns::host {

// Joins and summarizes. Throws what LoadPoseSeries throws, and UserError on a poses or truth
// CSV with no rows, and when no frame of the poses is in truth.csv (statistics of nothing would
// print as 0.000 mm, a perfect navigator; issue 14, defect 10).
PoseSummary ComparePoses(const std::filesystem::path& sim_dir, const std::filesystem::path& poses_csv);

// The table: counts, then per axis mean, std, RMS, the bound's RMS and RMS/bound, then the
// worst errors; without the axis table when nothing was compared (summary.used == 0).
std::string FormatCompare(const PoseSummary& summary);

}  // namespace mfns::host
