// The one writer of SVG (and the XML/HTML around it) for every host report (issue 15: three
// hand-written copies before, host/calib/report/svg.cc, host/report/html_report.cc and
// host/sim/analysis/svg_plot.cc). It writes elements with their attributes in the caller's
// order and XML-escapes every attribute value and every text (host/util/xml_escape.h), so no
// caller writes markup by hand; numbers are formatted by the caller with the helpers below,
// so each chart keeps its own precision. It adds no white space: line breaks are the caller's
// (Raw("\n")), so the charts' bytes stay what they were.
#pragma once

#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

namespace mfns::host {

// One attribute: its name and its (unescaped) value.
struct SvgAttr {
  std::string_view name;
  std::string value;
};

class SvgWriter {
 public:
  // <tag a="v" ...> (Open), <tag a="v" .../> (Empty), <tag a="v" ...>text</tag> (Element).
  SvgWriter& Open(std::string_view tag, std::initializer_list<SvgAttr> attrs = {});
  SvgWriter& Empty(std::string_view tag, std::initializer_list<SvgAttr> attrs = {});
  SvgWriter& Element(std::string_view tag, std::initializer_list<SvgAttr> attrs, std::string_view text);
  SvgWriter& Close(std::string_view tag);  // </tag>
  SvgWriter& Text(std::string_view text);  // escaped character data
  SvgWriter& Raw(std::string_view markup);  // written as it is: line breaks, a whole nested chart
  // The <svg> root with the SVG namespace, then `attrs` (width, height, viewBox, ...).
  SvgWriter& OpenSvg(std::initializer_list<SvgAttr> attrs);

  const std::string& str() const { return out_; }

 private:
  void Tag(std::string_view tag, std::initializer_list<SvgAttr> attrs);
  void Attrs(std::initializer_list<SvgAttr> attrs);
  std::string out_;
};

// Numbers as the charts print them: printf's "%.*f" and "%.*g" (General(v) = an ostream's default).
std::string Fixed(double v, int decimals = 2);
std::string General(double v, int significant = 6);

// The "nice" step for an axis: the smallest m x 10^k at or above raw * (1 - slack), m from
// {1, 2, 2.5, 5} (or {1, 2, 5} without 2.5); raw > 0.
double NiceStep(double raw, bool with_two_and_a_half = true, double slack = 0.0);

}  // namespace mfns::host
