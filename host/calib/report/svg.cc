#include "host/calib/report/svg.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "host/core/svg_writer.h"

namespace mfns::host {
namespace {

constexpr double kW = 420, kH = 320, kLeft = 62, kRight = 16, kTop = 30, kBottom = 46;

struct Axis {
  double lo = 0, hi = 1;
  std::vector<double> ticks;
};

// "Nice" ticks (1, 2, 2.5, 5 x 10^k) covering [lo, hi].
Axis NiceAxis(double lo, double hi, int target = 5) {
  if (!(hi > lo)) {
    const double c = std::isfinite(lo) ? lo : 0.0, h = std::max(1e-12, std::abs(c) * 0.1 + 1e-12);
    lo = c - h;
    hi = c + h;
  }
  const double step = NiceStep((hi - lo) / target);
  Axis a;
  a.lo = std::floor(lo / step) * step;
  a.hi = std::ceil(hi / step) * step;
  for (double t = a.lo; t <= a.hi + 0.5 * step; t += step) a.ticks.push_back(std::abs(t) < 1e-12 * step ? 0.0 : t);
  return a;
}

std::string Num(double v) { return General(v, 4); }
std::string Fmt(double v) { return Fixed(v, 2); }

// A chart's <svg> root, white background and title.
void OpenChart(SvgWriter& w, const std::string& title) {
  w.OpenSvg({{"class", "chart"}, {"width", General(kW)}, {"height", General(kH)},
             {"viewBox", "0 0 " + General(kW) + " " + General(kH)}})
      .Raw("\n");
  w.Empty("rect", {{"x", "0"}, {"y", "0"}, {"width", General(kW)}, {"height", General(kH)}, {"fill", "white"}})
      .Raw("\n");
  w.Element("text", {{"x", General(kW / 2)}, {"y", "18"}, {"text-anchor", "middle"}, {"font-size", "13"}}, title)
      .Raw("\n");
}

class Frame {
 public:
  Frame(const Axis& x, const Axis& y) : x_(x), y_(y) {}
  double X(double v) const { return kLeft + (v - x_.lo) / (x_.hi - x_.lo) * (kW - kLeft - kRight); }
  double Y(double v) const { return kH - kBottom - (v - y_.lo) / (y_.hi - y_.lo) * (kH - kTop - kBottom); }

  // The chart's <svg>, background, title, grid with tick labels, plot frame and axis labels.
  void Open(SvgWriter& w, const std::string& title, const std::string& xl, const std::string& yl,
            bool x_ticks = true) const {
    OpenChart(w, title);
    for (double t : y_.ticks) {
      w.Empty("line", {{"x1", Fmt(kLeft)}, {"x2", Fmt(kW - kRight)}, {"y1", Fmt(Y(t))}, {"y2", Fmt(Y(t))},
                       {"stroke", "#ddd"}});
      w.Element("text", {{"x", Fmt(kLeft - 4)}, {"y", Fmt(Y(t) + 4)}, {"text-anchor", "end"}, {"font-size", "10"}},
                Num(t))
          .Raw("\n");
    }
    if (x_ticks)
      for (double t : x_.ticks) {
        w.Empty("line", {{"x1", Fmt(X(t))}, {"x2", Fmt(X(t))}, {"y1", Fmt(kTop)}, {"y2", Fmt(kH - kBottom)},
                         {"stroke", "#ddd"}});
        w.Element("text", {{"x", Fmt(X(t))}, {"y", Fmt(kH - kBottom + 14)}, {"text-anchor", "middle"},
                           {"font-size", "10"}},
                  Num(t))
            .Raw("\n");
      }
    w.Empty("rect", {{"x", Fmt(kLeft)}, {"y", Fmt(kTop)}, {"width", Fmt(kW - kLeft - kRight)},
                     {"height", Fmt(kH - kTop - kBottom)}, {"fill", "none"}, {"stroke", "#444"}})
        .Raw("\n");
    w.Element("text", {{"x", Fmt((kLeft + kW - kRight) / 2)}, {"y", Fmt(kH - 8)}, {"text-anchor", "middle"},
                       {"font-size", "11"}},
              xl)
        .Raw("\n");
    const std::string yc = Fmt((kTop + kH - kBottom) / 2);
    w.Element("text", {{"x", "14"}, {"y", yc}, {"text-anchor", "middle"}, {"font-size", "11"},
                       {"transform", "rotate(-90 14 " + yc + ")"}},
              yl)
        .Raw("\n");
  }

