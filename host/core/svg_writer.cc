#include "host/core/svg_writer.h"

#include <cmath>
#include <cstdio>

#include "host/util/xml_escape.h"

namespace mfns::host {

void SvgWriter::Tag(std::string_view tag, std::initializer_list<SvgAttr> attrs) {
  out_ += '<';
  out_ += tag;
  Attrs(attrs);
}

void SvgWriter::Attrs(std::initializer_list<SvgAttr> attrs) {
  for (const SvgAttr& a : attrs) {
    out_ += ' ';
    out_ += a.name;
    out_ += "=\"";
    out_ += XmlEscape(a.value);
    out_ += '"';
  }
}

SvgWriter& SvgWriter::Open(std::string_view tag, std::initializer_list<SvgAttr> attrs) {
  Tag(tag, attrs);
  out_ += '>';
  return *this;
}

SvgWriter& SvgWriter::Empty(std::string_view tag, std::initializer_list<SvgAttr> attrs) {
  Tag(tag, attrs);
  out_ += "/>";
  return *this;
}

SvgWriter& SvgWriter::Element(std::string_view tag, std::initializer_list<SvgAttr> attrs, std::string_view text) {
  Open(tag, attrs);
  out_ += XmlEscape(text);
  return Close(tag);
}

SvgWriter& SvgWriter::Close(std::string_view tag) {
  out_ += "</";
  out_ += tag;
  out_ += '>';
  return *this;
}

SvgWriter& SvgWriter::Text(std::string_view text) {
  out_ += XmlEscape(text);
  return *this;
}

SvgWriter& SvgWriter::Raw(std::string_view markup) {
  out_ += markup;
  return *this;
}

SvgWriter& SvgWriter::OpenSvg(std::initializer_list<SvgAttr> attrs) {
  Tag("svg", {{"xmlns", "http://www.w3.org/2000/svg"}});
  Attrs(attrs);
  out_ += '>';
  return *this;
}

std::string Fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string General(double v, int significant) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", significant, v);
  return buf;
}

double NiceStep(double raw, bool with_two_and_a_half, double slack) {
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 2.5, 5.0, 10.0}) {
    if (m == 2.5 && !with_two_and_a_half) continue;
    if (m * p >= raw * (1.0 - slack)) return m * p;
  }
  return 10.0 * p;
}

}  // namespace mfns::host
