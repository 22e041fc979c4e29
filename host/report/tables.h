// The replication tables as fixed-width text (what `mfns-sim report` prints on stdout).
//   Table 5: per axis, the paper's published mean and std beside each run's mean, std and the
//            Cramér-Rao bound (RMS of the per-frame 1-sigma over the frames used).
//   Table 3: per camera and quantity, each method's estimate - truth (1-sigma) beside the
//            paper's published 1-sigma.
#pragma once

#include <string>
#include <vector>

#include "common/rig/rig.h"
#include "host/report/calib_errors.h"
#include "host/report/pose_errors.h"

namespace mfns::host {

struct NamedPoseSummary {
  std::string label;  // e.g. "ours", "paper pipeline"
  PoseSummary summary;
};

struct NamedCalibration {
  std::string label;  // e.g. "ml", "paper"
  std::vector<CameraCalibError> cameras;
};

std::string FormatTable5(const std::vector<NamedPoseSummary>& runs);

// `published` supplies the paper's sigma (common/rig/paper_rig.h PaperRig()), matched by
// camera name; cameras are listed in the first method's order.
std::string FormatTable3(const std::vector<NamedCalibration>& methods, const Rig& published);

// The same tables as cells, for the HTML report (host/report/html_report.h): the same rows,
// values and notes as the text, each value in its own cell ("-" where the text has one).
struct CellTable {
  std::string caption;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;  // each as long as the header
  std::vector<std::string> notes;              // lines under the table
  int key_columns = 1;                         // leading columns that name the row (text, not values)
};
CellTable Table5Cells(const std::vector<NamedPoseSummary>& runs);
CellTable Table3Cells(const std::vector<NamedCalibration>& methods, const Rig& published);

}  // namespace mfns::host
