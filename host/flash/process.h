// Running a child program with bytes on its stdin and its stdout/stderr captured, with a hard
// time limit (mfns-flash runs the system OpenSSH client this way).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace mfns::host {

struct ProcessResult {
  int exit_code = -1;      // the child's exit status; -1 when killed by a signal
  int signal = 0;          // the signal that ended it (0: exited)
  bool timed_out = false;  // killed (SIGKILL) after timeout_s
  std::string out, err;
};

// Runs argv[0] (searched in PATH) with argv, writes stdin_bytes to its stdin then closes it,
// and collects stdout and stderr until it exits; after timeout_s seconds it is killed.
// Throws UserError when the program cannot be started at all (e.g. not installed).
ProcessResult RunProcess(const std::vector<std::string>& argv, const std::vector<std::uint8_t>& stdin_bytes,
                         int timeout_s);

}  // namespace mfns::host
