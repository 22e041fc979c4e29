// mfns-calib survey end to end: rendered frames of a flight with a surveyed map (0.4 mm errors)
// through mfns-navd's loop and the adjustment, the outputs against the simulator's truth.
#include "host/calib/survey/survey_command.h"

#include "host/calib/survey/turntable_placement_yaml.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "common/blob/param_blob.h"
#include "common/rotation/rotation.h"
#include "host/rigio/rig_yaml.h"
#include "host/sim/frames/render_run.h"
#include "host/sim/scenario/scenario.h"
#include "host/util/user_error.h"

namespace mfns::host {
namespace {

namespace fs = std::filesystem;

std::string ReadText(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(f), {});
}

class SurveyCommandTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("mfns_survey_command_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    // A free flight (160 frame sets) through the free-flight module, map surveyed with 0.4 mm.
    const std::string text = PresetYaml("free-flight");
    Scenario s = ParseScenarioYaml(text, "free-flight", ".");
    s.frames = 160;
    s.seed = 3;
    s.errors.beacon_map = true;
    s.errors.beacon_sigma = 0.4e-3;
    RenderOptions ro;
    ro.out_dir = dir_ / "flight";
    ro.threads = 2;
    ro.progress = false;
    RenderScenario(s, text, ro);
    truth_ = s.rig;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  SurveyCommandOptions Options(const std::string& out) const {
    SurveyCommandOptions o;
    o.rig_path = (dir_ / "flight" / "believed-rig.yaml").string();
    o.out_dir = (dir_ / out).string();
    o.recordings = {(dir_ / "flight").string()};
    o.generation = 42;
    o.generation_set = true;
    return o;
  }

  static fs::path dir_;
  static Rig truth_;
};
fs::path SurveyCommandTest::dir_;
Rig SurveyCommandTest::truth_;

TEST_F(SurveyCommandTest, RefinesTheMapFromRenderedFramesAndWritesEveryOutput) {
  std::ostringstream log;
  const SurveyResult r = RunSurveyCommand(Options("out"), log);
  EXPECT_NE(log.str().find("160 frame sets"), std::string::npos) << log.str();
  const Rig believed = ReadRigYaml(dir_ / "flight" / "believed-rig.yaml");
  const Rig refined = ReadRigYaml(dir_ / "out" / "rig.yaml");
  ASSERT_EQ(refined.num_beacons, believed.num_beacons);
  double se = 0, re = 0;
  int n = 0, within = 0;
  for (int b = 0; b < refined.num_beacons; ++b) {
    const auto sb = static_cast<std::size_t>(b);
    if (r.beacons[sb].frame_sets < 20) {
      // Unseen (or seldom seen) beacons: a seldom seen one is refined too, an unseen one kept.
      if (r.beacons[sb].observations == 0) {
        EXPECT_LT((refined.beacons_w[sb] - believed.beacons_w[sb]).norm(), 2e-6);
      }
      continue;
    }
    const Eigen::Vector3d e = r.beacons[sb].refined_w - truth_.beacons_w[sb];
    se += (believed.beacons_w[sb] - truth_.beacons_w[sb]).squaredNorm();
    re += e.squaredNorm();
    for (int k = 0; k < 3; ++k) within += std::abs(e(k)) <= 3 * r.beacons[sb].Sigma()(k) ? 1 : 0;
    n += 3;
    // The rig file holds the refined map (to its 1 um text) and each beacon's sigma.
    EXPECT_LT((refined.beacons_w[sb] - r.beacons[sb].refined_w).norm(), 2e-6);
    ASSERT_TRUE(refined.has_beacon_sigmas);
    EXPECT_NEAR(refined.beacon_sigmas[sb], r.beacons[sb].Sigma().maxCoeff(), 1e-9);
    EXPECT_LT(refined.beacon_sigmas[sb], believed.beacon_sigma);  // seen: better known than surveyed
    EXPECT_GE(refined.beacon_sigma, refined.beacon_sigmas[sb]);
  }
  ASSERT_GE(n, 45);
  EXPECT_LT(std::sqrt(re / n), 0.7 * std::sqrt(se / n)) << std::sqrt(re / n) << " vs " << std::sqrt(se / n);
  EXPECT_GE(within, 0.95 * n);
  // The blob decodes to the same rig, generation as given.
  const std::string blob = ReadText(dir_ / "out" / "calibration.bin");
  Rig from_blob;
  BlobInfo info;
  ASSERT_EQ(DecodeParamBlob(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(blob.data()), blob.size()),
                            nullptr, &from_blob, &info),
            BlobStatus::kOk);
  EXPECT_EQ(info.generation, 42u);
  EXPECT_EQ(info.format_version, 2);  // per-beacon sigmas
  EXPECT_EQ(from_blob.num_beacons, refined.num_beacons);
  ASSERT_TRUE(from_blob.has_beacon_sigmas);
  for (int b = 0; b < refined.num_beacons; ++b)
    EXPECT_NEAR(from_blob.beacon_sigmas[static_cast<std::size_t>(b)], refined.beacon_sigmas[static_cast<std::size_t>(b)], 1e-9);
  // report.html: every beacon in its table, the unseen ones listed.
  const std::string html = ReadText(dir_ / "out" / "report.html");
  EXPECT_NE(html.find("<table id=\"beacons\">"), std::string::npos);
  EXPECT_EQ(static_cast<int>(std::count(html.begin(), html.end(), '\n')) > refined.num_beacons, true);
  int unseen = 0;
  for (const SurveyBeacon& b : r.beacons) unseen += b.observations == 0 ? 1 : 0;
  const std::size_t list = html.find("<ul id=\"unseen\">");
  ASSERT_NE(list, std::string::npos);
  const std::string items = html.substr(list, html.find("</ul>", list) - list);
  int listed = 0;
  for (std::size_t at = items.find("<li>beacon "); at != std::string::npos; at = items.find("<li>beacon ", at + 1)) ++listed;
  EXPECT_EQ(listed, unseen);
  EXPECT_NE(html.find("<svg"), std::string::npos);
  // survey.csv: a header and one row per beacon.
  const std::string csv = ReadText(dir_ / "out" / "survey.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), refined.num_beacons + 1);
}

// --refine-cameras on the same frames, the rig file's cameras 1 and 2 turned by 0.05 deg and
// moved by 0.5 mm: the command's plumbing and honesty (AdjustMap's accuracy on longer flights is
// survey_test's RefineCamerasFindsTheMountings). 160 frame sets see 18 beacons, too few to pin
// every mounting below the error given (camera z's 1-sigma comes out 0.066 deg): each refined
// mounting relative to camera 0 must be within 3 of its 1-sigma of the truth. Without
// calibration sigma camera 0 is held; with the paper's sigma the refined rig's sigmas are the
// posterior's (no larger than given). The log and the report show each camera's change.
TEST_F(SurveyCommandTest, RefineCamerasRestoresMovedCameras) {
  const Rig believed = ReadRigYaml(dir_ / "flight" / "believed-rig.yaml");
  Rig wrong = believed;
  for (std::size_t k = 1; k < 3; ++k) {
    wrong.cameras[k].C_k_b = ExpSO3(Eigen::Vector3d(0.0, DegToRad(0.05), DegToRad(-0.03))) * wrong.cameras[k].C_k_b;
    wrong.cameras[k].r_b_bk += Eigen::Vector3d(0.5e-3, -0.3e-3, 0.0);
  }
  const auto relative_error_deg = [&](const Rig& rig, std::size_t k) {
    const Eigen::Matrix3d est = rig.cameras[k].C_k_b * rig.cameras[0].C_k_b.transpose();
    const Eigen::Matrix3d tru = truth_.cameras[k].C_k_b * truth_.cameras[0].C_k_b.transpose();
    return RadToDeg(LogSO3(est * tru.transpose()).norm());
  };
  const auto rotation_sigma_deg = [](const SurveyCamera& c) {
    return RadToDeg(std::sqrt(c.covariance.topLeftCorner<3, 3>().trace()));
  };
  for (const bool with_sigma : {false, true}) {
    SCOPED_TRACE(with_sigma ? "with the calibration's sigma" : "without");
    wrong.has_sigma = with_sigma;
    const std::string name = with_sigma ? "cams-sigma" : "cams";
    WriteRigYaml(dir_ / (name + "-rig.yaml"), wrong);
    SurveyCommandOptions o = Options(name);
    o.rig_path = (dir_ / (name + "-rig.yaml")).string();
    o.refine_cameras = true;
    std::ostringstream log;
    const SurveyResult r = RunSurveyCommand(o, log);
    const Rig out = ReadRigYaml(dir_ / name / "rig.yaml");
    EXPECT_NE(log.str().find("rotation changed"), std::string::npos) << log.str();
    EXPECT_NE(ReadText(dir_ / name / "report.html").find("rotation change (deg)"), std::string::npos);
    ASSERT_EQ(r.cameras.size(), 3u);
    EXPECT_EQ(r.cameras[0].refined, with_sigma);
    if (!with_sigma) {
      EXPECT_LT((out.cameras[0].C_k_b - wrong.cameras[0].C_k_b).norm(), 1e-6);
    }
    for (std::size_t k = 1; k < 3; ++k) {
      const double before = relative_error_deg(wrong, k), after = relative_error_deg(out, k);
      const double sigma = std::hypot(rotation_sigma_deg(r.cameras[k]), rotation_sigma_deg(r.cameras[0]));
      std::printf("%s: camera %zu %.4f -> %.4f deg from the true relative mounting (1-sigma %.4f)\n", name.c_str(), k,
                  before, after, sigma);
      ASSERT_TRUE(r.cameras[k].refined);
      EXPECT_GT(sigma, 0.0);
      EXPECT_LT(after, 3.0 * sigma);
      if (!with_sigma) continue;
      for (int i = 0; i < 3; ++i) {
        EXPECT_LE(out.sigma[k].euler(i), 1.01 * wrong.sigma[k].euler(i)) << i;
        EXPECT_LE(out.sigma[k].r_b_bk(i), 1.01 * wrong.sigma[k].r_b_bk(i)) << i;
      }
    }
  }
}

TEST_F(SurveyCommandTest, BadInputLosesNothingAndNamesTheProblem) {
  // Earlier outputs in DIR stay as they were when a run fails.
  fs::create_directories(dir_ / "kept");
  std::ofstream(dir_ / "kept" / "rig.yaml") << "earlier";
  std::ostringstream log;
  SurveyCommandOptions o = Options("kept");
  o.recordings = {(dir_ / "no-such-recording").string()};
  try {
    RunSurveyCommand(o, log);
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-recording"), std::string::npos) << e.what();
  }
  // A rig without the survey's sigma.
  const fs::path no_sigma = dir_ / "no-sigma.yaml";
  Rig r = ReadRigYaml(dir_ / "flight" / "believed-rig.yaml");
  r.beacon_sigma = 0.0;
  WriteRigYaml(no_sigma, r);
  o = Options("kept");
  o.rig_path = no_sigma.string();
  try {
    RunSurveyCommand(o, log);
    FAIL();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("no-sigma.yaml: beacon_sigma_mm"), std::string::npos) << e.what();
  }
  o = Options("kept");
  o.initial_pose = {0, 0, 0, 0, 0};
  EXPECT_THROW(RunSurveyCommand(o, log), UserError);
  EXPECT_EQ(ReadText(dir_ / "kept" / "rig.yaml"), "earlier");
  EXPECT_FALSE(fs::exists(dir_ / "kept" / "calibration.bin"));
}

