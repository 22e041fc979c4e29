// mfns-view's command line (README.md "mfns-view"), parsed apart from running it so that the
// fuzz target and the tests can call it.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "host/view/view_server.h"

namespace mfns::host {

struct ViewCommandLine {
  std::string rig_path;      // --rig (else FRAMES/rig.yaml)
  std::string listen;        // --listen udp://HOST:PORT ("" with --play: no live input)
  std::string http = "127.0.0.1:8080";
  std::string play;          // --play POSES.csv
  std::string frames;        // --frames DIR (its rig.yaml and truth.csv)
  double speed = 1.0;        // playback speed (x the sample rate)
  HostPort listen_at, http_at;
};

// Parses argv into *cl (CLI11 ParseError for --help and bad options; UserError for bad values).
void ParseViewCommandLine(CLI::App& app, int argc, const char* const* argv, ViewCommandLine* cl);

}  // namespace mfns::host
