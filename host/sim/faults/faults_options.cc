#include <CLI/CLI.hpp>

#include "host/sim/faults/faults.h"

namespace mfns::host {

CLI::App* AddFaultsOptions(CLI::App& app, FaultsCommandOptions* a) {
  CLI::App* cmd = app.add_subcommand(
      "faults",
      "Fault scenarios (issue 14): rendered frames through the real NavLoop with a camera stalled, unplugged, "
      "corrupt frames, reflections, an occlusion, clock jumps, a wrong-rig reload; a markdown table and one SVG per fault");
  cmd->add_option("--out", a->out, "Folder for faults.md and fault-<name>.svg")->required();
  cmd->add_option("--preset", a->run.preset, "Scenario preset")->capture_default_str();
  cmd->add_option("--seed", a->run.seed, "Scenario seed")->capture_default_str();
  cmd->add_option("--frames", a->run.frames, "Frame sets per run")->capture_default_str();
  cmd->add_option("--fault-at", a->run.fault_at, "First frame set of every fault")->capture_default_str();
  cmd->add_option("--divisor", a->run.image_divisor, "Image size divisor (same field of view)")->capture_default_str();
  cmd->add_option("--only", a->only, "Faults to run, comma-separated (default: all)")->delimiter(',');
  cmd->add_option("--trace", a->trace, "Also write every run's frame sets (status, reason, errors) to this CSV file");
  cmd->add_flag("--cold", a->cold, "Also run the baseline without a start pose and report its first fix");
  cmd->add_flag("--check", a->check, "Exit 1 when a fault gave a wrong fix");
  return cmd;
}

}  // namespace mfns::host
