// mfns-sim: the simulator (DESIGN.md, "Simulator"; issue 3).
//   mfns-sim render --preset NAME|--scenario FILE --out DIR [--frames N] [--seed S] [--map-seed M]
//   mfns-sim crb    --preset NAME|--scenario FILE --out FILE.csv [--frames N] [--seed S] [--map-seed M]
//   mfns-sim calib-dataset --preset NAME|--scenario FILE --out DIR [--seed S]
//   mfns-sim compare DIR POSES.csv  estimates against truth and the bound (host/report/compare.h)
//   mfns-sim preset NAME            print a built-in scenario (to start a custom one)
//   mfns-sim analyze --out DIR ...  Figures 4-6 of the paper (error analysis)
//   mfns-sim report | merge-rig | solve-given   replication tables and report (host/report)
//   mfns-sim navmatrix ...          acquisition test matrix (host/sim/navmatrix)
//   mfns-sim faults --out DIR ...   fault scenarios through NavLoop (host/sim/faults)
// Exit 0 on success, 1 on a user error with a one-line reason on stderr.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>
#include <yaml-cpp/yaml.h>

#include "host/report/compare.h"
#include "host/report/report_command.h"
#include "host/sim/analysis/analyze_command.h"
#include "host/sim/calibdata/calib_dataset.h"
#include "host/sim/faults/faults.h"
#include "host/sim/frames/render_run.h"
#include "host/sim/navmatrix/matrix.h"
#include "host/sim/scenario/scenario.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

struct ScenarioArgs {
  std::string preset, file;
  int frames = 0;
  long long seed = -1, map_seed = -1;

  void Add(CLI::App* cmd) {
    auto* p = cmd->add_option("--preset", preset, "Built-in scenario (see `mfns-sim preset --list`)");
    auto* f = cmd->add_option("--scenario", file, "Scenario YAML file");
    p->excludes(f);
    cmd->add_option("--frames", frames, "Number of frame sets (overrides the scenario)")->check(CLI::Range(1, 1000000));
    cmd->add_option("--seed", seed,
                    "Random seed (overrides the scenario's seed: trajectory, noise, clutter; and beacons.seed, "
                    "the generated beacon map's)")
        ->check(CLI::NonNegativeNumber);
    cmd->add_option("--map-seed", map_seed, "Seed of the generated beacon map only (overrides beacons.seed)")
        ->check(CLI::NonNegativeNumber);
  }

