// Test helpers: a minimal XML well-formedness check (one root, balanced and properly nested
// tags, quoted attributes, only the five predefined or numeric entities), written here so the
// SVG tests need no XML library. Counts the plot's elements for structural assertions.
#pragma once

#include <cctype>
#include <string>
#include <vector>

namespace mfns::host {

struct XmlSummary {
  bool ok = false;
  std::string error;
  std::string root;
  int elements = 0;
  int mc_circles = 0;          // <circle class="mc">
  int analytic_polylines = 0;  // <polyline class="analytic">
};

// How often `what` occurs in `text` (elements of a class, say).
inline int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

inline XmlSummary CheckXml(const std::string& s) {
  XmlSummary r;
  std::size_t i = 0;
  std::vector<std::string> stack;
  bool root_done = false;
  const auto fail = [&](const std::string& why) {
    r.ok = false;
    r.error = why + " at byte " + std::to_string(i);
    return r;
  };
  const auto is_name = [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == ':' || c == '.';
  };
  // An entity starting at s[i] == '&'; advances i past it.
  const auto entity = [&]() {
    const std::size_t end = s.find(';', i);
    if (end == std::string::npos || end - i > 10) return false;
    const std::string e = s.substr(i + 1, end - i - 1);
    bool good = e == "amp" || e == "lt" || e == "gt" || e == "quot" || e == "apos";
    if (!good && e.size() > 1 && e[0] == '#') {
      good = true;
      const bool hex = e[1] == 'x';
      for (std::size_t k = hex ? 2 : 1; k < e.size(); ++k) {
        const auto c = static_cast<unsigned char>(e[k]);
        good = good && (hex ? std::isxdigit(c) : std::isdigit(c));
      }
    }
    i = end + 1;
    return good;
  };
  while (i < s.size()) {
    if (s.compare(i, 5, "<?xml") == 0 && i == 0) {
      const std::size_t end = s.find("?>", i);
      if (end == std::string::npos) return fail("unterminated declaration");
      i = end + 2;
    } else if (s.compare(i, 4, "<!--") == 0) {
      const std::size_t end = s.find("-->", i);
      if (end == std::string::npos) return fail("unterminated comment");
      i = end + 3;
    } else if (s.compare(i, 2, "</") == 0) {
      i += 2;
      std::string name;
      while (i < s.size() && is_name(s[i])) name += s[i++];
      while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
      if (i >= s.size() || s[i] != '>') return fail("bad end tag");
      ++i;
      if (stack.empty() || stack.back() != name) return fail("mismatched end tag </" + name + ">");
      stack.pop_back();
      if (stack.empty()) root_done = true;
    } else if (s[i] == '<') {
      ++i;
      std::string name;
      while (i < s.size() && is_name(s[i])) name += s[i++];
      if (name.empty()) return fail("empty tag name");
      if (root_done) return fail("second root element");
      if (stack.empty()) r.root = name;
      std::string cls;
      std::vector<std::string> seen;
      bool self_closing = false;
      for (;;) {
        while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i;
        if (i >= s.size()) return fail("unterminated tag");
        if (s[i] == '>') { ++i; break; }
        if (s.compare(i, 2, "/>") == 0) { i += 2; self_closing = true; break; }
        std::string attr;
        while (i < s.size() && is_name(s[i])) attr += s[i++];
        if (attr.empty() || i >= s.size() || s[i] != '=') return fail("bad attribute in <" + name + ">");
        for (const std::string& a : seen)
          if (a == attr) return fail("duplicate attribute " + attr);
        seen.push_back(attr);
        ++i;
        if (i >= s.size() || (s[i] != '"' && s[i] != '\'')) return fail("unquoted attribute " + attr);
        const char q = s[i++];
        std::string value;
        while (i < s.size() && s[i] != q) {
          if (s[i] == '<') return fail("'<' in attribute " + attr);
          if (s[i] == '&') {
            if (!entity()) return fail("bad entity in attribute " + attr);
            continue;
          }
          value += s[i++];
        }
        if (i >= s.size()) return fail("unterminated attribute " + attr);
        ++i;
        if (attr == "class") cls = value;
      }
      ++r.elements;
      if (name == "circle" && cls == "mc") ++r.mc_circles;
      if (name == "polyline" && cls == "analytic") ++r.analytic_polylines;
      if (self_closing) {
        if (stack.empty()) root_done = true;
      } else {
        stack.push_back(name);
      }
    } else if (s[i] == '&') {
      if (!entity()) return fail("bad entity in text");
    } else {
      if (stack.empty() && !std::isspace(static_cast<unsigned char>(s[i]))) return fail("text outside the root");
      ++i;
    }
  }
  if (!stack.empty()) return fail("unclosed <" + stack.back() + ">");
  if (r.root.empty()) return fail("no root element");
  r.ok = true;
  return r;
}

}  // namespace mfns::host
