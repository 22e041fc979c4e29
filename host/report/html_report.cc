#include "host/report/html_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "host/util/xml_escape.h"

namespace mfns::host {
namespace {

constexpr double kW = 760, kH = 320, kLeft = 70, kRight = 150, kTop = 36, kBottom = 46;
constexpr std::array<const char*, 8> kColors = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                                "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};

std::string Num(double v) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.2f", v);
  return b;
}

std::string Tick(double v) {
  char b[32];
  std::snprintf(b, sizeof(b), "%.6g", std::abs(v) < 1e-12 ? 0.0 : v);
  return b;
}

// Step of 1, 2 or 5 x 10^k giving about 5 intervals over span.
double NiceStep(double span) {
  const double raw = span / 5.0;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= raw) return m * p;
  return 10.0 * p;
}

struct Range {
  double lo = 0, hi = 1;
};

Range AxisRange(double lo, double hi) {
  if (!(lo <= hi)) return {0, 1};
  if (hi - lo < 1e-12) {
    const double pad = std::max(1e-3, std::abs(lo) * 0.1);
    lo -= pad;
    hi += pad;
  }
  const double step = NiceStep(hi - lo);
  return {std::floor(lo / step) * step, std::ceil(hi / step) * step};
}

// A CellTable as an HTML table: header, rows (the naming columns as row headers), the notes
// as a list after it. Every cell is XML-escaped.
std::string RenderTable(const char* id, const CellTable& t) {
  std::ostringstream o;
  o << "<table id=\"" << id << "\">\n<caption>" << XmlEscape(t.caption) << "</caption>\n<thead><tr>";
  for (const std::string& h : t.header) o << "<th scope=\"col\">" << XmlEscape(h) << "</th>";
  o << "</tr></thead>\n<tbody>\n";
  for (const std::vector<std::string>& row : t.rows) {
    o << "<tr>";
    for (std::size_t c = 0; c < row.size(); ++c) {
      const bool key = static_cast<int>(c) < t.key_columns;
      o << (key ? "<th scope=\"row\" class=\"key\">" : "<td>") << XmlEscape(row[c]) << (key ? "</th>" : "</td>");
    }
    o << "</tr>\n";
  }
  o << "</tbody>\n</table>\n";
  if (!t.notes.empty()) {
    o << "<ul class=\"table-notes\">\n";
    for (const std::string& n : t.notes) o << "<li>" << XmlEscape(n) << "</li>\n";
    o << "</ul>\n";
  }
  return o.str();
}

}  // namespace

std::string RenderChart(const Chart& c) {
  double xlo = INFINITY, xhi = -INFINITY, ylo = INFINITY, yhi = -INFINITY;
  for (const auto& s : c.series)
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      xlo = std::min(xlo, s.x[i]);
      xhi = std::max(xhi, s.x[i]);
      ylo = std::min(ylo, s.y[i]);
      yhi = std::max(yhi, s.y[i]);
    }
  const Range xr = AxisRange(xlo, xhi), yr = AxisRange(ylo, yhi);
  const double pw = kW - kLeft - kRight, ph = kH - kTop - kBottom;
  const auto X = [&](double x) { return kLeft + (x - xr.lo) / (xr.hi - xr.lo) * pw; };
  const auto Y = [&](double y) { return kTop + ph - (y - yr.lo) / (yr.hi - yr.lo) * ph; };

  std::ostringstream o;
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" id=\"" << XmlEscape(c.id) << "\" width=\"" << kW << "\" height=\"" << kH
    << "\" viewBox=\"0 0 " << kW << " " << kH << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  o << "<text x=\"" << kW / 2 << "\" y=\"20\" text-anchor=\"middle\" font-size=\"14\">" << XmlEscape(c.title) << "</text>\n";
  o << "<rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << pw << "\" height=\"" << ph
    << "\" fill=\"none\" stroke=\"#000\"/>\n";
  for (int axis = 0; axis < 2; ++axis) {
    const Range r = axis == 0 ? xr : yr;
    const double step = NiceStep(r.hi - r.lo);
    for (int k = 0; k <= 20; ++k) {
      const double v = r.lo + k * step;
      if (v > r.hi + step * 1e-6) break;
      if (axis == 0) {
        o << "<line class=\"grid\" x1=\"" << Num(X(v)) << "\" y1=\"" << kTop << "\" x2=\"" << Num(X(v)) << "\" y2=\""
          << kTop + ph << "\" stroke=\"#ddd\"/><text x=\"" << Num(X(v)) << "\" y=\"" << kTop + ph + 16
          << "\" text-anchor=\"middle\">" << Tick(v) << "</text>\n";
      } else {
        o << "<line class=\"grid\" x1=\"" << kLeft << "\" y1=\"" << Num(Y(v)) << "\" x2=\"" << kLeft + pw << "\" y2=\""
          << Num(Y(v)) << "\" stroke=\"#ddd\"/><text x=\"" << kLeft - 6 << "\" y=\"" << Num(Y(v) + 4)
          << "\" text-anchor=\"end\">" << Tick(v) << "</text>\n";
      }
    }
  }
  o << "<text x=\"" << kLeft + pw / 2 << "\" y=\"" << kH - 8 << "\" text-anchor=\"middle\">" << XmlEscape(c.x_label)
    << "</text>\n";
  o << "<text transform=\"translate(16," << kTop + ph / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
    << XmlEscape(c.y_label) << "</text>\n";
  for (std::size_t k = 0; k < c.series.size(); ++k) {
    const auto& s = c.series[k];
    const char* color = kColors[k % kColors.size()];
    o << "<g class=\"series\" data-name=\"" << XmlEscape(s.name) << "\" fill=\"" << color << "\" stroke=\"" << color
      << "\">\n";
    std::string points;
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      if (s.line) {
        points += Num(X(s.x[i])) + "," + Num(Y(s.y[i])) + " ";
      } else {
        o << "<circle cx=\"" << Num(X(s.x[i])) << "\" cy=\"" << Num(Y(s.y[i])) << "\" r=\"1.8\" stroke=\"none\"/>";
      }
    }
    if (s.line && !points.empty()) {
      points.pop_back();
      o << "<polyline fill=\"none\" stroke-width=\"1.2\" points=\"" << points << "\"/>";
    }
    o << "\n</g>\n";
    const double ly = kTop + 14 + 18 * static_cast<double>(k);
    o << "<rect x=\"" << kW - kRight + 12 << "\" y=\"" << ly - 9 << "\" width=\"10\" height=\"10\" fill=\"" << color
      << "\"/><text x=\"" << kW - kRight + 28 << "\" y=\"" << ly << "\">" << XmlEscape(s.name) << "</text>\n";
  }
  o << "</svg>\n";
  return o.str();
}

