#include "host/util/xml_escape.h"

#include <gtest/gtest.h>

namespace mfns::host {
namespace {

TEST(XmlEscape, EscapesAllFiveAndKeepsTheRest) {
  EXPECT_EQ(XmlEscape("&<>\"'a"), "&amp;&lt;&gt;&quot;&#39;a");
  EXPECT_EQ(XmlEscape(""), "");
  EXPECT_EQ(XmlEscape("x \xc2\xb5m"), "x \xc2\xb5m");  // UTF-8 passes
  EXPECT_EQ(XmlEscape(std::string_view("a\0b", 3)), std::string("a\0b", 3));
  EXPECT_EQ(XmlEscape("&amp;"), "&amp;amp;");  // not idempotent: escape once, at the writer
}

}  // namespace
}  // namespace mfns::host
