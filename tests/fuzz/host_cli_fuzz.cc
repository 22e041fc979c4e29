// libFuzzer target for the host tools' command lines (issue 14): mfns-calib, mfns-sim and
// mfns-flash (CLI11) and mfns-paramctl (getopt_long), through the parse-only entry points each
// tool runs before anything else (calib_cli.h, sim_cli.h, flash_cli.h, paramctl.h), with the
// option definitions the tools use: nothing runs, nothing is read or written.
//
// The first input byte selects the tool (its value mod 4: '0' calib, '1' sim, '2' flash, '3'
// paramctl in the seeds); the rest is cut at NUL bytes into at most 32 arguments. One target
// for the four, not four targets: the parsers take the same input (words) under the same
// contract, so one corpus carries what libFuzzer finds for one tool (--out, --store, ssh://
// targets, numbers at a range's edge) over to the others, and the fuzz preset keeps one build
// and one ctest slot for them (its ~4 min run).
//
// Checked on every input: the parse returns with a command, or throws CLI::ParseError or
// UserError whose message is one non-empty line (a --help "error", exit code 0, must render
// its help); paramctl returns true, or false after exactly one line "mfns-paramctl: ..." on its
// error stream. Anything else thrown escapes and fails the run.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>

#include "firmware/app/paramctl/paramctl.h"
#include "host/calib/app/calib_cli.h"
#include "host/flash/flash_cli.h"
#include "host/sim/app/sim_cli.h"
#include "host/util/cli_parse.h"
#include "host/util/user_error.h"
#include "tests/fuzz/fuzz_text.h"

namespace {

using mfns::fuzz::CheckMessage;
using mfns::host::Argv;

void CheckOneLine(const std::string& what) {
  if (what.empty()) __builtin_trap();
  CheckMessage(what, "");
}

// Parses with `parse` (one of the tools' Parse*CommandLine) on a fresh app and checks the
// outcome; `command` is the parsed subcommand (nullptr for mfns-flash, which has none).
template <typename CommandLineT, typename Parse>
void FuzzCli11(Argv& line, Parse parse, const std::string CommandLineT::*command) {
  CLI::App app;
  CommandLineT cl;
  try {
    parse(app, line.argc(), line.argv(), &cl);
    if (command != nullptr && (cl.*command).empty()) __builtin_trap();
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() != 0) return CheckOneLine(e.what());
    std::ostringstream out, err;  // --help, --help-all: the help must render
    if (app.exit(e, out, err) != 0 || out.str().empty()) __builtin_trap();
  } catch (const mfns::host::UserError& e) {
    CheckOneLine(e.what());
  }
}

void FuzzParamctl(Argv& line) {
  char* text = nullptr;
  std::size_t size = 0;
  std::FILE* err = open_memstream(&text, &size);
  if (err == nullptr) std::abort();
  mfns::fw::ParamctlOptions o;
  const bool ok = mfns::fw::ParseParamctlArgs(line.argc(), line.argv(), &o, err);
  std::fclose(err);
  const std::string message(text, size);
  std::free(text);
  if (ok) {
    if (!message.empty() || (!o.help && o.command == nullptr)) __builtin_trap();
  } else {
    const std::string kTool = "mfns-paramctl: ";
    if (message.size() <= kTool.size() + 1 || message.back() != '\n') __builtin_trap();
    CheckMessage(message.substr(0, message.size() - 1), kTool);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t kMaxArgs = 32;
  if (size == 0) return 0;
  const int tool = data[0] % 4;
  using namespace mfns::host;  // NOLINT(build/namespaces)
  switch (tool) {
    case 0: {
      Argv line(mfns::fuzz::SplitWords("mfns-calib", data + 1, size - 1, kMaxArgs));
      FuzzCli11(line, ParseCalibCommandLine, &CalibCommandLine::command);
      break;
    }
    case 1: {
      Argv line(mfns::fuzz::SplitWords("mfns-sim", data + 1, size - 1, kMaxArgs));
      FuzzCli11(line, ParseSimCommandLine, &SimCommandLine::command);
      break;
    }
    case 2: {
      Argv line(mfns::fuzz::SplitWords("mfns-flash", data + 1, size - 1, kMaxArgs));
      FuzzCli11<FlashCommandLine>(line, ParseFlashCommandLine, nullptr);
      break;
    }
    default: {
      Argv line(mfns::fuzz::SplitWords("mfns-paramctl", data + 1, size - 1, kMaxArgs));
      FuzzParamctl(line);
    }
  }
  return 0;
}
