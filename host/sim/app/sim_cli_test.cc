// mfns-sim's parse-only command line (sim_cli.h, issue 14): navmatrix's options parse like the
// other subcommands', into SimCommandLine, without running the matrix.
#include "host/sim/app/sim_cli.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "host/sim/app/load_scenario.h"
#include "host/util/cli_parse.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

SimCommandLine Parse(const std::vector<std::string>& words) { return ParseWords(ParseSimCommandLine, words); }

TEST(SimCommandLine, NavMatrixParsesWithoutRunning) {
  const fs::path dir = fs::path(::testing::TempDir()) / "mfns_sim_cli_navmatrix";
  fs::remove_all(dir);
  const std::string out = (dir / "m.md").string(), trace = (dir / "t.csv").string();
  const SimCommandLine cl = Parse({"mfns-sim", "navmatrix", "--presets", "station-box,free-flight", "--counts", "64,128",
                                   "--seeds", "2-3", "--frames", "40", "--spurious", "0", "--facing", "no", "--jobs",
                                   "1", "--out", out, "--trace", trace, "--check"});
  EXPECT_EQ(cl.command, "navmatrix");
  const NavMatrixArgs& a = cl.navmatrix;
  EXPECT_EQ(a.presets, (std::vector<std::string>{"station-box", "free-flight"}));
  EXPECT_EQ(a.counts, (std::vector<int>{64, 128}));
  EXPECT_EQ(a.seeds, "2-3");
  EXPECT_EQ(a.frames, 40);
  EXPECT_EQ(a.spurious, 0);
  EXPECT_EQ(a.facing, "no");
  EXPECT_EQ(a.jobs, 1);
  EXPECT_EQ(a.out, out);
  EXPECT_EQ(a.trace, trace);
  EXPECT_TRUE(a.check);
  EXPECT_FALSE(fs::exists(dir));  // nothing ran: no table, no trace
}

TEST(SimCommandLine, NavMatrixDefaultsAndOneLineErrors) {
  const NavMatrixArgs defaults;
  const SimCommandLine cl = Parse({"mfns-sim", "navmatrix"});
  EXPECT_EQ(cl.navmatrix.presets, defaults.presets);
  EXPECT_EQ(cl.navmatrix.counts, defaults.counts);
  EXPECT_EQ(cl.navmatrix.frames, 600);
  EXPECT_FALSE(cl.navmatrix.check);
  try {
    Parse({"mfns-sim", "navmatrix", "--frames", "4\n0"});
    ADD_FAILURE() << "accepted";
  } catch (const CLI::ParseError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    EXPECT_NE(what.find("--frames"), std::string::npos) << what;
  }
  // --facing and --seeds are checked when the command runs (a UserError naming the flag), not here.
  EXPECT_EQ(Parse({"mfns-sim", "navmatrix", "--facing", "maybe"}).navmatrix.facing, "maybe");
}

// render's, crb's and calib-dataset's scenario (LoadScenario, what host_cli_fuzz runs after each
// parse): the overrides applied, errors one line naming the option or file. A --scenario path or
// --preset holding a newline made a two-line error before (ReadFile and PresetYaml quoted it raw).
TEST(SimCommandLine, ScenarioLoadsWithOverridesAndOneLineErrors) {
  const auto error = [](const ScenarioArgs& a) -> std::string {
    std::string text;
    try {
      LoadScenario(a, &text);
    } catch (const UserError& e) {
      return e.what();
    }
    return "no error";
  };
  std::string text;
  const SimCommandLine cl = Parse({"mfns-sim", "crb", "--preset", "station-box", "--out", "unused.csv", "--frames",
                                   "7", "--seed", "3"});
  const Scenario s = LoadScenario(cl.scenario, &text);
  EXPECT_EQ(s.frames, 7);
  EXPECT_EQ(s.seed, 3u);
  EXPECT_EQ(text.rfind("# preset station-box with command-line overrides\n", 0), 0u);
  EXPECT_FALSE(fs::exists("unused.csv"));
  ScenarioArgs a;
  a.file = "no/such\nfile.yaml";
  EXPECT_EQ(error(a), "no/such\\nfile.yaml: no such file");
  a.preset = "station-box";
  EXPECT_EQ(error(a), "give exactly one of --preset or --scenario");
  a.file.clear();
  a.preset = "station\nbox";
  EXPECT_EQ(error(a).rfind("unknown preset 'station\\nbox' (known: ", 0), 0u) << error(a);
}

}  // namespace
}  // namespace mfns::host
