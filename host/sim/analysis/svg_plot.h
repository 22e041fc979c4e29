// A small self-contained SVG line plot: Monte Carlo dots and an analytic line on linear axes
// with ticks, axis labels, a title and a legend. No plotting library; the output is standalone
// SVG 1.1 (XML), viewable in any browser, written with host/core/svg_writer.h.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "host/util/xml_escape.h"  // XmlEscape, for callers writing text into a plot

namespace mfns::host {

struct SvgPlot {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<double> dots_x, dots_y;  // drawn as <circle class="mc">, one per point
  std::string dots_legend = "Monte Carlo";
  std::vector<double> line_x, line_y;  // drawn as one <polyline class="analytic">
  std::string line_legend = "first-order analytic";
  // Optional: a colour per dot (an SVG colour; missing or empty: the default blue), and x spans
  // drawn as light bands behind the data (e.g. a fault's duration) with their legend entry.
  std::vector<std::string> dots_fill;
  std::vector<std::pair<double, double>> shaded_x;
  std::string shaded_legend;
};

// Renders the plot. Axes start at 0 and end at a "nice" value (1, 2, 2.5, 5 x 10^k) at or above
// the largest value; non-finite values are skipped. Text is XML-escaped.
std::string RenderSvg(const SvgPlot& plot);

// Tick positions 0, step, 2 step, ... covering [0, max] with about `target` intervals, step a
// 1, 2, 2.5 or 5 times a power of ten; the last tick is >= max. max <= 0 gives {0, 1}.
std::vector<double> NiceTicks(double max, int target = 5);


}  // namespace mfns::host
