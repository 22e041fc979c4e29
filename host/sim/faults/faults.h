// Fault scenarios of issue 14 at image level (`mfns-sim faults`): a scenario's frames rendered
// in memory (RenderCameraFrame, the images `mfns-sim render` writes) are fed through an
// InProcessSource to the real fw::NavLoop (what mfns-navd runs, default configuration), with one
// fault injected at the source or frame level, and the published poses scored against the
// simulator's truth and against the same run without the fault (the baseline).
//
// Per fault (FaultResult):
//   - frame sets affected: those whose status is worse than the baseline's in the same frame
//     set (fix -> degraded, or a pose -> lost), counted apart;
//   - time to recover: frame sets (and seconds) from the first frame set after the fault to
//     the next fix (0: that very frame set is a fix); -1 when no fix follows (an unplugged
//     camera's fault never ends: its recovery is not defined);
//   - wrong poses published as fix (WrongPose of host/sim/navmatrix: off by more than max(20 mm,
//     10 x the published 1-sigma) or 1 deg), and wrong degraded poses apart;
//   - what health reported: every health counter (NavLoop::Health, LoopCounters, the camera
//     supervision) whose end value differs from the baseline's, with the difference.
// The loop starts at the true pose of frame set 0 (NavLoopConfig::initial_pose, as
// `mfns-navd --initial-pose`), so the fault's effect is what is measured; cold (no start pose)
// only the baseline's first fix is reported. Units: SI inside (m, rad, s).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "firmware/modules/publish/pose_message.h"
#include "host/sim/scenario/scenario.h"

namespace CLI {
class App;
}

