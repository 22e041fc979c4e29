#include "host/sim/analysis/analyze_command.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>

#include "host/core/xml_check_test_util.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

class AnalyzeCommand : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("mfns_analyze_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Parses "analyze ARGS" on a fresh app, as mfns-sim does.
  static void Parse(const std::string& args) {
    CLI::App app{"test"};
    AddAnalyzeCommand(app);
    app.parse("analyze " + args, false);
  }

  fs::path dir_;
};

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

TEST_F(AnalyzeCommand, WritesACsvAndAWellFormedSvgPerFigure) {
  AnalyzeOptions o;
  o.out_dir = (dir_ / "out").string();  // created, parent included
  o.trials = 300;
  o.points = 5;
  std::ostringstream summary, progress;
  const AnalyzeResult r = RunAnalyze(o, summary, progress);
  const char* stems[] = {"fig4_beacon_position", "fig5_camera_position", "fig6_camera_attitude"};
  const char* units[] = {"error_mm", "error_mm", "error_deg"};
  for (int f = 0; f < 3; ++f) {
    const std::string csv = ReadFile(fs::path(o.out_dir) / (std::string(stems[f]) + ".csv"));
    const std::vector<std::string> lines = Lines(csv);
    ASSERT_EQ(lines.size(), 6u) << stems[f];
    EXPECT_EQ(lines[0], std::string(units[f]) + ",mc_rms_u_px,analytic_rms_u_px,trials");
    for (std::size_t k = 1; k < lines.size(); ++k) {
      EXPECT_EQ(std::count(lines[k].begin(), lines[k].end(), ','), 3) << lines[k];
      EXPECT_EQ(lines[k].substr(lines[k].rfind(',') + 1), "300");
    }
    EXPECT_EQ(lines.back().substr(0, lines.back().find(',')), f == 2 ? "0.17" : "3");
    const XmlSummary x = CheckXml(ReadFile(fs::path(o.out_dir) / (std::string(stems[f]) + ".svg")));
    ASSERT_TRUE(x.ok) << x.error;
    EXPECT_EQ(x.root, "svg");
    EXPECT_EQ(x.mc_circles, 5);
    EXPECT_EQ(x.analytic_polylines, 1);
    EXPECT_EQ(r.figures[static_cast<std::size_t>(f)].points.size(), 5u);
  }
  EXPECT_EQ(Lines(progress.str()).size(), 15u);  // a line per point
  EXPECT_NE(summary.str().find("figure 6 (camera-to-body attitude error): slope MC"), std::string::npos);
  EXPECT_NE(summary.str().find("paper's conclusion"), std::string::npos);
}

TEST_F(AnalyzeCommand, SameSeedSameFilesDifferentSeedDifferent) {
  std::ostringstream sink;
  const auto run = [&](const std::string& sub, std::uint64_t seed) {
    AnalyzeOptions o;
    o.out_dir = (dir_ / sub).string();
    o.trials = 200;
    o.points = 3;
    o.seed = seed;
    RunAnalyze(o, sink, sink);
    return o.out_dir;
  };
  const fs::path a = run("a", 5), b = run("b", 5), c = run("c", 6);
  for (const char* name : {"fig4_beacon_position.csv", "fig5_camera_position.csv", "fig6_camera_attitude.csv",
                           "fig6_camera_attitude.svg"}) {
    EXPECT_EQ(ReadFile(a / name), ReadFile(b / name)) << name;
    EXPECT_NE(ReadFile(a / name), ReadFile(c / name)) << name;
  }
}

TEST_F(AnalyzeCommand, CommandLineRunsTheAnalysis) {
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  Parse("--out " + dir_.string() +
        " --trials 100 --points 2 --seed 3 --beacon-y-range-mm -500 500 --error-draw sphere");
  const std::string out = testing::internal::GetCapturedStdout();
  testing::internal::GetCapturedStderr();
  EXPECT_NE(out.find("Y [-500, 500]"), std::string::npos) << out;
  EXPECT_NE(out.find("error draw sphere"), std::string::npos) << out;
  EXPECT_EQ(Lines(ReadFile(dir_ / "fig5_camera_position.csv")).size(), 3u);
}

TEST_F(AnalyzeCommand, BadOptionsAreUserErrors) {
  const std::string out = "--out " + dir_.string() + " ";
  EXPECT_THROW(Parse("--trials 10"), UserError);  // no --out
  EXPECT_THROW(Parse(out + "--trials 0"), UserError);
  EXPECT_THROW(Parse(out + "--points 1"), UserError);
  EXPECT_THROW(Parse(out + "--beacon-y-range-mm 5 1"), UserError);
  EXPECT_THROW(Parse(out + "--beacon-y-range-mm 2000 3000"), UserError);  // never in view within Z <= 1 m
  EXPECT_THROW(Parse(out + "--beacon-z-range-mm 0 50"), UserError);       // all nearer than the min depth
  EXPECT_THROW(Parse(out + "--min-depth-mm -1"), UserError);
  EXPECT_THROW(Parse(out + "--error-draw uniform"), UserError);
  EXPECT_THROW(Parse(out + "--fig6-max-deg 0"), UserError);
  EXPECT_THROW(Parse(out + "--few-px -2"), UserError);
  EXPECT_FALSE(fs::exists(dir_));  // nothing written on a bad option
  // An output path that is a file.
  fs::create_directories(dir_);
  WriteFileAtomic(dir_ / "file", std::string_view("x"));
  EXPECT_THROW(Parse("--out " + (dir_ / "file").string() + " --trials 10 --points 2"), UserError);
}

// SetupFromOptions (what host_cli_fuzz runs after each parse) names the option in one line: an
// --error-draw holding a newline made a two-line error before.
TEST(AnalyzeSetup, ErrorsAreOneLineNamingTheOption) {
  AnalyzeOptions o;
  o.out_dir = "unused";
  o.error_draw = "sph\nere";
  try {
    SetupFromOptions(o);
    ADD_FAILURE() << "accepted";
  } catch (const UserError& e) {
    EXPECT_STREQ(e.what(), "--error-draw: 'sph\\nere' is not one of gaussian, sphere");
  }
  EXPECT_FALSE(fs::exists("unused"));
}

}  // namespace
}  // namespace mfns::host
