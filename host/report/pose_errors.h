// Navigation estimates against the simulator's truth, frame by frame and per axis: the one
// join of truth, bound and poses. It gives the Table-5-style numbers of issue 7 (mean and std
// of the pose error per axis over a sweep), the series the HTML report plots, and the
// statistics `mfns-sim compare` prints (compare.h).
//
// Inputs (DESIGN.md / host/sim/frames/render_run.h): truth.csv and crb.csv of `mfns-sim
// render`, and a poses CSV (`mfns-navd --log`, or `mfns-sim solve-given`), joined on `frame`.
// Errors are estimate - truth: position r_w_wb in mm (world axes), attitude as the 2-1-3 Euler
// angles of C_b_w in deg, each difference wrapped to (-180, 180].
#pragma once

#include <array>
#include <cstddef>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

namespace mfns::host {

inline constexpr std::array<const char*, 6> kPoseAxes = {"x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg"};

struct PoseSample {
  long frame = 0;
  double yaw_true_deg = 0.0;    // truth yaw (the sweep's abscissa)
  std::string status;           // fix | degraded | lost | "" (no row in the poses CSV)
  std::array<double, 6> error{};  // estimate - truth per kPoseAxes (valid unless status is lost or "")
  // The angle of the rotation from the true attitude to the estimate (deg; valid likewise): the
  // Euler errors above grow without bound near roll +-90 deg, where pitch and yaw turn about
  // nearly the same axis (seen: 0.24 deg in each for a 0.02 deg error at roll -85.7 deg).
  double attitude_error_deg = 0.0;
  int n_beacons = 0;            // beacons the estimator used
  double rms_px = 0.0;          // its residual RMS
  int n_visible = 0;            // beacons in view (crb.csv), total and per camera
  std::vector<int> visible_per_camera;
  bool bound_valid = false;     // crb.csv has a bound for this frame set
  std::array<double, 6> bound{};  // Cramér-Rao 1-sigma per axis (mm, deg)
};

struct PoseSeries {
  std::vector<std::string> cameras;  // from crb.csv's n_<camera> columns (empty without crb)
  std::vector<PoseSample> samples;   // one per truth row, in truth order
  std::size_t pose_rows = 0;         // rows of the poses CSV (also those of frames not in truth)
};

// Reads (truth, bound, poses, in that order) and joins the files; crb_csv may be empty (no
// bound, no visibility). A bound is valid when crb.csv says so and all six sigmas are finite.
// Throws UserError on a missing file, a malformed CSV, a missing column, a frame twice in one
// file or an unknown status (naming file and line).
PoseSeries LoadPoseSeries(const std::filesystem::path& truth_csv, const std::filesystem::path& poses_csv,
                          const std::filesystem::path& crb_csv);

struct AxisSummary {
  double mean = 0.0, std = 0.0, rms = 0.0;  // of the error (std with n - 1)
  double bound_rms = 0.0;  // sqrt(mean bound variance) over the frames with a valid bound
  int n = 0;
};

struct PoseSummary {
  int frames = 0, fixes = 0, degraded = 0, lost = 0, missing = 0;  // missing: no row in the poses
  int frames_3plus = 0;  // >= 3 beacons in view
  int posed_3plus = 0;   // ... of which the estimator gave a pose (fix or degraded)
  int fixes_3plus = 0;   // ... of which the status is fix
  int used = 0;          // samples in the statistics
  std::array<AxisSummary, 6> axes{};
  // Over the samples in the statistics: the largest |position error| (mm) and the largest
  // attitude error (PoseSample::attitude_error_deg, deg); 0 when none.
  double worst_position_mm = 0.0, worst_attitude_deg = 0.0;
};

// Statistics over the samples whose status is fix, or fix or degraded when include_degraded;
// when only_frames is given, whose frame is in it; when require_bound, that have a valid bound
// (`mfns-sim compare`: then bound_rms is over exactly the frames of the errors). The counts
// cover every sample.
PoseSummary SummarizePoses(const PoseSeries& s, bool include_degraded, const std::set<long>* only_frames = nullptr,
                           bool require_bound = false);

// The frames that have a pose (fix, or degraded when include_degraded) in every series: to
// compare estimators on the same frame sets.
std::set<long> CommonPosedFrames(const std::vector<const PoseSeries*>& series, bool include_degraded);

}  // namespace mfns::host
