// mfns-flash BLOB TARGET: install a parameter blob on a flyer (flash.h).
//   TARGET = a store directory, or ssh://[user@]host[:port]/dir
// Exit 0 on success (the blob's generation is confirmed active), 1 with one line on stderr.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "common/limits.h"
#include "host/flash/flash.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

int Run(int argc, char** argv) {
  CLI::App app{"Install a parameter blob in a flyer's parameter store (a directory, or ssh://[user@]host[:port]/dir)"};
  std::string blob_path, target_text;
  FlashOptions opt;
  bool no_signal = false;
  app.add_option("blob", blob_path, "Parameter blob (mfns-calib blob / calibration.bin)")->required();
  app.add_option("target", target_text, "Store directory, or ssh://[user@]host[:port]/dir")->required();
  app.add_flag("--force", opt.force, "Install even if the generation is not newer than the active one");
  app.add_flag("--allow-rig-change", opt.allow_rig_change, "Install a blob for another rig id than the active one");
  app.add_flag("--no-signal", no_signal, "Do not signal mfns-navd (it still reloads by inotify)");
  app.add_option("--remote-paramctl", opt.remote_paramctl,
                 "mfns-paramctl on the flyer (a path or command words, e.g. 'sudo mfns-paramctl')")
      ->capture_default_str();
  app.add_option("-i,--identity", opt.identity_file, "ssh identity file (ssh -i)");
  app.add_option("-o,--ssh-option", opt.ssh_options, "Extra ssh option, as ssh -o (repeatable)");
  app.add_option("-F,--ssh-config", opt.ssh_config, "ssh configuration file (ssh -F)");
  app.add_option("--ssh", opt.ssh_program, "ssh client program")->capture_default_str();
  app.add_option("--connect-timeout", opt.connect_timeout_s, "ssh connect timeout (s)")
      ->check(CLI::Range(1, 300))
      ->capture_default_str();
  app.add_option("--timeout", opt.timeout_s, "Limit for each ssh call (s)")->check(CLI::Range(1, 3600))->capture_default_str();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::cerr << "mfns-flash: " << e.what() << " (--help for usage)\n";
    return 1;
  }
  opt.signal_navd = !no_signal;
  try {
    const FlashTarget target = ParseTarget(target_text);
    const std::string data = ReadFile(blob_path, limits::kMaxBlobBytes);
    const std::vector<std::uint8_t> blob(data.begin(), data.end());
    const FlashResult r = Flash(blob, target, opt);
    std::cout << r.install_output;
    std::cout << "mfns-flash: " << target.Display() << ": generation " << r.active_generation << " (rig "
              << r.active_rig_id << ") is active\n";
    return 0;
  } catch (const UserError& e) {
    std::cerr << "mfns-flash: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace
}  // namespace mfns::host

int main(int argc, char** argv) { return mfns::host::Run(argc, argv); }