 private:
  Axis x_, y_;
};

// A perceptually ordered colour for t in [0, 1] (viridis' end points and three between).
std::string HeatColour(double t) {
  static const double kStops[5][3] = {{68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}};
  t = std::clamp(t, 0.0, 1.0) * 4.0;
  const int i = std::min(3, static_cast<int>(t));
  const double f = t - i;
  char buf[8];
  int rgb[3];
  for (int c = 0; c < 3; ++c)
    rgb[c] = static_cast<int>(std::lround(kStops[i][c] + f * (kStops[i + 1][c] - kStops[i][c])));
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", rgb[0], rgb[1], rgb[2]);
  return buf;
}

}  // namespace

std::string ScatterSvg(const SvgChart& c) {
  double xlo = 1e300, xhi = -1e300, ylo = 1e300, yhi = -1e300;
  for (const SvgSeries& s : c.series)
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      xlo = std::min(xlo, s.x[i]);
      xhi = std::max(xhi, s.x[i]);
      ylo = std::min(ylo, s.y[i]);
      yhi = std::max(yhi, s.y[i]);
    }
  if (xlo > xhi) xlo = xhi = ylo = yhi = 0.0;
  if (c.equal_axes) {
    const double m = std::max({std::abs(xlo), std::abs(xhi), std::abs(ylo), std::abs(yhi), 1e-6});
    xlo = ylo = -m;
    xhi = yhi = m;
  }
  const Axis ax = NiceAxis(xlo, xhi), ay = NiceAxis(ylo, yhi);
  const Frame f(ax, ay);
  SvgWriter w;
  f.Open(w, c.title, c.x_label, c.y_label);
  double ly = kTop + 12;
  for (const SvgSeries& s : c.series) {
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      w.Empty("circle", {{"class", s.css_class}, {"cx", Fmt(f.X(s.x[i]))}, {"cy", Fmt(f.Y(s.y[i]))}, {"r", "2"},
                         {"fill", s.color}, {"fill-opacity", "0.6"}})
          .Raw("\n");
    }
    if (c.series.size() > 1) {
      w.Empty("circle", {{"cx", Fmt(kW - kRight - 90)}, {"cy", Fmt(ly - 4)}, {"r", "4"}, {"fill", s.color}});
      w.Element("text", {{"x", Fmt(kW - kRight - 82)}, {"y", Fmt(ly)}, {"font-size", "10"}}, s.name).Raw("\n");
      ly += 14;
    }
  }
  w.Close("svg").Raw("\n");
  return w.str();
}

std::string HistogramSvg(const std::vector<double>& values, int bins, const std::string& title, const std::string& x_label) {
  double lo = 1e300, hi = -1e300;
  for (double v : values)
    if (std::isfinite(v)) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  if (lo > hi) lo = hi = 0.0;
  const Axis ax = NiceAxis(lo, hi);
  bins = std::max(1, bins);
  std::vector<int> count(static_cast<std::size_t>(bins), 0);
  const double w = (ax.hi - ax.lo) / bins;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    const int b = std::clamp(static_cast<int>((v - ax.lo) / w), 0, bins - 1);
    ++count[static_cast<std::size_t>(b)];
  }
  const int most = *std::max_element(count.begin(), count.end());
  const Axis ay = NiceAxis(0.0, std::max(1, most));
  const Frame f(ax, ay);
  SvgWriter o;
  f.Open(o, title, x_label, "count");
  for (int b = 0; b < bins; ++b) {
    const double x0 = f.X(ax.lo + b * w), x1 = f.X(ax.lo + (b + 1) * w), y = f.Y(count[static_cast<std::size_t>(b)]);
    o.Empty("rect", {{"class", "bar"}, {"x", Fmt(x0)}, {"y", Fmt(y)}, {"width", Fmt(std::max(0.5, x1 - x0 - 0.5))},
                     {"height", Fmt(f.Y(0.0) - y)}, {"fill", "#4c72b0"}})
        .Raw("\n");
  }
  o.Close("svg").Raw("\n");
  return o.str();
}

