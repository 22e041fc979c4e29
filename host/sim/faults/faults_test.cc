#include "host/sim/faults/faults.h"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "common/rotation/rotation.h"
#include "firmware/modules/solve/synthetic_scene.h"
#include "host/util/atomic_file.h"

namespace mfns::host {
namespace {

// The campaign, reduced: the shrunk station-box preset (320 x 256), faults from frame set 30
// (stall 20 frame sets, reflections and occlusion 37), fewer frame sets under the sanitizers.
// Run once (one test: ctest runs each gtest test in its own process) and checked below.
FaultCampaign ReducedCampaign() {
  FaultRunOptions o;
  o.frames = fw::testing::Trials(90, 80);
  o.fault_at = 30;
  return RunFaultCampaign(o, IssueFaults(o), false, [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); });
}

const FaultResult& Result(const FaultCampaign& c, const std::string& name) {
  for (const FaultResult& r : c.results)
    if (r.run.fault.name == name) return r;
  static const FaultResult none;
  ADD_FAILURE() << "no fault " << name;
  return none;
}

// Recovery bounds asserted (frame sets from the fault's end to the next fix): a set-aside
// camera is retried every 19 frame sets (NavLoopConfig, navd's default); after a fault that
// lost the track, the navigator needs a few frame sets to confirm it again (measured, seed 2:
// 6 after the reflections, 3 after the occlusion, 13 after the clock stepped 1 s forward; 0-2
// for the others; 5 after truncated frames before their blind cells, 0 since).
constexpr int kRetryEvery = 19, kSettle = 10, kAfterClockStep = 20;

// 0 wrong fixes in every fault; the baseline fixes.
void CheckNoWrongFix(const FaultCampaign& c) {
  std::printf("%s", FormatFaultTable(c).c_str());
  ASSERT_EQ(c.results.size(), IssueFaults(FaultRunOptions{}).size());
  for (const FaultResult& r : c.results) EXPECT_EQ(r.wrong_fixes, 0) << r.run.fault.name;
  int base_fixes = 0;
  for (const FaultFrame& f : c.baseline.frames) base_fixes += f.status == fw::NavStatus::kFix;
  EXPECT_GE(base_fixes, static_cast<int>(c.baseline.frames.size()) * 8 / 10) << "the baseline navigates";
}

// A stalled camera: timeouts counted, set aside, back, the next fix within a retry period.
void CheckStall(const FaultCampaign& c) {
  const FaultResult& r = Result(c, "stall");
  EXPECT_GE(r.Moved("y.timeouts"), 3);
  EXPECT_GE(r.Moved("y.set_asides"), 1);
  EXPECT_GE(r.recovery_sets, 0);
  EXPECT_LE(r.recovery_sets, kRetryEvery + kSettle);
  EXPECT_EQ(r.Moved("y.set_aside_at_end"), 0) << "back";
}

// An unplugged camera: errors counted, set aside at the end; the others go on.
void CheckUnplug(const FaultCampaign& c) {
  const FaultResult& r = Result(c, "unplug");
  EXPECT_GE(r.Moved("y.errors"), 3);
  EXPECT_GE(r.Moved("y.set_asides"), 1);
  EXPECT_EQ(r.Moved("y.set_aside_at_end"), 1);
  int posed_after = 0;
  for (const FaultFrame& f : r.run.frames) posed_after += f.frame > r.run.fault.first + 3 && f.status != fw::NavStatus::kLost;
  EXPECT_GT(posed_after, 0) << "cameras x and z still navigate";
}

// Zero and white frames: bad_frames +3 (the injected 3); the track back at once.
void CheckCorruptFrames(const FaultCampaign& c) {
  for (const char* name : {"zero-frames", "white-frames"}) {
    const FaultResult& r = Result(c, name);
    EXPECT_EQ(r.Moved("x.bad_frames"), 3) << name << ": the three blank frames";
    EXPECT_GE(r.recovery_sets, 0) << name;
    EXPECT_LE(r.recovery_sets, kSettle) << name;
  }
  // A rendered frame cut short with the rest zero is not blank but truncated: a bad frame in
  // health (it was counted by nothing), its upper half's blobs kept, its lower half blind, so
  // the beacons there are not missing: the track is kept (before: 8 frame sets lost).
  const FaultResult& cut = Result(c, "truncated-frames");
  EXPECT_EQ(cut.Moved("x.bad_frames"), 3) << "the three truncated frames";
  EXPECT_EQ(cut.Moved("x.detect_errors"), 0);
  EXPECT_EQ(cut.wrong_fixes, 0);
  EXPECT_EQ(cut.lost_vs_baseline, 0);
  EXPECT_EQ(cut.recovery_sets, 0);
}

// Reflections and an occlusion: the next fix within kSettle. Half of camera z saturated (a lamp,
// the sun in a window) lost the track (its hidden beacons missing) for the glare and beyond (at
// frame set 60 of the full campaign: 100 frame sets, no fix after it); its blind cells keep the
// track throughout now, never with a wrong fix.
void CheckSceneFaults(const FaultCampaign& c) {
  for (const char* name : {"reflections", "occlusion"}) {
    const FaultResult& r = Result(c, name);
    EXPECT_GE(r.recovery_sets, 0) << name;
    EXPECT_LE(r.recovery_sets, kSettle) << name;
  }
  const FaultResult& glare = Result(c, "glare");
  const FaultSpec& spec = glare.run.fault;
  EXPECT_EQ(glare.Moved("z.saturated_frames"), spec.last - spec.first + 1);
  EXPECT_EQ(glare.lost_vs_baseline, 0);
  EXPECT_EQ(glare.recovery_sets, 0);
  EXPECT_EQ(glare.wrong_fixes + glare.wrong_degraded, 0);
}

// Clock faults counted as injected; the track kept or back within the bounds.
void CheckClockJumps(const FaultCampaign& c) {
  const FaultResult& repeat = Result(c, "time-repeat");
  EXPECT_EQ(repeat.Moved("clock_faults"), 1);
  EXPECT_EQ(repeat.Moved("clock_offsets"), 1);
  EXPECT_EQ(repeat.recovery_sets, 0);
  const FaultResult& back = Result(c, "time-backward");
  EXPECT_EQ(back.Moved("clock_faults"), 3) << "three in a row, then the clock is taken as it is";
  EXPECT_GE(back.recovery_sets, 0);
  EXPECT_LE(back.recovery_sets, kSettle);
  const FaultResult& forward = Result(c, "time-forward");
  EXPECT_EQ(forward.Moved("clock_faults"), 0);
  EXPECT_EQ(forward.Moved("stamp_jumps"), 1) << "a forward step with no frame lost is a stamp jump";
  EXPECT_GE(forward.recovery_sets, 0);
  EXPECT_LE(forward.recovery_sets, kAfterClockStep);
}

// A wrong-rig reload: refused with the loader's reason, no frame set affected.
void CheckWrongRigReload(const FaultCampaign& c) {
  const FaultResult& r = Result(c, "wrong-rig-reload");
  EXPECT_EQ(r.run.reload_said.rfind("refused", 0), 0u) << r.run.reload_said;
  EXPECT_EQ(r.degraded_vs_baseline + r.lost_vs_baseline, 0);
}

TEST(Faults, EveryFaultOfTheIssueThroughNavLoop) {
  const FaultCampaign c = ReducedCampaign();
  CheckNoWrongFix(c);
  CheckStall(c);
  CheckUnplug(c);
  CheckCorruptFrames(c);
  CheckSceneFaults(c);
  CheckClockJumps(c);
  CheckWrongRigReload(c);
}

// Issue 20 item 1: windowed detection (navd's default) gives the fixes of full-frame detection
// at image level on the paper turntable sweep and the free-flight scenario (cameras shrunk 4x,
// cold start: the acquisition runs on full frames, tracking on windows): the same status and
// the same position and attitude errors in every frame set. (Full size, 360 and 120 frame sets,
// gave the same too: docs/navd.md.)
TEST(Faults, WindowedDetectionKeepsTheFixesOfFullFrames) {
  for (const char* preset : {"paper-turntable", "free-flight"}) {
    FaultRunOptions o;
    o.preset = preset;
    o.frames = fw::testing::Trials(120, 60);
    o.known_start = false;
    const FaultCampaign windowed = RunFaultCampaign(o, {}, false, nullptr);
    o.windowed_detection = false;
    const FaultCampaign full = RunFaultCampaign(o, {}, false, nullptr);
    ASSERT_EQ(windowed.baseline.frames.size(), full.baseline.frames.size());
    int fixes = 0;
    for (std::size_t n = 0; n < full.baseline.frames.size(); ++n) {
      const FaultFrame& a = windowed.baseline.frames[n];
      const FaultFrame& b = full.baseline.frames[n];
      ASSERT_EQ(a.status, b.status) << preset << " frame set " << n;
      fixes += b.status == fw::NavStatus::kFix ? 1 : 0;
      if (b.status == fw::NavStatus::kLost) continue;
      EXPECT_EQ(a.position_error_m, b.position_error_m) << preset << " frame set " << n;
      EXPECT_EQ(a.attitude_error_rad, b.attitude_error_rad) << preset << " frame set " << n;
      EXPECT_FALSE(a.wrong) << preset << " frame set " << n;
    }
    EXPECT_GT(fixes, static_cast<int>(full.baseline.frames.size()) / 3) << preset;
  }
}

// A baseline that published a wrong fix (seed 7: the view narrows to three beacons of one
// camera near a degenerate P3P configuration; an acquired pose 101 mm and 3.4 deg off with a
// 1.07 deg 1-sigma was a fix at frame set 150 while the attitude bound was 0.02 rad). Now
// degraded: a fix's attitude 1-sigma is at most a quarter of the 1 deg that makes a pose wrong.
TEST(Faults, AOneCameraThreeBeaconPoseNearDegeneracyIsNoFix) {
  FaultRunOptions o;
  o.seed = 7;
  o.frames = 160;
  const FaultCampaign c = RunFaultCampaign(o, {}, false, nullptr);
  ASSERT_EQ(c.baseline.frames.size(), 160u);
  int fixes = 0, wrong_fixes = 0;
  for (const FaultFrame& f : c.baseline.frames) {
    if (f.status != fw::NavStatus::kFix) continue;
    ++fixes;
    wrong_fixes += f.wrong;
    EXPECT_LT(f.attitude_error_rad, DegToRad(1.0)) << "frame set " << f.frame;
  }
  EXPECT_EQ(wrong_fixes, 0);
  EXPECT_GE(fixes, 130) << "the baseline navigates (145 fixes before)";
}

// `mfns-sim faults`: the table and one figure per chosen fault, nothing else left in --out (no
// temp file); an unknown fault name is a user error (one line, exit 1 in mfns-sim).
TEST(Faults, TheCommandWritesTheTableAndOneFigurePerFault) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(::testing::TempDir()) / "mfns_faults_command";
  fs::remove_all(dir);
  CLI::App app;
  AddFaultsCommand(app);
  app.parse("faults --out " + dir.string() + " --only zero-frames,time-repeat --frames 30 --fault-at 10", false);
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"fault-time-repeat.svg", "fault-zero-frames.svg", "faults.md"}));
  EXPECT_NE(ReadFile(dir / "faults.md").find("| zero-frames | camera x all-zero frames, frame sets 10-12 |"), std::string::npos);
  CLI::App bad;
  AddFaultsCommand(bad);
  EXPECT_THROW(bad.parse("faults --out " + dir.string() + " --only no-such-fault", false), UserError);
  fs::remove_all(dir);
}

