#include "host/sim/app/sim_cli.h"

#include "host/util/cli_parse.h"

namespace mfns::host {
namespace {

void AddScenarioOptions(CLI::App* cmd, ScenarioArgs* a) {
  auto* p = cmd->add_option("--preset", a->preset, "Built-in scenario (see `mfns-sim preset --list`)");
  auto* f = cmd->add_option("--scenario", a->file, "Scenario YAML file");
  p->excludes(f);
  cmd->add_option("--frames", a->frames, "Number of frame sets (overrides the scenario)")->check(CLI::Range(1, 1000000));
  cmd->add_option("--seed", a->seed,
                  "Random seed (overrides the scenario's seed: trajectory, noise, clutter; and beacons.seed, "
                  "the generated beacon map's)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--map-seed", a->map_seed, "Seed of the generated beacon map only (overrides beacons.seed)")
      ->check(CLI::NonNegativeNumber);
}

}  // namespace

void ParseSimCommandLine(CLI::App& app, int argc, char** argv, SimCommandLine* cl) {
  app.description("MFNS simulator: scenarios, rendered frames, truth, error analysis, Cramér-Rao bound");
  app.require_subcommand(1);

  CLI::App* render = app.add_subcommand("render", "Render a scenario's frames with truth, blob centres and bound");
  AddScenarioOptions(render, &cl->scenario);
  render->add_option("--out", cl->out, "Output directory")->required();
  render->add_option("--threads", cl->threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);
  render->add_flag("--no-images", cl->no_images, "Write truth, blobs and bound only");

  CLI::App* crb = app.add_subcommand("crb", "Cramér-Rao bound of the pose along a scenario's trajectory (CSV)");
  AddScenarioOptions(crb, &cl->scenario);
  crb->add_option("--out", cl->out, "Output CSV file")->required();

  CLI::App* calib = app.add_subcommand("calib-dataset", "Simulate a turntable calibration session (docs/calib-dataset.md)");
  AddScenarioOptions(calib, &cl->scenario);
  calib->add_option("--out", cl->out, "Output directory")->required();
  calib->add_option("--threads", cl->threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);

  CLI::App* compare = app.add_subcommand("compare", "Navigation estimates against truth and the Cramér-Rao bound");
  compare->add_option("dir", cl->compare_dir, "Directory written by `mfns-sim render` (truth.csv, crb.csv)")->required();
  compare->add_option("poses", cl->compare_poses, "Poses CSV written by `mfns-navd --log`")->required();

  CLI::App* preset = app.add_subcommand("preset", "Print a built-in scenario's YAML, or list them");
  preset->add_option("name", cl->preset_name, "Preset name");
  preset->add_flag("--list", cl->list, "List the built-in presets");

  AddAnalyzeOptions(app, &cl->analyze);
  AddReportOptions(app, &cl->report);  // report, merge-rig, solve-given (host/report)
  AddNavMatrixOptions(app, &cl->navmatrix);
  AddFaultsOptions(app, &cl->faults);

  ParseOneLine(app, argc, argv);
  cl->command = app.get_subcommands().front()->get_name();
}

}  // namespace mfns::host
