#include "host/sim/navmatrix/navmatrix_options.h"

namespace mfns::host {

CLI::App* AddNavMatrixOptions(CLI::App& app, NavMatrixArgs* a) {
  CLI::App* cmd = app.add_subcommand(
      "navmatrix",
      "Acquisition test matrix (issue 13): the navigator on blob-level simulations of presets x beacon counts x "
      "seeds x map facing, from a cold start; a markdown table of first-fix lag, posed share, wrong poses, CPU time");
  cmd->add_option("--presets", a->presets, "Presets, comma-separated")->delimiter(',')->capture_default_str();
  cmd->add_option("--counts", a->counts, "beacons.count of presets with a generated map, comma-separated")
      ->delimiter(',')
      ->capture_default_str();
  cmd->add_option("--seeds", a->seeds, "Seeds (trajectory, noise, clutter and the generated map): 1-5 or 1,3,8")
      ->capture_default_str();
  cmd->add_option("--frames", a->frames, "Frame sets per run")->capture_default_str();
  cmd->add_option("--spurious", a->spurious, "clutter.spurious.count: spurious blobs per camera per frame set")
      ->capture_default_str();
  cmd->add_option("--static-reflections", a->static_reflections,
                  "clutter.spurious.static_reflections: unmapped reflecting points on the module's walls, imaged "
                  "like beacons (clutter that moves with the scene); presets with a module only")
      ->capture_default_str();
  cmd->add_option("--rig", a->rig,
                  "A rig file in place of every preset's rig: its cameras (and its beacons where a preset takes "
                  "its map from the rig): the matrix on other cameras");
  cmd->add_option("--layout", a->layout,
                  "beacons.layout of the generated maps: jittered-grid or random (default: the preset's)");
  cmd->add_option("--jitter", a->jitter,
                  "beacons.jitter of the generated jittered grids: 0 (a regular grid) .. 0.5 (default: the preset's)");
  cmd->add_option("--facing", a->facing, "Beacon facing in the navigator's map: both, yes or no")
      ->capture_default_str();
  cmd->add_option("--jobs", a->jobs, "Worker threads, each with its own navigator (0: all cores)")
      ->capture_default_str();
  cmd->add_option("--out", a->out, "Also write the table to this markdown file");
  cmd->add_option("--trace", a->trace, "Also write every run's frame sets (status, reason, errors) to this CSV file");
  cmd->add_flag("--check", a->check, "Exit 1 when a requirement of issue 13 fails");
  cmd->add_flag("--three-beacon-fixes", a->three_beacon_fixes,
                "A track found on three beacons is a fix at once (mfns-navd's flag; default: degraded, "
                "'unverified', until a pose on four; and a pose on three beacons one of which just appeared, "
                "degraded until its blob is steady)");
  return cmd;
}

}  // namespace mfns::host
