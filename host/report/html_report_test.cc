#include "host/report/html_report.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "host/core/xml_check_test_util.h"

namespace mfns::host {
namespace {

// The <svg id="id"> ... </svg> element of a page.
std::string SvgById(const std::string& html, const std::string& id) {
  const std::size_t a = html.find("<svg xmlns=\"http://www.w3.org/2000/svg\" id=\"" + id + "\"");
  if (a == std::string::npos) return "";
  const std::size_t b = html.find("</svg>", a);
  return html.substr(a, b + 6 - a);
}

PoseSeries SweepWithKnownErrors() {
  PoseSeries s;
  s.cameras = {"x", "y", "z"};
  for (int k = 0; k < 10; ++k) {
    PoseSample p;
    p.frame = k;
    p.yaw_true_deg = 36.0 * k;
    p.status = k == 7 ? "lost" : (k == 3 ? "degraded" : "fix");
    p.error = {0.1 * k, -0.2, 0.3, 0.01, -0.02, 0.03 * (k - 5)};
    p.n_beacons = 3 + k % 2;
    p.rms_px = 0.1 + 0.01 * k;
    p.visible_per_camera = {k % 3, 1, 2};
    s.samples.push_back(p);
  }
  return s;
}

TEST(HtmlReport, HasTheFourPlotsWithOnePointPerPose) {
  ReportInputs in;
  in.runs.push_back({"ours", SweepWithKnownErrors()});
  in.table5 = CellTable{"Table 5 <caption>", {"axis", "a<b"}, {{"x_mm", "1 & 2"}, {"y_mm", "3"}}, {"note <1>"}, 1};
  in.notes = {"simulation: /tmp/x"};
  const std::string html = RenderReportHtml(in);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  // Table 5 as a table, every cell escaped; no Table 3 (no rows).
  const std::size_t t5 = html.find("<table id=\"table5\">");
  ASSERT_NE(t5, std::string::npos);
  const std::string table = html.substr(t5, html.find("</ul>", t5) - t5);
  EXPECT_NE(table.find("<caption>Table 5 &lt;caption&gt;</caption>"), std::string::npos) << table;
  EXPECT_NE(table.find("<th scope=\"col\">a&lt;b</th>"), std::string::npos) << table;
  EXPECT_NE(table.find("<tr><th scope=\"row\" class=\"key\">x_mm</th><td>1 &amp; 2</td></tr>"), std::string::npos) << table;
  EXPECT_EQ(Count(table, "<tr>"), 3);  // the header and two rows
  EXPECT_NE(table.find("<li>note &lt;1&gt;</li>"), std::string::npos);
  EXPECT_TRUE(CheckXml(table.substr(0, table.find("</table>") + 8)).ok);
  EXPECT_EQ(html.find("table3"), std::string::npos);
  for (const char* id : {"pose-error-position", "pose-error-attitude", "beacons-per-camera", "residuals"}) {
    const std::string svg = SvgById(html, id);
    ASSERT_FALSE(svg.empty()) << id;
    const XmlSummary x = CheckXml(svg);
    EXPECT_TRUE(x.ok) << id << ": " << x.error;
  }
  // 9 frame sets with a pose (one lost): 3 series of 9 dots per pose-error plot.
  EXPECT_EQ(Count(SvgById(html, "pose-error-position"), "<circle"), 27);
  EXPECT_EQ(Count(SvgById(html, "pose-error-attitude"), "<g class=\"series\""), 3);
  EXPECT_EQ(Count(SvgById(html, "residuals"), "<circle"), 9);
  // Three cameras in view as lines, plus the beacons used as 9 + 1 (lost still reports) dots.
  const std::string b = SvgById(html, "beacons-per-camera");
  EXPECT_EQ(Count(b, "<polyline"), 3);
  EXPECT_EQ(Count(b, "<circle"), 10);
  EXPECT_NE(b.find("in view, camera z"), std::string::npos);
}

TEST(HtmlReport, ChartMapsDataIntoThePlotArea) {
  Chart c;
  c.id = "t";
  c.series.push_back({"s", {-1.0, 0.0, 1.0, NAN}, {-2.0, 0.5, 2.0, 1.0}, false});
  const std::string svg = RenderChart(c);
  EXPECT_TRUE(CheckXml(svg).ok);
  EXPECT_EQ(Count(svg, "<circle"), 3);  // the NaN point is skipped
  // Every circle lies inside the frame rect (70..610 x 36..274).
  int seen = 0;
  for (std::size_t p = svg.find("<circle cx=\""); p != std::string::npos; p = svg.find("<circle cx=\"", p + 1), ++seen) {
    const std::size_t x0 = p + 12, y0 = svg.find("cy=\"", x0) + 4;
    const double cx = std::stod(svg.substr(x0)), cy = std::stod(svg.substr(y0));
    EXPECT_GE(cx, 70.0);
    EXPECT_LE(cx, 610.0);
    EXPECT_GE(cy, 36.0);
    EXPECT_LE(cy, 274.0);
  }
  EXPECT_EQ(seen, 3);
  // The extreme points sit on the frame when the range is already "nice" (-1..1, -2..2).
  EXPECT_NE(svg.find("cx=\"70.00\" cy=\"274.00\""), std::string::npos) << svg;
  EXPECT_NE(svg.find("cx=\"610.00\" cy=\"36.00\""), std::string::npos);
}

}  // namespace
}  // namespace mfns::host
