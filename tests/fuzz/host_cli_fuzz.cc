// libFuzzer target for the host tools' command lines (issue 14): mfns-calib, mfns-sim,
// mfns-flash and mfns-view (CLI11) and mfns-paramctl (getopt_long), through the parse-only entry
// points each tool runs before anything else (calib_cli.h, sim_cli.h, flash_cli.h, view_cli.h:
// --listen and --http addresses, --speed; paramctl.h), with the
// option definitions the tools use, and then, on a parsed command line, through the checks the
// command makes when it runs, before its work: mfns-calib rig's and intrinsics' options
// (ValidateRigCommand: --method, ...; ValidateIntrinsicsCommand: --target), mfns-sim's scenario
// of render, crb and calib-dataset (LoadScenario: the preset or file with the overrides),
// preset's NAME, analyze's SetupFromOptions, navmatrix's spec and its expansion
// (MatrixSpecFromArgs: --seeds, --facing; ExpandMatrix: --presets, --counts, the bounds) and
// faults' (SelectFaults: --only, --frames, --divisor, --preset). Nothing renders, calibrates or
// writes; the only files read are the scratch directory's scenario files (below).
//
// The first input byte selects the tool ((its value + 2) mod 5: '0' calib, '1' sim, '2' flash,
// '3' paramctl, '4' view in the seeds); the rest is cut at NUL bytes into at most 32 arguments.
// One target for the five, not five targets: the parsers take the same input (words) under the same
// contract, so one corpus carries what libFuzzer finds for one tool (--out, --store, ssh://
// targets, numbers at a range's edge) over to the others, and the fuzz preset keeps one build
// and one ctest slot for them (its ~4 min run).
//
// Checked on every input: the parse, and the run-time checks after it, return, or throw
// CLI::ParseError or UserError whose message is one non-empty line (a --help "error", exit code
// 0, must render its help); paramctl returns true, or false after exactly one line
// "mfns-paramctl: ..." on its error stream. Anything else thrown escapes and fails the run.
//
// --scenario FILE: a relative path without ".." is read from a scratch directory made at start
// (scenario.yaml: station-box's YAML; free-flight.yaml; bad.yaml: not YAML); any other path is
// not read (an absolute path could name any file on the machine: slow or huge, not hostile).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>

#include "firmware/app/paramctl/paramctl.h"
#include "host/calib/app/calib_cli.h"
#include "host/flash/flash_cli.h"
#include "host/view/view_cli.h"
#include "host/sim/analysis/analyze_command.h"
#include "host/sim/app/load_scenario.h"
#include "host/sim/app/sim_cli.h"
#include "host/sim/faults/faults.h"
#include "host/sim/navmatrix/matrix.h"
#include "host/util/atomic_file.h"
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

// Parses with `parse` (one of the tools' Parse*CommandLine) on a fresh app, then runs `check`
// (the command's run-time checks) on what it parsed, and checks the outcome; `command` is the
// parsed subcommand (nullptr for mfns-flash, which has none).
template <typename CommandLineT, typename Parse, typename Check>
void FuzzCli11(Argv& line, Parse parse, const std::string CommandLineT::*command, Check check) {
  CLI::App app;
  CommandLineT cl;
  try {
    parse(app, line.argc(), line.argv(), &cl);
    if (command != nullptr && (cl.*command).empty()) __builtin_trap();
    check(cl);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() != 0) return CheckOneLine(e.what());
    std::ostringstream out, err;  // --help, --help-all: the help must render
    if (app.exit(e, out, err) != 0 || out.str().empty()) __builtin_trap();
  } catch (const mfns::host::UserError& e) {
    CheckOneLine(e.what());
  }
}

// The scratch directory of the --scenario files (see the top), made at the first use and removed
// at exit (a heap object: the exit handler runs after static destructors).
const std::filesystem::path* g_scratch = nullptr;