// The options are checked before anything is rendered (SelectFaults, what host_cli_fuzz runs after
// each parse), each error one line naming its option. Before, --frames had no bound (a million
// frame sets were rendered into memory first), --divisor 4096 made cameras of 0 px, and --only
// quoted a name's newline raw.
TEST(Faults, OptionsAreCheckedBeforeAnythingRenders) {
  const auto error = [](const FaultsCommandOptions& a) -> std::string {
    try {
      SelectFaults(a);
    } catch (const UserError& e) {
      return e.what();
    }
    return "no error";
  };
  FaultsCommandOptions a;
  a.only = {"stall", "glare"};
  ASSERT_EQ(SelectFaults(a).size(), 2u);
  EXPECT_EQ(SelectFaults(a)[0].name, "stall");  // in the issue's order
  a.run.frames = 8138;  // 2000 megapixels at --divisor 4
  EXPECT_EQ(error(a), "no error");
  a.run.frames = 8139;
  EXPECT_EQ(error(a).rfind("--frames: 8139 frame sets at --divisor 4 are 2000 megapixels", 0), 0u) << error(a);
  a.run.frames = 1'000'001;
  EXPECT_EQ(error(a), "--frames: must be 2..1000000");
  a.run = FaultRunOptions{};
  a.run.image_divisor = 4096;
  EXPECT_EQ(error(a).rfind("--divisor: 4096 leaves camera ", 0), 0u) << error(a);
  a.run = FaultRunOptions{};
  a.run.preset = "moon-base";
  EXPECT_EQ(error(a).rfind("--preset: unknown preset 'moon-base'", 0), 0u) << error(a);
  a.run = FaultRunOptions{};
  a.only = {"sta\nll"};
  EXPECT_EQ(error(a), "--only: no fault named 'sta\\nll'");
}

}  // namespace
}  // namespace mfns::host
