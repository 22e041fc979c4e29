// Small self-contained SVG charts for report.html: scatter (several series), histogram, bar
// chart and heat map on linear axes with ticks and labels. Standalone SVG 1.1 elements, inlined in HTML,
// written with host/core/svg_writer.h.
#pragma once

#include <string>
#include <vector>

#include "host/util/xml_escape.h"  // XmlEscape, for callers writing text into a page

namespace mfns::host {

struct SvgSeries {
  std::string name;       // legend text
  std::string css_class;  // class of each <circle>
  std::string color;      // fill, e.g. "#1f77b4"
  std::vector<double> x, y;
};

struct SvgChart {
  std::string title, x_label, y_label;
  std::vector<SvgSeries> series;
  bool equal_axes = false;  // same scale on x and y, ranges symmetric about 0 (residual scatter)
};

// Points as <circle class="css_class">; non-finite points are skipped.
std::string ScatterSvg(const SvgChart& chart);
// values binned into `bins` equal bins over their range: <rect class="bar">.
std::string HistogramSvg(const std::vector<double>& values, int bins, const std::string& title,
                         const std::string& x_label);
// One <rect class="bar"> per label, heights from 0.
std::string BarSvg(const std::vector<std::string>& labels, const std::vector<double>& values, const std::string& title,
                   const std::string& y_label);

// A scalar field over an image (e.g. projection uncertainty): cols x rows cells, row-major
// from the top-left, covering a width x height image.
struct HeatmapGrid {
  int cols = 0, rows = 0;
  double width = 0, height = 0;  // the image's size, for the aspect and the caption
  std::vector<double> values;
};
// One <rect class="heat"> per cell coloured on a scale from 0 to the largest finite value
// (non-finite cells grey), the image's aspect kept, and a colour bar (<rect class="scale">)
// labelled in `unit`.
std::string HeatmapSvg(const HeatmapGrid& grid, const std::string& title, const std::string& unit);

}  // namespace mfns::host
