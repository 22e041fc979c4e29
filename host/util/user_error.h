// The host tools' one error type for what a user can fix (a bad file, field, option or device).
#pragma once

#include <stdexcept>
#include <string>

namespace mfns::host {

// A user-facing error: what() is one line naming the file, field or device and what is wrong.
// Tools print it as "<tool>: <what>" and exit 1.
class UserError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Text a user gave (a file's scalar, an argument; yaml-cpp's and CLI11's messages quoting it) made
// fit for a one-line error: control characters escaped (a newline as \n, others as \xHH), cut
// after 240 characters with "...". (Found by rig_yaml_fuzz: "unknown escape character" quoted a
// raw newline; by host_cli_fuzz: arguments holding a newline.)
inline std::string OneLine(const std::string& text) {
  constexpr std::size_t kMaxChars = 240;
  std::string out;
  for (const char ch : text) {
    if (out.size() >= kMaxChars) return out + "...";
    const auto c = static_cast<unsigned char>(ch);
    if (c == '\n') {
      out += "\\n";
    } else if (c < 0x20 || c == 0x7f) {
      constexpr char kHex[] = "0123456789abcdef";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    } else {
      out += ch;
    }
  }
  return out;
}

}  // namespace mfns::host
