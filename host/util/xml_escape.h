// The one escape for text written into SVG, XML and HTML (issue 15: three copies before).
#pragma once

#include <string>
#include <string_view>

namespace mfns::host {

// s with & < > " ' replaced by entities (the apostrophe as &#39;, which XML, SVG and every
// HTML version read), safe in element text and in quoted attribute values. Other bytes pass
// unchanged (UTF-8 stays UTF-8).
std::string XmlEscape(std::string_view s);

}  // namespace mfns::host
