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

namespace mfns::fw {

inline constexpr char kDefaultStoreDir[] = "/var/lib/mfns/params";

// Runs one command. stdin_fd is read for "install -"; out/err receive the output. Returns the
// process exit code. Not reentrant (getopt state, static buffers).
int RunParamctl(int argc, char** argv, int stdin_fd, std::FILE* out, std::FILE* err);

}  // namespace mfns::fw
