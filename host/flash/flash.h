// mfns-flash: put a parameter blob into a flyer's parameter store (DESIGN.md, "Flashing").
//
// TARGET is either a store directory on this machine (installed in-process through the same
// store code the flyer runs, firmware/modules/params) or ssh://[user@]host[:port]/dir: the
// system OpenSSH client streams the blob to `mfns-paramctl install --store DIR -` on the flyer
// (BatchMode, a connect timeout, an overall timeout), then runs `mfns-paramctl show` and checks
// that the blob's generation and rig id are the active ones. Every failure is a UserError with
// one line: unreachable host, missing paramctl (ssh exit 127), a refused blob (paramctl's own
// reason relayed), a confirmation mismatch.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "common/blob/param_blob.h"

namespace mfns::host {

struct FlashTarget {
  enum class Kind : unsigned char { kLocal, kSsh };
  Kind kind = Kind::kLocal;
  std::string dir;   // store directory (remote: the URL path, absolute)
  std::string user;  // ssh: "" = ssh's default
  std::string host;  // ssh: name or address (IPv6 without brackets)
  int port = 22;     // ssh
  std::string Display() const;  // "DIR" or "[user@]host:port:DIR"
};

// Parses TARGET; throws UserError naming what is wrong.
FlashTarget ParseTarget(const std::string& text);

struct FlashOptions {
  bool force = false;                        // paramctl --force (older/equal generation)
  bool allow_rig_change = false;             // paramctl --allow-rig-change
  bool signal_navd = true;                   // false: paramctl --no-signal
  std::string remote_paramctl = "mfns-paramctl";  // words, e.g. "sudo /usr/bin/mfns-paramctl"
  std::string ssh_program = "ssh";
  std::string identity_file;                 // ssh -i
  std::string ssh_config;                    // ssh -F ("" = the user's default)
  std::vector<std::string> ssh_options;      // each passed as -o OPTION
  int connect_timeout_s = 10;                // ssh -o ConnectTimeout
  int timeout_s = 60;                        // each ssh call as a whole
};

struct FlashResult {
  BlobInfo blob;             // the blob flashed (decoded here first)
  std::uint64_t active_generation = 0;
  std::string active_rig_id;
  std::string install_output;  // paramctl's stdout ("installed generation ..."; "reload: ...")
};

// Checks the blob, installs it at target, confirms it is active. Throws UserError.
FlashResult Flash(const std::vector<std::uint8_t>& blob, const FlashTarget& target, const FlashOptions& options);

// Building blocks (tested on their own).
// POSIX shell single-quoting: the remote shell sees s as one word, whatever it contains.
std::string ShellQuote(const std::string& s);
// The remote command line: paramctl words quoted one by one, then args quoted.
std::string RemoteCommand(const FlashOptions& options, const std::vector<std::string>& args);
// The full ssh argv for one remote command.
std::vector<std::string> SshArgv(const FlashTarget& target, const FlashOptions& options,
                                 const std::string& remote_command);
// "key: value" lines of `mfns-paramctl show`; "" when key is absent.
std::string ShowField(const std::string& show_output, const std::string& key);

}  // namespace mfns::host
