#include "host/core/svg_writer.h"

#include <gtest/gtest.h>

namespace mfns::host {
namespace {

TEST(SvgWriter, AttributesInTheCallersOrderAndNoWhiteSpaceAdded) {
  SvgWriter w;
  w.OpenSvg({{"width", "420"}, {"height", "320"}}).Raw("\n");
  w.Empty("line", {{"x1", "1.00"}, {"x2", "2.00"}, {"y1", "3.00"}});
  w.Element("text", {{"x", "5"}}, "t").Raw("\n");
  w.Open("g").Close("g").Close("svg");
  EXPECT_EQ(w.str(),
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"420\" height=\"320\">\n"
            "<line x1=\"1.00\" x2=\"2.00\" y1=\"3.00\"/><text x=\"5\">t</text>\n"
            "<g></g></svg>");
}

TEST(SvgWriter, EscapesEveryAttributeValueAndTextButNotRawMarkup) {
  SvgWriter w;
  w.Element("text", {{"class", "a\"b"}, {"fill", "<&>"}}, "x < y & 'z'").Text("\"").Raw("<br/>");
  EXPECT_EQ(w.str(), "<text class=\"a&quot;b\" fill=\"&lt;&amp;&gt;\">x &lt; y &amp; &#39;z&#39;</text>&quot;<br/>");
}

TEST(SvgWriter, NumbersAsPrintfFormatsThem) {
  EXPECT_EQ(Fixed(3.14159), "3.14");
  EXPECT_EQ(Fixed(2.5, 0), "2");  // round half to even, as printf does
  EXPECT_EQ(Fixed(-0.004, 2), "-0.00");
  EXPECT_EQ(General(420.0), "420");  // an ostream's default
  EXPECT_EQ(General(0.000123456789), "0.000123457");
  EXPECT_EQ(General(1234.5678, 4), "1235");
}

TEST(SvgWriter, NiceStepIsOneTwoTwoAndAHalfOrFiveTimesAPowerOfTen) {
  EXPECT_DOUBLE_EQ(NiceStep(0.034), 0.05);
  EXPECT_DOUBLE_EQ(NiceStep(2.46), 2.5);
  EXPECT_DOUBLE_EQ(NiceStep(2.46, false), 5.0);
  EXPECT_DOUBLE_EQ(NiceStep(7.0), 10.0);
  EXPECT_DOUBLE_EQ(NiceStep(1.0), 1.0);
  EXPECT_DOUBLE_EQ(NiceStep(2.0 * (1 + 1e-12), true, 1e-9), 2.0);  // the slack takes a rounding error
  EXPECT_DOUBLE_EQ(NiceStep(2.0 * (1 + 1e-12)), 2.5);
}

}  // namespace
}  // namespace mfns::host
