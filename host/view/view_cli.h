// mfns-view's command line (README.md "mfns-view"), parsed apart from running it so that the
// fuzz target and the tests can call it.
#pragma once

#include <CLI/CLI.hpp>
#include <string>


namespace mfns::host {

struct HostPort {
  std::string host;  // an IPv4 literal or a name ("localhost")
  int port = 0;      // 0: any free port (the bound one is reported)
};

// "[scheme]HOST:PORT" of option `option` (named in the UserError). PORT 0..65535.
HostPort ParseHostPort(const std::string& text, const std::string& option, const std::string& scheme);

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
// Its ParseError messages are one line whatever the arguments hold (ParseOneLine).
void ParseViewCommandLine(CLI::App& app, int argc, char** argv, ViewCommandLine* cl);

}  // namespace mfns::host
