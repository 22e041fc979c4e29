// The pose error a rig's calibration error causes (issue 18 item 5): the covariance navd adds
// to the one it publishes when the parameter blob carries the calibration's 1-sigma.
//
// A calibration error is the same in every frame set: it biases the pose and does not average
// out over beacons or frames as centroid noise does. Each camera parameter c with 1-sigma s_c
// (Rig::sigma: C_k_b's Euler angles, r_b_bk, the five intrinsics and five distortion terms) is
// therefore propagated through the solve at its solution, to first order:
//   d pose / d c = -(J^T W J)^-1 J^T W (d uv / d c),   Sigma_cal = sum_c (d pose/d c)(...)^T s_c^2
// with J the 2x6 pose Jacobians of the matched observations (PoseDelta parametrisation), W the
// solve's per-beacon weights (BeaconWeights; 1 without per-beacon sigmas) and d uv / d c by
// forward differences on a copy of the camera (steps 1e-6 rad, 1e-6 m, 1e-6 of an
// intrinsic). The parameters are taken as independent (the blob carries no cross-covariances):
// the calibration's correlations are lost, which errs on neither side in general; docs/navd.md
// shows the result against Monte Carlos of the rig (calibration_covariance_test, navigator).
//
// No heap, no exceptions, bounded loops (<= kMaxMatches observations x (1 + 16 parameters)).
// Cost: 11-15 us for 6-10 observations on the paper rig (solve_benchmark, docs/benchmarks.md).
#pragma once

#include <Eigen/Core>

#include "common/rig/rig.h"
#include "firmware/modules/solve/observation.h"
#include "firmware/modules/solve/solve.h"

namespace mfns::fw {

// Inputs: the rig the solve used (its sigma read when rig.has_sigma), the frame set's blobs,
// the matches of the pose (every one an inlier), the solved pose and the solve's options
// (beacon_px_per_m for the weights). Output: *cov (m^2, rad^2; [dr_w; dtheta_b]). Returns
// false and sets *cov to zero without rig.has_sigma, with bad input (a match naming a missing
// blob, camera or beacon), when a matched beacon does not project, or when fewer than three
// beacons leave J^T W J singular.
bool CalibrationCovariance(const Rig& rig, const BlobObs* blobs, int num_blobs, const Match* matches, int num_matches,
                           const BodyPose& pose, const SolveOptions& options, Eigen::Matrix<double, 6, 6>* cov);

}  // namespace mfns::fw
