// The paper's navigation pipeline on simulated data (Section 5: beacons matched by hand,
// Newton iteration): the firmware's joint solver (firmware/modules/solve) run on the true
// correspondences of a `mfns-sim render` directory instead of detected and identified blobs.
//
// Input: DIR/truth.csv (the frame list and timestamps) and DIR/blobs.csv (per frame, camera
// and beacon index the rendered spot centre u_px, v_px: what a perfect detector finds, with
// the scenario's centroid noise). Output: a poses CSV (DESIGN.md), written atomically.
// Per frame set with >= 3 beacons: Gauss-Newton from the previous frame set's pose (the first
// frame set, and any after a failure, from the turntable's reading: the yaw of truth.csv at
// the origin, as the paper's operator knew it; then yaws 0, 30, ..., 330 deg); plain least squares (no robust loss, no outlier rejection)
// as the paper's Newton iteration. Fewer than 3 beacons or a failed solve: status lost.
#pragma once

#include <filesystem>

#include "common/rig/rig.h"

namespace mfns::host {

struct GivenSolveOptions {
  double sigma_px = 0.1;       // centroid 1-sigma (covariance only; not written)
  bool use_geometric = false;  // use u_geom_px (no centroid noise) instead of u_px
};

struct GivenSolveSummary {
  int frames = 0, fixes = 0, lost = 0;
};

// `rig` is what the navigator believes (calibrated cameras, surveyed beacons). Throws
// UserError on unreadable input, a camera name not in the rig or a beacon index out of range.
GivenSolveSummary SolveGivenCorrespondences(const std::filesystem::path& sim_dir, const Rig& rig,
                                            const GivenSolveOptions& options, const std::filesystem::path& out_csv);

}  // namespace mfns::host
