#include "host/sim/app/load_scenario.h"

#include <yaml-cpp/yaml.h>

#include <filesystem>

#include "host/rigio/yaml_fields.h"
#include "host/util/atomic_file.h"

namespace mfns::host {

Scenario LoadScenario(const ScenarioArgs& a, std::string* text) {
  if (a.preset.empty() == a.file.empty()) throw UserError("give exactly one of --preset or --scenario");
  // One line: it starts the messages and the YAML comment below (a newline in it made YAML).
  const std::string source = OneLine(a.preset.empty() ? a.file : "preset " + a.preset);
  std::string yaml = a.preset.empty() ? ReadFile(a.file, 1u << 20) : PresetYaml(a.preset);
  const std::filesystem::path base = a.preset.empty() ? std::filesystem::path(a.file).parent_path() : ".";
  if (a.frames > 0 || a.seed >= 0 || a.map_seed >= 0) {
    YAML::Node root = LoadYaml(yaml, source);
    if (a.frames > 0) root["frames"] = a.frames;
    if (a.seed >= 0) root["seed"] = a.seed;
    // A generated map follows --seed too (a new seed, a new station), unless --map-seed pins it.
    const YAML::Node& const_root = root;  // const lookups insert nothing
    const bool generated = const_root["beacons"].IsDefined() && const_root["beacons"].IsMap();
    if (generated && a.seed >= 0 && const_root["beacons"]["seed"].IsDefined()) root["beacons"]["seed"] = a.seed;
    if (a.map_seed >= 0) {
      if (!generated) throw UserError("--map-seed: the scenario has no generated beacons (beacons: {layout: ...})");
      root["beacons"]["seed"] = a.map_seed;
    }
    YAML::Emitter out;
    out << root;
    yaml = std::string("# ") + source + " with command-line overrides\n" + out.c_str() + "\n";
  }
  *text = yaml;
  return ParseScenarioYaml(yaml, source, base);
}

}  // namespace mfns::host
