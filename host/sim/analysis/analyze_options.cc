#include "host/sim/analysis/analyze_options.h"

namespace mfns::host {

CLI::App* AddAnalyzeOptions(CLI::App& app, AnalyzeOptions* o) {
  CLI::App* cmd = app.add_subcommand(
      "analyze",
      "Error analysis of the paper's Section 3: RMS pixel error of u against beacon position, camera position and "
      "camera attitude error (Figures 4-6, Table 1), Monte Carlo beside the first-order analytic prediction");
  // --out is checked in SetupFromOptions so that every bad option is a UserError.
  cmd->add_option("--out", o->out_dir,
                  "Output directory (required; created if missing) for the CSV and SVG of each figure");
  cmd->add_option("--trials", o->trials, "Monte Carlo trials (kept beacons) per point")->capture_default_str();
  cmd->add_option("--points", o->points, "Error magnitudes per figure, evenly spaced from 0 to the maximum")
      ->capture_default_str();
  cmd->add_option("--seed", o->seed, "Random seed; the same seed gives the same files")->capture_default_str();
  cmd->add_option("--beacon-x-range-mm", o->beacon_x_range_mm, "Beacon X range MIN MAX in mm (Table 1: 0 1000)")
      ->expected(2)
      ->capture_default_str();
  cmd->add_option("--beacon-y-range-mm", o->beacon_y_range_mm,
                  "Beacon Y range MIN MAX in mm (not given in the paper; default: the same as X)")
      ->expected(2)
      ->capture_default_str();
  cmd->add_option("--beacon-z-range-mm", o->beacon_z_range_mm, "Beacon Z (depth) range MIN MAX in mm (Table 1: 0 1000)")
      ->expected(2)
      ->capture_default_str();
  cmd->add_option("--min-depth-mm", o->min_depth_mm,
                  "Reject beacons nearer than this depth (the paper's Z range starts at 0, where the error of u is "
                  "unbounded)")
      ->capture_default_str();
  cmd->add_option("--error-draw", o->error_draw,
                  "How an error of magnitude m is drawn: gaussian (each axis N(0, m^2)) or sphere (random direction, "
                  "norm m)")
      ->capture_default_str();
  cmd->add_flag("--no-fov-gate", o->no_fov_gate,
                "Keep beacons whose image falls off the 1280x1024 sensor (default: reject them)");
  cmd->add_option("--fig4-max-mm", o->fig4_max_mm, "Largest beacon position error of figure 4, mm")
      ->capture_default_str();
  cmd->add_option("--fig5-max-mm", o->fig5_max_mm, "Largest camera-to-body position error of figure 5, mm")
      ->capture_default_str();
  cmd->add_option("--fig6-max-deg", o->fig6_max_deg, "Largest camera-to-body attitude error of figure 6, deg")
      ->capture_default_str();
  cmd->add_option("--few-px", o->few_px, "Pixel error counted as 'a few pixels' in the conclusion check")
      ->capture_default_str();
  return cmd;
}

}  // namespace mfns::host
