#include "host/flash/flash_cli.h"

#include "host/util/cli_parse.h"

namespace mfns::host {

void ParseFlashCommandLine(CLI::App& app, int argc, char** argv, FlashCommandLine* cl) {
  app.description("Install a parameter blob in a flyer's parameter store (a directory, or ssh://[user@]host[:port]/dir)");
  std::string target_text;
  FlashOptions& opt = cl->options;
  bool no_signal = false;
  app.add_option("blob", cl->blob_path, "Parameter blob (mfns-calib blob / calibration.bin)")->required();
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
  ParseOneLine(app, argc, argv);
  opt.signal_navd = !no_signal;
  cl->target = ParseTarget(target_text);
}

}  // namespace mfns::host
