// mfns-flash's command line, parsed without running anything (issue 14): the one definition of
// the tool's arguments and options, used by mfns-flash (mfns_flash_main.cc, which then flashes)
// and by its fuzz target (tests/fuzz/host_cli_fuzz.cc).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "host/flash/flash.h"

namespace mfns::host {

struct FlashCommandLine {
  std::string blob_path;
  FlashTarget target;  // TARGET through ParseTarget
  FlashOptions options;
};

// Defines mfns-flash's arguments and options on `app` (a fresh one), parses argv into *cl and
// the target with ParseTarget; reads nothing, runs nothing. Throws what app.parse throws
// (CLI::ParseError, --help included: app.exit(e) prints it) and ParseTarget's UserError.
void ParseFlashCommandLine(CLI::App& app, int argc, char** argv, FlashCommandLine* cl);

}  // namespace mfns::host
