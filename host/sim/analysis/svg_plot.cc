#include "host/sim/analysis/svg_plot.h"

#include <algorithm>
#include <cmath>

#include "host/core/svg_writer.h"

namespace mfns::host {
namespace {

// Layout in SVG user units (px).
constexpr double kWidth = 640, kHeight = 440;
constexpr double kLeft = 80, kRight = 24, kTop = 44, kBottom = 64;

// Tick label with just enough decimals for the step.
std::string TickLabel(double v, double step) {
  int decimals = 0;
  while (decimals < 6 && std::abs(step * std::pow(10.0, decimals) - std::round(step * std::pow(10.0, decimals))) > 1e-9)
    ++decimals;
  return Fixed(v, decimals);
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
  const double step = NiceStep(max / target, true, 1e-9);
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
  const auto F = [](double v) { return Fixed(v); };

  SvgWriter w;
  w.Raw("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
  w.OpenSvg({{"version", "1.1"}, {"width", F(kWidth)}, {"height", F(kHeight)},
             {"viewBox", "0 0 " + F(kWidth) + " " + F(kHeight)}, {"font-family", "sans-serif"}})
      .Raw("\n");
  w.Empty("rect", {{"x", "0"}, {"y", "0"}, {"width", F(kWidth)}, {"height", F(kHeight)}, {"fill", "white"}}).Raw("\n");
  w.Element("text", {{"x", F(kWidth / 2)}, {"y", "24"}, {"text-anchor", "middle"}, {"font-size", "15"}}, plot.title)
      .Raw("\n");

  // Shaded spans first, under the grid and the data.
  for (const auto& [x0, x1] : plot.shaded_x) {
    if (!std::isfinite(x0) || !std::isfinite(x1)) continue;
    const double left = sx(std::min(x0, x1)), right = sx(std::max(x0, x1));
    w.Empty("rect", {{"class", "shaded"}, {"x", F(left)}, {"y", F(kTop)}, {"width", F(std::max(1.0, right - left))},
                     {"height", F(ph)}, {"fill", "#fdd9a8"}})
        .Raw("\n");
  }
  // Grid, ticks and tick labels.
  w.Open("g", {{"class", "axes"}, {"stroke", "#000"}, {"font-size", "12"}}).Raw("\n");
  for (const double x : xt) {
    w.Empty("line", {{"x1", F(sx(x))}, {"y1", F(kTop)}, {"x2", F(sx(x))}, {"y2", F(kTop + ph)}, {"stroke", "#ddd"}}).Raw("\n");
    w.Empty("line", {{"x1", F(sx(x))}, {"y1", F(kTop + ph)}, {"x2", F(sx(x))}, {"y2", F(kTop + ph + 5)}}).Raw("\n");
    w.Element("text", {{"x", F(sx(x))}, {"y", F(kTop + ph + 19)}, {"text-anchor", "middle"}, {"stroke", "none"}},
              TickLabel(x, xt[1] - xt[0]))
        .Raw("\n");
  }
  for (const double y : yt) {
    w.Empty("line", {{"x1", F(kLeft)}, {"y1", F(sy(y))}, {"x2", F(kLeft + pw)}, {"y2", F(sy(y))}, {"stroke", "#ddd"}}).Raw("\n");
    w.Empty("line", {{"x1", F(kLeft - 5)}, {"y1", F(sy(y))}, {"x2", F(kLeft)}, {"y2", F(sy(y))}}).Raw("\n");
    w.Element("text", {{"x", F(kLeft - 8)}, {"y", F(sy(y) + 4)}, {"text-anchor", "end"},
                       {"stroke", "none"}},
              TickLabel(y, yt[1] - yt[0]))
        .Raw("\n");
  }
  w.Empty("rect", {{"x", F(kLeft)}, {"y", F(kTop)}, {"width", F(pw)}, {"height", F(ph)}, {"fill", "none"}}).Raw("\n");
  w.Close("g").Raw("\n");
  w.Element("text", {{"x", F(kLeft + pw / 2)}, {"y", F(kHeight - 16)}, {"text-anchor", "middle"}, {"font-size", "13"}},
            plot.x_label)
      .Raw("\n");
  w.Element("text", {{"transform", "translate(20 " + F(kTop + ph / 2) + ") rotate(-90)"}, {"text-anchor", "middle"},
                     {"font-size", "13"}},
            plot.y_label)
      .Raw("\n");

  // Analytic line, then the dots on top.
  std::string pts;
  for (std::size_t i = 0; i < plot.line_x.size() && i < plot.line_y.size(); ++i) {
    if (!std::isfinite(plot.line_x[i]) || !std::isfinite(plot.line_y[i])) continue;
    pts += (pts.empty() ? "" : " ") + F(sx(plot.line_x[i])) + "," + F(sy(plot.line_y[i]));
  }
  w.Empty("polyline", {{"class", "analytic"}, {"points", pts}, {"fill", "none"}, {"stroke", "#d62728"},
                       {"stroke-width", "2"}})
      .Raw("\n");
  w.Open("g", {{"class", "dots"}, {"fill", "#1f77b4"}}).Raw("\n");
  for (std::size_t i = 0; i < plot.dots_x.size() && i < plot.dots_y.size(); ++i) {
    if (!std::isfinite(plot.dots_x[i]) || !std::isfinite(plot.dots_y[i])) continue;
    const bool coloured = i < plot.dots_fill.size() && !plot.dots_fill[i].empty();
    if (coloured)
      w.Empty("circle", {{"class", "mc"}, {"cx", F(sx(plot.dots_x[i]))}, {"cy", F(sy(plot.dots_y[i]))}, {"r", "4"},
                         {"fill", plot.dots_fill[i]}});
    else
      w.Empty("circle", {{"class", "mc"}, {"cx", F(sx(plot.dots_x[i]))}, {"cy", F(sy(plot.dots_y[i]))}, {"r", "4"}});
    w.Raw("\n");
  }
  w.Close("g").Raw("\n");

  // Legend, top left inside the plot area.
  const double lx = kLeft + 14, ly = kTop + 18;
  w.Open("g", {{"class", "legend"}, {"font-size", "12"}}).Raw("\n");
  const bool shaded_entry = !plot.shaded_legend.empty();
  w.Empty("rect", {{"x", F(lx - 8)}, {"y", F(ly - 12)}, {"width", F(shaded_entry ? 330 : 236)},
                   {"height", F(shaded_entry ? 64 : 44)}, {"fill", "white"}, {"stroke", "#888"}})
      .Raw("\n");
  w.Empty("circle", {{"cx", F(lx + 10)}, {"cy", F(ly)}, {"r", "4"}, {"fill", "#1f77b4"}}).Raw("\n");
  w.Element("text", {{"x", F(lx + 28)}, {"y", F(ly + 4)}}, plot.dots_legend).Raw("\n");
  w.Empty("line", {{"x1", F(lx)}, {"y1", F(ly + 20)}, {"x2", F(lx + 20)}, {"y2", F(ly + 20)}, {"stroke", "#d62728"},
                   {"stroke-width", "2"}})
      .Raw("\n");
  w.Element("text", {{"x", F(lx + 28)}, {"y", F(ly + 24)}}, plot.line_legend).Raw("\n");
  if (shaded_entry) {
    w.Empty("rect", {{"x", F(lx)}, {"y", F(ly + 34)}, {"width", "20"}, {"height", "12"}, {"fill", "#fdd9a8"}}).Raw("\n");
    w.Element("text", {{"x", F(lx + 28)}, {"y", F(ly + 44)}}, plot.shaded_legend).Raw("\n");
  }
  w.Close("g").Raw("\n");
  w.Close("svg").Raw("\n");
  return w.str();
}

}  // namespace mfns::host
