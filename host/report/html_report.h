// The demo's HTML report (issue 7): one self-contained page (inline SVG, no scripts, no
// external files) with the replication tables and the plots
//   pose-error-position  position error (mm) per axis against the true yaw
//   pose-error-attitude  attitude error (deg) per axis against the true yaw
//   beacons-per-camera   beacons in view per camera (crb.csv) and used by the estimator
//   residuals            the estimator's residual RMS (px) against the true yaw
// Each plot is an <svg id="NAME"> with one <g class="series"> per data series; the tables are
// <table id="table5"> and <table id="table3"> (a header row, one row per table row, the notes
// in a list after it).
#pragma once

#include <string>
#include <vector>

#include "host/report/pose_errors.h"
#include "host/report/tables.h"

namespace mfns::host {

// A scatter/line chart on linear axes that may be negative.
struct Chart {
  struct Series {
    std::string name;
    std::vector<double> x, y;  // non-finite points are skipped
    bool line = false;         // polyline through the points (else dots)
  };
  std::string id, title, x_label, y_label;
  std::vector<Series> series;
};

// Standalone SVG (XML) of the chart, written with host/core/svg_writer.h; text is XML-escaped.
std::string RenderChart(const Chart& chart);

struct NamedPoseSeries {
  std::string label;
  PoseSeries series;
};

struct ReportInputs {
  std::string title = "MFNS end-to-end demo";
  std::vector<NamedPoseSeries> runs;  // the first one drives the beacon and residual plots
  CellTable table5, table3;              // Table5Cells / Table3Cells (left out when without rows)
  std::vector<std::string> notes;        // lines printed under the title (commands, inputs)
};

// The whole page.
std::string RenderReportHtml(const ReportInputs& in);

}  // namespace mfns::host