std::string BarSvg(const std::vector<std::string>& labels, const std::vector<double>& values, const std::string& title,
                   const std::string& y_label) {
  double hi = 0;
  for (double v : values)
    if (std::isfinite(v)) hi = std::max(hi, v);
  const Axis ax{0.0, static_cast<double>(std::max<std::size_t>(1, values.size())), {}};
  const Axis ay = NiceAxis(0.0, hi > 0 ? hi : 1.0);
  const Frame f(ax, ay);
  SvgWriter o;
  f.Open(o, title, "image", y_label, false);
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double v = std::isfinite(values[i]) ? values[i] : 0.0;
    const double x0 = f.X(static_cast<double>(i) + 0.1), x1 = f.X(static_cast<double>(i) + 0.9), y = f.Y(v);
    const std::string label = i < labels.size() ? labels[i] : "";
    o.Open("rect", {{"class", "bar"}, {"x", Fmt(x0)}, {"y", Fmt(y)}, {"width", Fmt(x1 - x0)},
                    {"height", Fmt(f.Y(0.0) - y)}, {"fill", "#55a868"}})
        .Element("title", {}, label + ": " + Num(v))
        .Close("rect")
        .Raw("\n");
    if (values.size() <= 32 && i < labels.size())
      o.Element("text", {{"x", Fmt((x0 + x1) / 2)}, {"y", Fmt(kH - kBottom + 12)}, {"text-anchor", "middle"},
                         {"font-size", "8"}},
                labels[i])
          .Raw("\n");
  }
  o.Close("svg").Raw("\n");
  return o.str();
}

std::string HeatmapSvg(const HeatmapGrid& g, const std::string& title, const std::string& unit) {
  double hi = 0;
  for (double v : g.values)
    if (std::isfinite(v)) hi = std::max(hi, v);
  const Axis scale = NiceAxis(0.0, hi > 0 ? hi : 1.0);
  // The image keeps its aspect inside the plot area; the colour bar sits right of it.
  const double area_w = kW - kLeft - kRight - 70, area_h = kH - kTop - kBottom;
  const double aspect = g.height > 0 ? g.width / g.height : 1.0;
  const double img_w = std::min(area_w, area_h * aspect), img_h = img_w / aspect;
  const double cw = img_w / std::max(1, g.cols), ch = img_h / std::max(1, g.rows);
  SvgWriter o;
  OpenChart(o, title);
  for (int r = 0; r < g.rows; ++r)
    for (int c = 0; c < g.cols; ++c) {
      const double v = g.values[static_cast<std::size_t>(r * g.cols + c)];
      o.Empty("rect", {{"class", "heat"},
                       {"x", Fmt(kLeft + c * cw)},
                       {"y", Fmt(kTop + r * ch)},
                       {"width", Fmt(cw + 0.3)},
                       {"height", Fmt(ch + 0.3)},
                       {"fill", std::isfinite(v) ? HeatColour(v / scale.hi) : "#cccccc"},
                       {"shape-rendering", "crispEdges"}});
    }
  o.Raw("\n");
  o.Empty("rect", {{"x", Fmt(kLeft)},
                   {"y", Fmt(kTop)},
                   {"width", Fmt(img_w)},
                   {"height", Fmt(img_h)},
                   {"fill", "none"},
                   {"stroke", "#444"}})
      .Raw("\n");
  o.Element(
       "text",
       {{"x", Fmt(kLeft + img_w / 2)}, {"y", Fmt(kTop + img_h + 14)}, {"text-anchor", "middle"}, {"font-size", "10"}},
       General(g.width, 5) + " x " + General(g.height, 5) + " px")
      .Raw("\n");
  // Colour bar: 32 steps from 0 to the top tick, labelled at the ticks.
  const double bx = kLeft + img_w + 24, steps = 32;
  for (int i = 0; i < steps; ++i)
    o.Empty("rect", {{"class", "scale"},
                     {"x", Fmt(bx)},
                     {"y", Fmt(kTop + img_h * (1 - (i + 1) / steps))},
                     {"width", "12"},
                     {"height", Fmt(img_h / steps + 0.3)},
                     {"fill", HeatColour((i + 0.5) / steps)}});
  for (double t : scale.ticks)
    o.Element("text", {{"x", Fmt(bx + 16)}, {"y", Fmt(kTop + img_h * (1 - t / scale.hi) + 4)}, {"font-size", "10"}},
              Num(t));
  o.Element("text", {{"x", Fmt(bx)}, {"y", Fmt(kTop - 6)}, {"font-size", "10"}}, unit).Raw("\n");
  o.Close("svg").Raw("\n");
  return o.str();
}

}  // namespace mfns::host
