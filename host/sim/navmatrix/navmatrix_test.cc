#include "host/sim/navmatrix/navmatrix.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <cstdlib>
#include <filesystem>

#include "common/rig/paper_rig.h"
#include "common/rotation/rotation.h"
#include "host/rigio/rig_yaml.h"
#include "firmware/modules/identify/lost_in_space.h"
#include "host/sim/navmatrix/matrix.h"
#include "host/sim/observe/observe.h"

namespace mfns::host {
namespace {

// A run of the 64-beacon box (the matrix's map), as the regression cases below replay it.
RunSpec Box64Run(std::uint64_t seed, int frames) {
  RunSpec r;
  r.preset = "station-box";
  r.count = r.map_beacons = 64;
  r.seed = seed;
  r.frames = frames;
  return r;
}

using fw::NavStatus;

// ---- (a) Scoring, on synthetic inputs -------------------------------------------------------

TEST(NavMatrixScore, WrongPoseIsTwentyMillimetresOrTenSigmaOrOneDegree) {
  const NavMatrixOptions o;
  EXPECT_TRUE(WrongPose(0.025, 0.0, 0.001, o));   // 25 mm, 1 mm sigma: the 20 mm floor rules
  EXPECT_FALSE(WrongPose(0.015, 0.0, 0.005, o));  // 15 mm, 5 mm sigma
  EXPECT_FALSE(WrongPose(0.045, 0.0, 0.005, o));  // 45 mm within 10 x 5 mm
  EXPECT_TRUE(WrongPose(0.055, 0.0, 0.005, o));   // 55 mm beyond it
  EXPECT_FALSE(WrongPose(0.019, 0.0, 0.0, o));    // no covariance: the floor alone
  EXPECT_TRUE(WrongPose(0.001, DegToRad(1.1), 0.001, o));
  EXPECT_FALSE(WrongPose(0.001, DegToRad(0.9), 0.001, o));
  EXPECT_TRUE(WrongPose(0.001, DegToRad(1.1), 1.0, o));  // a large position sigma excuses no attitude error
  EXPECT_TRUE(WrongPose(std::numeric_limits<double>::quiet_NaN(), 0.0, 0.001, o));
}

TEST(NavMatrixScore, RecordFrameMeasuresThePublishedPoseAgainstTruth) {
  BodyPose truth;
  truth.C_w_b = EulerToMatrix({0.3, -0.2, 1.1}).transpose();
  truth.r_w_wb = Eigen::Vector3d(1.0, -0.5, 0.2);
  fw::NavOutput out;
  out.status = NavStatus::kDegraded;
  out.pose.r_w_wb = truth.r_w_wb + Eigen::Vector3d(0.0, 0.024, -0.007);  // 25 mm off
  out.pose.C_w_b = truth.C_w_b * ExpSO3(Eigen::Vector3d(0.0, 0.0, DegToRad(0.5)));
  out.covariance.setZero();
  out.covariance.diagonal() << 1e-6, 9e-6, 4e-6, 1e-8, 1e-8, 1e-8;  // 1, 3, 2 mm
  const FrameRecord f = RecordFrame(7, out, truth, 0.002);
  EXPECT_EQ(f.in_view, 7);
  EXPECT_EQ(f.status, NavStatus::kDegraded);
  EXPECT_NEAR(f.position_error_m, 0.025, 1e-12);
  EXPECT_NEAR(f.attitude_error_rad, DegToRad(0.5), 1e-12);
  EXPECT_NEAR(f.position_sigma_m, 0.003, 1e-12);  // the largest per-axis 1-sigma
  EXPECT_EQ(f.step_s, 0.002);
  out.status = NavStatus::kLost;  // a lost frame set has no pose to score
  const FrameRecord lost = RecordFrame(2, out, truth, 0.001);
  EXPECT_EQ(lost.position_error_m, 0.0);
  EXPECT_EQ(lost.attitude_error_rad, 0.0);
}

FrameRecord Frame(int in_view, NavStatus status, double error_m = 0.001, double sigma_m = 0.001,
                  double step_s = 0.001) {
  FrameRecord f;
  f.in_view = in_view;
  f.status = status;
  if (status != NavStatus::kLost) {
    f.position_error_m = error_m;
    f.position_sigma_m = sigma_m;
  }
  f.step_s = step_s;
  return f;
}

// Frame sets 0-2 see 3 beacons, 4 from frame set 3 on; the first fix comes at frame set 9 (lag
// 6); after it one frame set with 3 in view is lost (counted), one with 2 is lost (not counted).
TEST(NavMatrixScore, FirstFixLagPosedShareWrongPosesAndTime) {
  std::vector<FrameRecord> f;
  for (int i = 0; i < 3; ++i) f.push_back(Frame(3, NavStatus::kLost));
  for (int i = 3; i < 9; ++i) f.push_back(Frame(4, NavStatus::kLost, 0, 0, 0.016));  // acquiring, slow
  f.push_back(Frame(4, NavStatus::kFix));                                            // 9: first fix
  f.push_back(Frame(5, NavStatus::kFix, 0.030, 0.001));              // 10: wrong fix (30 mm, 1 mm sigma)
  f.push_back(Frame(3, NavStatus::kDegraded, 0.030, 0.005));         // 11: 30 mm with 5 mm sigma: right
  f.push_back(Frame(3, NavStatus::kDegraded, 0.001, 0.001, 0.060));  // 12: a deadline slip
  f.push_back(Frame(3, NavStatus::kLost));                           // 13: eligible, no pose
  f.push_back(Frame(2, NavStatus::kLost));                           // 14: not eligible
  f.push_back(Frame(2, NavStatus::kDegraded, 0.5, 0.01));            // 15: wrong degraded (not eligible, still scored)
  const RunResult r = ScoreRun(f, 1.0 / 18.6, NavMatrixOptions{});
  EXPECT_EQ(r.frames, 16);
  EXPECT_EQ(r.first_in_view, 3);
  EXPECT_EQ(r.first_fix, 9);
  ASSERT_TRUE(r.HasLag());
  EXPECT_EQ(r.Lag(), 6);
  EXPECT_FALSE(r.LagExceeds(10));
  EXPECT_TRUE(r.LagExceeds(5));
  EXPECT_FALSE(r.NeverFixed());
  EXPECT_EQ(r.eligible_after_fix, 5);  // 9-13
  EXPECT_EQ(r.posed_after_fix, 4);
  EXPECT_DOUBLE_EQ(r.PosedShare(), 0.8);
  EXPECT_EQ(r.fixes, 2);
  EXPECT_EQ(r.degraded, 3);
  EXPECT_EQ(r.wrong_fixes, 1);
  EXPECT_EQ(r.wrong_degraded, 1);
  EXPECT_DOUBLE_EQ(r.worst_fix_position_m, 0.030);
  EXPECT_EQ(r.slips, 1);
  EXPECT_EQ(r.slow, 7);  // six acquiring frame sets at 16 ms and the slip
  EXPECT_DOUBLE_EQ(r.worst_step_s, 0.060);
  EXPECT_NEAR(r.total_step_s, 6 * 0.016 + 0.060 + 9 * 0.001, 1e-12);
  EXPECT_NEAR(r.mean_in_view, (9 + 6 * 4 + 4 + 5 + 3 * 3 + 2 * 2) / 16.0, 1e-12);
}

TEST(NavMatrixScore, LateAndMissingFirstFixes) {
  std::vector<FrameRecord> f(20, Frame(4, NavStatus::kLost));
  f[2].in_view = 3;
  f[0].in_view = f[1].in_view = 2;  // first frame set with 4 in view: 3
  const NavMatrixOptions o;
  RunResult never = ScoreRun(f, 0.05, o);
  EXPECT_EQ(never.first_in_view, 3);
  EXPECT_TRUE(never.NeverFixed());
  EXPECT_FALSE(never.HasLag());
  EXPECT_TRUE(never.LagExceeds(10));          // 16 frame sets after frame set 3 without a fix
  EXPECT_DOUBLE_EQ(never.PosedShare(), 1.0);  // nothing after a fix that never came
  f[14] = Frame(4, NavStatus::kFix);
  const RunResult late = ScoreRun(f, 0.05, o);
  EXPECT_EQ(late.Lag(), 11);
  EXPECT_TRUE(late.LagExceeds(10));
  f[14] = Frame(4, NavStatus::kDegraded);  // a degraded pose is no first fix
  f[13] = Frame(4, NavStatus::kFix);
  EXPECT_EQ(ScoreRun(f, 0.05, o).Lag(), 10);
  EXPECT_FALSE(ScoreRun(f, 0.05, o).LagExceeds(10));
  // A run too short to tell (ends 5 frame sets after the first with 4 in view) is not late.
  const std::vector<FrameRecord> short_run(f.begin(), f.begin() + 9);
  EXPECT_TRUE(ScoreRun(short_run, 0.05, o).NeverFixed());
  EXPECT_FALSE(ScoreRun(short_run, 0.05, o).LagExceeds(10));
  // No frame set with 4 in view: no lag to judge, and a fix from 3 beacons counts as early.
  std::vector<FrameRecord> three(20, Frame(3, NavStatus::kLost));
  three[5] = Frame(3, NavStatus::kFix);
  const RunResult r3 = ScoreRun(three, 0.05, o);
  EXPECT_EQ(r3.first_in_view, -1);
  EXPECT_FALSE(r3.LagExceeds(0));
  EXPECT_EQ(r3.eligible_after_fix, 15);
  EXPECT_EQ(r3.posed_after_fix, 1);
}

// A held view: four beacons or more for held_view_frames (6) frame sets in a row. Frame sets 3-4
// see 4, 5 sees 3 (not held), 6-11 see 4 or 5 (held from 6), then 3.
TEST(NavMatrixScore, LagFromTheFirstHeldView) {
  std::vector<FrameRecord> f(30, Frame(3, NavStatus::kLost));
  f[3].in_view = f[4].in_view = 4;
  for (int i = 6; i < 12; ++i) f[static_cast<std::size_t>(i)].in_view = i == 8 ? 5 : 4;
  NavMatrixOptions o;
  ASSERT_EQ(o.held_view_frames, 6);
  RunResult r = ScoreRun(f, 0.05, o);
  EXPECT_EQ(r.first_in_view, 3);
  EXPECT_EQ(r.first_held_view, 6);
  EXPECT_FALSE(r.HasHeldLag());
  EXPECT_TRUE(r.HeldLagExceeds(10));  // 23 frame sets after frame set 6 without a fix
  f[16] = Frame(3, NavStatus::kFix);
  r = ScoreRun(f, 0.05, o);
  EXPECT_EQ(r.Lag(), 13);
  EXPECT_TRUE(r.LagExceeds(10));  // late from the first four-beacon frame set...
  EXPECT_EQ(r.HeldLag(), 10);
  EXPECT_FALSE(r.HeldLagExceeds(10));  // ...not from the held view
  // One frame set shorter is no held view: nothing to time from, never late by it.
  f[11].in_view = 3;
  r = ScoreRun(f, 0.05, o);
  EXPECT_EQ(r.first_held_view, -1);
  EXPECT_FALSE(r.HeldLagExceeds(0));
  // A fix before the held view: a negative lag, not late.
  o.held_view_frames = 2;
  r = ScoreRun(f, 0.05, o);
  EXPECT_EQ(r.first_held_view, 3);
  f[2] = Frame(3, NavStatus::kFix);
  r = ScoreRun(f, 0.05, o);
  EXPECT_EQ(r.HeldLag(), -1);
  EXPECT_FALSE(r.HeldLagExceeds(0));
}

// ---- The matrix: expansion, scenarios, aggregation, requirements -----------------------------

TEST(NavMatrixSpec, ExpandsPresetsCountsSeedsAndFacing) {
  const std::vector<RunSpec> runs = ExpandMatrix(MatrixSpec{});
  // free-flight: its own 60-beacon map without facing data: one row of 5 seeds; each station
  // module: 3 counts x 2 facings x 5 seeds.
  ASSERT_EQ(runs.size(), 5u + 2u * 3u * 2u * 5u);
  EXPECT_EQ(runs[0].preset, "free-flight");
  EXPECT_EQ(runs[0].count, 0);
  EXPECT_EQ(runs[0].map_beacons, 60);
  EXPECT_FALSE(runs[0].map_has_facing);
  EXPECT_EQ(runs[4].seed, 5u);
  EXPECT_EQ(runs[5].preset, "station-cylinder");
  EXPECT_EQ(runs[5].count, 64);
  EXPECT_TRUE(runs[5].facing);
  EXPECT_FALSE(runs[10].facing);
  EXPECT_EQ(runs[15].count, 128);
  MatrixSpec only_no;
  only_no.presets = {"station-box"};
  only_no.counts = {256};
  only_no.seeds = ParseSeeds("2,7-8");
  only_no.facing = FacingMode::kNo;
  const std::vector<RunSpec> no = ExpandMatrix(only_no);
  ASSERT_EQ(no.size(), 3u);
  EXPECT_EQ(no[2].seed, 8u);
  EXPECT_FALSE(no[0].facing);
}

// The run's overrides reach the scenario: the count, the map seed, the spurious blobs, the
// frames, and facing: false empties the navigator's map of facing while the LEDs keep theirs.
TEST(NavMatrixSpec, ScenarioCarriesTheRunsOverrides) {
  RunSpec r{.preset = "station-cylinder", .count = 64, .seed = 3, .facing = false, .frames = 17, .spurious = 2};
  const Scenario s = MatrixScenario(r);
  EXPECT_EQ(s.rig.num_beacons, 64);
  EXPECT_EQ(s.frames, 17);
  EXPECT_EQ(s.seed, 3u);
  EXPECT_EQ(s.map_seed, 3u);
  EXPECT_EQ(s.clutter.spurious, 2);
  EXPECT_EQ(s.trajectory.kind, TrajectoryKind::kWander);
  EXPECT_TRUE(s.rig.has_facing);
  EXPECT_FALSE(BelievedRig(s).has_facing);
  r.facing = true;
  EXPECT_TRUE(BelievedRig(MatrixScenario(r)).has_facing);
  r.seed = 4;
  EXPECT_NE(MatrixScenario(r).rig.beacons_w[0], s.rig.beacons_w[0]);  // a new seed, a new map
  const Scenario ff = MatrixScenario({.preset = "free-flight", .seed = 2, .frames = 5, .spurious = 2});
  EXPECT_EQ(ff.rig.num_beacons, 60);
  EXPECT_FALSE(ff.rig.has_facing);
  EXPECT_EQ(ff.clutter.spurious, 2);
  EXPECT_EQ(ff.trajectory.kind, TrajectoryKind::kFreeFlight);
  // Static reflections: points on the module's walls, none in the navigator's map.
  r.static_reflections = 12;
  const Scenario sr = MatrixScenario(r);
  EXPECT_EQ(sr.clutter.static_reflections, 12);
  EXPECT_EQ(sr.clutter.reflectors.num_beacons, 12);
  EXPECT_EQ(BelievedRig(sr).num_beacons, 64);
}

// --rig replaces every preset's rig (its cameras): the scenario and its believed rig have the
// file's cameras, the generated map stays the preset's.
TEST(NavMatrixSpec, RigFileReplacesThePresetsCameras) {
  const char* src = std::getenv("MFNS_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  MatrixSpec m;
  m.presets = {"station-box"};
  m.counts = {64};
  m.seeds = {2};
  m.facing = FacingMode::kYes;
  m.rig = std::string(src) + "/host/calib/tools/wide4-rig.yaml";
  const std::vector<RunSpec> runs = ExpandMatrix(m);
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0].rig, m.rig);
  const Scenario s = MatrixScenario(runs[0]);
  EXPECT_EQ(s.rig.num_cameras, 4);
  EXPECT_DOUBLE_EQ(s.rig.cameras[0].intrinsics.alpha_x, 760.0);
  EXPECT_EQ(BelievedRig(s).num_cameras, 4);
  EXPECT_EQ(s.rig.num_beacons, 64);
  m.rig = "/no/such/rig.yaml";
  EXPECT_THROW(ExpandMatrix(m), UserError);
}

// --layout and --jitter reach the generated maps (and only them), and bad values name the flag.
TEST(NavMatrixSpec, LayoutAndJitterReachTheGeneratedMaps) {
  MatrixSpec m;
  m.presets = {"station-cylinder", "free-flight"};
  m.counts = {64};
  m.seeds = {3};
  m.facing = FacingMode::kYes;
  m.layout = "random";
  std::vector<RunSpec> runs = ExpandMatrix(m);
  ASSERT_EQ(runs.size(), 2u);
  EXPECT_EQ(runs[0].layout, "random");
  EXPECT_EQ(runs[1].layout, "");  // free-flight's own map
  const Scenario random = MatrixScenario(runs[0]);
  EXPECT_EQ(random.beacon_layout.layout, BeaconLayoutKind::kRandom);
  EXPECT_EQ(random.rig.num_beacons, 64);
  m.layout = "";
  m.jitter = 0.0;
  runs = ExpandMatrix(m);
  const Scenario regular = MatrixScenario(runs[0]);
  EXPECT_EQ(regular.beacon_layout.layout, BeaconLayoutKind::kJitteredGrid);
  EXPECT_EQ(regular.beacon_layout.jitter, 0.0);
  EXPECT_NE(regular.rig.beacons_w[5], random.rig.beacons_w[5]);
  m.jitter = -1.0;
  EXPECT_EQ(MatrixScenario(ExpandMatrix(m)[0]).beacon_layout.jitter, 0.25);  // the preset's
  m.layout = "hexagonal";
  EXPECT_THROW(ExpandMatrix(m), UserError);
  m.layout = "";
  m.jitter = 0.6;
  EXPECT_THROW(ExpandMatrix(m), UserError);
}

// --static-reflections reaches the presets with a module only (free-flight has none).
TEST(NavMatrixSpec, StaticReflectionsOnlyWhereThereAreWalls) {
  MatrixSpec m;
  m.static_reflections = 20;
  m.seeds = {1};
  for (const RunSpec& r : ExpandMatrix(m))
    EXPECT_EQ(r.static_reflections, r.preset == "free-flight" ? 0 : 20) << r.preset;
}

std::string ErrorOf(const MatrixSpec& m) {
  try {
    ExpandMatrix(m);
  } catch (const UserError& e) {
    return e.what();
  }
  return "no error";
}

TEST(NavMatrixSpec, ErrorsNameTheFlag) {
  MatrixSpec m;
  m.counts = {64, 300};
  EXPECT_EQ(ErrorOf(m), "--counts: 300 is outside 10..256");
  m = MatrixSpec{};
  m.presets = {"moon-base"};
  EXPECT_EQ(ErrorOf(m).rfind("--presets: unknown preset 'moon-base' (known: ", 0), 0u) << ErrorOf(m);
  m = MatrixSpec{};
  m.spurious = -1;
  EXPECT_EQ(ErrorOf(m), "--spurious: must be 0..100");
  m = MatrixSpec{};
  m.static_reflections = 257;
  EXPECT_EQ(ErrorOf(m), "--static-reflections: must be 0..256");
  try {
    ParseSeeds("1-x");
    ADD_FAILURE() << "no error";
  } catch (const UserError& e) {
    EXPECT_STREQ(e.what(), "--seeds: expected seeds like 1-5 or 1,3,8, got '1-x'");
  }
  EXPECT_THROW(ParseSeeds("5-1"), UserError);
  EXPECT_EQ(ParseSeeds("1-3,9"), (std::vector<std::uint64_t>{1, 2, 3, 9}));
}

// The bounds checked before anything runs (issue 14, host_cli_fuzz's run-time checks): --seeds
// was bounded per range only ("0-9999,10000-19999,..." grew without end), a preset, count or
// seed given twice ran twice, nothing bounded the matrix's runs, and --facing quoted a newline raw.
TEST(NavMatrixSpec, SeedsAndRunsAreBoundedBeforeAnythingRuns) {
  const auto seeds_error = [](const std::string& text) -> std::string {
    try {
      ParseSeeds(text);
    } catch (const UserError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(ParseSeeds("1-10000").size(), 10000u);
  EXPECT_EQ(seeds_error("1-10000,20000-20001"), "--seeds: more than 10000 seeds in '1-10000,20000-20001'");
  EXPECT_EQ(seeds_error("1,\n2"), "--seeds: expected seeds like 1-5 or 1,3,8, got '1,\\n2'");
  MatrixSpec m;
  m.presets = {"station-box", "station-box"};
  EXPECT_EQ(ErrorOf(m), "--presets: 'station-box' given twice");
  m = MatrixSpec{};
  m.counts = {64, 64};
  EXPECT_EQ(ErrorOf(m), "--counts: '64' given twice");
  m = MatrixSpec{};
  m.seeds = ParseSeeds("1-3,2");
  EXPECT_EQ(ErrorOf(m), "--seeds: '2' given twice");
  m = MatrixSpec{};
  m.seeds = ParseSeeds("1-10000");  // 3 presets x 3 counts x 2 facings x 10 000 seeds
  EXPECT_EQ(ErrorOf(m), "--presets x --counts x --seeds: more than 100000 runs");
  NavMatrixArgs a;
  a.facing = "y\nes";
  try {
    MatrixSpecFromArgs(a);
    ADD_FAILURE() << "accepted";
  } catch (const UserError& e) {
    EXPECT_STREQ(e.what(), "--facing: expected both, yes or no, got 'y\\nes'");
  }
  a.facing = "no";
  EXPECT_EQ(MatrixSpecFromArgs(a).facing, FacingMode::kNo);
}

TEST(NavMatrixSpec, RowsAggregateSeedsAndRequirementsNameTheFailingRow) {
  const RunSpec a{.preset = "station-box", .count = 64, .seed = 1, .map_beacons = 64};
  RunSpec b = a;
  b.seed = 2;
  RunResult good;
  good.frames = 100;
  good.first_in_view = 2;
  good.first_held_view = 4;
  good.first_fix = 5;
  good.eligible_after_fix = 90;
  good.posed_after_fix = 90;
  good.fixes = 90;
  RunResult late = good;
  late.first_fix = 20;
  late.eligible_after_fix = 80;
  late.posed_after_fix = 78;
  late.wrong_fixes = 1;
  const MatrixLimits limits;
  const std::vector<MatrixRow> rows = Summarise({a, b}, {good, late}, limits);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_EQ(rows[0].runs, 2);
  EXPECT_EQ(rows[0].lags, (std::vector<int>{3, 18}));
  EXPECT_EQ(rows[0].lag_exceeded, 1);
  EXPECT_EQ(rows[0].held_lags, (std::vector<int>{1, 16}));
  EXPECT_EQ(rows[0].held_lag_exceeded, 1);
  EXPECT_DOUBLE_EQ(rows[0].min_posed_share, 78.0 / 80.0);
  EXPECT_EQ(rows[0].eligible, 170);
  EXPECT_EQ(rows[0].posed, 168);
  const std::vector<std::string> failures = RequirementFailures(rows, limits);
  ASSERT_EQ(failures.size(), 3u);
  EXPECT_EQ(failures[0].rfind("station-box 64 facing yes: first fix more than 10 frame sets", 0), 0u) << failures[0];
  EXPECT_NE(failures[1].find("97.50 %"), std::string::npos) << failures[1];
  EXPECT_EQ(failures[2], "1 wrong fixes over the matrix (requirement 0)");
  EXPECT_TRUE(RequirementFailures(Summarise({a}, {good}, limits), limits).empty());
  const std::string table = FormatMatrixTable(rows, limits, 1.0 / 18.6, NavMatrixOptions{});
  EXPECT_NE(table.find("| station-box | 64 | yes | 2 |"), std::string::npos) << table;
  EXPECT_NE(table.find("| 10.5 / 18 | 1 / 0 | 8.5 / 16, 1 |"), std::string::npos) << table;
  EXPECT_NE(table.find("6 frame sets in a row"), std::string::npos) << table;
}

// ---- (b) The real navigator on the blob-level simulation ------------------------------------

// The harness against a known outcome: issue 4's must-show (the paper's turntable sweep, cold
// start, centroid noise only; navd_must_show renders and detects it) acquires in about 22 frame
// sets and then poses every frame set with >= 3 beacons. At blob level the same holds. The
// acquisition, and the re-acquisition after the sweep's 2.3 s gap with two beacons, rest on
// three beacons, so by default the track is published degraded ("unverified",
// TrackOptions::verify_three_beacons) until a pose on four beacons, then fix;
// with three-beacon fixes allowed (the paper's dark lab: every light is a beacon), every posed
// frame set after the acquisition is a fix, as issue 4 asked. The poses are the same.
TEST(NavMatrix, PaperSweepAtBlobLevelAcquiresThenFixesEveryFrameSet) {
  const Scenario s = MatrixScenario({.preset = "paper-turntable", .seed = 1, .frames = 360, .spurious = 0});
  NavMatrixOptions lab;
  lab.navigator.track.verify_three_beacons = false;
  std::vector<FrameRecord> frames, lab_frames;
  const RunResult r = RunNavigation(s, NavMatrixOptions{}, &frames);
  const RunResult l = RunNavigation(s, lab, &lab_frames);
  for (const RunResult* x : {&l, &r})
    std::printf("paper-turntable%s: first >= 4 in view at %d, first fix at %d, posed %d of %d, fixes %d, worst fix "
                "%.2f mm %.3f deg\n",
                x == &l ? " (three-beacon fixes)" : "", x->first_in_view, x->first_fix, x->posed_after_fix,
                x->eligible_after_fix, x->fixes, x->worst_fix_position_m * 1e3, RadToDeg(x->worst_fix_attitude_rad));
  ASSERT_EQ(frames.size(), 360u);
  ASSERT_EQ(lab_frames.size(), 360u);
  EXPECT_GE(l.first_fix, 10);  // 3-4 beacons in view: an acquisition over frame sets, not at once
  EXPECT_LT(l.first_fix, 40);
  EXPECT_GT(l.eligible_after_fix, 250);
  EXPECT_EQ(l.posed_after_fix, l.eligible_after_fix);
  int first_pose = -1, unverified = 0, other_degraded = 0;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const bool posed = frames[i].status != fw::NavStatus::kLost;
    EXPECT_EQ(posed, lab_frames[i].status != fw::NavStatus::kLost) << "frame set " << i;
    if (posed && first_pose < 0) first_pose = static_cast<int>(i);
    if (frames[i].status == fw::NavStatus::kDegraded && lab_frames[i].status == fw::NavStatus::kFix) {
      EXPECT_EQ(frames[i].reason, fw::NavReason::kUnverified) << "frame set " << i;
      // A (re-)acquired track is unverified from its start: never right after a fix.
      EXPECT_TRUE(i > 0 && frames[i - 1].status != fw::NavStatus::kFix) << "frame set " << i << ": unverified after a fix";
      ++unverified;
    } else {
      other_degraded += frames[i].status != lab_frames[i].status;
    }
  }
  std::printf("default: first pose at %d (unverified, degraded), %d frame sets unverified, first fix at %d\n",
              first_pose, unverified, r.first_fix);
  EXPECT_EQ(first_pose, l.first_fix);
  EXPECT_GT(unverified, 0);
  EXPECT_EQ(other_degraded, 0);
  EXPECT_EQ(r.fixes + unverified, l.fixes);
  EXPECT_GT(r.first_fix, l.first_fix);
  for (const RunResult* x : {&l, &r}) {
    EXPECT_EQ(x->wrong_fixes, 0);
    EXPECT_EQ(x->wrong_degraded, 0);
    EXPECT_LT(x->worst_fix_position_m, 0.02);
  }
}

// station-cylinder with 64 and 128 beacons (2 seeds each, facing in the map) and free-flight
// (1 seed), 200 frame sets each, 2 spurious blobs per camera, cold start. A wrong fix must never
// happen. The acquisition requirements of issue 13 (first fix within 10 frame sets of the first
// with >= 4 beacons in view; >= 99 % of the frame sets with >= 3 in view posed after it) are
// checked by `mfns-sim navmatrix --check` (baseline in docs/acquisition.md); they do not hold
// yet, so this test holds floors that do, and prints the metrics. Measured at d3ef481: first
// fixes at frame sets 150, 3, 70, 36 (cylinder) and 0 (free-flight); posed after the first fix
// 74-100 %; 0 wrong fixes in 669. (At ad4b26a, before lost-in-space learnt station maps, the
// cylinder runs never fixed and free-flight fixed once.) Raise the floors as it improves.
// The matrix of issue 13 reduced for CI (seeds 1-3 of 5, 300 frame sets of 600): both station
// modules at 64, 128 and 256 beacons with facing data, free-flight, and two rows without facing
// data (cylinder 128, box 256: the navigator infers the facing from the walls). Floors, not the
// requirements (lag <= 10, posed >= 99 %: docs/acquisition.md): never a wrong fix; every run
// without facing data fixes (before the inference: box 256 never did, cylinder 128 was posed
// in 21 % of its frame sets), and at most one station run with facing data never fixes in 300
// frame sets (measured: cylinder 64 seed 3, 3.6 beacons in view on average); after the first
// fix, the frame sets with >= 3 beacons in view carry a pose in >= 90 % of each row (pooled;
// measured 93.8-100 % since lost-in-space's anchors, session 16; 88-100 % before) and >= 80 % of
// each run (measured >= 89.9 %; 50 % before).
TEST(NavMatrix, ReducedMatrixNeverPublishesAWrongFix) {
  MatrixSpec stations;
  stations.presets = {"station-cylinder", "station-box"};
  stations.counts = {64, 128, 256};
  stations.seeds = {1, 2, 3};
  stations.frames = 300;
  stations.facing = FacingMode::kYes;
  MatrixSpec ff = stations;
  ff.presets = {"free-flight"};
  ff.seeds = {1, 2};
  MatrixSpec no_facing = stations;
  no_facing.presets = {"station-cylinder"};
  no_facing.counts = {128};
  no_facing.seeds = {1, 2};
  no_facing.facing = FacingMode::kNo;
  MatrixSpec no_facing_box = no_facing;
  no_facing_box.presets = {"station-box"};
  no_facing_box.counts = {256};
  std::vector<RunSpec> runs = ExpandMatrix(stations);
  for (const MatrixSpec* m : {&ff, &no_facing, &no_facing_box})
    for (const RunSpec& r : ExpandMatrix(*m)) runs.push_back(r);
  ASSERT_EQ(runs.size(), 24u);
  const NavMatrixOptions o;
  const std::vector<RunResult> results = RunMatrix(runs, o, 2, nullptr);
  const MatrixLimits limits;
  const std::vector<MatrixRow> rows = Summarise(runs, results, limits);
  std::printf("%s", FormatMatrixTable(rows, limits, 1.0 / 18.6, o).c_str());
  int never = 0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const RunResult& r = results[i];
    const std::string what = runs[i].preset + " " + std::to_string(runs[i].map_beacons) + " seed " +
                             std::to_string(runs[i].seed) + (runs[i].facing ? "" : " (no facing)");
    std::printf("%s: in view %.1f, first >= 4 at %d, first fix at %d, posed %d/%d, fixes %d, degraded %d, wrong "
                "%d/%d, worst fix %.1f mm %.3f deg, Step worst %.1f ms mean %.2f ms\n",
                what.c_str(), r.mean_in_view, r.first_in_view, r.first_fix, r.posed_after_fix, r.eligible_after_fix,
                r.fixes, r.degraded, r.wrong_fixes, r.wrong_degraded, r.worst_fix_position_m * 1e3,
                RadToDeg(r.worst_fix_attitude_rad), r.worst_step_s * 1e3, r.total_step_s * 1e3 / r.frames);
    EXPECT_EQ(r.frames, 300);
    EXPECT_GT(r.mean_in_view, 3.0) << what;
    EXPECT_EQ(r.wrong_fixes, 0) << what;
    if (!runs[i].facing) {
      EXPECT_GE(r.first_fix, 0) << what;
    }
    never += r.first_fix < 0;
    if (r.first_fix >= 0) {
      EXPECT_GE(r.PosedShare(), 0.8) << what;
    }
  }
  EXPECT_LE(never, 1);
  for (const MatrixRow& row : rows) {
    ASSERT_GT(row.eligible, 0) << row.preset << " " << row.count;
    EXPECT_GE(static_cast<double>(row.posed) / static_cast<double>(row.eligible), 0.9) << row.preset << " " << row.count;
  }
}

// The paper's rig at half the resolution (640 x 512, f = 800 px), written to a temporary rig
// file for RunSpec::rig, named after the test (ctest runs tests at once); returns its path.
std::string PaperHalfRigFile(const std::string& test) {
  Rig half = PaperRig();
  for (int k = 0; k < half.num_cameras; ++k) {
    CameraIntrinsics& in = half.cameras[static_cast<std::size_t>(k)].intrinsics;
    in.width /= 2;
    in.height /= 2;
    in.alpha_x /= 2.0;
    in.alpha_y /= 2.0;
    in.skew /= 2.0;
    in.u0 /= 2.0;
    in.v0 /= 2.0;
  }
  half.has_sigma = false;
  const std::filesystem::path file = std::filesystem::temp_directory_path() / ("mfns-" + test + "-paper-half-rig.yaml");
  WriteRigYaml(file, half);
  return file.string();
}

// Other cameras than the paper's (issue 13: nothing tuned to one rig): a wide four-camera rig
// (two f = 760 px lenses with strong distortion, the paper's, one f = 1210 px; docs/calibration.md)
// and the paper's rig at half the resolution (640 x 512, f = 800 px: the pixel gates scaled by
// PixelGateScale, the centroid noise twice the angle). Stations of 64 and 128 beacons, 2 seeds,
// 300 frame sets: never a wrong fix, every run fixed, and posed after the first fix as on the
// paper's rig (docs/acquisition.md, session 32: 99.5-100 % on wide4, 93-99.9 % at half resolution
// over the full matrix).
TEST(NavMatrix, OtherRigsNeverPublishAWrongFix) {
  const char* src = std::getenv("MFNS_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  const std::string half = PaperHalfRigFile("OtherRigs");
  for (const std::string& rig : {std::string(src) + "/host/calib/tools/wide4-rig.yaml", half}) {
    MatrixSpec m;
    m.presets = {"station-cylinder", "station-box"};
    m.counts = {64, 128};
    m.seeds = {1, 2};
    m.frames = 300;
    m.facing = FacingMode::kYes;
    m.rig = rig;
    const std::vector<RunSpec> runs = ExpandMatrix(m);
    ASSERT_EQ(runs.size(), 8u);
    const NavMatrixOptions o;
    const std::vector<RunResult> results = RunMatrix(runs, o, 2, nullptr);
    const MatrixLimits limits;
    const std::vector<MatrixRow> rows = Summarise(runs, results, limits);
    std::printf("rig %s:\n%s", rig.c_str(), FormatMatrixTable(rows, limits, 1.0 / 18.6, o).c_str());
    for (std::size_t i = 0; i < runs.size(); ++i) {
      const std::string what = runs[i].preset + " " + std::to_string(runs[i].map_beacons) + " seed " +
                               std::to_string(runs[i].seed) + " on " + rig;
      EXPECT_EQ(results[i].wrong_fixes, 0) << what;
      EXPECT_GE(results[i].first_fix, 0) << what;
    }
    for (const MatrixRow& row : rows) {
      ASSERT_GT(row.eligible, 0) << row.preset << " " << row.count;
      EXPECT_GE(static_cast<double>(row.posed) / static_cast<double>(row.eligible), 0.9) << row.preset << " " << row.count;
    }
  }
  std::filesystem::remove(half);
}

// Cases that once published a wrong fix, replayed: station-box 64 with 3 spurious blobs per
// camera, seeds 12 and 13 (not among the matrix's seeds). Re-identification's check (tracking's
// trials from the found pose, with the wide hold gate) replaced an acquired three-beacon pose
// 5 mm off by a trial resting on a reflection, 56 mm off (seed 12, frame set 341; tracked on to
// 118 mm at 347), and 176 mm (seed 13, frame set 202). The trials may now only confirm the
// pose, never move it.
TEST(NavMatrix, SeenWrongFixesStayFixed) {
  std::vector<RunSpec> runs;
  for (const std::uint64_t seed : {12u, 13u}) {
    RunSpec r = Box64Run(seed, 360);
    r.spurious = 3;
    runs.push_back(r);
  }
  const std::vector<RunResult> results = RunMatrix(runs, NavMatrixOptions{}, 2, nullptr);
  for (std::size_t i = 0; i < runs.size(); ++i) {
    std::printf("station-box 64 seed %llu, 3 spurious: fixes %d, degraded %d, wrong %d/%d, worst fix %.1f mm\n",
                static_cast<unsigned long long>(runs[i].seed), results[i].fixes, results[i].degraded,
                results[i].wrong_fixes, results[i].wrong_degraded, results[i].worst_fix_position_m * 1e3);
    // (Fixes measured: 60 and 287; 50 and 287 since tracking's disagreeing trials are decided
    // by the motion: seed 12 has 3.3 beacons in view on average and its re-acquisition after a
    // stretch of one or two beacons, a cold search whose restarts fall on other frame sets, now
    // comes 5 frame sets later. This checks that the runs navigate, the test is the zero.)
    EXPECT_GT(results[i].fixes, 40) << "seed " << runs[i].seed;
    EXPECT_EQ(results[i].wrong_fixes, 0) << "seed " << runs[i].seed;
  }
}

// Found with --layout random (docs/acquisition.md, session 33), two fixes on three beacons, one
// of them a new blob (a spurious one beside where the beacon would be), within the innovation
// bounds. A 64-beacon cylinder without facing data (seed 3): after three frame sets with two
// beacons in view, a fix 21 mm / 1.6 deg off (the motion filter's squared Mahalanobis distance
// 10). A 64-beacon box without facing data, 3 spurious blobs per camera (seed 8): in continuous
// tracking, a tracked beacon's steady blob dropped for another beacon on a new blob, 24.6 mm /
// 1.2 deg off. Such a pose is degraded now (TrackOptions::three_beacon_fix_steady).
TEST(NavMatrix, ThreeBeaconsOnANewBlobAreNoFix) {
  RunSpec gap{.preset = "station-cylinder", .count = 64, .seed = 3, .facing = false, .frames = 470, .spurious = 2};
  RunSpec swap{.preset = "station-box", .count = 64, .seed = 8, .facing = false, .frames = 300, .spurious = 3};
  NavMatrixOptions off;
  off.navigator.track.three_beacon_fix_steady = false;
  for (RunSpec r : {gap, swap}) {
    r.layout = "random";
    const RunResult with = RunNavigation(MatrixScenario(r), NavMatrixOptions{});
    const RunResult without = RunNavigation(MatrixScenario(r), off);
    std::printf("random %s %d seed %llu, no facing: fixes %d, degraded %d, wrong %d/%d; without the rule: fixes %d, "
                "wrong %d/%d\n", r.preset.c_str(), r.count, static_cast<unsigned long long>(r.seed), with.fixes,
                with.degraded, with.wrong_fixes, with.wrong_degraded, without.fixes, without.wrong_fixes,
                without.wrong_degraded);
    EXPECT_EQ(with.wrong_fixes, 0) << r.preset;
    EXPECT_GE(without.wrong_fixes, 1) << r.preset;  // the case as found
    // The same frame sets posed; a few fixes degraded (measured 1-3 of ~300-400).
    EXPECT_EQ(with.fixes + with.degraded, without.fixes + without.degraded) << r.preset;
    EXPECT_GE(with.fixes, without.fixes - 8) << r.preset;
  }
}

// A stand-alone lost-in-space fix decides its identities itself (TrackOptions::
// identity_gate_chi2, identities.h). Found with `--layout random`: box 128 seed 4, frame set 48,
// four beacons 4 m away in one camera and one 1 m away in another; the near beacon matched a
// reflection 115 px from its own blob, and the pose that fits it (residuals 0.07 px, nothing
// missing) was published as a fix 69 mm / 0.95 deg off, 9 of its 1-sigma: within the matrix's
// "wrong" bounds by a hair, with a wrong identity.
TEST(NavMatrix, AStandAloneFixDecidesItsIdentities) {
  RunSpec r{.preset = "station-box", .count = 128, .seed = 4, .facing = true, .frames = 60};
  r.layout = "random";
  NavMatrixOptions off;
  off.navigator.track.identity_gate_chi2 = 0.0;
  for (const bool check : {true, false}) {
    std::vector<FrameRecord> frames;
    const RunResult result = RunNavigation(MatrixScenario(r), check ? NavMatrixOptions{} : off, &frames);
    int fixes_on_wrong_ids = 0;
    for (const FrameRecord& f : frames) fixes_on_wrong_ids += f.status == fw::NavStatus::kFix && f.wrong_ids > 0;
    std::printf("random box 128 seed 4, identity check %s: fixes %d, on a wrong identity %d, worst %.1f mm / %.2f deg, "
                "refused %u\n", check ? "on" : "off", result.fixes, fixes_on_wrong_ids, 1e3 * result.worst_fix_position_m,
                RadToDeg(result.worst_fix_attitude_rad), result.counters.identity_refused);
    if (check) {
      EXPECT_EQ(fixes_on_wrong_ids, 0);
      EXPECT_LT(result.worst_fix_position_m, 0.02);
      EXPECT_GT(result.counters.identity_refused, 0u);
      EXPECT_GT(result.fixes, 5);
    } else {
      EXPECT_GE(fixes_on_wrong_ids, 1);  // the case as found
    }
  }
}

// A tracked beacon whose blob another blob beside it explains better takes that one
// (Tracker::TakeBetterRival). Found with the wide2 rig on a regular 256-beacon cylinder (seed 1,
// frame set 560): 76 beacons in one camera and one near beacon in the other, whose reflection
// 7 px away was tracked: a fix 3.5 mm off, 26 of its 1-sigma (0.14 mm).
TEST(NavMatrix, ATrackedBeaconTakesTheBlobThatFitsBetter) {
  RunSpec r{.preset = "station-cylinder", .count = 256, .seed = 1, .facing = true, .frames = 562};
  const char* src = std::getenv("MFNS_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  r.jitter = 0.0;
  r.rig = std::string(src) + "/host/calib/tools/wide2-rig.yaml";
  NavMatrixOptions off;
  off.navigator.track.identity_gate_chi2 = 0.0;
  for (const bool check : {true, false}) {
    std::vector<FrameRecord> frames;
    const RunResult result = RunNavigation(MatrixScenario(r), check ? NavMatrixOptions{} : off, &frames);
    const FrameRecord& f = frames[560];
    std::printf("wide2, regular cylinder 256 seed 1, identity check %s: frame set 560 %s, %d wrong identities, "
                "%.2f mm off (1-sigma %.2f mm); swaps %u\n", check ? "on" : "off", fw::ToString(f.status), f.wrong_ids,
                1e3 * f.position_error_m, 1e3 * f.position_sigma_m, result.counters.identity_swapped);
    ASSERT_EQ(f.status, fw::NavStatus::kFix);
    if (check) {
      EXPECT_EQ(f.wrong_ids, 0);
      EXPECT_LT(f.position_error_m, 5.0 * f.position_sigma_m);
      EXPECT_GT(result.counters.identity_swapped, 0u);
    } else {
      EXPECT_GT(f.wrong_ids, 0);  // the case as found
    }
  }
}

// Heavy clutter (64 spurious blobs per camera, ~200 blobs a frame set) stays within the frame
// set's budget: tracking's leave-outs (each a tracking with up to 16 trials) are charged to it
// and stop when it is spent (TrackCounters::left_out_budget_out), and lost-in-space no longer
// walks beacon pairs that have no third (it did 2.7 million in one frame set). Measured with
// `mfns-sim navmatrix --spurious 64` (docs/acquisition.md, session 34): worst frame set 44 ->
// 17.9 ms; the time itself is not asserted here (no timed tests), the budget's work is.
TEST(NavMatrix, HeavyClutterIsTrackedWithinTheBudget) {
  RunSpec r{.preset = "station-box", .count = 128, .seed = 1, .facing = true, .frames = 400, .spurious = 64};
  const RunResult result = RunNavigation(MatrixScenario(r), NavMatrixOptions{});
  std::printf("box 128, 64 spurious blobs per camera: fixes %d, degraded %d, wrong %d/%d, leave-outs cut by the "
              "budget %u, worst step %.1f ms\n", result.fixes, result.degraded, result.wrong_fixes,
              result.wrong_degraded, result.counters.left_out_budget_out, 1e3 * result.worst_step_s);
  EXPECT_EQ(result.wrong_fixes, 0);
  EXPECT_GT(result.fixes, 200);
  EXPECT_GT(result.counters.left_out_budget_out, 0u);
}

// A map that repeats itself (a grid without jitter) cannot be acquired where a view has a copy:
// the navigator says so at start (Navigator::map_repeats: mfns-navd's warning) and in the lost
// frame sets' reason (kRepeatedView), and never publishes the copy as a fix. The presets' own
// jittered maps, and random ones, have neither. Both modules, with and without facing data.
TEST(NavMatrix, RepeatingMapsAreReported) {
  for (const char* preset : {"station-cylinder", "station-box"})
    for (const bool facing : {true, false}) {
      const RunSpec r{.preset = preset, .count = 64, .seed = 2, .facing = facing, .frames = 300};
      std::array<RunSpec, 3> runs{r, r, r};  // regular, the preset's jitter, random
      runs[0].jitter = 0.0;
      runs[2].layout = "random";
      for (const RunSpec& run : runs) {
        const Scenario s = MatrixScenario(run);
        static fw::Navigator nav;
        ASSERT_TRUE(nav.Init(BelievedRig(s), NavdNavigatorOptions()));
        const int repeated = nav.map_repeats().repeated;
        const RunResult result = RunNavigation(s, NavMatrixOptions{});
        const auto said = result.counters.by_reason[static_cast<std::size_t>(fw::TrackReason::kRepeatedView)];
        std::printf("%s 64 %s, jitter %.2f%s: %d beacons in repeated patches; fixes %d, wrong %d; lost frame sets "
                    "\"map repeats this view\" %u\n", preset, facing ? "facing" : "no facing",
                    s.beacon_layout.jitter, run.layout == "random" ? " random" : "", repeated, result.fixes,
                    result.wrong_fixes, said);
        EXPECT_EQ(result.wrong_fixes, 0) << preset;
        if (&run == &runs[0]) {
          EXPECT_GE(repeated, 8) << preset;
          EXPECT_GT(said, 0u) << preset;
        } else {
          EXPECT_EQ(repeated, 0) << preset;
          EXPECT_EQ(said, 0u) << preset;
        }
      }
    }
}

// Reflections that move with the scene (clutter.spurious.static_reflections: unmapped points on
// the walls, imaged like beacons) keep a wrong three-beacon pose consistent over frame sets,
// which the acquisition's motion test cannot refute: in the 64-beacon box without facing data
// (seed 4, 20 reflectors), a seeded chain lost the true pose (an ill-conditioned three-beacon
// view: its P3P root 72 mm off, refuted by a missing beacon) and its survivor, one beacon and
// two reflections, was published as a fix 147 mm and 10 deg off (frame set 441). An acquired
// three-beacon pose that leaves a steady blob unexplained is now refused (TrackCounters::
// steady_unexplained). The scenario is run as it was found, without the blob tracks' continuity
// (TrackOptions::continue_blob_tracks, which keeps that track and avoids the situation: 80
// fixes, the rule not needed), and with it.
TEST(NavMatrix, ReflectionsMovingWithTheSceneGiveNoWrongFix) {
  RunSpec r = Box64Run(4, 450);
  r.facing = false;
  r.static_reflections = 20;
  NavMatrixOptions as_found;
  as_found.navigator.track.continue_blob_tracks = false;
  const RunResult result = RunNavigation(MatrixScenario(r), as_found);
  const RunResult with_tracks = RunNavigation(MatrixScenario(r), NavMatrixOptions{});
  std::printf("station-box 64 seed 4, no facing, 20 static reflections: fixes %d, degraded %d, wrong %d/%d, "
              "refused for a steady blob %u; with the blob tracks' continuity: fixes %d, wrong %d/%d\n",
              result.fixes, result.degraded, result.wrong_fixes, result.wrong_degraded,
              result.counters.steady_unexplained, with_tracks.fixes, with_tracks.wrong_fixes,
              with_tracks.wrong_degraded);
  EXPECT_GT(result.fixes, 20);  // (41 measured: its first fix comes late, at frame set 287)
  EXPECT_EQ(result.wrong_fixes, 0);
  EXPECT_GT(result.counters.steady_unexplained, 0u);
  EXPECT_EQ(with_tracks.wrong_fixes, 0);
  EXPECT_GT(with_tracks.fixes, 20);
}

// Unmapped steady lights and no flickering spots (static_reflections, spurious 0): two beacons
// and one such light, or one beacon and two, fit a wrong three-beacon pose exactly, and the
// motion keeps it consistent frame set after frame set. With three-beacon fixes allowed, such
// acquisitions were published as fixes (the matrix of docs/acquisition.md, session 28: 29 in
// 64-128-beacon stations 0.18-0.75 m off, 220 in 12-24-beacon ones up to 4 m off). By default a
// track found on three beacons is degraded ("unverified") until a pose on four beacons fits the
// noise: the same poses, never a wrong fix. (The wrong poses are then published degraded, with
// that reason: the image cannot tell them from the truth.)
TEST(NavMatrix, UnmappedStaticLightsGiveNoWrongFix) {
  struct Case {
    const char* preset;
    int beacons;
    std::uint64_t seed;
    int lights;
    int frames;  // past the wrong fixes (measured: box 64 at 440-449, box 24 at 262-266, box 12 at 221-222)
  };
  // (In the two small maps every pose of these spans is such an alias.)
  for (const Case c : {Case{"station-box", 64, 2, 25, 460}, Case{"station-box", 24, 5, 8, 280},
                       Case{"station-box", 12, 6, 8, 240}}) {
    RunSpec r;
    r.preset = c.preset;
    r.count = r.map_beacons = c.beacons;
    r.seed = c.seed;
    r.frames = c.frames;
    r.spurious = 0;
    r.static_reflections = c.lights;
    NavMatrixOptions lab;
    lab.navigator.track.verify_three_beacons = false;
    std::vector<FrameRecord> frames, lab_frames;
    const RunResult d = RunNavigation(MatrixScenario(r), NavMatrixOptions{}, &frames);
    const RunResult l = RunNavigation(MatrixScenario(r), lab, &lab_frames);
    int unverified = 0, posed = 0, lab_posed = 0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      unverified += frames[i].reason == fw::NavReason::kUnverified;
      posed += frames[i].status != fw::NavStatus::kLost;
      lab_posed += lab_frames[i].status != fw::NavStatus::kLost;
    }
    std::printf("%s %d seed %d, %d unmapped lights: three-beacon fixes: fixes %d, wrong %d; default: fixes %d, "
                "degraded %d (%d unverified), wrong fixes %d, wrong degraded %d\n",
                c.preset, c.beacons, static_cast<int>(c.seed), c.lights, l.fixes, l.wrong_fixes, d.fixes, d.degraded,
                unverified, d.wrong_fixes, d.wrong_degraded);
    EXPECT_GT(l.wrong_fixes, 0) << c.beacons << ": the hazard is not in this run";
    EXPECT_EQ(d.wrong_fixes, 0) << c.beacons;
    EXPECT_GE(d.wrong_degraded, l.wrong_fixes) << c.beacons;  // the same poses, degraded
    EXPECT_EQ(posed, lab_posed) << c.beacons;
    if (c.beacons == 64) {
      EXPECT_GT(d.fixes, 300);  // the true track still fixes (391 measured)
    }
  }
}

// A re-acquisition after a gap whose seeded chain holds the truth, on steady blobs, and poses on
// reflections flickering beside a beacon (each names a blob that is new) keeps the one on steady
// blobs (TrackOptions::prune_to_steady), published unverified while it rests on three beacons.
// Box 64 seeds 2 and 4 (the matrix's facing row, 600 frame sets): posed after the first fix
// 883 -> 947 of 1001 frame sets with >= 3 beacons in view (docs/acquisition.md, session 29), no
// wrong pose either way; here the runs stop after the frame sets the rule changes (seed 2 at
// 198-216, seed 4 at 72-84, 118-121 and 249-269). With unmapped steady lights beside the spots
// the rule can keep an alias (two beacons and such a light, the truth on two beacons in no
// list: box 64 seed 2, frame sets 442-449, 176 mm off): it is published degraded, never as a
// fix; as a fix (three-beacon fixes allowed) it would be wrong.
TEST(NavMatrix, SeededChainsKeepThePoseOnSteadyBlobs) {
  const std::vector<RunSpec> runs = {Box64Run(2, 220), Box64Run(4, 275)};
  NavMatrixOptions before;
  before.navigator.track.prune_to_steady = false;
  const std::vector<RunResult> with = RunMatrix(runs, NavMatrixOptions{}, 2, nullptr);
  const std::vector<RunResult> without = RunMatrix(runs, before, 2, nullptr);
  int posed = 0, posed_before = 0, eligible = 0;
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const RunResult& d = with[i];
    const RunResult& b = without[i];
    const auto seed = static_cast<int>(runs[i].seed);
    std::printf("station-box 64 seed %d: posed after the first fix %d of %d (without the rule %d of %d); wrong %d + %d "
                "(%d + %d)\n",
                seed, d.posed_after_fix, d.eligible_after_fix, b.posed_after_fix, b.eligible_after_fix, d.wrong_fixes,
                d.wrong_degraded, b.wrong_fixes, b.wrong_degraded);
    EXPECT_EQ(d.wrong_fixes + d.wrong_degraded + b.wrong_fixes + b.wrong_degraded, 0) << seed;
    EXPECT_EQ(d.first_fix, b.first_fix) << seed;
    EXPECT_GT(d.counters.steady_pruned, 0u) << seed;
    posed += d.posed_after_fix;
    posed_before += b.posed_after_fix;
    eligible += d.eligible_after_fix;
  }
  EXPECT_GE(posed - posed_before, eligible / 10);  // (57 of 434 measured)

  RunSpec r = Box64Run(2, 460);
  r.static_reflections = 25;
  NavMatrixOptions lab;
  lab.navigator.track.verify_three_beacons = false;
  const RunResult d = RunNavigation(MatrixScenario(r), NavMatrixOptions{}, nullptr);
  const RunResult l = RunNavigation(MatrixScenario(r), lab, nullptr);
  std::printf("with 25 unmapped lights: wrong fixes %d, wrong degraded %d; three-beacon fixes: wrong fixes %d\n",
              d.wrong_fixes, d.wrong_degraded, l.wrong_fixes);
  EXPECT_GT(l.wrong_fixes, 0) << "the hazard is not in this run";
  EXPECT_EQ(d.wrong_fixes, 0);
}

// A seeded chain's pose on steady blobs does not push out a pose that explains more beacons
// with a new blob (Tracker::PruneToSteady): a reflection beside a beacon takes its beacon's
// place, so its pose explains no more; a beacon just come into view adds one. Found with the
// paper's rig at half resolution on a random 64-beacon cylinder (seed 5, frame sets 304-323):
// the chain held the truth (four beacons, the fourth's first blob) and a pose on three steady
// blobs 535 mm and 18 deg off, which was kept and published degraded for 16 frame sets with a
// 1-sigma of 5 mm.
TEST(NavMatrix, ABeaconComingIntoViewIsNotPrunedAsAReflection) {
  RunSpec r{.preset = "station-cylinder", .count = 64, .seed = 5, .facing = true, .frames = 330};
  r.layout = "random";
  r.rig = PaperHalfRigFile("ComingIntoView");
  std::vector<FrameRecord> frames;
  const RunResult result = RunNavigation(MatrixScenario(r), NavMatrixOptions{}, &frames);
  std::filesystem::remove(r.rig);
  int posed = 0, fixes = 0;
  for (int i = 304; i < 330; ++i) {
    const FrameRecord& f = frames[static_cast<std::size_t>(i)];
    if (f.status == fw::NavStatus::kLost) continue;
    ++posed;
    fixes += f.status == fw::NavStatus::kFix ? 1 : 0;
    EXPECT_EQ(f.wrong_ids, 0) << "frame set " << i;
    EXPECT_LT(f.position_error_m, 0.02) << "frame set " << i;
  }
  std::printf("half-resolution rig, random cylinder 64 seed 5, frame sets 304-329: %d posed, %d fixes; run: wrong "
              "fixes %d, wrong degraded %d, steady-pruned %u\n", posed, fixes, result.wrong_fixes,
              result.wrong_degraded, result.counters.steady_pruned);
  EXPECT_EQ(result.wrong_fixes, 0);
  EXPECT_EQ(result.wrong_degraded, 0);
  EXPECT_GE(fixes, 15);
}

// Three beacons in three cameras, each with a reflection 10-30 px beside it, give tracking eight
// trials that fit exactly and lie 15 mm and 1 deg apart: beyond 1 cm / 5 mrad (the spread
// published until session 35) the frame set was lost; within TrackOptions::
// ambiguity_max_spread_m / _rad (3 cm / 1 deg) the best is published degraded with the spread in
// its covariance. Station box 64 seed 4, frame sets 112-113; every such pose of the run lies
// within 3 of its published 1-sigma and within 1 deg.
TEST(NavMatrix, ReflectionsBesideThreeBeaconsArePublishedDegradedWithTheirSpread) {
  const RunSpec r{.preset = "station-box", .count = 64, .seed = 4, .facing = true, .frames = 600};
  NavMatrixOptions narrow;
  narrow.navigator.track.ambiguity_max_spread_m = 0.01;
  narrow.navigator.track.ambiguity_max_spread_rad = 0.005;
  std::vector<FrameRecord> before, after;
  RunNavigation(MatrixScenario(r), narrow, &before);
  const RunResult result = RunNavigation(MatrixScenario(r), NavMatrixOptions{}, &after);
  int ambiguous = 0, gained = 0;
  for (std::size_t i = 0; i < after.size(); ++i) {
    const FrameRecord& f = after[i];
    if (f.status != fw::NavStatus::kDegraded || f.reason != fw::NavReason::kAmbiguous) continue;
    ++ambiguous;
    gained += before[i].status == fw::NavStatus::kLost ? 1 : 0;
    EXPECT_LE(f.position_error_m, 3.0 * f.position_sigma_m) << "frame set " << i;
    EXPECT_LT(f.attitude_error_rad, DegToRad(1.0)) << "frame set " << i;
  }
  std::printf("box 64 seed 4: %d ambiguous poses published degraded, %d of them lost with 1 cm / 5 mrad; frame sets "
              "112-113 %s / %s\n", ambiguous, gained, fw::ToString(after[112].status), fw::ToString(after[113].status));
  EXPECT_EQ(before[112].status, fw::NavStatus::kLost);  // the case as found
  EXPECT_EQ(after[112].status, fw::NavStatus::kDegraded);
  EXPECT_EQ(after[113].status, fw::NavStatus::kDegraded);
  EXPECT_GT(gained, 0);
  EXPECT_EQ(result.wrong_fixes, 0);
  EXPECT_EQ(result.wrong_degraded, 0);
}

// Maps of fewer than lis.fourth_blob_min_beacons beacons search past the frame set's budget
// while their lists may be complete (the acquisition follows them), but stop at it once the
// list has overflowed (Tracker::RunSmallMapLis): a 16-beacon station box, 1-2 beacons in view
// among ~8 blobs, spent 20-40 ms a frame set on searches that overflowed every time (docs/
// acquisition.md, session 35: worst 41.6 -> 20.3 ms, frame sets over 15 ms 2 988 -> 36 of 3 000,
// the same poses). The time itself is not asserted here (no timed tests): the stops are.
TEST(NavMatrix, ASmallMapsOverflowingSearchesStopAtTheBudget) {
  const RunSpec r{.preset = "station-box", .count = 16, .seed = 1, .facing = true, .frames = 200};
  const RunResult result = RunNavigation(MatrixScenario(r), NavMatrixOptions{});
  std::printf("box 16 seed 1: fixes %d, degraded %d, wrong %d / %d, searches stopped after an overflow %u, worst step "
              "%.1f ms\n", result.fixes, result.degraded, result.wrong_fixes, result.wrong_degraded,
              result.counters.overflow_stopped, 1e3 * result.worst_step_s);
  EXPECT_EQ(result.wrong_fixes, 0);
  EXPECT_EQ(result.wrong_degraded, 0);
  EXPECT_GT(result.counters.overflow_stopped, 100u);
}

// Among the cross-camera triples of steady blobs, lost-in-space searches those over two cameras
// before those over three (LostInSpace::OrderItems): a same-camera pair's angle prunes its
// beacon pairs, three cameras leave distances alone, and in a large map one such triple's
// beacon triples fill whole cold searches. The case as found: station cylinder 64 seed 1, one
// beacon in each of two cameras and two in the third, first fix 140 frame sets after the first
// view of four beacons (59 now; measured on the matrix: docs/acquisition.md, session 36).
// One run of the matrix from a cold start: its first fix within max_lag frame sets of the first
// view of four beacons, and no wrong pose.
void ExpectFirstFixWithin(const RunSpec& r, int max_lag) {
  const RunResult result = RunNavigation(MatrixScenario(r), NavMatrixOptions{});
  std::printf("%s %d seed %llu: first view of 4 beacons %d, first fix %d; fixes %d, wrong %d / %d\n", r.preset.c_str(),
              r.count, static_cast<unsigned long long>(r.seed), result.first_in_view, result.first_fix, result.fixes,
              result.wrong_fixes, result.wrong_degraded);
  ASSERT_TRUE(result.HasLag());
  EXPECT_LE(result.Lag(), max_lag);
  EXPECT_EQ(result.wrong_fixes, 0);
  EXPECT_EQ(result.wrong_degraded, 0);
}

TEST(NavMatrix, SteadyTriplesOverTwoCamerasAreSearchedFirst) {
  ExpectFirstFixWithin(RunSpec{.preset = "station-cylinder", .count = 64, .seed = 1, .facing = true, .frames = 180}, 80);
}

// A cold search begun when the steady blobs made only a dearer kind of triple (one blob in
// each of three cameras) starts over once they make a cheaper one (two or three in one camera:
// Tracker::SteadyShapeOf), which its own order has behind the dearer one: in a large map that
// triple's beacon triples fill the search. The case as found: station box 64 seed 3, first fix
// 13 frame sets after the first view of four beacons with a restart only when three blobs first
// became steady, 2 with this rule (docs/acquisition.md, session 37).
TEST(NavMatrix, AColdSearchStartsOverWhenTheSteadyBlobsMakeACheaperTriple) {
  ExpectFirstFixWithin(RunSpec{.preset = "station-box", .count = 64, .seed = 3, .facing = true, .frames = 90}, 10);
}

// Triples of steady blobs ask for a steady fourth blob (LisOptions::steady_fourth): in a dense
// map a beacon lined up with one of the flickering spurious blobs passed most poses on to a full
// reprojection. The case as found: station box 256 seed 3, first fix 51 frame sets after the
// first view of four beacons (views of 5-6 beacons, a same-camera steady triple first), 20 with
// the rule (docs/acquisition.md, session 37).
TEST(NavMatrix, ADenseBoxIsFixedSoonerWhenSteadyTriplesAskForASteadyFourth) {
  ExpectFirstFixWithin(RunSpec{.preset = "station-box", .count = 256, .seed = 3, .facing = true, .frames = 60}, 30);
}

// Views of four beacons whose blobs are steady are acquired from a steady list (TrackOptions::
// steady_lists): the poses that explain four steady blobs, listed where every pose could not
// be, followed while they fit the noise. The case as found (docs/acquisition.md, session 43):
// a random 64-beacon box, seed 4, lost at frame set 359 with two beacons in view; from frame set
// 412 four beacons (1 + 2 + 1 cameras, two spurious blobs a camera): acquired there with steady
// lists, never before the run's end without (posed 253 -> 365 of 600). Run to frame set 440.
TEST(NavMatrix, FourSteadyBlobsAcquireWhereNoListIsComplete) {
  RunSpec r{.preset = "station-box", .count = 64, .seed = 4, .facing = true, .frames = 440};
  r.layout = "random";
  NavMatrixOptions off;
  off.navigator.track.steady_lists = false;
  const RunResult with = RunNavigation(MatrixScenario(r), NavMatrixOptions{});
  const RunResult without = RunNavigation(MatrixScenario(r), off);
  std::printf("random box 64 seed 4: posed %d of %d after the first fix, %d steady lists, %d poses refuted, wrong "
              "%d/%d; without them: posed %d of %d, wrong %d/%d\n",
              with.posed_after_fix, with.eligible_after_fix, with.counters.steady_lists, with.counters.steady_refuted,
              with.wrong_fixes, with.wrong_degraded, without.posed_after_fix, without.eligible_after_fix,
              without.wrong_fixes, without.wrong_degraded);
  EXPECT_GT(with.counters.steady_lists, 0u);
  EXPECT_GE(with.posed_after_fix, without.posed_after_fix + 20);
  EXPECT_EQ(with.wrong_fixes, 0);
  EXPECT_EQ(with.wrong_degraded, 0);
}

// A clean four-beacon view (no spurious blob, the four blobs steady) of a matrix scenario,
// listed by a steady list of unbounded work: how many listed poses are the truth (within 2 cm
// and 0.5 deg), and how many poses in all.
struct SteadyListed {
  int truth = 0;
  int poses = 0;
};
SteadyListed ListCleanFourBeaconView(const char* preset, int count, std::uint64_t seed, int frame) {
  RunSpec r{.preset = preset, .count = count, .seed = seed, .facing = true, .frames = frame + 1};
  r.map_beacons = count;
  r.spurious = 0;
  const Scenario s = MatrixScenario(r);
  const Rig rig = BelievedRig(s);
  static fw::LostInSpace lis;
  EXPECT_TRUE(lis.Reset(rig));
  const FrameTruth f = SimulateTrajectory(s).back();
  EXPECT_EQ(f.frame, frame);
  const BlobFrameSet b = SimulateBlobs(s, f);
  EXPECT_EQ(b.NumVisible(), 4) << preset << " seed " << seed;
  EXPECT_EQ(b.blobs.size(), 4u);
  const std::vector<std::uint8_t> steady(b.blobs.size(), 1);
  fw::LisOptions o;
  o.steady_list = true;
  o.max_hypotheses = limits::kMaxLisHypotheses;
  static fw::LisResult res;
  lis.Identify(b.blobs.data(), static_cast<int>(b.blobs.size()), o, &res, nullptr, fw::kAllCameras, steady.data());
  EXPECT_TRUE(lis.steady_list()) << preset << " seed " << seed << " frame " << frame;
  EXPECT_TRUE(res.steady_complete);
  SteadyListed out;
  out.poses = res.num_consistent;
  for (int i = 0; i < res.num_consistent; ++i) {
    const BodyPose& p = res.consistent_poses[static_cast<std::size_t>(i)];
    out.truth += (p.r_w_wb - f.pose.r_w_wb).norm() < 0.02 && LogSO3(f.pose.C_w_b.transpose() * p.C_w_b).norm() < DegToRad(0.5);
  }
  return out;
}

struct View {
  const char* preset;
  int count;
  std::uint64_t seed;
  int frame;
};

// A steady list holds the truth where its cover's triple is a weak one (LostInSpace::
// ScoreMatched's fourth): clean four-beacon views whose cheapest triple gives a raw pose that
// predicts the fourth beacon beside its blob but beyond the raw match's 15 px gate (within the
// fourth-blob test's 0.015 rad, 24 px at these cameras' f = 1600 px). The truth was then
// "missing" its fourth beacon, refuted, and the list was empty: in each of these three views
// before the association was kept for Refine (docs/acquisition.md, session 44: 8 of 119
// exhaustive steady lists of such views lacked the truth, 5 after).
TEST(NavMatrix, ASteadyListHoldsTheTruthWhoseRawPoseMissesTheFourthBeacon) {
  for (const View& v : {View{"station-box", 64, 4, 45}, View{"station-box", 64, 6, 300}, View{"station-cylinder", 64, 1, 126}}) {
    const SteadyListed l = ListCleanFourBeaconView(v.preset, v.count, v.seed, v.frame);
    EXPECT_EQ(l.truth, 1) << v.preset << " " << v.count << " seed " << v.seed << " frame " << v.frame << ": "
                          << l.poses << " poses listed";
  }
}

// ... and where the triple's geometry is weak (LisOptions::weak_fourth_blob_max_rad, P3pOptions::
// near_double_residual): three beacons of one camera 4.2 m away whose two roots lie 6 % apart
// (box 64 seed 4), three nearly collinear beacons whose double root noise turned complex (box 64
// seed 5, box 96 seed 4: no root at all before). Each list lacked the truth before
// (docs/acquisition.md, session 45: 4 of the 119 exhaustive lists, 0 after - the fourth, a
// camera near the danger cylinder whose roots split 6-17 cm to either side of the truth in a
// 128-beacon cylinder, lists beyond limits::kMaxLisHypotheses - and no list gained a rival).
TEST(NavMatrix, ASteadyListHoldsTheTruthOfAWeakTriple) {
  for (const View& v : {View{"station-box", 64, 4, 35}, View{"station-box", 64, 5, 35}, View{"station-box", 96, 4, 55}}) {
    const SteadyListed l = ListCleanFourBeaconView(v.preset, v.count, v.seed, v.frame);
    EXPECT_EQ(l.truth, 1) << v.preset << " " << v.count << " seed " << v.seed << " frame " << v.frame << ": "
                          << l.poses << " poses listed";
    EXPECT_EQ(l.poses, 1) << v.preset << " " << v.count << " seed " << v.seed << " frame " << v.frame;
  }
}

}  // namespace

}  // namespace mfns::host