// The turntable's surveyed placement: refused naming the option before anything is read.
TEST_F(SurveyCommandTest, BadTurntablePlacementIsRefusedNamingTheOption) {
  struct Bad {
    const char* expected;
    void (*edit)(SurveyCommandOptions*);
  };
  const Bad bad[] = {
      {"--turntable-centre-mm: only with --turntable", [](SurveyCommandOptions* o) {
         o->turntable = false;
         o->turntable_centre_mm = {1, 2, 3};
       }},
      {"--turntable-centre-mm: expected 3 finite", [](SurveyCommandOptions* o) { o->turntable_centre_mm = {1, NAN, 3}; }},
      {"--turntable-centre-sigma-mm", [](SurveyCommandOptions* o) {
         o->turntable_centre_mm = {1, 2, 3};
         o->turntable_centre_sigma_set = true;
         o->turntable_centre_sigma_mm = 0.0;
       }},
      {"--turntable-centre-sigma-mm", [](SurveyCommandOptions* o) { o->turntable_centre_sigma_set = true; }},
      {"--turntable-axis: expected 3 finite numbers X,Y,Z, not all 0",
       [](SurveyCommandOptions* o) { o->turntable_axis = {0, 0, 0}; }},
      {"--turntable-axis-sigma-deg", [](SurveyCommandOptions* o) {
         o->turntable_axis = {0, 0, 1};
         o->turntable_axis_sigma_deg = -1.0;
       }},
      {"--turntable-axis-sigma-deg", [](SurveyCommandOptions* o) { o->turntable_axis_sigma_set = true; }},
  };
  for (const Bad& b : bad) {
    SurveyCommandOptions o = Options("never");
    o.turntable = true;
    b.edit(&o);
    std::ostringstream log;
    try {
      RunSurveyCommand(o, log);
      ADD_FAILURE() << b.expected;
    } catch (const UserError& e) {
      EXPECT_NE(std::string(e.what()).find(b.expected), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
    }
  }
  EXPECT_FALSE(fs::exists(dir_ / "never"));
}

// Two turntable placements, each surveyed to 0.02 mm (a laser tracker's) in its own file, given
// one per recording (--turntable-placement): each reaches its own recording's pivot group (its
// centre refined within 3 sigma of the truth, no less certain than surveyed; the turntable moved
// 0.4 m between the recordings, so a swapped file would fail both). "none" leaves a recording's
// group without one. The simulator's own turntable-survey.yaml reads back as the placement it
// drew. (Short sweeps, 40 frame sets: this checks the command's plumbing; the two placements'
// effect on the map is SurveyTest.ASecondTurntablePlacementFixesTheShapeNotThePlacement's. With
// 150 frame sets each, measured once through this command: 0.17 of the survey's map error.)
TEST(SurveyCommandTurntableTest, EachRecordingTakesItsOwnPlacementFile) {
  const fs::path dir = fs::temp_directory_path() / ("mfns_survey_placement_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string text = PresetYaml("paper-turntable");
  Scenario s = ParseScenarioYaml(text, "paper-turntable", ".");
  s.frames = 60;  // (the first ~25 cold: no start pose is given)
  s.seed = 2;
  s.errors.beacon_map = true;
  s.errors.beacon_sigma = 0.4e-3;
  Scenario moved = s;  // the same station and survey, the turntable 0.4 m along y; other noise
  moved.seed = 102;
  moved.turntable.r_w_wt += Eigen::Vector3d(0.0, 0.4, 0.0);
  std::vector<std::string> files;
  std::vector<Eigen::Vector3d> centres;
  int i = 0;
  for (const Scenario& run : {s, moved}) {
    const fs::path out = dir / ("run" + std::to_string(i));
    RenderScenario(run, text, RenderOptions{out, 2, true, false});
    // The simulator's file: its own draw of the placement, as the reader reads it.
    const SurveyedTurntable st = SurveyTurntable(run);
    const TurntablePlacement sim = ReadTurntablePlacementYaml(out / "turntable-survey.yaml");
    EXPECT_LT((sim.centre_w - st.centre_w).norm(), 1e-7);
    EXPECT_NEAR(sim.centre_sigma_m, st.centre_sigma, 1e-7);
    EXPECT_LT((sim.centre_b - st.centre_b).norm(), 1e-7);
    EXPECT_LT((sim.axis_w - st.axis_w).norm(), 1e-8);
    // The laser tracker's: the same draw scaled to 0.02 mm.
    TurntablePlacement t = sim;
    t.centre_w = run.turntable.r_w_wt + (0.02e-3 / st.centre_sigma) * (st.centre_w - run.turntable.r_w_wt);
    t.centre_sigma_m = 0.02e-3;
    files.push_back((dir / ("placement" + std::to_string(i) + ".yaml")).string());
    std::ofstream(files.back()) << FormatTurntablePlacementYaml(t, "surveyed to 0.02 mm");
    centres.push_back(run.turntable.r_w_wt);
    ++i;
  }
  SurveyCommandOptions o;
  o.rig_path = (dir / "run0" / "believed-rig.yaml").string();
  o.recordings = {(dir / "run0").string(), (dir / "run1").string()};
  o.generation_set = true;
  o.turntable = true;
  o.turntable_placements = files;
  o.out_dir = (dir / "both").string();
  std::ostringstream both_log;
  const SurveyResult both = RunSurveyCommand(o, both_log);
  ASSERT_EQ(both.pivots.size(), 2u);
  double surveyed = 0.0, refined = 0.0;
  int n = 0;
  for (std::size_t b = 0; b < both.beacons.size(); ++b) {
    if (both.beacons[b].frame_sets < 10) continue;
    surveyed += (both.beacons[b].surveyed_w - s.rig.beacons_w[b]).squaredNorm();
    refined += (both.beacons[b].refined_w - s.rig.beacons_w[b]).squaredNorm();
    ++n;
  }
  ASSERT_GE(n, 5);
  std::printf("two placements at 0.02 mm through the command: map error %.3f of the survey's\n",
              std::sqrt(refined / surveyed));
  EXPECT_LT(refined, surveyed);
  // "none" for the first, and a third recording too short to give a fix (two frame sets, cold):
  // its placement is left out, said on the log, and the survey goes on with the other two.
  Scenario brief = s;
  brief.frames = 2;
  RenderScenario(brief, text, RenderOptions{dir / "brief", 2, true, false});
  o.recordings.push_back((dir / "brief").string());
  o.turntable_placements = {"none", files[1], files[0]};
  o.out_dir = (dir / "second").string();
  std::ostringstream log;
  const SurveyResult second = RunSurveyCommand(o, log);
  ASSERT_EQ(second.pivots.size(), 2u);
  EXPECT_NE(log.str().find("brief: no fix, its turntable placement is not used"), std::string::npos) << log.str();
  for (std::size_t g = 0; g < 2; ++g) {
    const Eigen::Vector3d sigma = both.pivots[g].covariance.bottomRightCorner<3, 3>().diagonal().cwiseSqrt();
    EXPECT_LE(sigma.maxCoeff(), 0.02e-3 * 1.0001) << g;
    for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(both.pivots[g].p_w(k) - centres[g](k)), 3.0 * sigma(k)) << g;
    const Eigen::Vector3d sigma2 = second.pivots[g].covariance.bottomRightCorner<3, 3>().diagonal().cwiseSqrt();
    if (g == 1) EXPECT_LE(sigma2.maxCoeff(), 0.02e-3 * 1.0001);
    else EXPECT_GT(sigma2.maxCoeff(), 0.05e-3);  // placed by the images and the map only
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mfns::host