namespace mfns::host {

enum class FaultKind {
  kNone,             // the baseline
  kStall,            // camera delivers nothing (timeouts) in [first, last], then frames again
  kUnplug,           // camera fails (driver errors) from `first` to the end of the run
  kZeroFrames,       // camera's frames all-zero in [first, last]
  kWhiteFrames,      // camera's frames saturated (255) in [first, last]
  kTruncatedFrames,  // camera's frames cut after half their rows (the rest 0) in [first, last]
  kReflections,      // 5 random reflections per camera in [first, last] (clutter.reflections_per_frame)
  kOcclusion,        // the left half of camera's image hidden in [first, last] (clutter.occlusions)
  kGlare,            // the left half of camera's image saturated (a lamp, the sun in a window) in [first, last]
  kTimeRepeat,       // frame set `first` repeats the previous stamp; the clock stays one period behind
  kTimeBackward,     // from `first` on every stamp jump_s earlier (the clock stepped back)
  kTimeForward,      // from `first` on every stamp jump_s later (the clock stepped forward)
  kWrongRigReload,   // before frame set `first` a blob for another rig is offered as a reload
};

struct FaultSpec {
  std::string name;  // table row, figure file name
  FaultKind kind = FaultKind::kNone;
  int camera = 1;
  int first = 0, last = 0;  // frame sets, inclusive
  double jump_s = 0.0;
  std::string Describe(const std::string& camera_name) const;  // one line for the table
};

struct FaultRunOptions {
  std::string preset = "station-box";
  std::uint64_t seed = 2;  // a wander that keeps >= 3 beacons in view throughout (9 on average)
  int frames = 160;
  int fault_at = 60;       // first frame set of every fault
  int image_divisor = 4;   // cameras shrunk by this factor (same field of view): faster rendering
  bool known_start = true;  // start at the true pose of frame set 0
  bool windowed_detection = true;  // NavLoopConfig::windowed_detection (navd's default; issue 20 item 1)
};

// The issue's faults, each starting at options.fault_at: stall (20 frame sets), unplug, 3 zero,
// 3 white and 3 truncated frames, 5 reflections per camera for 2 s, half a camera occluded for
// 2 s, half a camera saturated for 2 s, a repeated stamp, the clock 1 s back, 1 s forward, a
// wrong-rig reload.
std::vector<FaultSpec> IssueFaults(const FaultRunOptions& o);

// The scenario of a run: the preset with its cameras shrunk by image_divisor. UserError naming
// the option for a bad one, and for a run whose images would not fit in memory (RenderAll holds
// every frame set's: --frames x the cameras' pixels at most 2000 megapixels) or cameras under
// 16 px a side.
Scenario FaultBaseScenario(const FaultRunOptions& o);

// One published frame set, scored.
struct FaultFrame {
  int frame = 0;
  double t_s = 0.0;  // truth time since frame set 0
  fw::NavStatus status = fw::NavStatus::kLost;
  fw::NavReason reason = fw::NavReason::kNoFrames;
  double position_error_m = 0.0, attitude_error_rad = 0.0;  // NaN when lost
  bool wrong = false;
};

// A health counter's end value (name: "clock_faults", "y.timeouts", ...).
struct HealthCount {
  std::string name;
  std::int64_t value = 0;
};

struct FaultRun {
  FaultSpec fault;
  std::vector<FaultFrame> frames;
  std::vector<HealthCount> health;
  std::string reload_said;  // kWrongRigReload: what the loader said
};

struct FaultResult {
  FaultRun run;
  int degraded_vs_baseline = 0, lost_vs_baseline = 0;
  int recovery_sets = -1;
  double recovery_s = -1.0;
  int wrong_fixes = 0, wrong_degraded = 0;
  std::vector<HealthCount> health_moved;  // faulty minus baseline, non-zero only
  std::int64_t Moved(const std::string& name) const;  // 0 when it did not move
};

// Renders every frame set the faults need (the base scenario's, and the reflections'
// scenario's where that fault is on) once, then runs the baseline and each fault. progress
// (optional) is called with one line per step.
struct FaultCampaign {
  FaultRun baseline;
  std::vector<FaultResult> results;
  int cold_first_fix = -1;  // the baseline without a start pose: first fix (frame set)
  double period_s = 0.0;
  std::vector<std::string> camera_names;  // by index
};
FaultCampaign RunFaultCampaign(const FaultRunOptions& o, const std::vector<FaultSpec>& faults, bool cold,
                               const std::function<void(const std::string&)>& progress);

// Compares a run with the baseline (see the top of this file).
FaultResult ScoreFault(const FaultRun& run, const FaultRun& baseline, double period_s);

// The markdown table, one row per fault.
std::string FormatFaultTable(const FaultCampaign& c);
// Every run's frame sets as CSV: fault,frame,t_s,status,reason,position_error_mm,
// attitude_error_deg,wrong (the baseline's fault is "baseline").
std::string FormatFaultTrace(const FaultCampaign& c);
// One SVG per fault: position error (mm) against time, coloured by status, the baseline's as a
// line, the fault's span shaded.
std::string FaultFigureSvg(const FaultResult& r, const FaultRun& baseline, double period_s);

// `mfns-sim faults`' options (faults_options.cc: their one definition, needing CLI11 only; the
// fuzz preset compiles it, tests/fuzz/host_cli_fuzz.cc).
struct FaultsCommandOptions {
  FaultRunOptions run;
  std::vector<std::string> only;
  std::string out;
  std::string trace;
  bool cold = false;
  bool check = false;
};
// Adds the `faults` subcommand and its options (values into *o) to app; runs nothing.
CLI::App* AddFaultsOptions(CLI::App& app, FaultsCommandOptions* o);
// The faults a command runs: every option checked (--frames, --fault-at, --divisor, --preset
// through FaultBaseScenario; --only's names), reading and writing nothing. UserError naming the
// option otherwise (faults_setup.cc).
std::vector<FaultSpec> SelectFaults(const FaultsCommandOptions& a);
// Runs the campaign, writes the table and figures (faults_command.cc). Throws UserError, and
// CLI::RuntimeError(1) for --check with a wrong fix.
void RunFaultsCommand(const FaultsCommandOptions& a);
// AddFaultsOptions with a callback that runs RunFaultsCommand (mfns-sim parses first and runs
// after, host/sim/app/sim_cli.h).
void AddFaultsCommand(CLI::App& app);

}  // namespace mfns::host
