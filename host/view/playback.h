// mfns-view's playback: a poses CSV (mfns-navd --log, DESIGN.md) and a frames directory's
// truth.csv (mfns-sim render) read into what the view shows. Host only; allocates; throws
// UserError (one line naming the file, line and column) on a bad file.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <vector>

#include "host/view/view_state.h"

namespace mfns::host {

// One ViewPose per row. Columns by name: frame, t_ns, status (fix | degraded | lost),
// x_mm..z_mm, roll_deg..yaw_deg (of C_b_w, the 2-1-3 set), n_beacons, rms_px, and the optional
// reason. A row whose status is not one of the three is refused; lost rows carry no pose.
std::vector<ViewPose> ReadPosesCsv(const std::filesystem::path& path);

// The positions of truth.csv (frame, t_ns, x_mm, y_mm, z_mm, ...), in m.
std::vector<Eigen::Vector3d> ReadTruthTrail(const std::filesystem::path& path);

// The wall-clock seconds to wait before pose i (i >= 1) when played at `speed` times the
// sample rate: the sample-time step, clamped to [0, 1] s (a gap or a clock jump in the log
// does not stall the page).
double PlaybackDelayS(const std::vector<ViewPose>& poses, std::size_t i, double speed);

}  // namespace mfns::host