  // The effective scenario and its YAML text (with the overrides applied).
  Scenario Load(std::string* text) const {
    if (preset.empty() == file.empty()) throw UserError("give exactly one of --preset or --scenario");
    const std::string source = preset.empty() ? file : "preset " + preset;
    std::string yaml = preset.empty() ? ReadFile(file, 1u << 20) : PresetYaml(preset);
    const std::filesystem::path base = preset.empty() ? std::filesystem::path(file).parent_path() : ".";
    if (frames > 0 || seed >= 0 || map_seed >= 0) {
      YAML::Node root;
      try {
        root = YAML::Load(yaml);
      } catch (const YAML::Exception& e) {
        throw UserError(source + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
      }
      if (frames > 0) root["frames"] = frames;
      if (seed >= 0) root["seed"] = seed;
      // A generated map follows --seed too (a new seed, a new station), unless --map-seed pins it.
      const YAML::Node& const_root = root;  // const lookups insert nothing
      const bool generated = const_root["beacons"].IsDefined() && const_root["beacons"].IsMap();
      if (generated && seed >= 0 && const_root["beacons"]["seed"].IsDefined()) root["beacons"]["seed"] = seed;
      if (map_seed >= 0) {
        if (!generated) throw UserError("--map-seed: the scenario has no generated beacons (beacons: {layout: ...})");
        root["beacons"]["seed"] = map_seed;
      }
      YAML::Emitter out;
      out << root;
      yaml = std::string("# ") + source + " with command-line overrides\n" + out.c_str() + "\n";
    }
    *text = yaml;
    return ParseScenarioYaml(yaml, source, base);
  }
};

void PrintSummary(const RenderSummary& s) {
  std::printf("frame sets %d: >= 3 beacons visible in %d (%.1f%%), none in %d (%.1f%%), mean %.2f beacons\n", s.frames,
              s.frames_with_3, 100.0 * s.frames_with_3 / s.frames, s.frames_with_none,
              100.0 * s.frames_with_none / s.frames, s.mean_visible);
}

int Run(int argc, char** argv) {
  CLI::App app{"MFNS simulator: scenarios, rendered frames, truth, error analysis, Cramér-Rao bound"};
  app.require_subcommand(1);

  ScenarioArgs render_args;
  RenderOptions render_opt;
  std::string render_out;
  bool no_images = false;
  CLI::App* render = app.add_subcommand("render", "Render a scenario's frames with truth, blob centres and bound");
  render_args.Add(render);
  render->add_option("--out", render_out, "Output directory")->required();
  render->add_option("--threads", render_opt.threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);
  render->add_flag("--no-images", no_images, "Write truth, blobs and bound only");

  ScenarioArgs crb_args;
  std::string crb_out;
  CLI::App* crb = app.add_subcommand("crb", "Cramér-Rao bound of the pose along a scenario's trajectory (CSV)");
  crb_args.Add(crb);
  crb->add_option("--out", crb_out, "Output CSV file")->required();

  ScenarioArgs calib_args;
  CalibDatasetOptions calib_opt;
  std::string calib_out;
  CLI::App* calib = app.add_subcommand("calib-dataset", "Simulate a turntable calibration session (docs/calib-dataset.md)");
  calib_args.Add(calib);
  calib->add_option("--out", calib_out, "Output directory")->required();
  calib->add_option("--threads", calib_opt.threads, "Worker threads (0: all cores)")->check(CLI::NonNegativeNumber);

  std::string cmp_dir, cmp_poses;
  CLI::App* compare = app.add_subcommand("compare", "Navigation estimates against truth and the Cramér-Rao bound");
  compare->add_option("dir", cmp_dir, "Directory written by `mfns-sim render` (truth.csv, crb.csv)")->required();
  compare->add_option("poses", cmp_poses, "Poses CSV written by `mfns-navd --log`")->required();

  std::string preset_name;
  bool list = false;
  CLI::App* preset = app.add_subcommand("preset", "Print a built-in scenario's YAML, or list them");
  preset->add_option("name", preset_name, "Preset name");
  preset->add_flag("--list", list, "List the built-in presets");

  AddAnalyzeCommand(app);
  AddReportCommands(app);  // report, merge-rig, solve-given (host/report)
  AddNavMatrixCommand(app);
  AddFaultsCommand(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 1;
  }
  if (*render) {
    std::string text;
    const Scenario s = render_args.Load(&text);
    render_opt.out_dir = render_out;
    render_opt.write_images = !no_images;
    PrintSummary(RenderScenario(s, text, render_opt));
  }
  if (*crb) {
    std::string text;
    PrintSummary(WriteBoundCsv(crb_args.Load(&text), crb_out));
  }
  if (*calib) {
    std::string text;
    const Scenario s = calib_args.Load(&text);
    calib_opt.out_dir = calib_out;
    const CalibDatasetSummary sum = WriteCalibDataset(s, text, calib_opt);
    std::printf("calibration images %d, with the whole target in view %d\n", sum.images, sum.complete);
  }
  if (*compare) std::fputs(FormatCompare(ComparePoses(cmp_dir, cmp_poses)).c_str(), stdout);
  if (*preset) {
    if (list || preset_name.empty()) {
      for (const std::string& n : PresetNames()) std::printf("%s\n", n.c_str());
    } else {
      std::fputs(PresetYaml(preset_name).c_str(), stdout);
    }
  }
  return 0;
}

}  // namespace
}  // namespace mfns::host

int main(int argc, char** argv) {
  try {
    return mfns::host::Run(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mfns-sim: %s\n", e.what());
    return 1;
  }
}
