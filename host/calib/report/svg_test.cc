#include "host/calib/report/svg.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "host/core/xml_check_test_util.h"

namespace mfns::host {
namespace {

TEST(CalibReportSvg, ScatterHasACirclePerFinitePointALegendAndEscapedText) {
  SvgChart c;
  c.title = "residuals <z> & \"x\"";
  c.x_label = "u (px)";
  c.y_label = "v (px)";
  c.equal_axes = true;
  c.series.push_back({"turntable", "res-turntable", "#1f77b4", {0.1, -0.2, NAN}, {0.3, 0.0, 1.0}});
  c.series.push_back({"free <views>", "res-free", "#d62728", {0.05}, {-0.05}});
  const std::string svg = ScatterSvg(c);
  const XmlSummary x = CheckXml(svg);
  ASSERT_TRUE(x.ok) << x.error;
  EXPECT_EQ(x.root, "svg");
  EXPECT_EQ(Count(svg, "class=\"res-turntable\""), 2);  // the NaN point is left out
  EXPECT_EQ(Count(svg, "class=\"res-free\""), 1);
  EXPECT_NE(svg.find(">residuals &lt;z&gt; &amp; &quot;x&quot;<"), std::string::npos);
  EXPECT_NE(svg.find(">free &lt;views&gt;<"), std::string::npos) << "two series: a legend";
}

TEST(CalibReportSvg, HistogramHasABarPerBinAndBarsTitleEachImage) {
  std::vector<double> v;
  for (int i = 0; i < 50; ++i) v.push_back(0.01 * i);
  const std::string h = HistogramSvg(v, 12, "norms", "px");
  ASSERT_TRUE(CheckXml(h).ok) << CheckXml(h).error;
  EXPECT_EQ(Count(h, "<rect class=\"bar\""), 12);

  const std::string b = BarSvg({"000", "a&b"}, {0.2, NAN}, "per image", "RMS (px)");
  ASSERT_TRUE(CheckXml(b).ok) << CheckXml(b).error;
  EXPECT_EQ(Count(b, "<rect class=\"bar\""), 2);
  EXPECT_NE(b.find("<title>000: 0.2</title>"), std::string::npos);
  EXPECT_NE(b.find("<title>a&amp;b: 0</title>"), std::string::npos) << "a non-finite value draws as 0";
}

TEST(CalibReportSvg, HeatmapHasACellPerValueColouredOnItsScale) {
  HeatmapGrid g{4, 3, 1280, 1024, {0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, NAN}};
  const std::string svg = HeatmapSvg(g, "camera <x>: sigma", "px");
  const XmlSummary x = CheckXml(svg);
  ASSERT_TRUE(x.ok) << x.error;
  EXPECT_EQ(Count(svg, "<rect class=\"heat\""), 12);
  EXPECT_EQ(Count(svg, "<rect class=\"scale\""), 32);
  // The scale runs from 0 (viridis' dark purple) to the top tick, 1 here (its yellow); NaN is grey.
  EXPECT_EQ(Count(svg, "fill=\"#440154\""), 1);
  EXPECT_EQ(Count(svg, "fill=\"#fde725\""), 1);
  EXPECT_EQ(Count(svg, "fill=\"#cccccc\""), 1);
  EXPECT_NE(svg.find(">camera &lt;x&gt;: sigma<"), std::string::npos);
  EXPECT_NE(svg.find(">1280 x 1024 px<"), std::string::npos);
}

}  // namespace
}  // namespace mfns::host
