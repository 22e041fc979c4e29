// The acquisition test matrix of issue 13, at blob level: the real navigator (fw::Navigator,
// what mfns-navd runs) fed the blob-level simulation (host/sim/observe SimulateBlobs) of a
// scenario, frame set by frame set, from a cold start (no initial pose), scored against the
// simulator's truth. No images, no detector: a 600-frame-set run takes seconds, so a matrix of
// presets x beacon counts x map seeds x facing fits in minutes (`mfns-sim navmatrix`).
//
// Per run (ScoreRun, from one FrameRecord per frame set):
//   - first fix: the frame set of the first status `fix` against the first frame set with >= 4
//     beacons in view (truth: BlobFrameSet::NumVisible, beacons seen, once per camera); and,
//     for telling the views a search could not decide from those it did not, against the first
//     frame set of a held view (>= 4 in view for held_view_frames frame sets in a row);
//   - from the first fix on: the share of frame sets with >= 3 beacons in view that carry a
//     pose (fix or degraded);
//   - wrong poses (WrongPose): position off by more than max(20 mm, 10 x the published largest
//     per-axis 1-sigma), or attitude by more than 1 deg; fixes and degraded poses counted apart;
//   - CPU time of Navigator::Step per frame set (steady_clock): worst, mean, deadline slips
//     (above the scenario's frame period) and frame sets above 15 ms.
// Units: SI inside (m, rad, s).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "firmware/app/navd/navigator.h"
#include "host/sim/scenario/scenario.h"

namespace mfns::host {

// mfns-navd's navigator configuration: NavigatorOptions{} with navd's --sigma-px default (0.15
// px) in the solve and lost-in-space, as NavLoop sets it (nav_loop.cc).
fw::NavigatorOptions NavdNavigatorOptions();

struct NavMatrixOptions {
  fw::NavigatorOptions navigator = NavdNavigatorOptions();
  // Wrong pose: position error above max(wrong_position_floor_m, wrong_position_sigmas x the
  // published 1-sigma), or attitude error above wrong_attitude_rad.
  double wrong_position_floor_m = 0.020;
  double wrong_position_sigmas = 10.0;
  double wrong_attitude_rad = 1.0 * 3.14159265358979323846 / 180.0;
  int first_fix_in_view = 4;    // the first fix is timed from the first frame set seeing this many
  int posed_in_view = 3;        // frame sets seeing this many should carry a pose
  // A held view: >= first_fix_in_view beacons in view for this many frame sets in a row. The
  // tracker cannot acquire a view much shorter: a blob is steady after BlobTracks::steady_age
  // (3) frame sets, and an acquisition lasts TrackOptions::min_acquire_frames (3). Reported
  // beside the lag (which it does not replace): a run late from its first four-beacon
  // frame set but not from its first held view was late for want of a view, not of a search.
  int held_view_frames = 6;
  double slow_frame_s = 0.015;  // CPU budget per frame set on the host (reported)
};

// One frame set of a run, as ScoreRun needs it.
struct FrameRecord {
  int in_view = 0;  // truth: beacons seen (BlobFrameSet::NumVisible)
  int num_blobs = 0;  // blobs given to the navigator (beacons and spurious)
  fw::NavStatus status = fw::NavStatus::kLost;
  fw::NavReason reason = fw::NavReason::kNoFrames;  // as published
  fw::TrackSource source = fw::TrackSource::kNone;
  int num_beacons = 0;  // beacons the published pose used
  double rms_px = 0.0;  // its residual RMS
  int wrong_ids = 0;    // its matches whose blob is not that beacon (a spurious blob or another beacon)
  // When not lost: |r_est - r_true| (m), the angle of C_true^T C_est (rad), and the published
  // largest per-axis position 1-sigma (m; sqrt of the largest of covariance(0..2, 0..2)'s
  // diagonal, the tracker's PositionSigma).
  double position_error_m = 0.0;
  double attitude_error_rad = 0.0;
  double position_sigma_m = 0.0;
  double step_s = 0.0;  // CPU (wall) time of Navigator::Step
  // Diagnostics: beacons seen per camera (truth), and the tracker's lost-in-space outcome.
  std::array<int, limits::kMaxCameras> in_view_per_camera{};
  bool lis_run = false;
  fw::LisStatus lis_status = fw::LisStatus::kBadInput;
  int acquisition_poses = 0;  // poses followed (acquiring)
};

// Whether a published pose is wrong (see NavMatrixOptions).
bool WrongPose(double position_error_m, double attitude_error_rad, double position_sigma_m, const NavMatrixOptions& o);

struct RunResult {
  int frames = 0;
  int first_in_view = -1;  // first frame set with >= first_fix_in_view beacons in view; -1: none
  int first_fix = -1;      // first frame set with status fix; -1: none
  int first_held_view = -1;  // first frame set of the first held view (held_view_frames); -1: none
  // From the first fix on (inclusive): frame sets with >= posed_in_view beacons in view, and
  // those of them with a pose (fix or degraded).
  int eligible_after_fix = 0;
  int posed_after_fix = 0;
  int fixes = 0, degraded = 0;
  int wrong_fixes = 0, wrong_degraded = 0;
  double worst_fix_position_m = 0.0, worst_fix_attitude_rad = 0.0;  // largest errors of any fix
  double worst_step_s = 0.0, total_step_s = 0.0;
  int slips = 0;  // Navigator::Step above the frame period
  int slow = 0;   // above slow_frame_s
  double mean_in_view = 0.0;
  fw::TrackCounters counters;  // RunNavigation only

  // first_fix - first_in_view (may be negative: a fix from 3 beacons and the motion); only
  // meaningful when HasLag().
  bool HasLag() const { return first_in_view >= 0 && first_fix >= 0; }
  int Lag() const { return first_fix - first_in_view; }
  // The first fix came later than max_lag frame sets after first_in_view, or not at all
  // within the run (when the run lasted that long after first_in_view).
  bool LagExceeds(int max_lag) const;
  // The same from the first held view: first_fix - first_held_view (negative: fixed before it).
  bool HasHeldLag() const { return first_held_view >= 0 && first_fix >= 0; }
  int HeldLag() const { return first_fix - first_held_view; }
  bool HeldLagExceeds(int max_lag) const;
  bool NeverFixed() const { return first_in_view >= 0 && first_fix < 0; }
  // posed_after_fix / eligible_after_fix; 1 when nothing was eligible.
  double PosedShare() const;
};

// Scores the frame records of one run; frame_period_s: the deadline (1 / frame rate).
RunResult ScoreRun(const std::vector<FrameRecord>& frames, double frame_period_s, const NavMatrixOptions& o);

// The record of one navigated frame set: out against the true pose.
FrameRecord RecordFrame(int in_view, const fw::NavOutput& out, const BodyPose& truth, double step_s);

// Navigates scenario s from a cold start: for each frame of SimulateTrajectory(s), the blobs of
// SimulateBlobs go to a fw::Navigator initialised with BelievedRig(s) (so beacons.facing: false
// leaves the facing out of the navigator's map), `delivered` from the cameras' delivered flags,
// no camera set aside. Throws UserError when the navigator refuses the rig or options.
// frames_out (optional): every frame set's record.
RunResult RunNavigation(const Scenario& s, const NavMatrixOptions& o, std::vector<FrameRecord>* frames_out = nullptr);

}  // namespace mfns::host
