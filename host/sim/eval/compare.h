// `mfns-sim compare`: navigation estimates against the simulator's truth and the Cramér-Rao
// bound (issue 4's acceptance, issue 7's Table 5).
//
// Inputs: DIR/truth.csv and DIR/crb.csv (from `mfns-sim render`), and a poses CSV (from
// `mfns-navd --log`), joined on the frame column. Errors are estimate - truth per axis:
// position in mm (world axes) and the Euler angles of C_b_w in deg (wrapped to +-180).
#pragma once

#include <array>
#include <filesystem>
#include <string>

namespace mfns::host {

struct AxisStats {
  double mean = 0.0, std = 0.0, rms = 0.0;
  double bound_rms = 0.0;  // sqrt(mean of the bound's variance) over the same frames
  double ratio = 0.0;      // rms / bound_rms
};

struct CompareResult {
  int frames = 0;            // rows of truth.csv
  int frames_3plus = 0;      // frame sets with >= 3 beacons visible (crb.csv n_visible)
  int fixes_3plus = 0;       // ... of which the estimate's status is fix
  int fixes = 0, degraded = 0, lost = 0, missing = 0;  // estimate statuses (missing: no row)
  int compared = 0;          // frames in the statistics: status fix with a valid bound
  std::array<AxisStats, 6> axes{};  // x, y, z (mm); roll, pitch, yaw (deg)
  double worst_position_mm = 0.0, worst_attitude_deg = 0.0;
};

inline constexpr std::array<const char*, 6> kAxisNames = {"x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg"};

// Throws UserError on a missing file or a malformed CSV (naming the file and line), on a poses
// or truth CSV with no rows, and when no frame of the poses is in truth.csv.
CompareResult ComparePoses(const std::filesystem::path& sim_dir, const std::filesystem::path& poses_csv);

// A fixed-width table for people (without the axis table when nothing was compared).
std::string FormatCompare(const CompareResult& r);

}  // namespace mfns::host