std::string RenderReportHtml(const ReportInputs& in) {
  std::vector<Chart> charts;
  static const char* kAxisName[6] = {"x", "y", "z", "roll", "pitch", "yaw"};
  for (int group = 0; group < 2; ++group) {
    Chart c;
    c.id = group == 0 ? "pose-error-position" : "pose-error-attitude";
    c.title = group == 0 ? "Position error against yaw" : "Attitude error against yaw";
    c.x_label = "true yaw (deg)";
    c.y_label = group == 0 ? "estimate - truth (mm)" : "estimate - truth (deg)";
    for (const NamedPoseSeries& run : in.runs)
      for (int a = group * 3; a < group * 3 + 3; ++a) {
        Chart::Series s;
        s.name = (in.runs.size() > 1 ? run.label + " " : std::string()) + kAxisName[a];
        for (const PoseSample& p : run.series.samples) {
          if (p.status != "fix" && p.status != "degraded") continue;
          s.x.push_back(p.yaw_true_deg);
          s.y.push_back(p.error[static_cast<std::size_t>(a)]);
        }
        c.series.push_back(std::move(s));
      }
    charts.push_back(std::move(c));
  }
  if (!in.runs.empty()) {
    const PoseSeries& first = in.runs.front().series;
    Chart b;
    b.id = "beacons-per-camera";
    b.title = "Beacons in view per camera, and used by " + in.runs.front().label;
    b.x_label = "true yaw (deg)";
    b.y_label = "beacons";
    for (std::size_t k = 0; k < first.cameras.size(); ++k) {
      Chart::Series s;
      s.name = "in view, camera " + first.cameras[k];
      s.line = true;
      for (const PoseSample& p : first.samples) {
        if (k >= p.visible_per_camera.size()) continue;
        s.x.push_back(p.yaw_true_deg);
        s.y.push_back(p.visible_per_camera[k]);
      }
      b.series.push_back(std::move(s));
    }
    Chart::Series used;
    used.name = "used (all cameras)";
    for (const PoseSample& p : first.samples) {
      if (p.status.empty()) continue;
      used.x.push_back(p.yaw_true_deg);
      used.y.push_back(p.n_beacons);
    }
    b.series.push_back(std::move(used));
    charts.push_back(std::move(b));

    Chart r;
    r.id = "residuals";
    r.title = "Residual RMS of the pose solve";
    r.x_label = "true yaw (deg)";
    r.y_label = "residual RMS (px)";
    for (const NamedPoseSeries& run : in.runs) {
      Chart::Series s;
      s.name = run.label;
      for (const PoseSample& p : run.series.samples) {
        if (p.status != "fix" && p.status != "degraded") continue;
        s.x.push_back(p.yaw_true_deg);
        s.y.push_back(p.rms_px);
      }
      r.series.push_back(std::move(s));
    }
    charts.push_back(std::move(r));
  }

  std::ostringstream o;
  o << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" << XmlEscape(in.title)
    << "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em}"
       "table{border-collapse:collapse;font-size:13px;margin:.4em 0}th,td{border:1px solid #ccc;padding:2px 8px}"
       "td{text-align:right;font-variant-numeric:tabular-nums}th.key{text-align:left;font-weight:normal}th{background:#f0f0f0}"
       "ul.table-notes{font-size:12px;color:#444}</style>\n</head>\n<body>\n";
  o << "<h1>" << XmlEscape(in.title) << "</h1>\n";
  if (!in.notes.empty()) {
    o << "<ul class=\"notes\">\n";
    for (const std::string& n : in.notes) o << "<li>" << XmlEscape(n) << "</li>\n";
    o << "</ul>\n";
  }
  if (!in.table5.rows.empty()) o << "<h2>Table 5: navigation</h2>\n" << RenderTable("table5", in.table5);
  if (!in.table3.rows.empty()) o << "<h2>Table 3: calibration</h2>\n" << RenderTable("table3", in.table3);
  o << "<h2>Plots</h2>\n";
  for (const Chart& c : charts) o << "<div class=\"plot\">\n" << RenderChart(c) << "</div>\n";
  o << "</body>\n</html>\n";
  return o.str();
}

}  // namespace mfns::host
