// Fuzz support for the host's text parsers: the input split into parts, and the one check every
// host error must pass (a UserError is one line that starts with what it names).
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mfns::fuzz {

// The input as text, cut into at most max_parts parts at each "\n---8<---\n" (a separator no
// parser gives a meaning to), so that one input can hold several files.
inline std::vector<std::string> SplitParts(const std::uint8_t* data, std::size_t size, std::size_t max_parts) {
  static const std::string kCut = "\n---8<---\n";
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> parts;
  std::size_t from = 0;
  while (parts.size() + 1 < max_parts) {
    const std::size_t at = text.find(kCut, from);
    if (at == std::string::npos) break;
    parts.push_back(text.substr(from, at - from));
    from = at + kCut.size();
  }
  parts.push_back(text.substr(from));
  parts.resize(max_parts);
  return parts;
}

// The input as a command line's words: `tool` (argv[0]), then the input cut at each NUL byte
// into at most max_args words (what a shell passes: a word holds anything but NUL).
inline std::vector<std::string> SplitWords(const char* tool, const std::uint8_t* data, std::size_t size,
                                           std::size_t max_args) {
  std::vector<std::string> words{tool};
  const std::string text(reinterpret_cast<const char*>(data), size);
  for (std::size_t from = 0; from <= text.size() && words.size() <= max_args;) {
    const std::size_t nul = std::min(text.find('\0', from), text.size());
    words.push_back(text.substr(from, nul - from));
    from = nul + 1;
  }
  return words;
}

// A host error message: one line, starting with `prefix` (the file or option it names).
inline void CheckMessage(const std::string& what, const std::string& prefix) {
  if (what.rfind(prefix, 0) != 0 || what.find('\n') != std::string::npos || what.find('\0') != std::string::npos)
    __builtin_trap();
}

}  // namespace mfns::fuzz
