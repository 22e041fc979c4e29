#include "host/sim/analysis/svg_plot.h"

#include <gtest/gtest.h>

#include "host/core/xml_check_test_util.h"

namespace mfns::host {
namespace {

TEST(SvgPlot, NiceTicksCoverTheRangeWithRoundSteps) {
  EXPECT_EQ(NiceTicks(3.0), (std::vector<double>{0.0, 1.0, 2.0, 3.0}));
  const std::vector<double> t = NiceTicks(0.17);
  ASSERT_EQ(t.size(), 5u);  // 0.17 / 5 = 0.034 rounds up to the nice step 0.05: 0 .. 0.2
  EXPECT_NEAR(t[1], 0.05, 1e-12);
  EXPECT_GE(t.back(), 0.17);
  EXPECT_EQ(NiceTicks(12.3).back(), 12.5);  // step 2.5
  EXPECT_EQ(NiceTicks(0.0), (std::vector<double>{0.0, 1.0}));
}

TEST(SvgPlot, IsWellFormedWithOneCirclePerDotAndEscapedText) {
  SvgPlot p;
  p.title = "u error <vs> \"beacon\" & co";
  p.x_label = "error (mm)";
  p.y_label = "RMS u (px)";
  p.dots_x = {0, 1, 2, 3};
  p.dots_y = {0, 2.9, 5.8, 8.8};
  p.line_x = {0, 3};
  p.line_y = {0, 8.7};
  const std::string svg = RenderSvg(p);
  const XmlSummary x = CheckXml(svg);
  ASSERT_TRUE(x.ok) << x.error;
  EXPECT_EQ(x.root, "svg");
  EXPECT_EQ(x.mc_circles, 4);
  EXPECT_EQ(x.analytic_polylines, 1);
  EXPECT_NE(svg.find("u error &lt;vs&gt; &quot;beacon&quot; &amp; co"), std::string::npos);
}

// host/sim/faults: dots coloured one by one, a shaded span (a fault) with its legend entry; the
// x axis reaches the span's end even beyond the data.
TEST(SvgPlot, ColouredDotsAndAShadedSpan) {
  SvgPlot p;
  p.dots_x = {0, 1, 2};
  p.dots_y = {1, 2, 0};
  p.dots_fill = {"", "#ff7f0e", "#d62728"};
  p.shaded_x = {{1.5, 7.0}};
  p.shaded_legend = "the fault";
  const std::string svg = RenderSvg(p);
  const XmlSummary x = CheckXml(svg);
  ASSERT_TRUE(x.ok) << x.error;
  EXPECT_EQ(x.mc_circles, 3);
  EXPECT_NE(svg.find("fill=\"#ff7f0e\""), std::string::npos);
  EXPECT_NE(svg.find("fill=\"#d62728\""), std::string::npos);
  EXPECT_NE(svg.find("class=\"shaded\""), std::string::npos);
  EXPECT_NE(svg.find(">the fault<"), std::string::npos);
  EXPECT_NE(svg.find(">8<"), std::string::npos) << "x ticks reach the span's end (7 -> 8, step 2)";
}

TEST(SvgPlot, TheCheckerRejectsBrokenXml) {
  EXPECT_FALSE(CheckXml("<svg><g></svg>").ok);
  EXPECT_FALSE(CheckXml("<svg a=\"1></svg>").ok);
  EXPECT_FALSE(CheckXml("<svg>a & b</svg>").ok);
  EXPECT_FALSE(CheckXml("<svg></svg><svg></svg>").ok);
  EXPECT_TRUE(CheckXml("<?xml version=\"1.0\"?>\n<svg><circle class=\"mc\"/></svg>\n").ok);
}


}  // namespace
}  // namespace mfns::host