void RemoveScratch() {
  std::error_code ec;
  std::filesystem::remove_all(*g_scratch, ec);
}

const std::filesystem::path& ScratchDir() {
  if (g_scratch != nullptr) return *g_scratch;
  std::string name = (std::filesystem::temp_directory_path() / "host_cli_fuzz.XXXXXX").string();
  if (::mkdtemp(name.data()) == nullptr) std::abort();
  g_scratch = new std::filesystem::path(name);
  std::atexit(RemoveScratch);
  mfns::host::WriteFileAtomic(*g_scratch / "scenario.yaml", mfns::host::PresetYaml("station-box"));
  mfns::host::WriteFileAtomic(*g_scratch / "free-flight.yaml", mfns::host::PresetYaml("free-flight"));
  mfns::host::WriteFileAtomic(*g_scratch / "bad.yaml", std::string_view("frames: [1\n"));
  return *g_scratch;
}

void CheckScenario(mfns::host::ScenarioArgs a) {
  if (!a.file.empty()) {
    const std::filesystem::path p(a.file);
    for (const auto& part : p)
      if (part == "..") return;
    if (p.is_absolute()) return;
    a.file = (ScratchDir() / p).string();
  }
  std::string text;
  mfns::host::LoadScenario(a, &text);
}

void CheckCalib(const mfns::host::CalibCommandLine& cl) {
  if (cl.command == "rig") mfns::host::ValidateRigCommand(cl.rig);
  if (cl.command == "intrinsics") mfns::host::ValidateIntrinsicsCommand(cl.intrinsics);
  if (cl.command == "survey") mfns::host::ValidateSurveyCommand(cl.survey);
}

void CheckSim(const mfns::host::SimCommandLine& cl) {
  using namespace mfns::host;  // NOLINT(build/namespaces)
  const std::string& c = cl.command;
  if (c == "render" || c == "crb" || c == "calib-dataset") CheckScenario(cl.scenario);
  if (c == "preset" && !cl.list && !cl.preset_name.empty()) PresetYaml(cl.preset_name);
  if (c == "analyze") SetupFromOptions(cl.analyze);
  if (c == "navmatrix") ExpandMatrix(MatrixSpecFromArgs(cl.navmatrix));
  if (c == "faults") SelectFaults(cl.faults);
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
  // The first byte picks the tool: '0' calib, '1' sim, '2' flash, '3' paramctl, '4' view (mod 5;
  // the seeds' first bytes are these digits).
  const int tool = (data[0] + 2) % 5;
  using namespace mfns::host;  // NOLINT(build/namespaces)
  switch (tool) {
    case 0: {
      Argv line(mfns::fuzz::SplitWords("mfns-calib", data + 1, size - 1, kMaxArgs));
      FuzzCli11(line, ParseCalibCommandLine, &CalibCommandLine::command, CheckCalib);
      break;
    }
    case 1: {
      Argv line(mfns::fuzz::SplitWords("mfns-sim", data + 1, size - 1, kMaxArgs));
      FuzzCli11(line, ParseSimCommandLine, &SimCommandLine::command, CheckSim);
      break;
    }
    case 2: {
      Argv line(mfns::fuzz::SplitWords("mfns-flash", data + 1, size - 1, kMaxArgs));
      FuzzCli11<FlashCommandLine>(line, ParseFlashCommandLine, nullptr, [](const FlashCommandLine&) {});
      break;
    }
    case 3: {
      Argv line(mfns::fuzz::SplitWords("mfns-paramctl", data + 1, size - 1, kMaxArgs));
      FuzzParamctl(line);
      break;
    }
    default: {
      Argv line(mfns::fuzz::SplitWords("mfns-view", data + 1, size - 1, kMaxArgs));
      FuzzCli11<ViewCommandLine>(line, ParseViewCommandLine, nullptr, [](const ViewCommandLine&) {});
    }
  }
  return 0;
}
