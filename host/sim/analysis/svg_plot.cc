#include "host/sim/analysis/svg_plot.h"
#include "host/util/xml_escape.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace mfns::host {
namespace {

// Layout in SVG user units (px).
constexpr double kWidth = 640, kHeight = 440;
constexpr double kLeft = 80, kRight = 24, kTop = 44, kBottom = 64;

std::string Num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

// Tick label with just enough decimals for the step.
std::string TickLabel(double v, double step) {
  int decimals = 0;
  while (decimals < 6 && std::abs(step * std::pow(10.0, decimals) - std::round(step * std::pow(10.0, decimals))) > 1e-9)
    ++decimals;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

double MaxFinite(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (const auto* v : {&a, &b})
    for (const double x : *v)
      if (std::isfinite(x)) m = std::max(m, x);
  return m;
}

}  // namespace

std::vector<double> NiceTicks(double max, int target) {
  if (!(max > 0.0) || !std::isfinite(max)) return {0.0, 1.0};
  target = std::max(target, 1);
  const double raw = max / target;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10.0 * p;
  for (const double f : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    if (f * p >= raw * (1.0 - 1e-9)) {
      step = f * p;
      break;
    }
  }
  std::vector<double> ticks;
  for (int i = 0; ticks.empty() || ticks.back() < max * (1.0 - 1e-9); ++i) ticks.push_back(i * step);
  return ticks;
}

std::string RenderSvg(const SvgPlot& plot) {
  std::vector<double> span_ends;
  for (const auto& [x0, x1] : plot.shaded_x) span_ends.push_back(std::max(x0, x1));
  const std::vector<double> xt = NiceTicks(std::max(MaxFinite(plot.dots_x, plot.line_x), MaxFinite(span_ends, {})));
  const std::vector<double> yt = NiceTicks(MaxFinite(plot.dots_y, plot.line_y));
  const double x_max = xt.back(), y_max = yt.back();
  const double pw = kWidth - kLeft - kRight, ph = kHeight - kTop - kBottom;
  const auto sx = [&](double x) { return kLeft + pw * x / x_max; };
  const auto sy = [&](double y) { return kTop + ph * (1.0 - y / y_max); };

  std::string s;
  s += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  s += "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" + Num(kWidth) + "\" height=\"" +
       Num(kHeight) + "\" viewBox=\"0 0 " + Num(kWidth) + " " + Num(kHeight) + "\" font-family=\"sans-serif\">\n";
  s += "<rect x=\"0\" y=\"0\" width=\"" + Num(kWidth) + "\" height=\"" + Num(kHeight) + "\" fill=\"white\"/>\n";
  s += "<text x=\"" + Num(kWidth / 2) + "\" y=\"24\" text-anchor=\"middle\" font-size=\"15\">" + XmlEscape(plot.title) +
       "</text>\n";

  // Shaded spans first, under the grid and the data.
  for (const auto& [x0, x1] : plot.shaded_x) {
    if (!std::isfinite(x0) || !std::isfinite(x1)) continue;
    s += "<rect class=\"shaded\" x=\"" + Num(sx(std::min(x0, x1))) + "\" y=\"" + Num(kTop) + "\" width=\"" +
         Num(std::max(1.0, sx(std::max(x0, x1)) - sx(std::min(x0, x1)))) + "\" height=\"" + Num(ph) +
         "\" fill=\"#fdd9a8\"/>\n";
  }
  // Grid, ticks and tick labels.
  s += "<g class=\"axes\" stroke=\"#000\" font-size=\"12\">\n";
  for (const double x : xt) {
    s += "<line x1=\"" + Num(sx(x)) + "\" y1=\"" + Num(kTop) + "\" x2=\"" + Num(sx(x)) + "\" y2=\"" +
         Num(kTop + ph) + "\" stroke=\"#ddd\"/>\n";
    s += "<line x1=\"" + Num(sx(x)) + "\" y1=\"" + Num(kTop + ph) + "\" x2=\"" + Num(sx(x)) + "\" y2=\"" +
         Num(kTop + ph + 5) + "\"/>\n";
    s += "<text x=\"" + Num(sx(x)) + "\" y=\"" + Num(kTop + ph + 19) + "\" text-anchor=\"middle\" stroke=\"none\">" +
         TickLabel(x, xt[1] - xt[0]) + "</text>\n";
  }
  for (const double y : yt) {
    s += "<line x1=\"" + Num(kLeft) + "\" y1=\"" + Num(sy(y)) + "\" x2=\"" + Num(kLeft + pw) + "\" y2=\"" +
         Num(sy(y)) + "\" stroke=\"#ddd\"/>\n";
    s += "<line x1=\"" + Num(kLeft - 5) + "\" y1=\"" + Num(sy(y)) + "\" x2=\"" + Num(kLeft) + "\" y2=\"" +
         Num(sy(y)) + "\"/>\n";
    s += "<text x=\"" + Num(kLeft - 8) + "\" y=\"" + Num(sy(y) + 4) + "\" text-anchor=\"end\" stroke=\"none\">" +
         TickLabel(y, yt[1] - yt[0]) + "</text>\n";
  }
  s += "<rect x=\"" + Num(kLeft) + "\" y=\"" + Num(kTop) + "\" width=\"" + Num(pw) + "\" height=\"" + Num(ph) +
       "\" fill=\"none\"/>\n";
  s += "</g>\n";
  s += "<text x=\"" + Num(kLeft + pw / 2) + "\" y=\"" + Num(kHeight - 16) +
       "\" text-anchor=\"middle\" font-size=\"13\">" +
       XmlEscape(plot.x_label) + "</text>\n";
  s += "<text transform=\"translate(20 " + Num(kTop + ph / 2) +
       ") rotate(-90)\" text-anchor=\"middle\" font-size=\"13\">" + XmlEscape(plot.y_label) + "</text>\n";

  // Analytic line, then the dots on top.
  std::string pts;
  for (std::size_t i = 0; i < plot.line_x.size() && i < plot.line_y.size(); ++i) {
    if (!std::isfinite(plot.line_x[i]) || !std::isfinite(plot.line_y[i])) continue;
    pts += (pts.empty() ? "" : " ") + Num(sx(plot.line_x[i])) + "," + Num(sy(plot.line_y[i]));
  }
  s += "<polyline class=\"analytic\" points=\"" + pts + "\" fill=\"none\" stroke=\"#d62728\" stroke-width=\"2\"/>\n";
  s += "<g class=\"dots\" fill=\"#1f77b4\">\n";
  for (std::size_t i = 0; i < plot.dots_x.size() && i < plot.dots_y.size(); ++i) {
    if (!std::isfinite(plot.dots_x[i]) || !std::isfinite(plot.dots_y[i])) continue;
    const bool coloured = i < plot.dots_fill.size() && !plot.dots_fill[i].empty();
    s += "<circle class=\"mc\" cx=\"" + Num(sx(plot.dots_x[i])) + "\" cy=\"" + Num(sy(plot.dots_y[i])) + "\" r=\"4\"" +
         (coloured ? " fill=\"" + XmlEscape(plot.dots_fill[i]) + "\"" : std::string()) + "/>\n";
  }
  s += "</g>\n";

  // Legend, top left inside the plot area.
  const double lx = kLeft + 14, ly = kTop + 18;
  s += "<g class=\"legend\" font-size=\"12\">\n";
  const bool shaded_entry = !plot.shaded_legend.empty();
  s += "<rect x=\"" + Num(lx - 8) + "\" y=\"" + Num(ly - 12) + "\" width=\"" + Num(shaded_entry ? 330 : 236) +
       "\" height=\"" + Num(shaded_entry ? 64 : 44) + "\" fill=\"white\" stroke=\"#888\"/>\n";
  s += "<circle cx=\"" + Num(lx + 10) + "\" cy=\"" + Num(ly) + "\" r=\"4\" fill=\"#1f77b4\"/>\n";
  s += "<text x=\"" + Num(lx + 28) + "\" y=\"" + Num(ly + 4) + "\">" + XmlEscape(plot.dots_legend) + "</text>\n";
  s += "<line x1=\"" + Num(lx) + "\" y1=\"" + Num(ly + 20) + "\" x2=\"" + Num(lx + 20) + "\" y2=\"" + Num(ly + 20) +
       "\" stroke=\"#d62728\" stroke-width=\"2\"/>\n";
  s += "<text x=\"" + Num(lx + 28) + "\" y=\"" + Num(ly + 24) + "\">" + XmlEscape(plot.line_legend) + "</text>\n";
  if (shaded_entry) {
    s += "<rect x=\"" + Num(lx) + "\" y=\"" + Num(ly + 34) + "\" width=\"20\" height=\"12\" fill=\"#fdd9a8\"/>\n";
    s += "<text x=\"" + Num(lx + 28) + "\" y=\"" + Num(ly + 44) + "\">" + XmlEscape(plot.shaded_legend) + "</text>\n";
  }
  s += "</g>\n";
  s += "</svg>\n";
  return s;
}

}  // namespace mfns::host
