#include "host/report/html_report.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "host/core/svg_writer.h"

namespace mfns::host {
namespace {

constexpr double kW = 760, kH = 320, kLeft = 70, kRight = 150, kTop = 36, kBottom = 46;
constexpr std::array<const char*, 8> kColors = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e",
                                                "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};

std::string Num(double v) { return Fixed(v, 2); }
std::string Tick(double v) { return General(std::abs(v) < 1e-12 ? 0.0 : v, 6); }

// Step of 1, 2 or 5 x 10^k giving about 5 intervals over span.
double AxisStep(double span) { return NiceStep(span / 5.0, false); }

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
  const double step = AxisStep(hi - lo);
  return {std::floor(lo / step) * step, std::ceil(hi / step) * step};
}

// A CellTable as an HTML table: header, rows (the naming columns as row headers), the notes
// as a list after it. Every cell is XML-escaped.
void RenderTable(SvgWriter& w, const char* id, const CellTable& t) {
  w.Open("table", {{"id", id}}).Raw("\n").Element("caption", {}, t.caption).Raw("\n").Open("thead").Open("tr");
  for (const std::string& h : t.header) w.Element("th", {{"scope", "col"}}, h);
  w.Close("tr").Close("thead").Raw("\n").Open("tbody").Raw("\n");
  for (const std::vector<std::string>& row : t.rows) {
    w.Open("tr");
    for (std::size_t c = 0; c < row.size(); ++c) {
      if (static_cast<int>(c) < t.key_columns)
        w.Element("th", {{"scope", "row"}, {"class", "key"}}, row[c]);
      else
        w.Element("td", {}, row[c]);
    }
    w.Close("tr").Raw("\n");
  }
  w.Close("tbody").Raw("\n").Close("table").Raw("\n");
  if (!t.notes.empty()) {
    w.Open("ul", {{"class", "table-notes"}}).Raw("\n");
    for (const std::string& n : t.notes) w.Element("li", {}, n).Raw("\n");
    w.Close("ul").Raw("\n");
  }
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
  const auto G = [](double v) { return General(v); };

  SvgWriter w;
  w.OpenSvg({{"id", c.id}, {"width", G(kW)}, {"height", G(kH)}, {"viewBox", "0 0 " + G(kW) + " " + G(kH)},
             {"font-family", "sans-serif"}, {"font-size", "12"}})
      .Raw("\n");
  w.Element("text", {{"x", G(kW / 2)}, {"y", "20"}, {"text-anchor", "middle"}, {"font-size", "14"}}, c.title).Raw("\n");
  w.Empty("rect", {{"x", G(kLeft)}, {"y", G(kTop)}, {"width", G(pw)}, {"height", G(ph)}, {"fill", "none"},
                   {"stroke", "#000"}})
      .Raw("\n");
  for (int axis = 0; axis < 2; ++axis) {
    const Range r = axis == 0 ? xr : yr;
    const double step = AxisStep(r.hi - r.lo);
    for (int k = 0; k <= 20; ++k) {
      const double v = r.lo + k * step;
      if (v > r.hi + step * 1e-6) break;
      if (axis == 0) {
        w.Empty("line", {{"class", "grid"}, {"x1", Num(X(v))}, {"y1", G(kTop)}, {"x2", Num(X(v))}, {"y2", G(kTop + ph)},
                         {"stroke", "#ddd"}});
        w.Element("text", {{"x", Num(X(v))}, {"y", G(kTop + ph + 16)}, {"text-anchor", "middle"}}, Tick(v)).Raw("\n");
      } else {
        w.Empty("line", {{"class", "grid"}, {"x1", G(kLeft)}, {"y1", Num(Y(v))}, {"x2", G(kLeft + pw)}, {"y2", Num(Y(v))},
                         {"stroke", "#ddd"}});
        w.Element("text", {{"x", G(kLeft - 6)}, {"y", Num(Y(v) + 4)}, {"text-anchor", "end"}}, Tick(v)).Raw("\n");
      }
    }
  }
  w.Element("text", {{"x", G(kLeft + pw / 2)}, {"y", G(kH - 8)}, {"text-anchor", "middle"}}, c.x_label).Raw("\n");
  w.Element("text", {{"transform", "translate(16," + G(kTop + ph / 2) + ") rotate(-90)"}, {"text-anchor", "middle"}},
            c.y_label)
      .Raw("\n");
  for (std::size_t k = 0; k < c.series.size(); ++k) {
    const auto& s = c.series[k];
    const char* color = kColors[k % kColors.size()];
    w.Open("g", {{"class", "series"}, {"data-name", s.name}, {"fill", color}, {"stroke", color}}).Raw("\n");
    std::string points;
    for (std::size_t i = 0; i < std::min(s.x.size(), s.y.size()); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      if (s.line) {
        points += Num(X(s.x[i])) + "," + Num(Y(s.y[i])) + " ";
      } else {
        w.Empty("circle", {{"cx", Num(X(s.x[i]))}, {"cy", Num(Y(s.y[i]))}, {"r", "1.8"}, {"stroke", "none"}});
      }
    }
    if (s.line && !points.empty()) {
      points.pop_back();
      w.Empty("polyline", {{"fill", "none"}, {"stroke-width", "1.2"}, {"points", points}});
    }
    w.Raw("\n").Close("g").Raw("\n");
    const double ly = kTop + 14 + 18 * static_cast<double>(k);
    w.Empty("rect", {{"x", G(kW - kRight + 12)}, {"y", G(ly - 9)}, {"width", "10"}, {"height", "10"}, {"fill", color}});
    w.Element("text", {{"x", G(kW - kRight + 28)}, {"y", G(ly)}}, s.name).Raw("\n");
  }
  w.Close("svg").Raw("\n");
  return w.str();
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

  SvgWriter w;
  w.Raw("<!DOCTYPE html>\n").Open("html", {{"lang", "en"}}).Raw("\n").Open("head").Raw("\n");
  w.Open("meta", {{"charset", "utf-8"}}).Raw("\n").Element("title", {}, in.title).Raw("\n");
  w.Element("style", {},
            "body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em}"
            "table{border-collapse:collapse;font-size:13px;margin:.4em 0}th,td{border:1px solid #ccc;padding:2px 8px}"
            "td{text-align:right;font-variant-numeric:tabular-nums}th.key{text-align:left;font-weight:normal}"
            "th{background:#f0f0f0}ul.table-notes{font-size:12px;color:#444}")
      .Raw("\n");
  w.Close("head").Raw("\n").Open("body").Raw("\n");
  w.Element("h1", {}, in.title).Raw("\n");
  if (!in.notes.empty()) {
    w.Open("ul", {{"class", "notes"}}).Raw("\n");
    for (const std::string& n : in.notes) w.Element("li", {}, n).Raw("\n");
    w.Close("ul").Raw("\n");
  }
  if (!in.table5.rows.empty()) {
    w.Element("h2", {}, "Table 5: navigation").Raw("\n");
    RenderTable(w, "table5", in.table5);
  }
  if (!in.table3.rows.empty()) {
    w.Element("h2", {}, "Table 3: calibration").Raw("\n");
    RenderTable(w, "table3", in.table3);
  }
  w.Element("h2", {}, "Plots").Raw("\n");
  for (const Chart& c : charts) w.Open("div", {{"class", "plot"}}).Raw("\n").Raw(RenderChart(c)).Close("div").Raw("\n");
  w.Close("body").Raw("\n").Close("html").Raw("\n");
  return w.str();
}

}  // namespace mfns::host
