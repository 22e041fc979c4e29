// mfns-paramctl: the parameter store on the flyer from the command line (DESIGN.md, "Flashing").
//
//   mfns-paramctl install  [--store DIR] [--force] [--allow-rig-change] [--pid-file F|--no-signal] BLOB|-
//   mfns-paramctl show     [--store DIR]
//   mfns-paramctl verify   [--store DIR] [--rig-id ID]
//   mfns-paramctl rollback [--store DIR] [--pid-file F|--no-signal]
//
// DIR defaults to /var/lib/mfns/params (the package's store). Exit 0 on success; 1 with one
// line "mfns-paramctl: <reason>" on stderr for a refusal or an error; the old blob stays
// active on every refusal (firmware/modules/params/param_store.h). After an install or a
// rollback a running mfns-navd is told to reload (SIGHUP through its pid file; reload_signal.h).
// `show` prints "key: value" lines (mfns-flash reads "generation:" and "rig_id:" from them).
//
// Flight-code style: no heap (the store and a blob buffer live in static storage), no
// exceptions, getopt_long.
#pragma once

#include <cstdio>

#include "firmware/modules/params/reload_signal.h"

namespace mfns::fw {

inline constexpr char kDefaultStoreDir[] = "/var/lib/mfns/params";

// The command line: the command (argv[1]) and its options; pointers into argv.
struct ParamctlOptions {
  const char* command = nullptr;  // install, show, verify or rollback
  const char* store = kDefaultStoreDir;
  const char* blob = nullptr;  // install: file or "-"
  const char* pid_file = kDefaultNavdPidFile;
  const char* rig_id = nullptr;
  bool force = false;
  bool allow_rig_change = false;
  bool signal = true;
  bool help = false;
};

// Parses argv into *o and runs nothing (the parse RunParamctl runs first; the fuzz target
// tests/fuzz/host_cli_fuzz.cc calls it alone). true when the command line is valid or asks for
// --help (o->help); false after one line "mfns-paramctl: <reason>" on err. getopt_long reorders
// argv; not reentrant (getopt state).
bool ParseParamctlArgs(int argc, char** argv, ParamctlOptions* o, std::FILE* err);

// Runs one command. stdin_fd is read for "install -"; out/err receive the output. Returns the
// process exit code. Not reentrant (getopt state, static buffers).
int RunParamctl(int argc, char** argv, int stdin_fd, std::FILE* out, std::FILE* err);

}  // namespace mfns::fw
