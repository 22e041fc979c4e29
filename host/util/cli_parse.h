// The host tools' CLI11 parse (issue 14, found by host_cli_fuzz): CLI11 quotes the arguments as
// given in its messages ("--timeout: Value 6\n0 could not be converted"), so an argument holding
// a newline made a two-line error. A message with control characters is made one line (OneLine);
// every other message, and --help, is CLI11's as it was.
#pragma once

#include <CLI/CLI.hpp>

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "host/util/user_error.h"

namespace mfns::host {

// app.parse(argc, argv), throwing what it throws, a ParseError's message made one line.
inline void ParseOneLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const std::string what = e.what();
    const bool control =
        std::any_of(what.begin(), what.end(), [](char c) { return c == 0x7f || (c >= 0 && c < 0x20); });
    if (e.get_exit_code() == 0 || !control) throw;
    throw CLI::ParseError(OneLine(what), e.get_exit_code());
  }
}

// Words as a writable argv (argv()[argc()] == nullptr), to call the tools' parse-only functions
// from code: their tests and their fuzz target. Not copyable: argv points into the words.
class Argv {
 public:
  explicit Argv(std::vector<std::string> words) : words_(std::move(words)) {
    for (std::string& w : words_) argv_.push_back(w.data());
    argv_.push_back(nullptr);
  }
  Argv(const Argv&) = delete;
  Argv& operator=(const Argv&) = delete;
  int argc() const { return static_cast<int>(words_.size()); }
  char** argv() { return argv_.data(); }

 private:
  std::vector<std::string> words_;
  std::vector<char*> argv_;
};

// `parse` (a tool's parse-only function) on a fresh app and these words; for the tools' tests.
template <typename CommandLine>
CommandLine ParseWords(void (*parse)(CLI::App&, int, char**, CommandLine*), const std::vector<std::string>& words) {
  Argv line(words);
  CLI::App app;
  CommandLine cl;
  parse(app, line.argc(), line.argv(), &cl);
  return cl;
}

}  // namespace mfns::host
